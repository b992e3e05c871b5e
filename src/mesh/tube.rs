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
    /// A half tube turned to the camera ([`TubeTopology::facing`]).
    facing: bool,
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
            closed_sides,
            cos_sin,
            indices,
            uvs,
        }
    }

    /// Whether this is a half tube turned to the camera ([`TubeTopology::facing`]).
    pub fn is_facing(&self) -> bool {
        self.facing
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
            Some(eye) if topology.facing => {
                facing_start(eye - samples[r], normal, binormal, section.len())
            }
            _ => 0,
        };
        let range = r * sides..(r + 1) * sides;
        let ring = RingOut {
            positions: &mut positions[range.clone()],
            normals: &mut normals[range.clone()],
            tangents: tangents.as_deref_mut().map(|t| &mut t[range]),
        };
        let frame = RingFrame {
            centre: samples[r],
            normal,
            binormal,
            axial: tangent * tangent_weight,
            radius: ring_radius,
            radial_weight,
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
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn v3(a: [f32; 3]) -> Vec3 {
        Vec3::from_array(a)
    }

    fn straight(n: usize, length: f32) -> Vec<Vec3> {
        (0..n)
            .map(|i| Vec3::Y * (length * i as f32 / (n - 1) as f32))
            .collect()
    }

    fn params_up(radius: f32) -> TubeParams {
        TubeParams {
            radius,
            taper: [0.0, 0.0, 1.0],
            reference: FrameReference {
                direction: Vec3::Y,
                normal: Vec3::Z,
            },
            aspect: 1.0,
            section: LockSection::Round,
            eye: None,
        }
    }

    struct Built {
        positions: Vec<[f32; 3]>,
        normals: Vec<[f32; 3]>,
        tangents: Vec<[f32; 4]>,
    }

    fn build(topology: &TubeTopology, particles: &[Vec3], params: &TubeParams) -> Built {
        let n = topology.vertex_count();
        let mut b = Built {
            positions: vec![[f32::NAN; 3]; n],
            normals: vec![[f32::NAN; 3]; n],
            tangents: vec![[f32::NAN; 4]; n],
        };
        build_tube(
            topology,
            particles,
            params,
            &mut TubeScratch::default(),
            &mut b.positions,
            &mut b.normals,
            Some(&mut b.tangents),
        );
        b
    }

    fn assert_finite_unit_normals(b: &Built) {
        for (i, p) in b.positions.iter().enumerate() {
            assert!(v3(*p).is_finite(), "position {i} = {p:?}");
            let n = v3(b.normals[i]);
            assert!((n.length() - 1.0).abs() < 1e-4, "normal {i} = {n:?}");
            let t = b.tangents[i];
            assert!(t.iter().all(|x| x.is_finite()), "tangent {i} = {t:?}");
        }
    }

    #[test]
    fn an_elliptic_section_lies_on_its_ellipse_with_its_normals() {
        // A straight, untapered strand up +Y, rest normal +Z: the ring's wide axis is Z (half
        // width r), its narrow one X (r * aspect).
        let t = TubeTopology::new(4, 16);
        let particles = straight(4, 1.0);
        let r = 0.1;
        for aspect in [1.0, 0.5, 0.2] {
            let params = TubeParams {
                aspect,
                section: LockSection::Round,
                ..params_up(r)
            };
            let b = build(&t, &particles, &params);
            assert_finite_unit_normals(&b);
            for ring in 0..t.rings() {
                for side in 0..t.sides() {
                    let i = t.ring_vertex(ring, side) as usize;
                    let p = v3(b.positions[i]);
                    let (x, z) = (p.x / (r * aspect), p.z / r);
                    assert!(
                        (x * x + z * z - 1.0).abs() < 1e-4,
                        "{aspect}: {p:?} off the ellipse"
                    );
                    // The outward normal is the ellipse's gradient (x / (r a)^2, z / r^2),
                    // and the tangent runs around the ring, perpendicular to it.
                    let gradient =
                        Vec3::new(p.x / (r * aspect).powi(2), 0.0, p.z / (r * r)).normalize();
                    let n = v3(b.normals[i]);
                    assert!(
                        n.abs_diff_eq(gradient, 1e-4),
                        "{aspect}: {n:?} vs {gradient:?}"
                    );
                    let around = bevy::math::Vec4::from_array(b.tangents[i]).truncate();
                    assert!(n.dot(around).abs() < 1e-4 && around.y.abs() < 1e-4);
                    // cross(normal, tangent) * w still runs along the strand.
                    assert!(n.cross(around).dot(Vec3::Y) > 0.99, "{aspect}: {around:?}");
                }
            }
        }
        // Out-of-range aspects are clamped, not NaN.
        for aspect in [0.0, -1.0, f32::NAN, 5.0] {
            let params = TubeParams {
                aspect,
                section: LockSection::Round,
                ..params_up(r)
            };
            assert_finite_unit_normals(&build(&t, &particles, &params));
        }
    }

    #[test]
    fn counts_match_the_formulas_and_clamp() {
        for (rings, sides) in [(2, 3), (4, 5), (16, 8), (33, 64)] {
            let t = TubeTopology::new(rings, sides);
            assert_eq!(t.vertex_count(), rings * sides + 2);
            assert_eq!(t.triangle_count(), 2 * sides * rings);
            assert_eq!(t.indices.len(), 3 * t.triangle_count());
            assert_eq!(t.uvs.len(), t.vertex_count());
            assert!(t.indices.iter().all(|&i| (i as usize) < t.vertex_count()));
        }
        let t = TubeTopology::new(0, 1000);
        assert_eq!((t.rings(), t.sides()), (MIN_RINGS, MAX_SIDES));
        let t = TubeTopology::new(10_000, 0);
        assert_eq!((t.rings(), t.sides()), (MAX_RINGS, MIN_SIDES));
    }

    #[test]
    fn mesh_is_closed_every_edge_in_two_triangles() {
        for (rings, sides) in [(2, 3), (3, 4), (16, 8), (7, 13)] {
            let t = TubeTopology::new(rings, sides);
            let mut count: HashMap<(u32, u32), usize> = HashMap::new();
            for tri in t.indices.chunks_exact(3) {
                assert!(tri[0] != tri[1] && tri[1] != tri[2] && tri[2] != tri[0]);
                for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
                    *count.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
            for (edge, n) in &count {
                assert_eq!(
                    *n, 2,
                    "edge {edge:?} of {rings}x{sides} is in {n} triangles"
                );
            }
            // Euler characteristic of a sphere: V - E + F = 2.
            let (v, e, f) = (t.vertex_count(), count.len(), t.triangle_count());
            assert_eq!(v + f, e + 2);
        }
    }

    #[test]
    fn uvs_run_around_and_along() {
        let t = TubeTopology::new(5, 4);
        assert_eq!(t.uvs[t.ring_vertex(0, 0) as usize], [0.0, 0.0]);
        assert_eq!(t.uvs[t.ring_vertex(4, 3) as usize], [0.75, 1.0]);
        assert_eq!(t.uvs[t.ring_vertex(2, 1) as usize], [0.25, 0.5]);
        assert_eq!(t.uvs[t.root_cap_vertex() as usize], [0.5, 0.0]);
        assert_eq!(t.uvs[t.tip_cap_vertex() as usize], [0.5, 1.0]);
    }

    #[test]
    fn straight_strand_normals_and_winding_point_outward() {
        let t = TubeTopology::new(6, 7);
        let b = build(&t, &straight(4, 1.0), &params_up(0.05));
        assert_finite_unit_normals(&b);
        for r in 0..t.rings() {
            for k in 0..t.sides() {
                let i = t.ring_vertex(r, k) as usize;
                let p = v3(b.positions[i]);
                let axis = Vec3::new(0.0, p.y, 0.0);
                assert!((p.distance(axis) - 0.05).abs() < 1e-5, "radius at {r},{k}");
                assert!(v3(b.normals[i]).dot(p - axis) > 0.0, "normal at {r},{k}");
                let tangent = bevy::math::Vec4::from_array(b.tangents[i]).truncate();
                assert!(tangent.dot(v3(b.normals[i])).abs() < 1e-5);
            }
        }
        assert!(v3(b.normals[t.root_cap_vertex() as usize]).distance(Vec3::NEG_Y) < 1e-5);
        assert!(v3(b.normals[t.tip_cap_vertex() as usize]).distance(Vec3::Y) < 1e-5);
        // Face normals from the index order point away from the axis (walls) or along it (caps).
        for (f, tri) in t.indices.chunks_exact(3).enumerate() {
            let [a, b_, c] = [0, 1, 2].map(|j| v3(b.positions[tri[j] as usize]));
            let n = (b_ - a).cross(c - a);
            let centroid = (a + b_ + c) / 3.0;
            let outward = if f < 2 * t.sides() * (t.rings() - 1) {
                centroid - Vec3::new(0.0, centroid.y, 0.0)
            } else if f < 2 * t.sides() * (t.rings() - 1) + t.sides() {
                Vec3::NEG_Y
            } else {
                Vec3::Y
            };
            assert!(n.dot(outward) > 0.0, "triangle {f} faces inward");
        }
    }

    #[test]
    fn tapered_normals_tilt_toward_the_tip() {
        let t = TubeTopology::new(5, 6);
        let params = TubeParams {
            taper: [0.0, -1.0, 1.0],
            ..params_up(0.1)
        };
        let b = build(&t, &straight(3, 1.0), &params);
        assert_finite_unit_normals(&b);
        let n = v3(b.normals[t.ring_vertex(1, 0) as usize]);
        // r(s) = 0.1 (1 - s): the outward normal is (1, 0.1)/|..| in (radial, axial).
        assert!((n.y - 0.1 / 1.01f32.sqrt()).abs() < 1e-4, "{n:?}");
        let tip = v3(b.positions[t.ring_vertex(4, 2) as usize]);
        assert!(tip.distance(Vec3::Y) < 1e-6);
    }

    #[test]
    fn spline_passes_through_the_points() {
        let points = [
            Vec3::ZERO,
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.5, -2.0, 0.2),
            Vec3::new(1.5, -2.5, 0.1),
        ];
        let mut out = Vec::new();
        sample_spline(&points, 7, &mut out);
        assert_eq!(out.len(), 7);
        assert_eq!(out[0], points[0]);
        assert_eq!(out[6], points[3]);
        // Equally spaced points are hit exactly when the samples land on them.
        let points = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 1.0),
        ];
        sample_spline(&points, 10, &mut out);
        for (i, p) in points.iter().enumerate() {
            assert!(out[3 * i].distance(*p) < 1e-5, "{i}: {:?}", out[3 * i]);
        }
        // The curve is smooth: no sample strays far from the control polygon.
        sample_spline(&points, 64, &mut out);
        assert!(
            out.iter()
                .all(|p| p.min_element() > -0.2 && p.max_element() < 1.2)
        );
    }

    #[test]
    fn spline_of_two_points_is_an_even_straight_segment() {
        let mut out = Vec::new();
        sample_spline(&[Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0)], 5, &mut out);
        for (i, p) in out.iter().enumerate() {
            assert!(p.distance(Vec3::X * i as f32) < 1e-5, "{i}: {p:?}");
        }
        sample_spline(&[Vec3::ONE], 0, &mut out);
        assert_eq!(out, vec![Vec3::ONE; 2]);
    }

    #[test]
    fn spline_does_not_allocate_with_capacity() {
        let mut out = Vec::with_capacity(16);
        let ptr = out.as_ptr();
        let points = [Vec3::ZERO, Vec3::Y, Vec3::ONE, Vec3::X];
        for samples in [2, 9, 16] {
            sample_spline(&points, samples, &mut out);
            assert_eq!(out.as_ptr(), ptr);
            assert_eq!(out.capacity(), 16);
        }
    }

    #[test]
    fn coincident_points_give_no_nan() {
        let mut out = Vec::new();
        let p = Vec3::new(1.0, 2.0, 3.0);
        sample_spline(&[p; 5], 8, &mut out);
        assert!(out.iter().all(|q| *q == p));
        sample_spline(&[p, p, p + Vec3::X, p + Vec3::X, p + Vec3::X], 8, &mut out);
        assert!(out.iter().all(|q| q.is_finite()), "{out:?}");
        assert_eq!(out[7], p + Vec3::X);

        let t = TubeTopology::new(8, 6);
        let b = build(&t, &[p; 4], &TubeParams::default());
        assert_finite_unit_normals(&b);
        assert!(b.positions.iter().all(|q| v3(*q).distance(p) < 1e-3));
        let b = build(
            &t,
            &[p, p, p + Vec3::Y, p + Vec3::Y],
            &TubeParams::default(),
        );
        assert_finite_unit_normals(&b);
    }

    #[test]
    fn non_finite_input_gives_a_finite_fallback() {
        let t = TubeTopology::new(4, 5);
        let bad = [
            vec![],
            vec![Vec3::ZERO, Vec3::NAN, Vec3::Y],
            vec![Vec3::INFINITY, Vec3::ZERO],
            vec![Vec3::splat(3e38), Vec3::splat(-3e38), Vec3::splat(3e38)],
        ];
        let params = TubeParams {
            radius: f32::NAN,
            taper: [f32::NAN, 1.0, f32::INFINITY],
            reference: FrameReference {
                direction: Vec3::NAN,
                normal: Vec3::ZERO,
            },
            aspect: 1.0,
            section: LockSection::Round,
            eye: None,
        };
        for particles in &bad {
            for params in [TubeParams::default(), params] {
                assert_finite_unit_normals(&build(&t, particles, &params));
            }
        }
    }

    /// A deterministic pseudo-random vector in the unit cube around zero.
    fn jitter(seed: u32) -> Vec3 {
        let h = |s: u32| {
            let x = s.wrapping_mul(0x9E37_79B9).rotate_left(13) ^ 0x85EB_CA6B;
            (x.wrapping_mul(0xC2B2_AE35) >> 8) as f32 / (1 << 24) as f32 - 0.5
        };
        Vec3::new(h(3 * seed), h(3 * seed + 1), h(3 * seed + 2))
    }

    #[test]
    fn frames_are_stable_under_small_perturbations() {
        let t = TubeTopology::new(16, 8);
        let radius = 0.02;
        let params = TubeParams {
            radius,
            taper: [0.0, -0.5, 1.0],
            reference: FrameReference::from_direction(Vec3::NEG_Y),
            aspect: 1.0,
            section: LockSection::Round,
            eye: None,
        };
        // A strand that hangs down, curls and bends sideways.
        let base: Vec<Vec3> = (0..10)
            .map(|i| {
                let s = i as f32 * 0.1;
                Vec3::new((3.0 * s).sin() * 0.2, -s, (2.0 * s).cos() * 0.1 - 0.1)
            })
            .collect();
        let reference = build(&t, &base, &params);
        assert_finite_unit_normals(&reference);
        let eps = 0.002;
        for trial in 0..20 {
            let moved: Vec<Vec3> = base
                .iter()
                .enumerate()
                .map(|(i, p)| *p + jitter(trial * 100 + i as u32).normalize_or_zero() * eps)
                .collect();
            let b = build(&t, &moved, &params);
            for (i, (p, q)) in reference.positions.iter().zip(&b.positions).enumerate() {
                let d = v3(*p).distance(v3(*q));
                assert!(
                    d < 2.0 * eps + 0.2 * radius,
                    "trial {trial} vertex {i} moved {d}"
                );
            }
        }
        // Swinging the whole strand (about its root at the origin) through a wide arc, past the
        // vertical, never flips or twists the rings: each step is the previous tube turned
        // rigidly by the step, up to a small fraction of the radius.
        let step = bevy::math::Quat::from_rotation_z(4f32.to_radians());
        let mut previous: Option<Built> = None;
        for k in 0..=60 {
            let angle = (k as f32 - 30.0).to_radians() * 4.0; // -120° ..= 120°
            let rotation = bevy::math::Quat::from_rotation_z(angle);
            let swung: Vec<Vec3> = base.iter().map(|p| rotation * *p).collect();
            let b = build(&t, &swung, &params);
            if let Some(prev) = &previous {
                for (i, (p, q)) in prev.positions.iter().zip(&b.positions).enumerate() {
                    let d = (step * v3(*p)).distance(v3(*q));
                    assert!(d < 0.25 * radius, "step {k} vertex {i} jumped {d}");
                }
            }
            previous = Some(b);
        }
    }

    #[test]
    fn rings_do_not_twist_along_a_planar_bend() {
        // A strand bending in the XY plane: parallel transport keeps the +Z side on +Z.
        let t = TubeTopology::new(12, 4);
        let particles: Vec<Vec3> = (0..8)
            .map(|i| {
                let a = i as f32 * 0.2;
                Vec3::new(a.sin(), -a.cos(), 0.0)
            })
            .collect();
        let params = TubeParams {
            radius: 0.05,
            taper: [0.0, 0.0, 1.0],
            reference: FrameReference {
                direction: Vec3::X,
                normal: Vec3::Z,
            },
            aspect: 1.0,
            section: LockSection::Round,
            eye: None,
        };
        let b = build(&t, &particles, &params);
        for r in 0..t.rings() {
            let n = v3(b.normals[t.ring_vertex(r, 0) as usize]);
            assert!(n.distance(Vec3::Z) < 1e-4, "ring {r}: {n:?}");
        }
    }

    /// A half tube has half the closed tube's triangles and draws the closed tube's front: at
    /// each ring the closed ring's vertices around the way to the eye, its ends two opposite
    /// vertices (as wide as the closed tube), its middle vertex within half a side of the way
    /// to the eye, no wall triangle turned away. Without an eye it starts at the frame's
    /// vertex 0.
    #[test]
    fn a_half_tube_faces_the_eye_with_half_the_triangles() {
        let closed = TubeTopology::new(16, 8);
        let half = TubeTopology::facing(16, 8);
        assert_eq!((half.sides(), half.closed_sides()), (5, 8));
        assert!(half.is_facing() && !closed.is_facing());
        assert_eq!(2 * half.triangle_count(), closed.triangle_count());
        assert_eq!(half.vertex_count(), 16 * 5 + CAP_VERTICES);
        let particles = straight(6, 0.5);
        let eighth = std::f32::consts::PI / 8.0;
        for eye in [
            Vec3::new(0.0, 0.2, 3.0),
            Vec3::new(-2.0, 0.4, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
        ] {
            let params = TubeParams {
                eye: Some(eye),
                ..params_up(0.05)
            };
            let b = build(&half, &particles, &params);
            let at = |r: usize, k: usize| v3(b.positions[half.ring_vertex(r, k) as usize]);
            for r in 0..half.rings() {
                let centre = Vec3::Y * (0.5 * r as f32 / 15.0);
                let to_eye = eye - centre;
                let across = (to_eye - Vec3::Y * to_eye.y).normalize();
                let (first, last) = (at(r, 0) - centre, at(r, 4) - centre);
                let middle = v3(b.normals[half.ring_vertex(r, 2) as usize]);
                assert!(
                    (first + last).length() < 1e-5,
                    "ring {r}: ends not opposite"
                );
                assert!(first.dot(across).abs() <= 0.05 * eighth.sin() + 1e-5);
                assert!(middle.angle_between(across) <= eighth + 1e-4, "ring {r}");
            }
            for tri in half.indices.chunks(3).take(2 * 4 * 15) {
                let [a, b2, c] = [0, 1, 2].map(|i| v3(b.positions[tri[i] as usize]));
                let n = (b2 - a).cross(c - a).normalize();
                let facing = n.dot((eye - (a + b2 + c) / 3.0).normalize());
                assert!(facing > -0.2, "a wall triangle turned away: {facing}");
            }
        }
        // No eye: from the frame's vertex 0 (+Z here) on.
        let b = build(&half, &particles, &params_up(0.05));
        assert!(v3(b.normals[half.ring_vertex(3, 0) as usize]).distance(Vec3::Z) < 1e-5);
        assert!(
            half.uvs[..5]
                .iter()
                .all(|uv| (0.25..=0.75).contains(&uv[0]))
        );
    }
}
