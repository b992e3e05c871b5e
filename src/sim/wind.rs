//! Wind: a global [`HairWind`] resource, or a [`HairWind`] component on a hair that overrides
//! it. Each particle's velocity is pulled toward the wind's (a drag, so loose tips follow it
//! more than anchored roots), and gusts vary its strength smoothly in time, each strand at its
//! own phase (seeded). Wind is sampled at each substep's own time, so it does not depend on the
//! frame rate.

use bevy::prelude::*;

use crate::math::finite_or;

/// Wind on hair. As a resource it blows on every hair; a [`HairWindOverride`] on a hair replaces
/// it for that hair. Every field may change every frame; the panel edits the resource.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub struct HairWind {
    /// The air's mean velocity, metres per second (world space). Default: zero (no wind).
    pub velocity: Vec3,
    /// How fast a particle's velocity is pulled toward the wind's, per second: higher makes
    /// hair follow the wind more closely. Clamped to `[0, 100]`. Default: `3.0`.
    pub drag: f32,
    /// Gust strength: the wind's speed swings by up to this fraction of itself. Clamped to
    /// `[0, 2]`. Default: `0.5`.
    pub gust: f32,
    /// Gusts per second, about. Clamped to `[0, 20]`. Default: `0.4`.
    pub gust_frequency: f32,
    /// Seeds each strand's gust phase. Default: `1`.
    pub seed: u64,
}

/// A hair's own wind, instead of the [`HairWind`] resource (a character indoors: a calm
/// `HairWind::default()`; a hair in a fan's stream).
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairWindOverride(pub HairWind);

impl Default for HairWind {
    fn default() -> Self {
        Self {
            velocity: Vec3::ZERO,
            drag: 3.0,
            gust: 0.5,
            gust_frequency: 0.4,
            seed: 1,
        }
    }
}

impl HairWind {
    /// Whether this wind moves anything.
    pub fn is_calm(&self) -> bool {
        !self.velocity.is_finite() || self.velocity == Vec3::ZERO || self.drag() == 0.0
    }

    /// Drag after clamping.
    pub fn drag(&self) -> f32 {
        finite_or(self.drag, 3.0).clamp(0.0, 100.0)
    }

    /// The wind's speed factor at time `t` (seconds) for a strand at gust phase `phase`:
    /// `1 + gust * n(t)`, with `n` a smooth noise in `[-1, 1]` (three incommensurate waves).
    pub fn gust_factor(&self, t: f32, phase: f32) -> f32 {
        let gust = finite_or(self.gust, 0.5).clamp(0.0, 2.0);
        let f = finite_or(self.gust_frequency, 0.4).clamp(0.0, 20.0);
        let x = std::f32::consts::TAU * f * (t + phase);
        let n = (x.sin() + 0.5 * (2.31 * x + 1.7).sin() + 0.25 * (4.13 * x + 0.3).sin()) / 1.75;
        (1.0 + gust * n).max(0.0)
    }

    /// A strand's gust phase, seconds: a hash of (seed, strand) in `[0, 100)`.
    pub fn phase(&self, strand: u32) -> f32 {
        let mut z = self.seed ^ u64::from(strand).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 31)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z ^= z >> 29;
        (z >> 40) as f32 / (1u64 << 24) as f32 * 100.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gusts_are_smooth_bounded_and_seeded() {
        let w = HairWind {
            velocity: Vec3::X,
            ..default()
        };
        let mut last = w.gust_factor(0.0, 0.0);
        for i in 1..1000 {
            let g = w.gust_factor(i as f32 / 240.0, 0.0);
            assert!((0.5..=1.5).contains(&g), "{g}");
            assert!((g - last).abs() < 0.02, "not smooth at {i}: {last} -> {g}");
            last = g;
        }
        assert_ne!(w.phase(3), w.phase(4));
        assert_eq!(w.phase(3), w.phase(3));
        assert!(HairWind::default().is_calm());
        assert!(!w.is_calm());
        let bad = HairWind {
            gust: f32::NAN,
            gust_frequency: f32::INFINITY,
            drag: -4.0,
            ..w
        };
        assert!(bad.gust_factor(1.0, 2.0).is_finite());
        assert_eq!(bad.drag(), 0.0);
    }
}
