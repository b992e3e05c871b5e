//! The quadratic curves that shape hair along its length.
//!
//! The thesis controls three things with `value = a*x^2 + b*x + c`, `x` in `[0, 1]` from root to
//! tip: the tube radius (the **H** curve), the anchor stiffness (the **S** curve) and the
//! silhouette fade (the **E** curve). The same formula is mirrored in WGSL
//! (`bevy_cartoon_hair::curves::quadratic`).

use bevy::prelude::*;

use crate::math::finite_or;

/// `value = a*x^2 + b*x + c` over `x` in `[0, 1]` from root (`0`) to tip (`1`).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct QuadraticCurve {
    /// Quadratic term: bends the curve. Default: `0.0`.
    pub a: f32,
    /// Linear term: slope from root to tip. Default: `0.0`.
    pub b: f32,
    /// Constant term: the value at the root. Default: `1.0`.
    pub c: f32,
}

impl Default for QuadraticCurve {
    fn default() -> Self {
        Self::constant(1.0)
    }
}

impl QuadraticCurve {
    /// A curve from its three coefficients.
    pub const fn new(a: f32, b: f32, c: f32) -> Self {
        Self { a, b, c }
    }

    /// The same value everywhere.
    pub const fn constant(c: f32) -> Self {
        Self::new(0.0, 0.0, c)
    }

    /// Straight from `root` to `tip`.
    pub const fn linear(root: f32, tip: f32) -> Self {
        Self::new(0.0, tip - root, root)
    }

    /// The curve's value at `x`; `x` is clamped to `[0, 1]` (`0` when not finite).
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        let x = finite_or(x, 0.0).clamp(0.0, 1.0);
        (self.a * x + self.b) * x + self.c
    }

    /// Like [`QuadraticCurve::eval`] but clamped to `[0, 1]` and `0` for non-finite results: for
    /// stiffnesses and alphas.
    #[inline]
    pub fn eval_unit(&self, x: f32) -> f32 {
        finite_or(self.eval(x), 0.0).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evaluates_the_quadratic_and_clamps_x() {
        let c = QuadraticCurve::new(1.0, -2.0, 3.0);
        assert_eq!(c.eval(0.0), 3.0);
        assert_eq!(c.eval(1.0), 2.0);
        assert_eq!(c.eval(0.5), 0.25 - 1.0 + 3.0);
        assert_eq!(c.eval(7.0), c.eval(1.0));
        assert_eq!(c.eval(f32::NAN), 3.0);
        assert_eq!(QuadraticCurve::linear(1.0, 0.0).eval(0.25), 0.75);
        assert_eq!(QuadraticCurve::constant(5.0).eval_unit(0.3), 1.0);
        assert_eq!(
            QuadraticCurve::new(f32::INFINITY, 0.0, 0.0).eval_unit(1.0),
            0.0
        );
    }
}
