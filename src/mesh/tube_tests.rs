//! Tests of the strand tube mesh.

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

/// Eyes around a strand up the y axis: in front, to the left, below and behind.
const EYES: [Vec3; 3] = [
    Vec3::new(0.0, 0.2, 3.0),
    Vec3::new(-2.0, 0.4, 1.0),
    Vec3::new(1.0, -1.0, -1.0),
];

/// A straight 0.5 m strand up the y axis (6 particles), its tube 0.05 thick, built to face `eye`.
fn built_for_eye(topology: &TubeTopology, eye: Vec3) -> Built {
    let params = TubeParams {
        eye: Some(eye),
        ..params_up(0.05)
    };
    build(topology, &straight(6, 0.5), &params)
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
    for eye in EYES {
        let b = built_for_eye(&half, eye);
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

/// A ribbon is two vertices a ring, across the strand and the way to the eye at the ring's
/// radius (the round tube's outline seen from there), two triangles a segment turned to the
/// eye, normals leaning toward it from either edge and along-strand tangents up the strand.
#[test]
fn a_ribbon_is_the_tubes_outline_turned_to_the_eye() {
    let closed = TubeTopology::new(16, 4);
    let ribbon = TubeTopology::ribbon(16, 4);
    assert_eq!((ribbon.sides(), ribbon.closed_sides()), (RIBBON_SIDES, 4));
    assert!(ribbon.is_facing() && ribbon.is_ribbon() && !closed.is_ribbon());
    assert_eq!(ribbon.triangle_count(), 2 * 15);
    assert_eq!(ribbon.vertex_count(), 16 * 2 + CAP_VERTICES);
    assert!(ribbon.indices.iter().all(|&i| (i as usize) < 32));
    let particles = straight(6, 0.5);
    for eye in EYES {
        let b = built_for_eye(&ribbon, eye);
        assert!(b.positions.iter().flatten().all(|v| v.is_finite()));
        let at = |r: usize, k: usize| v3(b.positions[ribbon.ring_vertex(r, k) as usize]);
        for r in 0..ribbon.rings() {
            let centre = Vec3::Y * (0.5 * r as f32 / 15.0);
            let to_eye = eye - centre;
            let toward = (to_eye - Vec3::Y * to_eye.y).normalize();
            let across = Vec3::Y.cross(toward);
            assert!(at(r, 1).distance(centre + across * 0.05) < 1e-5, "ring {r}");
            assert!(at(r, 0).distance(centre - across * 0.05) < 1e-5, "ring {r}");
            for k in 0..2 {
                let i = ribbon.ring_vertex(r, k) as usize;
                let n = v3(b.normals[i]);
                assert!((n.length() - 1.0).abs() < 1e-5);
                assert!((n.dot(toward) - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-5);
                let around = bevy::math::Vec4::from_array(b.tangents[i]).truncate();
                assert!(
                    n.cross(around).distance(Vec3::Y) < 1e-5,
                    "ring {r} side {k}"
                );
            }
        }
        for tri in ribbon.indices.chunks(3) {
            let [a, b2, c] = [0, 1, 2].map(|i| v3(b.positions[tri[i] as usize]));
            let n = (b2 - a).cross(c - a).normalize();
            let facing = n.dot((eye - (a + b2 + c) / 3.0).normalize());
            assert!(facing > 0.0, "a ribbon triangle turned away: {facing}");
        }
    }
    // The eye straight along the strand: the ribbon lies across the ring normal's side.
    let params = TubeParams {
        eye: Some(Vec3::Y * 5.0),
        ..params_up(0.05)
    };
    let b = build(&ribbon, &particles, &params);
    assert!(b.positions.iter().flatten().all(|v| v.is_finite()));
    assert!((v3(b.positions[1]) - v3(b.positions[0])).length() > 0.099);
}
