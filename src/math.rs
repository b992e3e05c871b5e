//! Small numeric helpers shared by the stages: what to do with non-finite user input, frames
//! that can be inverted, perpendicular unit vectors.

use bevy::math::{Affine3A, Vec3};

/// `v`, or `default` when `v` is NaN or infinite (user-edited settings).
#[inline]
pub(crate) fn finite_or(v: f32, default: f32) -> f32 {
    if v.is_finite() { v } else { default }
}

/// Whether a bone's (or any) world transform can be followed: finite and invertible.
pub(crate) fn usable_frame(frame: &Affine3A) -> bool {
    frame.is_finite() && frame.matrix3.determinant().abs() > 1e-12
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
        let p = orthonormalise(Vec3::new(1.0, 1.0, 0.0), Vec3::Y);
        assert!((p - Vec3::X).length() < 1e-6);
        let q = orthonormalise(Vec3::Y, Vec3::Y);
        assert!(q.dot(Vec3::Y).abs() < 1e-6 && (q.length() - 1.0).abs() < 1e-6);
    }
}
