//! Tuning of the strand simulation. One component per hair; the egui panel edits these same types.

use bevy::prelude::*;

use crate::math::finite_or;

use crate::curve::QuadraticCurve;

use super::HairVolume;

/// How a hair moves. A component on the entity that holds [`Hair`](super::Hair); inserted with
/// defaults when missing. Changing it takes effect on the next frame without rebuilding strands,
/// except [`HairSimSettings::structure_offset`], which rebuilds them.
///
/// Stiffnesses are in `[0, 1]`: `0` is loose, `1` nearly rigid. They map to XPBD compliances on a
/// logarithmic scale and the solver runs fixed-size substeps, so the look does not change with the
/// frame rate.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairSimSettings {
    /// Edge springs between neighbouring particles: how much strands stretch.
    /// Higher keeps length; lower lets hair stretch like rubber. Default: `1.0`.
    pub edge_stiffness: f32,
    /// Bending springs (every other particle): how easily strands bend away from their style.
    /// Higher holds the styled curl; lower lets hair droop and swing. For bone chains
    /// ([`HairBoneChains`](super::HairBoneChains)) they join each particle to the one two before
    /// it, and hold the first bone at its angle to the bone the chain hangs from.
    /// Default: `0.8`.
    pub bend_stiffness: f32,
    /// Torsion springs (every third particle): how much strands twist.
    /// Higher keeps spikes pointing their way; lower lets them roll. Bone chains have none: a
    /// joint is turned by the shortest arc onto the next particle, so their twist never shows.
    /// Default: `0.6`.
    pub torsion_stiffness: f32,
    /// Anchor ("blending") spring stiffness along the strand, root `x = 0` to tip `x = 1` (the
    /// thesis's S curve). `1` holds the keyframe pose exactly; `0` leaves the hair free.
    /// Default: `QuadraticCurve { a: 0.0, b: -0.4, c: 0.7 }` (0.7 at the root to 0.3 at the tip:
    /// spiky styles hold against gravity, tips still swing).
    pub anchor_stiffness: QuadraticCurve,
    /// Gravity in world space, m/s^2. Default: `(0, -9.81, 0)`.
    pub gravity: Vec3,
    /// Velocity damping per second (`0` none). Higher calms motion; too high looks underwater.
    /// Default: `2.0`.
    pub damping: f32,
    /// The frame damping works in. Default: [`HairDampingFrame::World`].
    pub damping_frame: HairDampingFrame,
    /// Substeps per second of simulated time. More is stiffer and steadier but costs linearly.
    /// Clamped to `[30, 2000]`. Default: `240.0` (4 substeps in a 60 Hz frame).
    pub substep_rate: f32,
    /// Longest frame the simulation advances by; longer frames (a hitch, a 1 s stall) are
    /// clamped so hair slows down instead of exploding. Clamped to `[0.001, 0.25]`.
    /// Default: `0.1`.
    pub max_frame_time: f32,
    /// A bone that moves farther than this in one frame (metres) teleported: the hair is carried
    /// with it rigidly instead of whipping. Default: `1.0`.
    pub teleport_distance: f32,
    /// Strain limit: at the end of every frame no chain edge is longer than this times its rest
    /// length (follow the leader, root to tip, velocities kept). The springs hold lengths within
    /// a few percent in ordinary motion; this bounds what a bone moving faster than the solver
    /// can follow does (a 0.99 m jump in one frame stretched segments 13x without it).
    /// Clamped to `[1, 100]`. Default: `1.1`.
    pub max_stretch: f32,
    /// Style limit: the farthest (metres, at the character's built size) a particle may leave
    /// its anchor, the keyframed style, at the end of a frame; it is pulled back onto that
    /// sphere, its velocity kept. Like VRM's angle limits and Magica Cloth's backstop: bangs stay
    /// out of the face however hard the head shakes. `None`: no limit. Default: `None`.
    pub style_limit: Option<f32>,
    /// Hair–hair volume: strands of this hair keep apart instead of passing through each other
    /// (see [`HairVolume`]). `None`: strands pass through each other, as in the thesis.
    /// Default: `None`.
    pub volume: Option<HairVolume>,
    /// A bone that turns more than this in one frame (radians) teleported, as above.
    /// Default: `PI / 2` (90 degrees).
    pub teleport_angle: f32,
    /// Smallest collision margin of a strand (metres): distance kept from colliders. Both
    /// margins are clamped to `[0, MAX_MARGIN]` ([`MAX_MARGIN`]: 0.25 m, at the built size).
    /// Default: `0.005`.
    pub margin_min: f32,
    /// Largest collision margin; each strand draws its margin in `[margin_min, margin_max]`.
    /// Default: `0.015`.
    pub margin_max: f32,
    /// Seed of the margin draw ("Alter margins" draws again with a new seed). Default: `1`.
    pub margin_seed: u64,
    /// Coulomb friction coefficient between this hair and every collider: a particle a collider
    /// pushes loses up to this times the push of its motion along the surface (relative to the
    /// collider's own motion), so hair resting on a slope steeper than `atan(friction)` slides
    /// and on a gentler one stays. `0` is frictionless, as in the thesis. Clamped to `[0, 10]`.
    /// Default: `0.0`.
    pub friction: f32,
    /// Distance of the extra structural particles from the strand, as a fraction of the segment
    /// length (Selle et al. 2008). Larger resists twisting better. Changing it rebuilds strands.
    /// Clamped to `[0.05, 2]`. Default: `0.5`.
    pub structure_offset: f32,
}

impl Default for HairSimSettings {
    fn default() -> Self {
        Self {
            edge_stiffness: 1.0,
            bend_stiffness: 0.8,
            torsion_stiffness: 0.6,
            anchor_stiffness: QuadraticCurve::new(0.0, -0.4, 0.7),
            gravity: Vec3::new(0.0, -9.81, 0.0),
            damping: 2.0,
            damping_frame: HairDampingFrame::World,
            substep_rate: 240.0,
            max_frame_time: 0.1,
            teleport_distance: 1.0,
            max_stretch: 1.1,
            style_limit: None,
            volume: None,
            teleport_angle: std::f32::consts::FRAC_PI_2,
            margin_min: 0.005,
            margin_max: 0.015,
            margin_seed: 1,
            friction: 0.0,
            structure_offset: 0.5,
        }
    }
}

impl HairSimSettings {
    /// Substep length in seconds after clamping.
    pub fn substep(&self) -> f32 {
        1.0 / finite_or(self.substep_rate, 240.0).clamp(30.0, 2000.0)
    }

    /// Friction after clamping (`0` when not finite).
    pub fn friction(&self) -> f32 {
        finite_or(self.friction, 0.0).clamp(0.0, 10.0)
    }

    /// Longest frame after clamping.
    pub fn frame_clamp(&self) -> f32 {
        finite_or(self.max_frame_time, 0.1).clamp(0.001, 0.25)
    }

    /// Style limit after clamping (`>= 0`); infinite when there is none.
    pub fn style_limit(&self) -> f32 {
        match self.style_limit {
            Some(m) if !m.is_nan() => m.max(0.0),
            _ => f32::INFINITY,
        }
    }

    /// Strain limit after clamping.
    pub fn max_stretch(&self) -> f32 {
        finite_or(self.max_stretch, 1.1).clamp(1.0, 100.0)
    }

    /// Structural offset after clamping.
    pub fn structure_offset(&self) -> f32 {
        finite_or(self.structure_offset, 0.5).clamp(0.05, 2.0)
    }

    /// Margins after clamping: both in `[0, MAX_MARGIN]`, ordered.
    pub fn margins(&self) -> (f32, f32) {
        let a = finite_or(self.margin_min, 0.0).clamp(0.0, MAX_MARGIN);
        let b = finite_or(self.margin_max, a).clamp(0.0, MAX_MARGIN);
        (a.min(b), a.max(b))
    }

    /// Damping factor applied to velocity each substep.
    pub fn damping_factor(&self) -> f32 {
        (-finite_or(self.damping, 0.0).max(0.0) * self.substep()).exp()
    }

    /// Gravity, or zero if not finite.
    pub fn gravity(&self) -> Vec3 {
        if self.gravity.is_finite() {
            self.gravity
        } else {
            Vec3::ZERO
        }
    }
}

/// The frame [`HairSimSettings::damping`] acts in.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Debug, PartialEq)]
#[non_exhaustive]
pub enum HairDampingFrame {
    /// Velocity relative to the world is damped, as if by still air: hair trails a moving
    /// character (at a steady 30 m/s the ninja's hair is blown 9.5 cm back) and settles when
    /// the character stops. The thesis's model.
    #[default]
    World,
    /// Only velocity relative to the bone is damped, as if the air moved with the character:
    /// a character riding a vehicle at any steady speed keeps its hair as at rest, while
    /// head turns and shakes still swing it.
    Bone,
}

/// Simulates a hair in the frame of another entity (VRM's spring `center`): each substep its
/// particles, and their velocities, are carried by that entity's motion, so moving it (a
/// character's root or hips running, jumping, riding) gives the hair no inertia, while motion
/// relative to it (a head turn) still swings the hair. On the [`Hair`](super::Hair) entity, or
/// on a [`HairBoneChains`](super::HairBoneChains) entity, whose hairs get a copy. An entity
/// without a usable transform leaves the hair in the world frame.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub struct HairInertiaFrame(pub Entity);

/// The largest collision margin (metres, at the character's built size): a margin is a gap of
/// air between the hair and a collider, and a huge one (a typo, a slider dragged off) would
/// throw the hair off the head.
pub const MAX_MARGIN: f32 = 0.25;

/// Maps a stiffness in `[0, 1]` to the fraction of a constraint's error a substep removes for two
/// unit-mass particles, via XPBD: `alpha~ = compliance / h^2`, correction `w / (w + alpha~)`.
/// Compliance spans `1e-9` (stiffness 1) to `1` (stiffness ~0) logarithmically; stiffness 0 is
/// exactly loose (no correction). Non-finite input counts as 0.
pub fn compliance_factor(stiffness: f32, h: f32, w_sum: f32) -> f32 {
    let s = if stiffness.is_finite() {
        stiffness.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if s <= 0.0 {
        return 0.0;
    }
    let compliance = 10f32.powf(-9.0 * s);
    let alpha = compliance / (h * h);
    w_sum / (w_sum + alpha)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stiffness_maps_monotonically_onto_zero_to_one() {
        let h = 1.0 / 240.0;
        assert_eq!(compliance_factor(0.0, h, 2.0), 0.0);
        assert_eq!(compliance_factor(f32::NAN, h, 2.0), 0.0);
        assert!(compliance_factor(1.0, h, 2.0) > 0.9999);
        let mut last = 0.0;
        for i in 1..=10 {
            let f = compliance_factor(i as f32 / 10.0, h, 2.0);
            assert!(f > last && f <= 1.0, "{i}: {f}");
            last = f;
        }
    }

    #[test]
    fn extreme_settings_are_clamped() {
        let s = HairSimSettings {
            substep_rate: f32::INFINITY,
            max_frame_time: -3.0,
            margin_min: 0.2,
            margin_max: f32::NAN,
            damping: f32::NAN,
            gravity: Vec3::NAN,
            structure_offset: 1e9,
            ..default()
        };
        assert_eq!(s.substep(), 1.0 / 240.0);
        assert_eq!(s.frame_clamp(), 0.001);
        assert_eq!(s.margins(), (0.2, 0.2));
        assert_eq!(s.damping_factor(), 1.0);
        assert_eq!(s.gravity(), Vec3::ZERO);
        assert_eq!(s.structure_offset(), 2.0);
        let huge = HairSimSettings {
            margin_min: 1e9,
            margin_max: f32::INFINITY,
            ..default()
        };
        assert_eq!(huge.margins(), (MAX_MARGIN, MAX_MARGIN));
    }
}
