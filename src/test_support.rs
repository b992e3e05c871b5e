//! What several test modules share.

use bevy::math::Vec3;

/// A small deterministic generator (xorshift) for random test inputs.
pub(crate) struct Rng(pub u64);

impl Rng {
    /// Uniform in `[0, 1)`.
    pub(crate) fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[-1, 1)`.
    pub(crate) fn next(&mut self) -> f32 {
        self.unit() * 2.0 - 1.0
    }

    /// Each coordinate uniform in `[-scale, scale)`.
    pub(crate) fn vec3(&mut self, scale: f32) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next()) * scale
    }
}
