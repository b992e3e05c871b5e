//! Angle limits on bone-chain joints (`VRMC_springBone_limit`, 1.0 draft): when the chains are
//! posed, each limited joint's bone is kept inside its [`JointLimit`]'s cone, hinge or
//! spherical range, and the joints after it follow the limited bone.
//!
//! The limit's frame is the joint's bind rotation under its posed parent, turned by the shortest
//! arc from `+Y` to the bone's bind direction (by half a turn about `X` when the bone points
//! exactly along `-Y`, as the draft requires), then by the limit's own `rotation`. The shapes
//! are the draft's reference ones: a cone keeps the angle to `+Y`; a hinge drops the `X` part
//! and then keeps the angle; a spherical limit keeps pitch (about `X`) and yaw (toward `X`).

use bevy::prelude::*;

use crate::asset::{JointLimit, JointLimitShape};

/// Angle limits of a [`HairBoneChains`](super::HairBoneChains)'s joints, by joint entity: put it
/// beside the chains (the VRM spawner does, from `VRMC_springBone_limit`).
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component, Debug)]
pub struct ChainJointLimits(pub Vec<(Entity, JointLimit)>);

impl ChainJointLimits {
    /// The limit of `joint`, if it has one.
    pub fn of(&self, joint: Entity) -> Option<JointLimit> {
        self.0.iter().find(|(e, _)| *e == joint).map(|(_, l)| *l)
    }
}

/// The shortest turn from `+Y` to `bone_axis` (a unit vector), or half a turn about `X` when
/// `bone_axis` is `-Y`.
pub fn axis_rotation(bone_axis: Vec3) -> Quat {
    let dot = bone_axis.y;
    if dot + 1.0 < 1e-8 {
        return Quat::from_xyzw(1.0, 0.0, 0.0, 0.0);
    }
    Quat::from_xyzw(bone_axis.z, 0.0, -bone_axis.x, dot + 1.0).normalize()
}

/// The limit's frame in the world: `joint_rest` is the joint's bind rotation under its posed
/// parent (world), `bone_axis` the bone's bind direction in the joint's own frame.
pub fn limit_frame(joint_rest: Quat, bone_axis: Vec3, limit: &JointLimit) -> Quat {
    let axis = bone_axis.try_normalize().unwrap_or(Vec3::Y);
    (joint_rest * axis_rotation(axis) * limit.rotation).normalize()
}

/// `dir` (a unit vector in the limit's frame) moved inside `shape`.
pub fn limit_direction(shape: &JointLimitShape, dir: Vec3) -> Vec3 {
    match *shape {
        JointLimitShape::Cone { angle } => clamp_to_cone(dir, angle),
        JointLimitShape::Hinge { angle } => {
            let flat = Vec3::new(0.0, dir.y, dir.z)
                .try_normalize()
                .unwrap_or(Vec3::Y);
            clamp_to_cone(flat, angle)
        }
        JointLimitShape::Spherical { pitch, yaw } => {
            let mut p = dir.z.atan2(dir.y);
            let mut w = dir.x.clamp(-1.0, 1.0).asin();
            if p.abs() > pitch {
                p = pitch.copysign(p);
            }
            if w.abs() > yaw {
                w = yaw.copysign(w);
            }
            Vec3::new(w.sin(), w.cos() * p.cos(), w.cos() * p.sin())
        }
    }
}

/// `dir` within `angle` of `+Y`: its `Y` part raised to the angle's cosine and its `X` and `Z`
/// parts scaled to keep it unit length (straight down, where they vanish, it tilts toward `+Z`).
fn clamp_to_cone(dir: Vec3, angle: f32) -> Vec3 {
    let c = angle.cos();
    if dir.y >= c {
        return dir;
    }
    let sin_limit = (1.0 - c * c).max(0.0).sqrt();
    let sideways = Vec2::new(dir.x, dir.z);
    let Some(side) = sideways.try_normalize() else {
        return Vec3::new(0.0, c, sin_limit);
    };
    Vec3::new(side.x * sin_limit, c, side.y * sin_limit)
}

/// `to` (the world offset from a joint to its child) kept inside `limit`, at its own length.
pub fn limit_offset(frame: Quat, limit: &JointLimit, to: Vec3) -> Vec3 {
    let length = to.length();
    let Some(dir) = to.try_normalize() else {
        return to;
    };
    let local = frame.inverse() * dir;
    let limited = limit_direction(&limit.shape, local);
    let out = frame * limited * length;
    if out.is_finite() { out } else { to }
}

#[cfg(test)]
mod tests {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, FRAC_PI_6};

    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        a.distance(b) < 1e-5
    }

    #[test]
    fn a_cone_keeps_the_bone_within_its_angle_and_leaves_inside_directions_alone() {
        let cone = JointLimitShape::Cone { angle: FRAC_PI_6 };
        // 60 degrees from +Y toward +X comes back to 30, in the same plane.
        let d = Vec3::new(60f32.to_radians().sin(), 60f32.to_radians().cos(), 0.0);
        let got = limit_direction(&cone, d);
        assert!(close(got, Vec3::new(0.5, 3f32.sqrt() / 2.0, 0.0)), "{got}");
        // Toward -X and +Z at 45 degrees of azimuth: the azimuth is kept.
        let d = Vec3::new(-1.0, 0.0, 1.0).normalize();
        let got = limit_direction(&cone, d);
        let s = 0.5 / 2f32.sqrt();
        assert!(close(got, Vec3::new(-s, 3f32.sqrt() / 2.0, s)), "{got}");
        // Inside: unchanged. Straight down: onto the cone, not NaN.
        let inside = Vec3::new(0.2, 1.0, 0.1).normalize();
        assert_eq!(limit_direction(&cone, inside), inside);
        let down = limit_direction(&cone, Vec3::NEG_Y);
        assert!(
            down.is_finite() && (down.y - FRAC_PI_6.cos()).abs() < 1e-6,
            "{down}"
        );
    }

    #[test]
    fn a_hinge_turns_only_about_x_within_its_angle() {
        let hinge = JointLimitShape::Hinge { angle: FRAC_PI_4 };
        // Sideways (X) motion is dropped: (0.6, 0.8, 0) becomes +Y.
        assert!(close(
            limit_direction(&hinge, Vec3::new(0.6, 0.8, 0.0)),
            Vec3::Y
        ));
        // In the hinge's plane, 90 degrees toward +Z comes back to 45.
        let got = limit_direction(&hinge, Vec3::Z);
        let h = FRAC_PI_4.cos();
        assert!(close(got, Vec3::new(0.0, h, h)), "{got}");
        // Within the angle, the X part still goes.
        let got = limit_direction(&hinge, Vec3::new(0.3, 0.9, -0.2).normalize());
        assert!(got.x == 0.0 && close(got, Vec3::new(0.0, 0.9, -0.2).normalize()));
    }

    #[test]
    fn a_spherical_limit_keeps_pitch_and_yaw_apart() {
        let sphere = JointLimitShape::Spherical {
            pitch: FRAC_PI_6,
            yaw: FRAC_PI_4,
        };
        // Pitch 60 degrees (toward +Z), no yaw: back to 30.
        let d = Vec3::new(0.0, 60f32.to_radians().cos(), 60f32.to_radians().sin());
        let got = limit_direction(&sphere, d);
        assert!(close(got, Vec3::new(0.0, FRAC_PI_6.cos(), 0.5)), "{got}");
        // Yaw 60 degrees (toward +X), no pitch: back to 45.
        let d = Vec3::new(60f32.to_radians().sin(), 60f32.to_radians().cos(), 0.0);
        let got = limit_direction(&sphere, d);
        assert!(
            close(got, Vec3::new(FRAC_PI_4.sin(), FRAC_PI_4.cos(), 0.0)),
            "{got}"
        );
        // Both within: unchanged.
        let d = Vec3::new(0.3, 0.9, 0.2).normalize();
        assert!(close(limit_direction(&sphere, d), d));
    }

    #[test]
    fn the_limit_frame_turns_plus_y_onto_the_bone_then_by_the_limit_rotation() {
        let none = |shape| JointLimit {
            shape,
            rotation: Quat::IDENTITY,
        };
        let cone = none(JointLimitShape::Cone { angle: 0.0 });
        // A bone along +X in a joint turned 90 degrees about Z: +Y of the frame is world +Y.
        let joint = Quat::from_rotation_z(FRAC_PI_2);
        let frame = limit_frame(joint, Vec3::X, &cone);
        assert!(close(frame * Vec3::Y, Vec3::Y), "{}", frame * Vec3::Y);
        // A bone straight down: half a turn about X.
        let frame = limit_frame(Quat::IDENTITY, Vec3::NEG_Y, &cone);
        assert!(close(frame * Vec3::Y, Vec3::NEG_Y) && close(frame * Vec3::Z, Vec3::NEG_Z));
        // The limit's rotation turns the cone's axis: a cone of 0 pointing 90 degrees off the
        // bone pulls any direction onto that axis.
        let turned = JointLimit {
            rotation: Quat::from_rotation_x(FRAC_PI_2),
            ..cone
        };
        let frame = limit_frame(Quat::IDENTITY, Vec3::Y, &turned);
        let got = limit_offset(frame, &turned, Vec3::new(0.0, 2.0, 0.0));
        assert!(close(got, Vec3::new(0.0, 0.0, 2.0)), "{got}");
    }
}
