//! Tests of the general silhouette path: adjacency, chaining and strips.

use super::adjacency::*;
use super::chain::*;
use super::strip::*;
use crate::curve::QuadraticCurve;
use crate::mesh::tube::{FrameReference, TubeParams, TubeScratch, TubeTopology, build_tube};
use bevy::math::{Mat4, Vec2, Vec3};
use std::collections::HashMap;

struct Tube {
    topology: TubeTopology,
    positions: Vec<[f32; 3]>,
}

fn tube(rings: usize, sides: usize, particles: &[Vec3], radius: f32) -> Tube {
    shaped_tube(rings, sides, particles, radius, 1.0)
}

/// A tube of cross-section `aspect` (1 round, 0.2 a flat blade).
fn shaped_tube(rings: usize, sides: usize, particles: &[Vec3], radius: f32, aspect: f32) -> Tube {
    let topology = TubeTopology::new(rings, sides);
    let mut positions = vec![[0.0; 3]; topology.vertex_count()];
    let mut normals = positions.clone();
    let params = TubeParams {
        radius,
        taper: [0.0, 0.0, 1.0],
        reference: FrameReference {
            direction: Vec3::Y,
            normal: Vec3::Z,
        },
        aspect,
        ..Default::default()
    };
    build_tube(
        &topology,
        particles,
        &params,
        &mut TubeScratch::default(),
        &mut positions,
        &mut normals,
        None,
    );
    Tube {
        topology,
        positions,
    }
}

fn undirected(e: [u32; 2]) -> (u32, u32) {
    (e[0].min(e[1]), e[0].max(e[1]))
}

/// Every input edge appears exactly once as a consecutive (or closing) pair of a chain.
fn assert_chains_cover(edges: &[[u32; 2]], chains: &SilhouetteChains) {
    let mut wanted: HashMap<(u32, u32), usize> = HashMap::new();
    for &e in edges {
        *wanted.entry(undirected(e)).or_default() += 1;
    }
    let mut got: HashMap<(u32, u32), usize> = HashMap::new();
    for chain in chains.iter() {
        let v = chain.vertices;
        assert!(!v.is_empty());
        let mut pairs: Vec<[u32; 2]> = v.windows(2).map(|w| [w[0], w[1]]).collect();
        if chain.closed {
            pairs.push([v[v.len() - 1], v[0]]);
        } else {
            assert!(v.len() >= 2, "open chain of one vertex");
        }
        for p in pairs {
            *got.entry(undirected(p)).or_default() += 1;
        }
    }
    assert_eq!(wanted, got, "chains do not use every edge exactly once");
}

#[test]
fn adjacency_of_the_tube_is_complete_and_oriented() {
    let t = TubeTopology::new(5, 6);
    let adjacency = EdgeAdjacency::from_triangles(&t.indices).unwrap();
    assert_eq!(adjacency.edges.len(), 3 * t.triangle_count() / 2);
    assert_eq!(adjacency.triangle_count(), t.triangle_count());
    for e in &adjacency.edges {
        let runs = |f: u32, a: u32, b: u32| {
            let tri = &t.indices[3 * f as usize..3 * f as usize + 3];
            (0..3).any(|i| tri[i] == a && tri[(i + 1) % 3] == b)
        };
        assert!(runs(e.faces[0], e.v[0], e.v[1]));
        assert!(runs(e.faces[1], e.v[1], e.v[0]));
    }
}

#[test]
fn adjacency_errors_name_the_problem() {
    assert_eq!(
        EdgeAdjacency::from_triangles(&[0, 1]),
        Err(AdjacencyError::NotTriangleList { len: 2 })
    );
    // A single triangle is open.
    let err = EdgeAdjacency::from_triangles(&[0, 1, 2]).unwrap_err();
    assert_eq!(
        err,
        AdjacencyError::NonManifoldEdge {
            edge: [0, 1],
            faces: 1
        }
    );
    assert!(err.to_string().contains("[0, 1]"));
    // Two copies of the same triangle: closed but wound the same way.
    assert!(matches!(
        EdgeAdjacency::from_triangles(&[0, 1, 2, 0, 1, 2]),
        Err(AdjacencyError::InconsistentWinding { .. })
    ));
    assert!(matches!(
        EdgeAdjacency::from_triangles(&[0, 0, 1]),
        Err(AdjacencyError::DegenerateTriangle { face: 0, .. })
    ));
    // A tetrahedron is fine.
    let tetra = [0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3];
    assert_eq!(
        EdgeAdjacency::from_triangles(&tetra).unwrap().edges.len(),
        6
    );
}

#[test]
fn straight_tube_side_on_has_one_loop_with_both_long_sides() {
    let (rings, sides, length, radius) = (16, 8, 1.0, 0.02);
    let tube = tube(rings, sides, &[Vec3::ZERO, Vec3::Y * length], radius);
    let t = &tube.topology;
    let adjacency = EdgeAdjacency::from_triangles(&t.indices).unwrap();
    let eye = Vec3::new(0.0, length / 2.0, 3.0);
    let mut scratch = SilhouetteScratch::default();
    let mut edges = Vec::new();
    silhouette_edges(
        &adjacency,
        &t.indices,
        &tube.positions,
        eye,
        &mut scratch,
        &mut edges,
    );
    // Two long sides, plus the 4 edges of the visible half of each cap rim.
    assert_eq!(edges.len(), 2 * (rings - 1) + 8, "{edges:?}");
    let mut chains = SilhouetteChains::default();
    chain_edges(&edges, &mut scratch, &mut chains);
    assert_chains_cover(&edges, &chains);
    assert_eq!(chains.len(), 1);
    let chain = chains.get(0).unwrap();
    assert!(chain.closed);
    assert_eq!(chain.vertices.len(), edges.len());
    // Both long sides (x = ±radius) are there from root ring to tip ring, in order.
    for side_x in [radius, -radius] {
        let side: Vec<usize> = chain
            .vertices
            .iter()
            .map(|&v| tube.positions[v as usize])
            .filter(|p| (p[0] - side_x).abs() < 1e-4)
            .map(|p| (p[1] / length * (rings - 1) as f32).round() as usize)
            .collect();
        assert_eq!(side.len(), rings, "side x = {side_x}: {side:?}");
        let mut sorted = side.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..rings).collect::<Vec<_>>());
        let increasing = side.windows(2).all(|w| w[0] < w[1]);
        let decreasing = side.windows(2).all(|w| w[0] > w[1]);
        // The loop may start anywhere, so one side may be split at the start.
        let rotations = (0..rings).any(|r| {
            let mut s = side.clone();
            s.rotate_left(r);
            s.windows(2).all(|w| w[0] < w[1]) || s.windows(2).all(|w| w[0] > w[1])
        });
        assert!(increasing || decreasing || rotations, "{side:?}");
    }
}

#[test]
fn silhouette_edges_have_the_front_face_on_their_left() {
    let particles: Vec<Vec3> = (0..8)
        .map(|i| {
            let s = i as f32 * 0.15;
            Vec3::new((2.0 * s).sin() * 0.3, -s, s * s * 0.2)
        })
        .collect();
    // Round, elliptic and blade cross-sections: the edges come from the geometry, whatever
    // its shape.
    for aspect in [1.0, 0.5, 0.2] {
        let tube = shaped_tube(16, 8, &particles, 0.03, aspect);
        let t = &tube.topology;
        let adjacency = EdgeAdjacency::from_triangles(&t.indices).unwrap();
        let mut scratch = SilhouetteScratch::default();
        let (mut edges, mut chains) = (Vec::new(), SilhouetteChains::default());
        for k in 0..24 {
            let a = k as f32 * 0.5;
            let eye = Vec3::new(a.cos() * 2.0, (k as f32 * 0.3).sin() - 0.5, a.sin() * 2.0);
            silhouette_edges(
                &adjacency,
                &t.indices,
                &tube.positions,
                eye,
                &mut scratch,
                &mut edges,
            );
            assert!(!edges.is_empty());
            for &[a, b] in &edges {
                let e = adjacency
                    .edges
                    .iter()
                    .find(|e| undirected(e.v) == undirected([a, b]))
                    .unwrap();
                let front = if e.v == [a, b] {
                    e.faces[0]
                } else {
                    e.faces[1]
                };
                let tri = &t.indices[3 * front as usize..3 * front as usize + 3];
                let p = |i: u32| Vec3::from_array(tube.positions[i as usize]);
                let n = (p(tri[1]) - p(tri[0])).cross(p(tri[2]) - p(tri[0]));
                assert!(
                    n.dot(eye - p(tri[0])) > 0.0,
                    "face {front} is not the front one"
                );
                assert!((0..3).any(|i| tri[i] == a && tri[(i + 1) % 3] == b));
            }
            chain_edges(&edges, &mut scratch, &mut chains);
            assert_chains_cover(&edges, &chains);
            // On a closed mesh every silhouette vertex has even degree: loops only... unless
            // the chains were split at junctions, which then are shared by several chains.
            for chain in chains.iter().filter(|c| !c.closed) {
                let (first, last) = (chain.vertices[0], *chain.vertices.last().unwrap());
                let degree = |v: u32| edges.iter().flatten().filter(|&&x| x == v).count();
                assert!(degree(first) != 2 && degree(last) != 2);
            }
            // Consistently oriented edges give consistently oriented chains.
            for chain in chains.iter() {
                for w in chain.vertices.windows(2) {
                    assert!(edges.contains(&[w[0], w[1]]), "chain runs against an edge");
                }
            }
        }
    }
}

#[test]
fn loop_fast_path_gives_the_general_walk() {
    let mut scratch = SilhouetteScratch::default();
    let (mut edges, mut fast, mut general) = (
        Vec::new(),
        SilhouetteChains::default(),
        SilhouetteChains::default(),
    );
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut random = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let mut loops = 0;
    for trial in 0..300 {
        // Random bent tubes from random eye points: mostly plain loops, sometimes junctions.
        let particles: Vec<Vec3> = (0..5)
            .map(|k| Vec3::new(random(), random(), random()) * 0.1 + Vec3::Y * 0.1 * k as f32)
            .collect();
        let tube = tube(12, 6, &particles, 0.02);
        let topology = &tube.topology;
        let positions = &tube.positions;
        let adjacency = EdgeAdjacency::from_triangles(&topology.indices).unwrap();
        let eye = Vec3::new(random(), random(), random()) * 6.0;
        silhouette_edges(
            &adjacency,
            &topology.indices,
            positions,
            eye,
            &mut scratch,
            &mut edges,
        );
        // Odd inputs too: reversed and repeated edges.
        if trial % 10 == 9 && !edges.is_empty() {
            let e = edges[0];
            edges.push([e[1], e[0]]);
            edges.push(e);
        }
        chain_edges_with(&edges, &mut scratch, &mut fast, true);
        chain_edges_with(&edges, &mut scratch, &mut general, false);
        assert_eq!(fast, general, "trial {trial}: {edges:?}");
        assert_chains_cover(&edges, &fast);
        // Sparse vertex ids take the compacting path; the chains are the same.
        let sparse: Vec<[u32; 2]> = edges.iter().map(|e| e.map(|v| v * 100_003)).collect();
        let (mut sparse_fast, mut sparse_general) =
            (SilhouetteChains::default(), SilhouetteChains::default());
        chain_edges_with(&sparse, &mut scratch, &mut sparse_fast, true);
        chain_edges_with(&sparse, &mut scratch, &mut sparse_general, false);
        assert_eq!(sparse_fast, sparse_general, "trial {trial}, sparse");
        assert_eq!(sparse_fast.spans, fast.spans);
        assert!(
            sparse_fast
                .vertices
                .iter()
                .zip(&fast.vertices)
                .all(|(s, d)| *s == d * 100_003)
        );
        loops += usize::from(fast.spans.iter().all(|s| s.closed) && !fast.is_empty());
    }
    assert!(loops > 100, "only {loops} trials were pure loops");
}

#[test]
fn odd_topology_loses_no_edge() {
    let edges: Vec<[u32; 2]> = vec![
        // Figure eight: two loops through vertex 0 (degree 4).
        [0, 1],
        [1, 2],
        [2, 0],
        [0, 3],
        [3, 4],
        [4, 0],
        // Two separate loops.
        [10, 11],
        [11, 12],
        [12, 13],
        [13, 10],
        [20, 22],
        [22, 21],
        [21, 20],
        // An open chain, listed backwards and shuffled.
        [32, 33],
        [30, 31],
        [31, 32],
        // A T junction (31 has degree 3 already... use 40).
        [40, 41],
        [40, 42],
        [40, 43],
        [43, 44],
        // A self-loop and a double edge.
        [50, 50],
        [60, 61],
        [61, 60],
    ];
    let mut scratch = SilhouetteScratch::default();
    let mut chains = SilhouetteChains::default();
    chain_edges(&edges, &mut scratch, &mut chains);
    assert_chains_cover(&edges, &chains);
    let again = chains.clone();
    chain_edges(&edges, &mut scratch, &mut chains);
    assert_eq!(chains, again, "not deterministic");
    let closed = chains.iter().filter(|c| c.closed).count();
    // 2 figure-eight lobes, 2 loops, the self-loop and the double edge.
    assert_eq!(closed, 6, "{chains:?}");
    let open: Vec<&[u32]> = chains
        .iter()
        .filter(|c| !c.closed)
        .map(|c| c.vertices)
        .collect();
    assert!(open.contains(&&[30, 31, 32, 33][..]), "{open:?}");
    // The T junction: three branches.
    assert_eq!(open.len(), 4, "{open:?}");

    // Sparse, huge vertex ids take the sorting path and give the same chains.
    let offset = u32::MAX - 100;
    let shifted: Vec<[u32; 2]> = edges.iter().map(|e| e.map(|v| v + offset)).collect();
    let mut sparse = SilhouetteChains::default();
    chain_edges(&shifted, &mut scratch, &mut sparse);
    assert_chains_cover(&shifted, &sparse);
    assert_eq!(sparse.spans, chains.spans);
    let unshifted: Vec<u32> = sparse.vertices.iter().map(|v| v - offset).collect();
    assert_eq!(unshifted, chains.vertices);

    chain_edges(&[], &mut scratch, &mut chains);
    assert!(chains.is_empty());
}

fn camera() -> StrokeCamera {
    let view = bevy::transform::components::Transform::from_xyz(0.0, 0.0, 5.0)
        .looking_at(Vec3::ZERO, Vec3::Y)
        .to_matrix()
        .inverse();
    let proj = bevy::math::proj::perspective_infinite_reverse(1.0, 16.0 / 9.0, 0.1);
    StrokeCamera::new(proj * view, Vec2::new(1600.0, 900.0))
}

fn pixel_width(camera: &StrokeCamera, out: &StrokeVertices, pair: usize) -> f32 {
    let (l, _) = camera.project(Vec3::from_array(out.positions[2 * pair]));
    let (r, _) = camera.project(Vec3::from_array(out.positions[2 * pair + 1]));
    l.distance(r)
}

#[test]
fn strokes_keep_their_pixel_width_at_any_depth() {
    let camera = camera();
    let params = StrokeParams {
        width_px: 3.0,
        ..StrokeParams::default()
    };
    let mut out = StrokeVertices::new();
    // From 1 to 95 units away from the camera.
    let points = [Vec3::new(-0.5, 0.2, 4.0), Vec3::new(20.0, 5.0, -90.0)];
    build_stroke_strip(&points, &[0.0, 1.0], false, &camera, &params, &mut out);
    assert_eq!(out.positions.len(), 4);
    assert_eq!(out.indices.len(), 6);
    for (pair, point) in points.iter().enumerate() {
        let width = pixel_width(&camera, &out, pair);
        assert!((width - 3.0).abs() < 0.01, "pair {pair}: {width} px");
        // At the original point's depth.
        let (_, w) = camera.project(*point);
        let (_, wl) = camera.project(Vec3::from_array(out.positions[2 * pair]));
        assert!((w - wl).abs() < 1e-3 * w);
    }
    // With depth scaling the far end is thinner, and the limit clamps.
    out.clear();
    let params = StrokeParams {
        depth_scale: 1.0,
        width_px: 10.0,
        stroke_limit_px: 6.0,
        ..params
    };
    build_stroke_strip(&points, &[0.0, 1.0], false, &camera, &params, &mut out);
    let (near, far) = (pixel_width(&camera, &out, 0), pixel_width(&camera, &out, 1));
    assert!((near - 6.0).abs() < 0.01, "near {near}");
    assert!(far < 0.2, "far {far}");
}

#[test]
fn cameras_know_their_viewer_and_bias_keeps_the_stroke_on_screen() {
    let eye = Vec3::new(0.3, 0.2, 5.0);
    let world_from_view = bevy::transform::components::Transform::from_translation(eye)
        .looking_at(Vec3::ZERO, Vec3::Y)
        .to_matrix();
    let viewport = Vec2::new(800.0, 600.0);
    let perspective = bevy::math::proj::perspective_infinite_reverse(1.0, 4.0 / 3.0, 0.1);
    let camera = StrokeCamera::from_view(world_from_view, perspective, viewport);
    assert_eq!(camera.viewer(), Some(Viewer::Point(eye)));
    let orthographic = bevy::math::proj::orthographic(-2.0, 2.0, -1.5, 1.5, 100.0, 0.1);
    let ortho = StrokeCamera::from_view(world_from_view, orthographic, viewport);
    let Some(Viewer::Direction(back)) = ortho.viewer() else {
        panic!("orthographic camera without a view direction");
    };
    assert!(back.normalize().dot((eye - Vec3::ZERO).normalize()) > 0.999);
    assert_eq!(StrokeCamera::new(Mat4::IDENTITY, viewport).viewer(), None);

    // The pulled stroke covers the same pixels, is nearer, and keeps its width.
    let points = [Vec3::new(-0.4, 0.1, 0.0), Vec3::new(0.5, -0.2, 0.3)];
    for camera in [camera, ortho] {
        let (mut plain, mut pulled) = (StrokeVertices::new(), StrokeVertices::new());
        let params = StrokeParams::default();
        build_stroke_strip(&points, &[], false, &camera, &params, &mut plain);
        let biased = StrokeParams {
            depth_bias: 0.25,
            ..params
        };
        build_stroke_strip(&points, &[], false, &camera, &biased, &mut pulled);
        for (a, b) in plain.positions.iter().zip(&pulled.positions) {
            let (a, b) = (Vec3::from_array(*a), Vec3::from_array(*b));
            let (sa, _) = camera.project(a);
            let (sb, _) = camera.project(b);
            assert!(sa.distance(sb) < 0.01, "{sa} vs {sb}");
            let toward = match camera.viewer().unwrap() {
                Viewer::Point(e) => (e - a).normalize(),
                Viewer::Direction(d) => d.normalize(),
            };
            assert!(((b - a).dot(toward) - 0.25).abs() < 0.01, "{a} -> {b}");
        }
        for pair in 0..2 {
            let width = pixel_width(&camera, &pulled, pair);
            assert!((width - 2.0).abs() < 0.01, "{width} px");
        }
    }
}

#[test]
fn orthographic_views_face_by_direction() {
    // A tube along X seen from far above, orthographically: the silhouette is where the
    // normals turn horizontal, whatever the eye point would say.
    let tube = tube(4, 16, &[Vec3::ZERO, Vec3::X], 0.1);
    let t = &tube.topology;
    let adjacency = EdgeAdjacency::from_triangles(&t.indices).unwrap();
    let mut scratch = SilhouetteScratch::default();
    let mut edges = Vec::new();
    silhouette_edges(
        &adjacency,
        &t.indices,
        &tube.positions,
        Viewer::Direction(Vec3::Y),
        &mut scratch,
        &mut edges,
    );
    let long: Vec<_> = edges
        .iter()
        .filter(|e| (e[0] as usize) < 4 * 16 && (e[1] as usize) < 4 * 16)
        .filter(|e| e[0] % 16 == e[1] % 16)
        .collect();
    assert_eq!(long.len(), 6, "{edges:?}");
    for e in long {
        let y = tube.positions[e[0] as usize][1];
        assert!(y.abs() < 0.05, "silhouette at height {y}");
    }
}

#[test]
fn strips_are_counter_clockwise_faded_and_textured() {
    let camera = camera();
    let params = StrokeParams {
        fade: QuadraticCurve::new(0.0, -1.0, 1.0),
        texture_length_px: 10.0,
        ..StrokeParams::default()
    };
    let mut out = StrokeVertices::new();
    let points = [Vec3::ZERO, Vec3::X * 0.5, Vec3::new(1.0, 0.3, 0.0)];
    build_stroke_strip(&points, &[0.0, 0.5, 1.0], false, &camera, &params, &mut out);
    let alphas: Vec<f32> = out.colors.iter().map(|c| c[3]).collect();
    assert_eq!(alphas, vec![1.0, 1.0, 0.5, 0.5, 0.0, 0.0]);
    assert!(out.colors.iter().all(|c| c[..3] == [0.0; 3]));
    let (s0, _) = camera.project(points[0]);
    let (s1, _) = camera.project(points[1]);
    assert!((out.uvs[2][0] - s0.distance(s1) / 10.0).abs() < 1e-3);
    assert_eq!(out.uvs[3][1], 1.0);
    for tri in out.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|i| {
            camera
                .project(Vec3::from_array(out.positions[tri[i] as usize]))
                .0
        });
        assert!((b - a).perp_dot(c - a) > 0.0, "clockwise triangle {tri:?}");
    }
    // The corner keeps each segment's width (miter): wider than the plain width.
    assert!(pixel_width(&camera, &out, 1) > 2.0);
}

#[test]
fn closed_strokes_wrap() {
    let camera = camera();
    let square = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut out = StrokeVertices::new();
    build_stroke_strip(
        &square,
        &[0.0; 4],
        true,
        &camera,
        &StrokeParams::default(),
        &mut out,
    );
    // Four corners plus the repeated first pair; four segments.
    assert_eq!(out.positions.len(), 10);
    assert_eq!(out.indices.len(), 24);
    assert_eq!(out.positions[8], out.positions[0]);
    assert!(out.uvs[8][0] > out.uvs[6][0]);
    // Miters at the 90° corners: sqrt(2) times the width along the diagonal.
    let width = pixel_width(&camera, &out, 0);
    assert!((width - 2.0 * 2f32.sqrt()).abs() < 0.05, "{width}");
    // Appending keeps earlier strokes.
    build_stroke_strip(
        &square,
        &[0.0; 4],
        false,
        &camera,
        &StrokeParams::default(),
        &mut out,
    );
    assert_eq!(out.positions.len(), 18);
    assert!(
        out.indices
            .iter()
            .all(|&i| (i as usize) < out.positions.len())
    );
    assert!(out.indices[24..].iter().all(|&i| i >= 10));
}

#[test]
fn degenerate_strokes_are_skipped_not_nan() {
    let camera = camera();
    let mut out = StrokeVertices::new();
    let params = StrokeParams::default();
    let behind = Vec3::new(0.0, 0.0, 10.0); // the camera is at z = 5 looking at -z
    let cases: [(&[Vec3], bool); 6] = [
        (&[Vec3::ZERO; 4], false),
        (&[Vec3::ZERO; 4], true),
        (&[Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::X], true),
        (&[Vec3::ZERO, behind, Vec3::X, Vec3::Y, behind], true),
        (
            &[Vec3::NAN, Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.0, 5.0)],
            false,
        ),
        (&[Vec3::ZERO, Vec3::X, Vec3::ZERO, Vec3::X], false),
    ];
    for (points, closed) in cases {
        build_stroke_strip(points, &[], closed, &camera, &params, &mut out);
    }
    assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
    assert!(out.uvs.iter().flatten().all(|x| x.is_finite()));
    assert!(
        out.indices
            .iter()
            .all(|&i| (i as usize) < out.positions.len())
    );
    // A closed loop with a point behind the camera is cut open there: 0 -> X -> Y.
    let mut cut = StrokeVertices::new();
    let points = [Vec3::X, Vec3::Y, behind, Vec3::ZERO];
    build_stroke_strip(&points, &[], true, &camera, &params, &mut cut);
    assert_eq!((cut.positions.len(), cut.indices.len()), (6, 12));
    let (origin, _) = camera.project(Vec3::ZERO);
    let (left, _) = camera.project(Vec3::from_array(cut.positions[0]));
    assert!(left.distance(origin) < 2.0);
    let singular = StrokeCamera::new(Mat4::ZERO, Vec2::ZERO);
    build_stroke_strip(
        &[Vec3::ZERO, Vec3::X],
        &[],
        false,
        &singular,
        &params,
        &mut out,
    );
    assert!(out.positions.iter().flatten().all(|x| x.is_finite()));
}

/// The AVX2 projection and offset kernels give the portable path's strips, bit for bit, on
/// random polylines (open and closed, sharp turns, points behind the camera, varied widths,
/// depth scaling and fades).
#[test]
#[cfg_attr(
    not(cartoon_hair_avx2_host),
    ignore = "this CPU has no AVX2: the AVX2 kernels cannot be compared here (not run)"
)]
fn strip_avx2_and_portable_paths_agree_bit_for_bit() {
    let mut rng = crate::test_support::Rng(0x9e37_79b9_7f4a_7c15);
    let mut next = move || rng.next();
    let camera = camera();
    let mut compared = 0usize;
    for trial in 0..200 {
        let n = 2 + trial % 40;
        let centre = Vec3::new(next(), next(), next() * 3.0);
        let points: Vec<Vec3> = (0..n)
            .map(|_| centre + Vec3::new(next(), next(), next()) * 0.5)
            .collect();
        let along: Vec<f32> = (0..n).map(|i| i as f32 / n as f32).collect();
        let params = StrokeParams {
            width_px: 1.0 + 6.0 * next().abs(),
            angle_scale: next().abs(),
            depth_scale: next().abs(),
            stroke_limit_px: 2.0 + 10.0 * next().abs(),
            fade: QuadraticCurve::new(next(), next(), next()),
            depth_bias: 0.01 * next().abs(),
            ..Default::default()
        };
        let closed = trial % 3 == 0;
        let run = || {
            let mut out = StrokeVertices::default();
            build_stroke_strip(&points, &along, closed, &camera, &params, &mut out);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
            (
                bits(out.positions.as_flattened()),
                bits(out.uvs.as_flattened()),
                bits(out.colors.as_flattened()),
                out.indices.clone(),
            )
        };
        let (portable, vector) = crate::simd::on_both_paths(run);
        if let Some(vector) = vector {
            assert_eq!(portable, vector, "trial {trial}: the paths differ");
            compared += portable.0.len();
        }
    }
    // Run only where the CPU has AVX2 (see the attribute): both paths must have been compared.
    assert!(compared > 10_000, "only {compared} values compared");
}
