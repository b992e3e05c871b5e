//! The colliders near a hair, found without testing every collider of the world: each frame the
//! colliders' boxes are sorted along the world's X axis once, and each hair takes the run whose
//! boxes can overlap its own along X (two binary searches). A crowd of a hundred characters has
//! four hundred colliders; each hair meets its own character's four.
//!
//! The index only narrows the list: every collider it returns is still tested whole by the
//! caller, and it returns them in the order they were added, so what a hair meets, and in which
//! order its contacts are solved, is what testing every collider would give.

use bevy::math::Vec3A;

/// The colliders' boxes along X, rebuilt every frame ([`clear`](Self::clear), [`add`](Self::add)
/// for each collider in order, [`sort`](Self::sort)).
#[derive(Clone, Debug, Default)]
pub(super) struct ColliderIndex {
    /// `(lowest X, collider)` of each collider with a finite box, sorted by X.
    by_x: Vec<(f32, u32)>,
    /// Colliders without a finite box along X (planes, keep-inside shapes, unusable poses):
    /// every hair gets them.
    everywhere: Vec<u32>,
    /// The widest finite box along X (grown a little against rounding).
    widest: f32,
}

impl ColliderIndex {
    /// Empties the index for a new frame.
    pub(super) fn clear(&mut self) {
        self.by_x.clear();
        self.everywhere.clear();
        self.widest = 0.0;
    }

    /// Colliders added since the last [`clear`](Self::clear).
    fn count(&self) -> u32 {
        u32::try_from(self.by_x.len() + self.everywhere.len()).unwrap_or(u32::MAX)
    }

    /// Adds the next collider, whose shapes lie within `boxes` (their boxes, any number of them;
    /// the index keeps the X extent of their union).
    pub(super) fn add(&mut self, boxes: impl IntoIterator<Item = (Vec3A, Vec3A)>) {
        let (lo, hi) = boxes
            .into_iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(a.x), hi.max(b.x))
            });
        let i = self.count();
        if lo.is_finite() && hi.is_finite() && lo <= hi {
            self.by_x.push((lo, i));
            self.widest = self.widest.max(hi - lo);
        } else {
            self.everywhere.push(i);
        }
    }

    /// Sorts what was added: call once after the last [`add`](Self::add) of a frame.
    pub(super) fn sort(&mut self) {
        self.by_x.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        // Rounding in `hi - lo` must not drop a collider that touches a hair's box.
        self.widest = self.widest * (1.0 + 1e-4) + 1e-4;
    }

    /// Into `out` (emptied first), in the order they were added: every collider whose box, grown
    /// by `margin`, can overlap `reach` along X. A superset of the colliders whose box overlaps
    /// `reach` in all three axes; every collider for a `reach` without finite bounds.
    pub(super) fn near(&self, reach: (Vec3A, Vec3A), margin: f32, out: &mut Vec<u32>) {
        out.clear();
        // A little wider than the caller's test, whose rounding may differ.
        let slack = 1e-3 + 1e-6 * reach.0.x.abs().max(reach.1.x.abs());
        let (from, to) = (
            reach.0.x - margin - self.widest - slack,
            reach.1.x + margin + slack,
        );
        if !(from.is_finite() && to.is_finite()) {
            out.extend(0..self.count());
            return;
        }
        let first = self.by_x.partition_point(|&(lo, _)| lo < from);
        let end = self.by_x.partition_point(|&(lo, _)| lo <= to);
        out.extend(self.by_x[first..end.max(first)].iter().map(|&(_, i)| i));
        out.extend_from_slice(&self.everywhere);
        out.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator.
    struct Lcg(u64);

    impl Lcg {
        fn next(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn overlaps(a: (Vec3A, Vec3A), b: (Vec3A, Vec3A), margin: f32) -> bool {
        (a.0 - margin).cmple(b.1).all() && (a.1 + margin).cmpge(b.0).all()
    }

    /// Against testing every collider: random boxes (some infinite, some empty, some touching
    /// the hair's box exactly), random hair boxes and margins; the index's list, filtered by the
    /// same test, is exactly the colliders that meet, in the order they were added.
    #[test]
    fn near_colliders_are_those_every_collider_tested_would_give_in_order() {
        let mut rng = Lcg(7);
        let mut index = ColliderIndex::default();
        let mut out = Vec::new();
        for round in 0..200 {
            let count = (rng.next() * 60.0) as usize;
            let mut boxes = Vec::new();
            index.clear();
            for _ in 0..count {
                let lo = Vec3A::new(rng.next(), rng.next(), rng.next()) * 100.0 - 50.0;
                let size = Vec3A::new(rng.next(), rng.next(), rng.next()) * 4.0;
                let b = match (rng.next() * 10.0) as u32 {
                    0 => (Vec3A::NEG_INFINITY, Vec3A::INFINITY),
                    1 => (Vec3A::INFINITY, Vec3A::NEG_INFINITY),
                    _ => (lo, lo + size),
                };
                // A collider of two shapes, the second beside the first.
                let shift = Vec3A::X * (rng.next() * 3.0);
                index.add([b, (b.0 + shift, b.1 + shift)]);
                boxes.push((b.0.min(b.0 + shift), b.1.max(b.1 + shift)));
            }
            index.sort();
            let lo = Vec3A::new(rng.next(), rng.next(), rng.next()) * 100.0 - 50.0;
            let mut reach = (lo, lo + Vec3A::splat(rng.next() * 10.0));
            if round % 7 == 0 && count > 0 {
                // Touching a collider's box exactly along X.
                reach.0.x = boxes[0].1.x;
            }
            let margin = rng.next() * 0.5;
            index.near(reach, margin, &mut out);
            assert!(out.windows(2).all(|w| w[0] < w[1]), "not in order: {out:?}");
            let found: Vec<u32> = out
                .iter()
                .copied()
                .filter(|&i| overlaps(boxes[i as usize], reach, margin))
                .collect();
            let every: Vec<u32> = (0..count as u32)
                .filter(|&i| overlaps(boxes[i as usize], reach, margin))
                .collect();
            assert_eq!(found, every, "round {round}");
        }
    }

    /// The point of it: in a row of a hundred characters a metre apart, a hair near one of them
    /// gets that character's colliders and its neighbours', not all of them.
    #[test]
    fn a_hair_in_a_crowd_gets_only_the_colliders_around_it() {
        let mut index = ColliderIndex::default();
        for character in 0..100 {
            let x = character as f32;
            for _ in 0..4 {
                index.add([(
                    Vec3A::new(x - 0.2, 1.0, -0.2),
                    Vec3A::new(x + 0.2, 1.8, 0.2),
                )]);
            }
        }
        index.sort();
        let mut out = Vec::new();
        let reach = (Vec3A::new(49.7, 1.2, -0.3), Vec3A::new(50.3, 1.9, 0.3));
        index.near(reach, 0.05, &mut out);
        assert_eq!(out, (200..204).collect::<Vec<u32>>());
        // Infinite reach: every collider.
        index.near((Vec3A::NEG_INFINITY, Vec3A::INFINITY), 0.0, &mut out);
        assert_eq!(out.len(), 400);
    }
}
