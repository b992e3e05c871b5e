//! Small numeric helpers shared by the stages: what to do with non-finite user input, frames
//! that can be inverted, perpendicular unit vectors.

use bevy::math::{Affine3A, Vec3};

/// `v`, or `default` when `v` is NaN or infinite (user-edited settings).
#[inline]
pub(crate) fn finite_or(v: f32, default: f32) -> f32 {
    if v.is_finite() { v } else { default }
}

/// Farthest from the world origin (metres) a frame the hair follows may be. Past it an `f32`
/// position is coarser than 6 cm, so hair cannot be simulated there anyway.
pub(crate) const MAX_FRAME_DISTANCE: f32 = 1e6;
/// Range of axis scales a frame the hair follows may have: a centimetre rig under a 0.01
/// armature is 0.01, a character a thousand times its size 1000. Past that the solver's lengths,
/// gravity and margins scale out of the range it is tested in (a bone of scale 6,329 threw a
/// strand 40,000 km: found by the solver fuzz target).
pub(crate) const FRAME_SCALE_RANGE: (f32, f32) = (1e-4, 1e3);

/// Whether a bone's (or any) world transform can be followed: finite, invertible, within
/// [`MAX_FRAME_DISTANCE`] of the origin and with axis scales within [`FRAME_SCALE_RANGE`]. A
/// finite transform of huge scale or distance would overflow the solver's arithmetic to NaN.
pub(crate) fn usable_frame(frame: &Affine3A) -> bool {
    let (lo, hi) = FRAME_SCALE_RANGE;
    let axes = [
        frame.matrix3.x_axis,
        frame.matrix3.y_axis,
        frame.matrix3.z_axis,
    ];
    frame.is_finite()
        && frame.translation.abs().max_element() <= MAX_FRAME_DISTANCE
        && axes.iter().all(|a| (lo..=hi).contains(&a.length()))
        && frame.matrix3.determinant().abs() > 1e-12
}

/// `v` made perpendicular to unit `t` and normalised; any perpendicular when `v` is parallel to
/// `t` (or zero).
pub(crate) fn orthonormalise(v: Vec3, t: Vec3) -> Vec3 {
    (v - t * t.dot(v))
        .try_normalize()
        .unwrap_or_else(|| t.any_orthonormal_vector())
}

/// The largest of an affine transform's axis scales (what a radius grows by).
pub(crate) fn largest_scale(m: &Affine3A) -> f32 {
    m.matrix3
        .x_axis
        .length()
        .max(m.matrix3.y_axis.length())
        .max(m.matrix3.z_axis.length())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers_handle_bad_input() {
        assert_eq!(finite_or(f32::NAN, 2.0), 2.0);
        assert_eq!(finite_or(f32::INFINITY, 2.0), 2.0);
        assert_eq!(finite_or(-3.0, 2.0), -3.0);
        assert!(usable_frame(&Affine3A::IDENTITY));
        assert!(!usable_frame(&Affine3A::from_scale(Vec3::new(
            1.0, 0.0, 1.0
        ))));
        assert!(!usable_frame(&Affine3A::from_translation(Vec3::NAN)));
        // Finite but overflowing: found by the solver fuzz target (a 3e19 scale made NaN).
        assert!(!usable_frame(&Affine3A::from_scale(Vec3::splat(-3.2e19))));
        assert!(!usable_frame(&Affine3A::from_translation(Vec3::new(
            0.0, 0.0, 2e11
        ))));
        assert!(usable_frame(&Affine3A::from_scale(Vec3::splat(0.01))));
        assert!(usable_frame(&Affine3A::from_scale(Vec3::splat(1000.0))));
        // Found by the solver fuzz target: a scale of 6,329 threw a strand 40,000 km.
        assert!(!usable_frame(&Affine3A::from_scale(Vec3::splat(-6328.7))));
        assert!(usable_frame(&Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            bevy::math::Quat::from_rotation_y(1.0),
            Vec3::new(9e5, 0.0, -9e5),
        )));
        let p = orthonormalise(Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        assert!((p - Vec3::X).length() < 1e-6);
        let q = orthonormalise(Vec3::Y, Vec3::Y);
        assert!(q.dot(Vec3::Y).abs() < 1e-6 && (q.length() - 1.0).abs() < 1e-6);
    }
}
