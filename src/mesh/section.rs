//! Cross-sections of a strand's tube: the round (or elliptic) tube of the thesis, and the flat,
//! triangular and rhombic locks of anime hair.
//!
//! A section is drawn in the ring's frame: `N`, the strand's rest normal turned with the bone,
//! across the lock (tangent to the hair's mass), and `B = T x N`, through the lock's thickness
//! (away from the mass). Widths are in units of the ring's radius: `1` along `N`, the section's
//! aspect along `B`.

use bevy::prelude::*;

/// The shape of a strand's cross-section. [`HairMeshSettings::section`](super::HairMeshSettings)
/// picks it for a whole hair and [`HairStrandSections`](super::HairStrandSections) per strand;
/// [`HairMeshSettings::section_aspect`](super::HairMeshSettings) is its thickness over its width
/// for every kind. With a taper that ends at `0` each lock ends in a sharp point.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Debug, PartialEq)]
#[non_exhaustive]
pub enum LockSection {
    /// An ellipse: a round tube at aspect `1`, the thesis's strands.
    #[default]
    Round,
    /// A flat ribbon: a thin rectangle lying on the hair's mass, flat faces in and out.
    Ribbon,
    /// A triangle with its base on the mass and its ridge outward: front bangs.
    Triangle,
    /// A rhombus, its long axis across the lock: the rows of spikes behind the bangs.
    Rhombus,
}

impl LockSection {
    /// Every kind, in menu order.
    pub const ALL: [LockSection; 4] = [
        LockSection::Round,
        LockSection::Ribbon,
        LockSection::Triangle,
        LockSection::Rhombus,
    ];

    /// Corners of the polygon (`0` for the smooth ellipse): a ring's side count is rounded up to
    /// a multiple of this, so every corner has a vertex and stays sharp.
    pub fn corners(self) -> usize {
        match self {
            LockSection::Round => 0,
            LockSection::Triangle => 3,
            LockSection::Ribbon | LockSection::Rhombus => 4,
        }
    }

    /// The corners, counter-clockwise in `(N, B)`, at thickness `1` (scaled along `B` by the
    /// aspect when used); empty for the ellipse.
    fn unit_polygon(self) -> &'static [(f32, f32)] {
        match self {
            LockSection::Round => &[],
            LockSection::Ribbon => &[(1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)],
            // Centroid on the strand: the base on the mass side, the ridge outward.
            LockSection::Triangle => &[(1.0, -0.5), (0.0, 1.0), (-1.0, -0.5)],
            LockSection::Rhombus => &[(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)],
        }
    }
}

/// One ring side of a section in `(N, B)`: its position, outward unit normal and unit direction
/// of increasing `u` (counter-clockwise around the ring).
pub(crate) type SectionSide = [(f32, f32); 3];

/// Writes the `sides` sides of `section` at thickness `aspect` (clamped to `[0.05, 1]`, `1` when
/// not finite) into `out`, side `k` at angle `cos_sin[k]` for the ellipse. A polygon's sides are
/// spread evenly over its edges from corner `0`; a corner's normal and direction are the mean of
/// its two edges'.
pub(crate) fn fill_section(
    section: LockSection,
    aspect: f32,
    cos_sin: &[(f32, f32)],
    out: &mut Vec<SectionSide>,
) {
    let aspect = if aspect.is_finite() {
        aspect.clamp(0.05, 1.0)
    } else {
        1.0
    };
    out.clear();
    let polygon = section.unit_polygon();
    if polygon.is_empty() {
        // An ellipse of half widths 1 (along N) and `aspect` (along B): the position, its
        // outward normal (the ellipse's gradient) and its direction of increasing u. A circle
        // keeps the exact table.
        out.extend(cos_sin.iter().map(|&(cos, sin)| {
            if aspect >= 1.0 {
                return [(cos, sin), (cos, sin), (-sin, cos)];
            }
            [
                (cos, sin * aspect),
                unit((cos * aspect, sin)),
                unit((-sin, cos * aspect)),
            ]
        }));
        return;
    }
    let k = polygon.len();
    let mut corners = [(0.0, 0.0); 4];
    for (c, &(n, b)) in corners.iter_mut().zip(polygon) {
        *c = (n, b * aspect);
    }
    // Edge j runs from corner j to corner j + 1; its outward normal is its direction turned
    // clockwise (the polygon is counter-clockwise).
    let edge = |j: usize| {
        let (a, b) = (corners[j % k], corners[(j + 1) % k]);
        unit((b.0 - a.0, b.1 - a.1))
    };
    let sides = cos_sin.len();
    out.extend((0..sides).map(|i| {
        // Position along the perimeter in edges: corner j at j.
        let t = (i * k) as f32 / sides as f32;
        let j = (t.floor() as usize).min(k - 1);
        let f = t - j as f32;
        let (a, b) = (corners[j], corners[(j + 1) % k]);
        let position = (a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f);
        let d = edge(j);
        let (direction, normal) = if f < 1e-4 {
            let before = edge(j + k - 1);
            let mean = unit((d.0 + before.0, d.1 + before.1));
            (mean, (mean.1, -mean.0))
        } else {
            (d, (d.1, -d.0))
        };
        [position, normal, direction]
    }));
}

/// `v` scaled to unit length (unchanged if it vanishes).
fn unit((x, y): (f32, f32)) -> (f32, f32) {
    let l = (x * x + y * y).sqrt();
    if l > 1e-12 { (x / l, y / l) } else { (x, y) }
}

/// `sides` rounded up to a multiple of the corners of every section in `sections`, so each
/// corner gets a vertex; past `max`, the largest multiple below it.
pub(crate) fn sides_for(
    sides: usize,
    sections: impl IntoIterator<Item = LockSection>,
    max: usize,
) -> usize {
    let mut step = 1;
    for s in sections {
        let c = s.corners();
        if c > 1 {
            step = lcm(step, c);
        }
    }
    let rounded = sides.div_ceil(step) * step;
    if rounded <= max {
        rounded
    } else {
        (max / step * step).max(1)
    }
}

fn lcm(a: usize, b: usize) -> usize {
    let (mut x, mut y) = (a, b);
    while y != 0 {
        (x, y) = (y, x % y);
    }
    a / x * b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn circle(sides: usize) -> Vec<(f32, f32)> {
        (0..sides)
            .map(|k| {
                let (s, c) = (std::f32::consts::TAU * k as f32 / sides as f32).sin_cos();
                (c, s)
            })
            .collect()
    }

    #[test]
    fn polygons_put_a_vertex_on_every_corner_and_normals_point_out() {
        for section in [
            LockSection::Ribbon,
            LockSection::Triangle,
            LockSection::Rhombus,
        ] {
            let sides = sides_for(8, [section], 64);
            assert_eq!(sides % section.corners(), 0, "{section:?}");
            let mut out = Vec::new();
            fill_section(section, 0.4, &circle(sides), &mut out);
            assert_eq!(out.len(), sides);
            for (corner, &(n, b)) in section.unit_polygon().iter().enumerate() {
                let side = corner * sides / section.corners();
                let p = out[side][0];
                assert!(
                    (p.0 - n).abs() < 1e-6 && (p.1 - b * 0.4).abs() < 1e-6,
                    "{section:?}"
                );
            }
            // Convex and centred near the strand: every normal points away from the centre, and
            // every direction is perpendicular to its normal and runs counter-clockwise.
            for [p, n, d] in &out {
                assert!(p.0 * n.0 + p.1 * n.1 > 0.0, "{section:?} {p:?} {n:?}");
                assert!((n.0 * d.0 + n.1 * d.1).abs() < 1e-5);
                assert!(p.0 * d.1 - p.1 * d.0 > 0.0, "{section:?} turns clockwise");
                assert!(((n.0 * n.0 + n.1 * n.1) - 1.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn a_ribbon_is_flat_and_thin() {
        let mut out = Vec::new();
        fill_section(LockSection::Ribbon, 0.1, &circle(8), &mut out);
        let width = out.iter().map(|s| s[0].0).fold(f32::MIN, f32::max);
        let thickness = out.iter().map(|s| s[0].1).fold(f32::MIN, f32::max);
        assert_eq!((width, thickness), (1.0, 0.1));
        // The long faces' vertices (not the corners) face straight out along B.
        let faces = out
            .iter()
            .filter(|s| s[1] == (0.0, 1.0) || s[1] == (0.0, -1.0));
        assert!(faces.count() >= 2);
    }

    #[test]
    fn the_ellipse_is_the_old_table() {
        let mut out = Vec::new();
        fill_section(LockSection::Round, 1.0, &circle(6), &mut out);
        for ([p, n, d], (c, s)) in out.iter().zip(circle(6)) {
            assert_eq!((*p, *n, *d), ((c, s), (c, s), (-s, c)));
        }
        fill_section(LockSection::Round, f32::NAN, &circle(6), &mut out);
        assert_eq!(out[1][0], circle(6)[1]);
    }

    #[test]
    fn side_counts_round_up_to_every_sections_corners() {
        assert_eq!(sides_for(8, [LockSection::Round], 64), 8);
        assert_eq!(sides_for(8, [LockSection::Triangle], 64), 9);
        assert_eq!(
            sides_for(8, [LockSection::Triangle, LockSection::Rhombus], 64),
            12
        );
        assert_eq!(sides_for(3, [LockSection::Rhombus], 64), 4);
        assert_eq!(sides_for(64, [LockSection::Triangle], 64), 63);
    }
}
