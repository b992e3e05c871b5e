//! Wind: a global [`HairWind`] resource, or a [`HairWind`] component on a hair that overrides
//! it; and local [`HairForceField`]s (a fan, a passing car, a blast), spawned as entities. Each particle's velocity is pulled toward the wind's (a drag, so loose tips follow it
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

/// A local wind, spawned as an entity with a `Transform`: a passing car's draught, a fan, a
/// blast. Inside its radius, particles' velocities are pulled toward the field's air velocity
/// like [`HairWind`]'s (a drag, so loose tips follow more than anchored roots), the pull fading
/// smoothly to nothing at the radius. The field moves, turns and scales with its entity and is
/// followed per substep, so it does not depend on the frame rate. Every field may change every
/// frame (the panel edits them); despawn the entity to end it.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
#[require(Transform)]
pub struct HairForceField {
    /// Which way the air moves.
    pub kind: HairForceFieldKind,
    /// The air's speed, metres per second (negative: toward the centre, for a point field).
    /// Clamped to `[-1000, 1000]`. Default: `10.0`.
    pub speed: f32,
    /// How far the field reaches from its entity's origin, metres (times the entity's scale).
    /// The pull fades as `(1 - (d / radius)^2)^2`. Clamped to `[0, 1000]`. Default: `1.0`.
    pub radius: f32,
    /// How fast a particle's velocity is pulled toward the air's at the centre, per second.
    /// Clamped to `[0, 100]`. Default: `3.0`.
    pub drag: f32,
}

/// The direction of a [`HairForceField`]'s air.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Debug, Default, PartialEq)]
pub enum HairForceFieldKind {
    /// Away from the entity's origin (a blast, a fan blowing all round). Default.
    #[default]
    Point,
    /// Along the entity's local `-Z` (its forward, like a camera or a light): a fan, a draught.
    Directional,
}

impl Default for HairForceField {
    fn default() -> Self {
        Self {
            kind: HairForceFieldKind::Point,
            speed: 10.0,
            radius: 1.0,
            drag: 3.0,
        }
    }
}

impl HairForceField {
    /// Radius after clamping.
    pub fn radius(&self) -> f32 {
        finite_or(self.radius, 1.0).clamp(0.0, 1000.0)
    }

    /// Drag after clamping.
    pub fn drag(&self) -> f32 {
        finite_or(self.drag, 3.0).clamp(0.0, 100.0)
    }

    /// Speed after clamping to `[-1000, 1000]` m/s (`0` when not finite).
    pub fn speed(&self) -> f32 {
        finite_or(self.speed, 0.0).clamp(-1000.0, 1000.0)
    }

    /// Whether this field moves anything.
    pub fn is_calm(&self) -> bool {
        self.speed() == 0.0 || self.radius() == 0.0 || self.drag() == 0.0
    }
}

/// One force field for one substep, in world space, for the solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldStep {
    /// The field's origin.
    pub centre: Vec3,
    /// `Some(unit direction)` for a directional field; `None`: away from the centre.
    pub direction: Option<Vec3>,
    /// Air speed times the substep (metres per substep).
    pub speed_h: f32,
    /// Radius, metres.
    pub radius: f32,
    /// The share of the velocity gap closed at the centre this substep: `1 - exp(-drag h)`.
    pub pull: f32,
}

impl FieldStep {
    /// The velocity (per substep) `v` of a node at `x` becomes, under this field.
    #[inline]
    pub fn blow(&self, x: Vec3, v: Vec3) -> Vec3 {
        let d = x - self.centre;
        let q = d.length_squared() / (self.radius * self.radius);
        if q.is_nan() || q >= 1.0 {
            return v;
        }
        let fade = (1.0 - q) * (1.0 - q);
        let dir = match self.direction {
            Some(dir) => dir,
            None => d.normalize_or_zero(),
        };
        v + (dir * self.speed_h - v) * (self.pull * fade)
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
