//! The strand tube mesh (thesis 4.3.1-4.3.2).
//!
//! Each simulated strand is a polyline of particles, root first. It is drawn as a closed, tapered
//! tube around a smooth centripetal Catmull-Rom spline through the particles.
//!
//! * [`sample_spline`] samples the spline.
//! * [`TubeTopology`] is built once per (hair resolution, shape resolution): the triangle list and
//!   the UVs, which never change.
//! * [`build_tube`] rewrites positions, normals and (optionally) tangents every frame, without
//!   allocating.
//!
//! ## Vertex layout
//!
//! `rings * sides` ring vertices, ring by ring from root to tip (vertex `ring * sides + side`),
//! then the root cap centre (`rings * sides`) and the tip cap centre (`rings * sides + 1`). The
//! caps are triangle fans, so the mesh is closed: every edge belongs to exactly two triangles,
//! which the silhouette edge adjacency relies on.
//!
//! ## No UV seam
//!
//! Ring vertices are not duplicated at a seam, so index adjacency is true geometric adjacency.
//! `u = side / sides` runs around the ring from `0` up to (but not reaching) `1`; the triangles
//! that close the ring interpolate `u` from `(sides - 1) / sides` back to `0`, so shaders that
//! texture around the tube should wrap (`fract`) or use textures that do not depend on `u`.
//! `v` runs along the strand: `0` at the root ring, `1` at the tip ring. The cap centres have
//! `u = 0.5` and `v = 0` / `v = 1`.
//!
//! ## Frames
//!
//! Rings are oriented by parallel transport (a rotation-minimising frame) of a root frame along
//! the spline. The root frame is the caller's [`FrameReference`] carried by the smallest rotation
//! from the reference direction onto the strand's root direction, so the rings neither twist nor
//! flip while the strand moves, as long as the root direction stays away from the exact opposite
//! of the reference direction.

use bevy::math::{Vec3, Vec3A};

use super::section::{LockSection, SectionSide, fill_section};
use crate::math::orthonormalise;

/// The fewest rings (samples along the strand) a tube has.
pub const MIN_RINGS: usize = 2;
/// The most rings (samples along the strand) a tube has.
pub const MAX_RINGS: usize = 256;
/// The fewest vertices per ring.
pub const MIN_SIDES: usize = 3;
/// The most vertices per ring.
pub const MAX_SIDES: usize = 64;
/// Vertices after a strand's rings: the centres of its root and tip caps.
pub const CAP_VERTICES: usize = 2;
/// Vertices a ring of a ribbon has ([`TubeTopology::ribbon`]).
pub const RIBBON_SIDES: usize = 2;

/// Below this total length (world units) a strand is degenerate and drawn as the fallback tube.
const MIN_STRAND_LENGTH: f32 = 1e-6;
/// Length and largest radius of the fallback tube drawn for degenerate strands.
const FALLBACK_SIZE: f32 = 1e-4;
/// Largest tilt of the normals caused by the taper (|dr/ds|).
const MAX_TAPER_SLOPE: f32 = 1e3;

/// Samples a centripetal Catmull-Rom spline (alpha `0.5`: no cusps or self-intersections within a
/// segment) through `points` into `out`.
///
/// `out` is cleared and receives `samples.max(2)` points, spread evenly over the points' chord
/// length (the cumulative distance between consecutive points, which is close to arc length and
/// does not depend on how the particles are spaced); within a segment the curve is the
/// centripetal Catmull-Rom curve. The first sample is exactly `points[0]` and the last exactly
/// `points.last()`; interior points are passed through too. The ends are extended by mirrored
/// phantom points (`2 * p0 - p1`), which keeps the end tangents along the end segments (duplicated
/// end points would give zero end tangents and bunch the samples up near the ends).
///
/// Two points give an evenly sampled straight segment; one point (or coincident points) gives
/// copies of it; no points give zeros. Coincident neighbours never produce NaN. Non-finite input
/// gives unspecified output ([`build_tube`] checks for it). Does not allocate when `out` has the
/// capacity.
pub fn sample_spline(points: &[Vec3], samples: usize, out: &mut Vec<Vec3>) {
    spline(points, samples, out);
}

/// [`sample_spline`], returning the chord length of `points` (`0` for fewer than two points).
fn spline(points: &[Vec3], samples: usize, out: &mut Vec<Vec3>) -> f32 {
    let samples = samples.max(2);
    out.clear();
    let (first, last) = match points {
        [] => {
            out.resize(samples, Vec3::ZERO);
            return 0.0;
        }
        [p] => {
            out.resize(samples, *p);
            return 0.0;
        }
        [first, .., last] => (*first, *last),
    };
    let total: f32 = points.windows(2).map(|w| w[0].distance(w[1])).sum();
    if !(total > 0.0 && total.is_finite()) {
        out.resize(samples - 1, first);
        out.push(last);
        return total;
    }
    let step = total / (samples - 1) as f32;
    let mut curve = Segment::first(points);
    let mut segment_start = 0.0;
    out.push(first);
    for j in 1..samples - 1 {
        let s = j as f32 * step;
        while curve.index + 2 < points.len() && s > segment_start + curve.length {
            segment_start += curve.length;
            curve = curve.next(points);
        }
        let u = if curve.length > 0.0 {
            ((s - segment_start) / curve.length).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(curve.eval(u));
    }
    out.push(last);
    total
}

/// One centripetal Catmull-Rom segment in cubic (Horner) form, `((a u + b) u + c) u + d`, and
/// the chord lengths around it so that walking to the next segment measures one new distance.
struct Segment {
    /// The segment runs from `points[index]` to `points[index + 1]`.
    index: usize,
    /// `|p2 - p1|`: this segment's chord length.
    length: f32,
    /// `|p3 - p2|`: the next segment's chord length (the phantom's for the last segment).
    next_length: f32,
    /// Knot intervals `|p1 - p0|^0.5`, `|p2 - p1|^0.5`, `|p3 - p2|^0.5` (centripetal).
    knots: [f32; 3],
    a: Vec3,
    b: Vec3,
    c: Vec3,
    d: Vec3,
}

impl Segment {
    /// The first segment (`points.len() >= 2`).
    fn first(points: &[Vec3]) -> Self {
        // The mirrored phantom p0 = 2 p1 - p2 is as far from p1 as p2 is.
        let length = points[0].distance(points[1]);
        Self::new(points, 0, [length.sqrt(), length.sqrt()], length)
    }

    /// The segment after this one (`self.index + 2 < points.len()`).
    fn next(&self, points: &[Vec3]) -> Self {
        Self::new(
            points,
            self.index + 1,
            [self.knots[1], self.knots[2]],
            self.next_length,
        )
    }

    /// Segment `i`, given its first two knot intervals and its chord length.
    fn new(points: &[Vec3], i: usize, [t01, t12]: [f32; 2], length: f32) -> Self {
        let p1 = points[i];
        let p2 = points[i + 1];
        let p0 = if i > 0 { points[i - 1] } else { 2.0 * p1 - p2 };
        let (p3, next_length) = match points.get(i + 2) {
            Some(&p3) => (p3, p2.distance(p3)),
            None => (2.0 * p2 - p1, length),
        };
        let t23 = next_length.sqrt();
        let m1 = p2 - p1 + t12 * ((p1 - p0) * safe_recip(t01) - (p2 - p0) * safe_recip(t01 + t12));
        let m2 = p2 - p1 + t12 * ((p3 - p2) * safe_recip(t23) - (p3 - p1) * safe_recip(t12 + t23));
        Self {
            index: i,
            length,
            next_length,
            knots: [t01, t12, t23],
            a: 2.0 * (p1 - p2) + m1 + m2,
            b: -3.0 * (p1 - p2) - 2.0 * m1 - m2,
            c: m1,
            d: p1,
        }
    }

    fn eval(&self, u: f32) -> Vec3 {
        ((self.a * u + self.b) * u + self.c) * u + self.d
    }
}

/// `1 / t`, or zero where `t` vanishes (then the vector it scales, of length `t^2`, vanishes too).
fn safe_recip(t: f32) -> f32 {
    if t > 1e-20 { t.recip() } else { 0.0 }
}

/// The triangle list and UVs of a strand tube: built once, shared by every strand with the same
/// resolution. See the [module documentation](self) for the vertex layout and the UV seam.
#[derive(Clone, Debug, PartialEq)]
pub struct TubeTopology {
    rings: usize,
    sides: usize,
    /// A half tube turned to the camera ([`TubeTopology::facing`]), or a ribbon
    /// ([`TubeTopology::ribbon`]).
    facing: bool,
    /// A ribbon facing the camera ([`TubeTopology::ribbon`]).
    ribbon: bool,
    /// Sides of the closed tube it is (half of, when facing).
    closed_sides: usize,
    /// `(cos, sin)` of each side's angle around the ring.
    cos_sin: Vec<(f32, f32)>,
    /// Triangle list, counter-clockwise seen from outside (outward facing): the walls ring by ring
    /// from the root, then the root cap fan, then the tip cap fan.
    pub indices: Vec<u32>,
    /// One `[u, v]` per vertex: `u = side / sides` around the ring (no seam column), `v` from `0`
    /// at the root ring to `1` at the tip ring.
    pub uvs: Vec<[f32; 2]>,
}

impl TubeTopology {
    /// A tube with `rings` samples along the strand (the "hair resolution", clamped to
    /// [`MIN_RINGS`]`..=`[`MAX_RINGS`]) and `sides` vertices per ring (the "shape resolution",
    /// clamped to [`MIN_SIDES`]`..=`[`MAX_SIDES`]).
    pub fn new(rings: usize, sides: usize) -> Self {
        let rings = rings.clamp(MIN_RINGS, MAX_RINGS);
        let sides = sides.clamp(MIN_SIDES, MAX_SIDES);
        let cos_sin = (0..sides)
            .map(|k| {
                let (sin, cos) = (std::f64::consts::TAU * k as f64 / sides as f64).sin_cos();
                (cos as f32, sin as f32)
            })
            .collect();
        let at = |ring: usize, side: usize| (ring * sides + side % sides) as u32;
        let mut indices = Vec::with_capacity(6 * sides * rings);
        for r in 0..rings - 1 {
            for k in 0..sides {
                let (a0, a1, b0, b1) = (at(r, k), at(r, k + 1), at(r + 1, k), at(r + 1, k + 1));
                indices.extend_from_slice(&[a0, a1, b1, a0, b1, b0]);
            }
        }
        let root = (rings * sides) as u32;
        let tip = root + 1;
        for k in 0..sides {
            indices.extend_from_slice(&[root, at(0, k + 1), at(0, k)]);
        }
        for k in 0..sides {
            indices.extend_from_slice(&[tip, at(rings - 1, k), at(rings - 1, k + 1)]);
        }
        let mut uvs = Vec::with_capacity(rings * sides + 2);
        for r in 0..rings {
            let v = r as f32 / (rings - 1) as f32;
            uvs.extend((0..sides).map(|k| [k as f32 / sides as f32, v]));
        }
        uvs.push([0.5, 0.0]);
        uvs.push([0.5, 1.0]);
        Self {
            rings,
            sides,
            facing: false,
            ribbon: false,
            closed_sides: sides,
            cos_sin,
            indices,
            uvs,
        }
    }

    /// The half of a closed tube of `sides` sides that a camera sees: each ring has
    /// `sides / 2 + 1` vertices (rounded up, at least 3), the closed ring's vertices that bound
    /// the faces turned to the eye ([`TubeParams::eye`]), chosen ring by ring. So it draws the
    /// closed tube's front faces, its outline and normals, from half the triangles; the caps
    /// are half fans. `u` runs from `0.25` at one end of a ring to `0.75` at the other,
    /// whichever way the tube has turned, so a texture around the tube stays put on screen
    /// rather than on the strand. Not closed: only for a tube seen by the one camera it faces.
    pub fn facing(rings: usize, sides: usize) -> Self {
        let rings = rings.clamp(MIN_RINGS, MAX_RINGS);
        let closed = Self::new(2, sides);
        let closed_sides = closed.sides;
        let cos_sin = closed.cos_sin;
        let sides = Self::facing_sides(sides);
        let at = |ring: usize, side: usize| (ring * sides + side) as u32;
        let mut indices = Vec::with_capacity(6 * (sides - 1) * rings);
        for r in 0..rings - 1 {
            for k in 0..sides - 1 {
                let (a0, a1, b0, b1) = (at(r, k), at(r, k + 1), at(r + 1, k), at(r + 1, k + 1));
                indices.extend_from_slice(&[a0, a1, b1, a0, b1, b0]);
            }
        }
        let root = (rings * sides) as u32;
        let tip = root + 1;
        for k in 0..sides - 1 {
            indices.extend_from_slice(&[root, at(0, k + 1), at(0, k)]);
        }
        for k in 0..sides - 1 {
            indices.extend_from_slice(&[tip, at(rings - 1, k), at(rings - 1, k + 1)]);
        }
        let mut uvs = Vec::with_capacity(rings * sides + 2);
        for r in 0..rings {
            let v = r as f32 / (rings - 1) as f32;
            uvs.extend((0..sides).map(|k| [0.25 + 0.5 * k as f32 / (sides - 1) as f32, v]));
        }
        uvs.push([0.5, 0.0]);
        uvs.push([0.5, 1.0]);
        Self {
            rings,
            sides,
            facing: true,
            ribbon: false,
            closed_sides,
            cos_sin,
            indices,
            uvs,
        }
    }

    /// A strand drawn as a flat ribbon turned to the camera, for strands a few pixels wide:
    /// each ring has two vertices, at the ring's centre plus and minus its radius across the
    /// strand and the way to the eye ([`TubeParams::eye`]), so its outline is the round tube's
    /// from two triangles a segment. Its normals lean from the eye by half a right angle at
    /// either edge, and `u` runs `0.25` to `0.75` across it, as on a half tube. No cap
    /// triangles (the two cap centres stay in the vertex layout). `sides` is the closed tube's
    /// that the strokes find the outline on ([`TubeTopology::closed_sides`]). Like the half
    /// tube, only for a tube seen by the one camera it faces.
    pub fn ribbon(rings: usize, sides: usize) -> Self {
        let rings = rings.clamp(MIN_RINGS, MAX_RINGS);
        let closed = Self::new(2, sides);
        let at = |ring: usize, side: usize| (ring * RIBBON_SIDES + side) as u32;
        let mut indices = Vec::with_capacity(6 * rings);
        for r in 0..rings - 1 {
            let (a0, a1, b0, b1) = (at(r, 0), at(r, 1), at(r + 1, 0), at(r + 1, 1));
            indices.extend_from_slice(&[a0, a1, b1, a0, b1, b0]);
        }
        let mut uvs = Vec::with_capacity(rings * RIBBON_SIDES + CAP_VERTICES);
        for r in 0..rings {
            let v = r as f32 / (rings - 1) as f32;
            uvs.extend_from_slice(&[[0.25, v], [0.75, v]]);
        }
        uvs.push([0.5, 0.0]);
        uvs.push([0.5, 1.0]);
        Self {
            rings,
            sides: RIBBON_SIDES,
            facing: true,
            ribbon: true,
            closed_sides: closed.sides,
            cos_sin: closed.cos_sin,
            indices,
            uvs,
        }
    }

    /// Whether this is a half tube turned to the camera ([`TubeTopology::facing`]) or a ribbon
    /// ([`TubeTopology::ribbon`]).
    pub fn is_facing(&self) -> bool {
        self.facing
    }

    /// Whether this is a ribbon turned to the camera ([`TubeTopology::ribbon`]).
    pub fn is_ribbon(&self) -> bool {
        self.ribbon
    }

    /// Sides of the closed tube: [`TubeTopology::sides`], or for a half tube the sides of the
    /// tube it is half of (its vertices are that tube's, its outline found on that ring).
    pub fn closed_sides(&self) -> usize {
        self.closed_sides
    }

    /// The vertices a ring of the half tube of a `sides`-sided tube has
    /// ([`TubeTopology::facing`]).
    pub fn facing_sides(sides: usize) -> usize {
        (sides.clamp(MIN_SIDES, MAX_SIDES).div_ceil(2) + 1).max(3)
    }

    /// `(cos, sin)` of each side's angle around the closed ring.
    #[cfg(feature = "render")]
    pub(crate) fn cos_sin(&self) -> &[(f32, f32)] {
        &self.cos_sin
    }

    /// Samples along the strand (after clamping).
    pub fn rings(&self) -> usize {
        self.rings
    }

    /// Vertices per ring (after clamping).
    pub fn sides(&self) -> usize {
        self.sides
    }

    /// `rings * sides + 2`: the ring vertices and the two cap centres.
    pub fn vertex_count(&self) -> usize {
        self.rings * self.sides + CAP_VERTICES
    }

    /// `2 * sides * rings`: `2 * sides * (rings - 1)` wall triangles and `sides` per cap
    /// (`sides - 1` for each for a [`TubeTopology::facing`] half tube).
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The index of ring vertex `side` (taken modulo `sides`) of ring `ring`.
    pub fn ring_vertex(&self, ring: usize, side: usize) -> u32 {
        (ring * self.sides + side % self.sides) as u32
    }

    /// The index of the root cap's centre vertex.
    pub fn root_cap_vertex(&self) -> u32 {
        (self.rings * self.sides) as u32
    }

    /// The index of the tip cap's centre vertex.
    pub fn tip_cap_vertex(&self) -> u32 {
        (self.rings * self.sides + 1) as u32
    }
}

/// The reference the root ring's frame is seeded from.
///
/// The root frame's normal (the direction of ring vertex `0`) is `normal` carried by the smallest
/// rotation from `direction` onto the strand's current root direction. Pass the strand's rest
/// root direction and a normal perpendicular to it, both rotated by the bone the strand hangs on,
/// and the rings stay put however the strand and the head move. The frame is only ill-defined
/// when the root direction turns exactly opposite to `direction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameReference {
    /// The reference root direction. Need not be normalised; `-Y` is used when it is zero or not
    /// finite.
    pub direction: Vec3,
    /// The direction of ring vertex `0` when the root points along `direction`. Need not be
    /// normalised or exactly perpendicular to `direction`; a perpendicular is picked when it is
    /// parallel to `direction` or not finite.
    pub normal: Vec3,
}

impl Default for FrameReference {
    /// Hanging down (`-Y`), ring vertex `0` facing `+Z`.
    fn default() -> Self {
        Self {
            direction: Vec3::NEG_Y,
            normal: Vec3::Z,
        }
    }
}

impl FrameReference {
    /// A reference for a strand whose root points along `direction`, with a normal taken from a
    /// fixed up vector (`+Y`, or `+Z` when `direction` is nearly vertical).
    pub fn from_direction(direction: Vec3) -> Self {
        let d = direction.normalize_or(Vec3::NEG_Y);
        let up = if d.y.abs() < 0.9 { Vec3::Y } else { Vec3::Z };
        Self {
            direction: d,
            normal: (up - d * d.dot(up)).normalize(),
        }
    }

    /// The reference, orthonormalised and with fallbacks for bad input.
    fn orthonormal(&self) -> (Vec3, Vec3) {
        let d = if self.direction.is_finite() {
            self.direction.normalize_or(Vec3::NEG_Y)
        } else {
            Vec3::NEG_Y
        };
        let n = if self.normal.is_finite() {
            self.normal - d * d.dot(self.normal)
        } else {
            Vec3::ZERO
        };
        let n = n
            .try_normalize()
            .unwrap_or_else(|| d.any_orthonormal_vector());
        (d, n)
    }
}

/// Shape parameters of a strand tube.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TubeParams {
    /// Radius at taper `1.0`, in world units. Negative or non-finite values give `0`.
    pub radius: f32,
    /// The **H** curve `[a, b, c]`: the radius is scaled by `a*x^2 + b*x + c` at `x` from `0`
    /// (root ring) to `1` (tip ring), clamped at `0`.
    pub taper: [f32; 3],
    /// Seeds the ring frames; see [`FrameReference`].
    pub reference: FrameReference,
    /// Cross-section: the ring's width along the frame's binormal over its width along the
    /// frame's normal (the strand's rest normal). `1` is a circle, less an ellipse, about `0.2`
    /// a flat blade; for the polygon sections, their thickness over their width. Clamped to
    /// `[0.05, 1]`; not finite gives `1`.
    pub aspect: f32,
    /// The shape of the cross-section; see [`LockSection`].
    pub section: LockSection,
    /// Where the camera is, for a [`TubeTopology::facing`] half tube (which faces it); unused
    /// by a closed tube. `None` leaves a half tube in the ring frame.
    pub eye: Option<Vec3>,
}

impl Default for TubeParams {
    /// Radius `0.01`, tapering linearly to 10% at the tip, hanging down.
    fn default() -> Self {
        Self {
            radius: 0.01,
            taper: [0.0, -0.9, 1.0],
            reference: FrameReference::default(),
            aspect: 1.0,
            section: LockSection::Round,
            eye: None,
        }
    }
}

/// Reusable temporaries of [`build_tube`]: keep one per thread (or per strand) so that
/// building a tube does not allocate.
#[derive(Clone, Debug, Default)]
pub struct TubeScratch {
    samples: Vec<Vec3>,
    tangents: Vec<Vec3>,
    /// Per side: the position's `(cos, sin)` factors, the outward normal's and the around
    /// tangent's, for the cross-section's aspect.
    section: Vec<SectionSide>,
    /// What `section` was filled for: the kind, the aspect's bits and the side count.
    section_for: Option<(LockSection, u32, usize)>,
}

impl TubeScratch {
    /// The ring centres of the tube [`build_tube`] built last with this scratch, root first.
    pub fn ring_centres(&self) -> &[Vec3] {
        &self.samples
    }
}

/// Writes the tube around the spline through `particles` (root first) into the vertex buffers.
///
/// * `positions`: ring vertices `centre + radius * (cos θ N + sin θ B)`, cap centres at the spline
///   ends.
/// * `normals`: unit, outward: the ring direction tilted by the taper's slope; the cap centres
///   point backward (root) and forward (tip) along the strand.
/// * `tangents` (optional, Bevy's `[x, y, z, w]`): the unit direction of increasing `u` around the
///   ring with `w = 1`, so `cross(normal, tangent) * w` runs along the strand (increasing `v`);
///   at the cap centres the frame normal `N`.
///
/// The ring frames are parallel-transported from the root frame seeded by `params.reference`
/// (see [`FrameReference`]). Particles that are empty, not finite or all (nearly) coincident
/// give a tiny tube (`1e-4` long) along `+Y` at the first particle (or the origin): the output
/// is always finite.
///
/// # Panics
///
/// If a given buffer is shorter than [`TubeTopology::vertex_count`].
pub fn build_tube(
    topology: &TubeTopology,
    particles: &[Vec3],
    params: &TubeParams,
    scratch: &mut TubeScratch,
    positions: &mut [[f32; 3]],
    normals: &mut [[f32; 3]],
    mut tangents: Option<&mut [[f32; 4]]>,
) {
    let (rings, sides) = (topology.rings, topology.sides);
    let vertex_count = topology.vertex_count();
    assert!(
        positions.len() >= vertex_count
            && normals.len() >= vertex_count
            && tangents.as_ref().is_none_or(|t| t.len() >= vertex_count),
        "tube vertex buffers need {vertex_count} vertices"
    );

    let TubeScratch {
        samples,
        tangents: directions,
        section,
        section_for,
    } = scratch;
    // The cross-section: each side's position, outward normal and direction of increasing u.
    // The same for every strand of a hair: filled again only when the key changes.
    let key = (
        params.section,
        params.aspect.to_bits(),
        topology.cos_sin.len(),
    );
    if *section_for != Some(key) {
        fill_section(params.section, params.aspect, &topology.cos_sin, section);
        *section_for = Some(key);
    }
    let mut radius = if params.radius.is_finite() {
        params.radius.max(0.0)
    } else {
        0.0
    };
    let finite = particles.iter().all(|p| p.is_finite());
    let mut length = f32::NAN;
    if finite && !particles.is_empty() {
        length = spline(particles, rings, samples);
        if !samples.iter().all(|p| p.is_finite()) {
            length = f32::NAN;
        }
    }
    if !(length > MIN_STRAND_LENGTH && length.is_finite()) {
        let base = particles
            .first()
            .copied()
            .filter(|p| p.is_finite())
            .unwrap_or(Vec3::ZERO);
        samples.clear();
        samples.extend(
            (0..rings).map(|r| base + Vec3::Y * (FALLBACK_SIZE * r as f32 / (rings - 1) as f32)),
        );
        length = FALLBACK_SIZE;
        radius = radius.min(FALLBACK_SIZE);
    }

    // Unit directions of the samples (central differences, one-sided at the ends); zero where
    // samples coincide. Independent of each other, so computed ahead of the frame chain.
    directions.clear();
    directions.extend((0..rings).map(|r| {
        let d = samples[(r + 1).min(rings - 1)] - samples[r.saturating_sub(1)];
        let l2 = d.length_squared();
        if l2 > 1e-24 && l2.is_finite() {
            d * l2.sqrt().recip()
        } else {
            Vec3::ZERO
        }
    }));

    let [ta, tb, tc] = params.taper;
    // The chord length of the particles stands in for the arc length in the taper's slope.
    let inv_length = length.recip();
    let (reference_direction, reference_normal) = params.reference.orthonormal();
    let first_direction = directions
        .iter()
        .copied()
        .find(|d| *d != Vec3::ZERO)
        .unwrap_or(reference_direction);
    let mut tangent = first_direction;
    let mut normal = orthonormalise(
        transport(reference_normal, reference_direction, tangent),
        tangent,
    );
    let root_frame = (tangent, normal);

    for r in 0..rings {
        if r > 0 && directions[r] != Vec3::ZERO {
            let next = directions[r];
            // Parallel transport: the rotation preserves length and perpendicularity, so only
            // rounding is removed here, and the (slow) normalisation is rarely needed.
            normal = transport(normal, tangent, next);
            normal -= next * next.dot(normal);
            if (normal.length_squared() - 1.0).abs() > 1e-4 {
                normal = orthonormalise(normal, next);
            }
            tangent = next;
        }
        let binormal = tangent.cross(normal);
        let x = r as f32 / (rings - 1) as f32;
        let h = (ta * x + tb) * x + tc;
        let (ring_radius, slope) = if h > 0.0 && h.is_finite() {
            let slope = radius * (2.0 * ta * x + tb) * inv_length;
            let slope = if slope.is_finite() {
                slope.clamp(-MAX_TAPER_SLOPE, MAX_TAPER_SLOPE)
            } else {
                0.0
            };
            (radius * h, slope)
        } else {
            (0.0, 0.0)
        };
        // The outward normal of a tube r(s) is radial - r'(s) T, normalised; radial ⟂ T.
        let radial_weight = (1.0 + slope * slope).sqrt().recip();
        let tangent_weight = -slope * radial_weight;
        // A half tube takes the closed ring's vertices from the one that starts the faces
        // turned to the eye.
        let start = match params.eye {
            Some(eye) if topology.facing && !topology.ribbon => {
                facing_start(eye - samples[r], normal, binormal, section.len())
            }
            _ => 0,
        };
        let range = r * sides..(r + 1) * sides;
        let frame = RingFrame {
            centre: samples[r],
            normal,
            binormal,
            axial: tangent * tangent_weight,
            radius: ring_radius,
            radial_weight,
        };
        if topology.ribbon {
            let to_eye = params.eye.map_or(normal, |eye| eye - samples[r]);
            write_ribbon_ring(
                &mut positions[range.clone()],
                &mut normals[range.clone()],
                tangents.as_deref_mut().map(|t| &mut t[range]),
                &frame,
                tangent,
                to_eye,
            );
            continue;
        }
        let ring = RingOut {
            positions: &mut positions[range.clone()],
            normals: &mut normals[range.clone()],
            tangents: tangents.as_deref_mut().map(|t| &mut t[range]),
        };
        if topology.facing {
            write_ring(ring, &frame, section.iter().cycle().skip(start).take(sides));
        } else {
            write_ring(ring, &frame, section.iter());
        }
    }

    let root = rings * sides;
    positions[root] = samples[0].to_array();
    positions[root + 1] = samples[rings - 1].to_array();
    normals[root] = (-root_frame.0).to_array();
    normals[root + 1] = tangent.to_array();
    if let Some(tangents) = tangents {
        tangents[root] = root_frame.1.extend(1.0).to_array();
        tangents[root + 1] = normal.extend(1.0).to_array();
    }
}

/// One ring's vertices to write.
struct RingOut<'a> {
    positions: &'a mut [[f32; 3]],
    normals: &'a mut [[f32; 3]],
    tangents: Option<&'a mut [[f32; 4]]>,
}

/// One ring's frame, radius and normal tilt.
struct RingFrame {
    centre: Vec3,
    normal: Vec3,
    binormal: Vec3,
    /// The normals' part along the strand (the taper's tilt).
    axial: Vec3,
    radius: f32,
    radial_weight: f32,
}

/// Writes a ring's vertices from `table`, its cross-section's sides in order.
#[inline(always)]
fn write_ring<'a>(
    out: RingOut<'_>,
    frame: &RingFrame,
    table: impl Iterator<Item = &'a SectionSide> + Clone,
) {
    // 4-wide vectors: this loop is most of the work.
    let (n, b) = (Vec3A::from(frame.normal), Vec3A::from(frame.binormal));
    let centre = Vec3A::from(frame.centre);
    let axial = Vec3A::from(frame.axial);
    let ring = out
        .positions
        .iter_mut()
        .zip(out.normals.iter_mut())
        .zip(table.clone());
    for ((position, normal_out), [(pc, ps), (nc, ns), _]) in ring {
        let radial = n * *pc + b * *ps;
        *position = (centre + radial * frame.radius).to_array();
        let outward = n * *nc + b * *ns;
        *normal_out = (outward * frame.radial_weight + axial).to_array();
    }
    if let Some(tangents) = out.tangents {
        for (t, [_, _, (tc, ts)]) in tangents.iter_mut().zip(table) {
            // (-sin, cos) in the circle's table: binormal * cos - normal * sin.
            *t = (frame.normal * *tc + frame.binormal * *ts)
                .extend(1.0)
                .to_array();
        }
    }
}

/// Writes a ribbon's ring ([`TubeTopology::ribbon`]): its two vertices at the centre minus and
/// plus the radius along `across = tangent x to_eye` (unit; the ring normal's direction where
/// the eye lies along the strand), the first of them where a half tube's vertices start, so the
/// faces turn to the eye. Their outward directions lean halfway toward the eye,
/// `(±across + to_eye) / sqrt 2` within the ring, tilted by the taper as a tube's are; the
/// direction of increasing `u` is `tangent x` that outward direction, as around a tube.
fn write_ribbon_ring(
    positions: &mut [[f32; 3]],
    normals: &mut [[f32; 3]],
    mut tangents: Option<&mut [[f32; 4]]>,
    frame: &RingFrame,
    tangent: Vec3,
    to_eye: Vec3,
) {
    let (toward, across) = ribbon_axes(tangent, to_eye, frame.normal);
    for (k, side) in [-1.0f32, 1.0].into_iter().enumerate() {
        let outward = (across * side + toward) * std::f32::consts::FRAC_1_SQRT_2;
        positions[k] = (frame.centre + across * (side * frame.radius)).to_array();
        normals[k] = (outward * frame.radial_weight + frame.axial).to_array();
        if let Some(t) = tangents.as_deref_mut() {
            t[k] = tangent.cross(outward).extend(1.0).to_array();
        }
    }
}

/// A ribbon ring's two axes: the unit way to the eye within the ring (`to_eye` less its part
/// along the unit `tangent`; `normal` where that vanishes) and `tangent x` it, across the strand.
pub(crate) fn ribbon_axes(tangent: Vec3, to_eye: Vec3, normal: Vec3) -> (Vec3, Vec3) {
    let toward = (to_eye - tangent * tangent.dot(to_eye)).normalize_or(normal);
    (toward, tangent.cross(toward))
}

/// The closed ring's vertex (of `closed` around it, vertex `k` at angle `2 pi k / closed` from
/// `normal` toward `binormal`, face `k` between vertices `k` and `k + 1`) that starts its faces
/// turned to the eye, `to_eye`, seen from the ring's centre: the first face whose normal is
/// less than a quarter turn from the way to the eye. A half tube draws it and the next ones.
pub(crate) fn facing_start(to_eye: Vec3, normal: Vec3, binormal: Vec3, closed: usize) -> usize {
    let angle = to_eye.dot(binormal).atan2(to_eye.dot(normal));
    let step = std::f32::consts::TAU / closed.max(1) as f32;
    let start = ((angle - std::f32::consts::FRAC_PI_2) / step - 0.5).floor() + 1.0;
    if start.is_finite() {
        (start as i64).rem_euclid(closed.max(1) as i64) as usize
    } else {
        0
    }
}

/// `v` rotated by the smallest rotation taking unit `from` onto unit `to`; a half turn about `v`
/// itself when they are opposite.
fn transport(v: Vec3, from: Vec3, to: Vec3) -> Vec3 {
    let c = from.dot(to);
    if 1.0 + c < 1e-6 {
        return v;
    }
    let a = from.cross(to);
    v * c + a.cross(v) + a * (a.dot(v) / (1.0 + c))
}

#[cfg(test)]
#[path = "tube_tests.rs"]
mod tests;
