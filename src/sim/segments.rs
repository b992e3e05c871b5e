//! Segment collision: the strand between two particles kept off spheres and capsules, not only
//! the particles, so a collider smaller than a segment (a hand between two joints of a long
//! bone chain) cannot pass through it.
//!
//! After the particles' own collisions in a substep, each segment's point nearest a sphere's
//! centre or a capsule's axis is found; when it lies strictly between the segment's ends,
//! within the collider's radius plus the lane's margin, while both ends are outside it (an end
//! inside is the particles' collision's), both ends move out along the normal, by
//! the share each end has of that point (the XPBD correction of a point on a segment: a pinned
//! root does not move and its other end takes it all). Planes need none (a segment's deepest
//! point on a plane is one of its ends), and keep-inside shapes and boxes are left to the
//! particles.

use bevy::math::{Vec3, Vec3A};

use super::solver::{
    Batch, ContactShape, LANES, PINNED, ParticleSpan, StepInput, lanes_near, set_lanes,
};

/// A segment end nearer its collider than this share of the segment is left to the particle
/// collision.
const END: f32 = 1e-4;

/// How much longer than at rest a segment is taken to be when deciding which shapes it can
/// reach.
const SEGMENT_STRETCH: f32 = 1.25;

/// A collider's core: the point or segment its radius is measured from.
#[derive(Clone, Copy)]
enum Core {
    Point(Vec3A),
    Segment(Vec3A, Vec3A),
}

impl Core {
    /// The core's point nearest `p`.
    #[inline(always)]
    fn nearest_to(self, p: Vec3A) -> Vec3A {
        match self {
            Self::Point(c) => c,
            Self::Segment(c0, c1) => c0 + (c1 - c0) * nearest_on_segment(c0, c1, p),
        }
    }

    /// The parameter of segment `a`-`b` nearest the core, and the core's point nearest it.
    #[inline(always)]
    fn nearest_on(self, a: Vec3A, b: Vec3A) -> (f32, Vec3A) {
        match self {
            Self::Point(c) => (nearest_on_segment(a, b, c), c),
            Self::Segment(c0, c1) => {
                let (t, u) = nearest_between_segments(a, b, c0, c1);
                (t, c0 + (c1 - c0) * u)
            }
        }
    }

    /// The core's bounds.
    fn bounds(self) -> (Vec3A, Vec3A) {
        match self {
            Self::Point(c) => (c, c),
            Self::Segment(c0, c1) => (c0.min(c1), c0.max(c1)),
        }
    }
}

/// `b` where it is above `m`, else `m`: `f32::max` without its NaN test (a NaN `b` is left out,
/// as `f32::max` leaves it out), so lanes side by side stay side by side.
#[inline(always)]
fn larger(m: f32, b: f32) -> f32 {
    if b > m { b } else { m }
}

impl Batch {
    /// Keeps every segment of every lane off substep `s`'s spheres and outside capsules (out of
    /// line: most hairs never come here, and the solver's loop stays as it was). `span` holds
    /// every particle ([`Batch::particle_span`]), and grows with those moved.
    #[inline(never)]
    pub(super) fn collide_segments(
        &mut self,
        input: &StepInput,
        s: usize,
        span: &mut ParticleSpan,
    ) {
        let n = input.sphere_count;
        let spheres = &input.spheres[s * n..(s + 1) * n];
        let n = input.contact_count;
        let contacts = input.contacts[s * n..(s + 1) * n]
            .iter()
            .filter(|contact| !contact.inside)
            .map(|contact| &contact.shape);
        // A segment whose ends are outside a shape's reach `r + m` dips at most to
        // `sqrt((r + m)^2 - L^2 / 4)` from its core (a chord; a capsule's distance is a
        // circle's across its axis): segments no longer than `2 sqrt(2 r m + m^2)` cannot reach
        // the shape itself, only the margin around it, and that shape is skipped.
        let particles = self.nodes.len() / 2;
        let live = self.count.clamp(1, LANES);
        // Each lane's longest segment, the lanes side by side, then the longest of the live
        // lanes ([`larger`], not `f32::max`, which tests each number for NaN one after another).
        let mut longest = [0.0f32; LANES];
        for i in 1..particles {
            let rest = &self.nodes[2 * i + 1].rest[1];
            for l in 0..LANES {
                longest[l] = larger(longest[l], rest[l]);
            }
        }
        let longest = longest[..live].iter().fold(0.0f32, |m, &r| larger(m, r));
        // Room for the stretch a substep allows before the strain limit.
        let longest = longest * SEGMENT_STRETCH;
        let margin = self.margin[..live]
            .iter()
            .fold(f32::INFINITY, |m, &r| if r < m { r } else { m });
        let short =
            |radius: f32| longest * longest <= 4.0 * (2.0 * radius * margin + margin * margin);
        // The widest margin of any lane: how far from a shape a segment can be pushed.
        let widest = self.margin.iter().fold(0.0f32, |m, &r| larger(m, r));
        for &(centre, radius) in spheres {
            if !short(radius) {
                self.push_segments(Core::Point(centre), (radius, widest), span);
            }
        }
        for shape in contacts {
            match *shape {
                ContactShape::Sphere { centre, radius } if !short(radius) => {
                    self.push_segments(Core::Point(centre), (radius, widest), span);
                }
                ContactShape::Capsule { a, b, radius } if !short(radius) => {
                    self.push_segments(Core::Segment(a, b), (radius, widest), span);
                }
                _ => {}
            }
        }
    }

    /// Pushes each segment `a`-`b` of each lane whose point nearest `core` lies strictly
    /// between its ends, within `radius` plus the lane's margin, while both ends are outside
    /// that reach (an end inside is the particle collision's; a pinned root inside cannot be
    /// turned out). `margin` is the widest lane's margin; `span` holds every particle, and
    /// grows with those moved.
    #[inline(always)]
    fn push_segments(&mut self, core: Core, (radius, margin): (f32, f32), span: &mut ParticleSpan) {
        let (lo, hi) = core.bounds();
        let (lo, hi) = (lo - (radius + margin), hi + (radius + margin));
        // No segment of any lane near the collider.
        if span.apart(lo, hi) {
            return;
        }
        // Particle `i` is node `2 i + 1`; the root particle is pinned.
        let particles = self.nodes.len() / 2;
        for i in 0..particles.saturating_sub(1) {
            let (ia, ib) = (2 * i + 1, 2 * i + 3);
            let wa = if ia < PINNED { 0.0 } else { 1.0 };
            // Far from the collider: nothing to test.
            let near = lanes_near(&self.nodes[ia].x, &self.nodes[ib].x, lo, hi);
            for l in set_lanes(near) {
                let a = get(&self.nodes[ia].x, l);
                let b = get(&self.nodes[ib].x, l);
                let (t, near) = core.nearest_on(a, b);
                if !(END..=1.0 - END).contains(&t) {
                    continue;
                }
                let reach = radius + self.margin[l];
                let reach2 = reach * reach;
                let q = a + (b - a) * t;
                let d = q - near;
                let dist2 = d.length_squared();
                if dist2 >= reach2 || dist2 <= 1e-18 {
                    continue;
                }
                if a.distance_squared(core.nearest_to(a)) < reach2
                    || b.distance_squared(core.nearest_to(b)) < reach2
                {
                    continue;
                }
                let dist = dist2.sqrt();
                let n = d / dist;
                let depth = reach - dist;
                // The correction of a point on a segment: each end by its share of the point.
                let (sa, sb) = (wa * (1.0 - t), t);
                let scale = depth / (sa * (1.0 - t) + sb * t).max(1e-6);
                if wa > 0.0 {
                    let moved = a + n * (sa * scale);
                    set(&mut self.nodes[ia].x, l, moved);
                    span.take(moved);
                }
                let moved = b + n * (sb * scale);
                set(&mut self.nodes[ib].x, l, moved);
                span.take(moved);
            }
        }
    }
}

fn get(a: &[[f32; LANES]; 3], l: usize) -> Vec3A {
    Vec3A::new(a[0][l], a[1][l], a[2][l])
}

fn set(a: &mut [[f32; LANES]; 3], l: usize, v: Vec3A) {
    let v = Vec3::from(v);
    a[0][l] = v.x;
    a[1][l] = v.y;
    a[2][l] = v.z;
}

/// The parameter of the point of segment `a`-`b` nearest `p`, in `[0, 1]`.
fn nearest_on_segment(a: Vec3A, b: Vec3A, p: Vec3A) -> f32 {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 1e-20 {
        return 0.0;
    }
    ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

/// The parameters `(t, u)` of the nearest points of segments `a`-`b` and `c`-`d`, each in
/// `[0, 1]` (for parallel segments, one of the nearest pairs).
fn nearest_between_segments(a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A) -> (f32, f32) {
    let (d1, d2, r) = (b - a, d - c, a - c);
    let (aa, ee, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    const TINY: f32 = 1e-20;
    if aa <= TINY && ee <= TINY {
        return (0.0, 0.0);
    }
    if aa <= TINY {
        return (0.0, (f / ee).clamp(0.0, 1.0));
    }
    let cc = d1.dot(r);
    if ee <= TINY {
        return ((-cc / aa).clamp(0.0, 1.0), 0.0);
    }
    let bb = d1.dot(d2);
    let denom = aa * ee - bb * bb;
    let mut t = if denom > TINY * aa * ee {
        ((bb * f - cc * ee) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut u = (bb * t + f) / ee;
    if u < 0.0 {
        u = 0.0;
        t = (-cc / aa).clamp(0.0, 1.0);
    } else if u > 1.0 {
        u = 1.0;
        t = ((bb - cc) / aa).clamp(0.0, 1.0);
    }
    (t, u)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the nearest pair over a fine grid of both segments.
    fn brute(a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A) -> f32 {
        let mut best = f32::INFINITY;
        for i in 0..=400 {
            for j in 0..=400 {
                let p = a.lerp(b, i as f32 / 400.0);
                let q = c.lerp(d, j as f32 / 400.0);
                best = best.min(p.distance(q));
            }
        }
        best
    }

    #[test]
    fn nearest_points_between_segments_match_a_brute_force_search() {
        let cases = [
            // Crossing, skew.
            (
                Vec3A::new(-1.0, 0.0, 0.0),
                Vec3A::new(1.0, 0.0, 0.0),
                Vec3A::new(0.2, -1.0, 0.5),
                Vec3A::new(0.2, 1.0, 0.5),
            ),
            // Parallel, overlapping.
            (
                Vec3A::ZERO,
                Vec3A::X,
                Vec3A::new(0.5, 0.3, 0.0),
                Vec3A::new(1.5, 0.3, 0.0),
            ),
            // End to end.
            (
                Vec3A::ZERO,
                Vec3A::X,
                Vec3A::new(2.0, 1.0, 0.0),
                Vec3A::new(3.0, 2.0, 0.0),
            ),
            // A point against a segment.
            (
                Vec3A::new(0.3, 0.4, 0.0),
                Vec3A::new(0.3, 0.4, 0.0),
                Vec3A::ZERO,
                Vec3A::X,
            ),
        ];
        for (a, b, c, d) in cases {
            let (t, u) = nearest_between_segments(a, b, c, d);
            let got = a.lerp(b, t).distance(c.lerp(d, u));
            let want = brute(a, b, c, d);
            assert!(
                (got - want).abs() < 5e-3,
                "{a} {b} {c} {d}: {got} vs {want}"
            );
        }
    }
}
