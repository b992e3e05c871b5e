//! Object-space silhouettes of strand tubes (thesis 4.3.7).
//!
//! Every frame, for every strand:
//!
//! 1. [`silhouette_edges`] finds the mesh edges between a front-facing and a back-facing triangle
//!    (seen from the eye point), using an [`EdgeAdjacency`] built once per tube topology;
//! 2. [`chain_edges`] links them into ordered polylines ([`SilhouetteChains`]);
//! 3. [`build_chain_strip`] (or [`build_stroke_strip`] for any polyline) turns each polyline into
//!    a screen-space stroke of constant pixel width (Northrup & Markosian 2000, Kalnins et al.
//!    2003) for a [`StrokeCamera`], unprojected back to world space so that an ordinary mesh
//!    pipeline draws it.
//!
//! Unlike the thesis, chaining is linear (per-vertex edge slots kept in a reused
//! [`SilhouetteScratch`] instead of an O(n²) insertion sort), never drops an edge, and splits
//! chains at vertices where more than two silhouette edges meet. Nothing allocates per call once
//! the reused buffers have grown; keep one [`SilhouetteScratch`] and one [`SilhouetteChains`] per
//! thread.
//!
//! A capped tube seen from the side has one closed silhouette loop: the two long sides joined
//! by the visible halves of the root and tip cap rims.

use bevy::math::{Mat4, Vec2, Vec3, Vec3A, Vec4};
use std::fmt;

/// An edge of a closed, consistently wound triangle mesh, with its two triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AdjacentEdge {
    /// The end vertices, in the order in which triangle `faces[0]` runs along the edge
    /// (`faces[1]` runs the other way).
    pub v: [u32; 2],
    /// The two triangles (indices into the triangle list, i.e. `index / 3`), lower index first.
    pub faces: [u32; 2],
}

/// The edges of a closed triangle mesh with their two triangles each; built once per topology
/// by [`EdgeAdjacency::from_triangles`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EdgeAdjacency {
    /// Every undirected edge once, sorted by `(min vertex, max vertex)`.
    pub edges: Vec<AdjacentEdge>,
    triangle_count: usize,
}

/// Why a triangle list has no [`EdgeAdjacency`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum AdjacencyError {
    /// The index count is not a multiple of three.
    NotTriangleList {
        /// The index count.
        len: usize,
    },
    /// A triangle uses one vertex twice.
    DegenerateTriangle {
        /// The triangle's index.
        face: usize,
        /// Its vertices.
        vertices: [u32; 3],
    },
    /// An edge does not belong to exactly two triangles: the mesh is open or non-manifold.
    NonManifoldEdge {
        /// The edge's vertices, lower first.
        edge: [u32; 2],
        /// How many triangles it belongs to.
        faces: usize,
    },
    /// Both triangles of an edge run along it in the same direction: inconsistent winding.
    InconsistentWinding {
        /// The edge's vertices, lower first.
        edge: [u32; 2],
        /// The two triangles.
        faces: [u32; 2],
    },
}

impl fmt::Display for AdjacencyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotTriangleList { len } => {
                write!(f, "{len} indices are not a triangle list")
            }
            Self::DegenerateTriangle { face, vertices } => {
                write!(f, "triangle {face} {vertices:?} repeats a vertex")
            }
            Self::NonManifoldEdge { edge, faces } => write!(
                f,
                "edge {edge:?} belongs to {faces} triangles, not 2: the mesh is not closed"
            ),
            Self::InconsistentWinding { edge, faces } => write!(
                f,
                "triangles {faces:?} both run along edge {edge:?} the same way: inconsistent winding"
            ),
        }
    }
}

impl std::error::Error for AdjacencyError {}

impl EdgeAdjacency {
    /// The adjacency of a closed, consistently wound triangle list; the first offending edge (in
    /// vertex order) is named when it is not one.
    pub fn from_triangles(indices: &[u32]) -> Result<Self, AdjacencyError> {
        if !indices.len().is_multiple_of(3) {
            return Err(AdjacencyError::NotTriangleList { len: indices.len() });
        }
        // (min << 32 | max, face, runs min -> max)
        let mut half = Vec::with_capacity(indices.len());
        for (face, tri) in indices.chunks_exact(3).enumerate() {
            let [a, b, c] = [tri[0], tri[1], tri[2]];
            if a == b || b == c || c == a {
                return Err(AdjacencyError::DegenerateTriangle {
                    face,
                    vertices: [a, b, c],
                });
            }
            for (p, q) in [(a, b), (b, c), (c, a)] {
                let key = (u64::from(p.min(q)) << 32) | u64::from(p.max(q));
                half.push((key, face as u32, p < q));
            }
        }
        half.sort_unstable_by_key(|&(key, face, _)| (key, face));
        let mut edges = Vec::with_capacity(half.len() / 2);
        for group in half.chunk_by(|x, y| x.0 == y.0) {
            let edge = [(group[0].0 >> 32) as u32, group[0].0 as u32];
            let &[(_, f0, forward0), (_, f1, forward1)] = group else {
                return Err(AdjacencyError::NonManifoldEdge {
                    edge,
                    faces: group.len(),
                });
            };
            if forward0 == forward1 {
                return Err(AdjacencyError::InconsistentWinding {
                    edge,
                    faces: [f0, f1],
                });
            }
            edges.push(AdjacentEdge {
                v: if forward0 { edge } else { [edge[1], edge[0]] },
                faces: [f0, f1],
            });
        }
        Ok(Self {
            edges,
            triangle_count: indices.len() / 3,
        })
    }

    /// The number of triangles of the mesh the adjacency was built from.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }
}

/// Reusable buffers of [`silhouette_edges`] and [`chain_edges`]: keep one per thread so that
/// neither allocates once warmed up.
#[derive(Clone, Debug, Default)]
pub struct SilhouetteScratch {
    facing: Vec<bool>,
    points: Vec<Vec3A>,
    /// Per edge: its ends as compact vertex ids (only when ids are sparse).
    ends: Vec<[u32; 2]>,
    /// Per compact vertex id: how many edge ends are at it. All zero between calls: only the
    /// entries a call touches are reset.
    degree: Vec<u32>,
    /// Per compact vertex id: its first two edge ends (enough to walk through a vertex of
    /// degree two).
    slots: Vec<[Slot; 2]>,
    used: Vec<bool>,
    /// Sorted distinct vertex ids, when they are too sparse to index directly.
    ids: Vec<u32>,
    /// Per compact vertex id: the far end of the edge leaving it, compact and as a vertex id
    /// (see [`chain_loops`]).
    next: Vec<[u32; 2]>,
}

/// An edge end at a vertex: the edge and its far end.
#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    edge: u32,
    /// The far end's compact id.
    far: u32,
    /// The far end's vertex id.
    far_id: u32,
}

/// Where a mesh is seen from, for the facing test of silhouette extraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Viewer {
    /// A perspective eye point: triangle `(a, b, c)` faces it when
    /// `dot((b - a) x (c - a), eye - a) > 0`.
    Point(Vec3),
    /// An orthographic view: the direction toward the viewer (need not be normalised); a
    /// triangle faces it when `dot((b - a) x (c - a), direction) > 0`.
    Direction(Vec3),
}

impl From<Vec3> for Viewer {
    /// A perspective eye point.
    fn from(eye: Vec3) -> Self {
        Self::Point(eye)
    }
}

impl Viewer {
    /// Whether triangle `(a, b, c)` (counter-clockwise seen from its front) faces the viewer.
    /// Zero-area and non-finite triangles do not.
    #[inline(always)]
    pub fn faces(self, a: Vec3A, b: Vec3A, c: Vec3A) -> bool {
        // Edge vectors first: they are small and exact, unlike positions relative to the eye.
        let normal = (b - a).cross(c - a);
        let toward = match self {
            Self::Point(eye) => Vec3A::from(eye) - a,
            Self::Direction(d) => Vec3A::from(d),
        };
        normal.dot(toward) > 0.0
    }
}

/// Writes the silhouette edges of a closed mesh seen from `viewer` (an eye point as a `Vec3`, or
/// a [`Viewer`]) (a perspective eye point) into
/// `out` (cleared first).
///
/// A triangle is front-facing when [`Viewer::faces`] says so: `dot(normal, eye - point on it) > 0`
/// for an eye point (normal from the counter-clockwise index order; zero-area triangles, such as
/// those of a tip tapered to a point, are not front-facing); an edge is a silhouette edge when one of its triangles is
/// front-facing and the other is not. Each edge is oriented so that its front-facing triangle lies
/// on its left as seen from the eye (it runs along the edge in that triangle's winding), so the
/// edges of a silhouette loop all run the same way round.
///
/// # Panics
///
/// If `indices` is not the triangle list `adjacency` was built from (its length differs) or a
/// vertex index is out of range of `positions`.
pub fn silhouette_edges(
    adjacency: &EdgeAdjacency,
    indices: &[u32],
    positions: &[[f32; 3]],
    viewer: impl Into<Viewer>,
    scratch: &mut SilhouetteScratch,
    out: &mut Vec<[u32; 2]>,
) {
    assert_eq!(
        indices.len(),
        3 * adjacency.triangle_count,
        "the triangle list is not the one the adjacency was built from"
    );
    let SilhouetteScratch { facing, points, .. } = scratch;
    // Aligned 4-wide copies make the per-triangle test cheaper than reading `[f32; 3]`s.
    points.clear();
    points.extend(positions.iter().map(|p| Vec3A::from_array(*p)));
    let viewer = viewer.into();
    facing.clear();
    facing.extend(indices.chunks_exact(3).map(|tri| {
        let a = points[tri[0] as usize];
        let b = points[tri[1] as usize];
        let c = points[tri[2] as usize];
        viewer.faces(a, b, c)
    }));
    let facing: &[bool] = facing;
    // Branch-free: every edge is written, and kept only when its faces differ (silhouette edges
    // are few and scattered, so a branch on them would mispredict often).
    out.clear();
    out.resize(adjacency.edges.len(), [0; 2]);
    let mut kept = 0;
    for edge in &adjacency.edges {
        let front0 = facing[edge.faces[0] as usize];
        let [v0, v1] = edge.v;
        out[kept] = if front0 { [v0, v1] } else { [v1, v0] };
        kept += usize::from(front0 != facing[edge.faces[1] as usize]);
    }
    out.truncate(kept);
}

/// One ordered polyline of silhouette vertices, borrowed from [`SilhouetteChains`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SilhouetteChain<'a> {
    /// The vertices in order; each consecutive pair is an input edge. A closed chain lists each
    /// vertex once (the closing edge runs from the last vertex back to the first).
    pub vertices: &'a [u32],
    /// Whether an edge joins the last vertex to the first.
    pub closed: bool,
}

/// Where one chain lies in [`SilhouetteChains::vertices`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainSpan {
    /// First vertex (index into [`SilhouetteChains::vertices`]).
    pub start: usize,
    /// One past the last vertex.
    pub end: usize,
    /// Whether an edge joins the last vertex to the first.
    pub closed: bool,
}

/// The chains of one strand, stored flat so that rebuilding them does not allocate.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SilhouetteChains {
    /// Every chain's vertices, chain after chain.
    pub vertices: Vec<u32>,
    /// The chains, in the order [`chain_edges`] found them.
    pub spans: Vec<ChainSpan>,
}

impl SilhouetteChains {
    /// Removes every chain, keeping the buffers.
    pub fn clear(&mut self) {
        self.vertices.clear();
        self.spans.clear();
    }

    /// The number of chains.
    pub fn len(&self) -> usize {
        self.spans.len()
    }

    /// Whether there are no chains.
    pub fn is_empty(&self) -> bool {
        self.spans.is_empty()
    }

    /// Chain `i`, if there is one.
    pub fn get(&self, i: usize) -> Option<SilhouetteChain<'_>> {
        self.spans.get(i).map(|s| SilhouetteChain {
            vertices: &self.vertices[s.start..s.end],
            closed: s.closed,
        })
    }

    /// The chains in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = SilhouetteChain<'_>> + '_ {
        self.spans.iter().map(|s| SilhouetteChain {
            vertices: &self.vertices[s.start..s.end],
            closed: s.closed,
        })
    }
}

/// Links `edges` into ordered polylines, written to `out` (cleared first).
///
/// Every input edge ends up in exactly one chain, as a consecutive pair of vertices (or as the
/// closing pair of a closed chain). Chains end at vertices where other than two edges meet
/// (ends of open chains, and junctions of three or more edges, where every branch becomes a
/// chain of its own); loops of vertices with two edges each become closed chains. A chain runs
/// the way its first edge points, so the consistently oriented edges of [`silhouette_edges`]
/// give consistently oriented chains. A self-loop `[v, v]` is a closed chain `[v]`.
///
/// Deterministic. `O(edges)` when vertex ids are small (below `8 * edges.len() + 4096`, as for
/// a strand's mesh: per-vertex lists live in `scratch`, and only the entries a call touches are
/// reset), `O(edges log edges)` otherwise. Does not allocate once `scratch` and `out` have grown.
pub fn chain_edges(
    edges: &[[u32; 2]],
    scratch: &mut SilhouetteScratch,
    out: &mut SilhouetteChains,
) {
    chain_edges_with(edges, scratch, out, true);
}

/// [`chain_edges`], with the fast path for pure loops ([`chain_loops`]) on or off.
fn chain_edges_with(
    edges: &[[u32; 2]],
    scratch: &mut SilhouetteScratch,
    out: &mut SilhouetteChains,
    fast_loops: bool,
) {
    out.clear();
    if edges.is_empty() {
        return;
    }
    let SilhouetteScratch {
        ends,
        degree,
        slots,
        used,
        ids,
        next,
        ..
    } = scratch;
    let max_id = edges.iter().map(|e| e[0].max(e[1])).max().unwrap_or(0) as usize;
    let (ends, vertex_count): (&[[u32; 2]], usize) = if max_id < 8 * edges.len() + 4096 {
        (edges, max_id + 1)
    } else {
        ids.clear();
        ids.extend(edges.iter().flatten().copied());
        ids.sort_unstable();
        ids.dedup();
        ends.clear();
        ends.extend(
            edges
                .iter()
                .map(|e| e.map(|v| ids.binary_search(&v).unwrap_or_default() as u32)),
        );
        (ends, ids.len())
    };
    if degree.len() < vertex_count {
        degree.resize(vertex_count, 0);
        slots.resize(vertex_count, [Slot::default(); 2]);
        next.resize(vertex_count, [0; 2]);
    }
    if fast_loops && chain_loops(edges, ends, degree, next, out) {
        return;
    }
    for (e, (pair, ids)) in ends.iter().zip(edges).enumerate() {
        for side in 0..2 {
            let v = pair[side] as usize;
            let d = degree[v];
            if d < 2 {
                slots[v][d as usize] = Slot {
                    edge: e as u32,
                    far: pair[1 - side],
                    far_id: ids[1 - side],
                };
            }
            degree[v] = d + 1;
        }
    }
    used.clear();
    used.resize(edges.len(), false);

    let mut walker = Walker {
        edges,
        ends,
        degree,
        slots,
        used,
        out,
    };
    // Open chains (and loops through junctions) start at vertices of degree other than two.
    for (e, pair) in ends.iter().enumerate() {
        for &v in pair {
            if walker.degree[v as usize] != 2 && !walker.used[e] {
                walker.walk(v, e as u32);
            }
        }
    }
    // What is left are loops of vertices of degree two.
    for (e, pair) in ends.iter().enumerate() {
        if !walker.used[e] {
            walker.walk(pair[0], e as u32);
        }
    }
    // Restore the all-zero invariant of the degrees.
    for pair in ends {
        degree[pair[0] as usize] = 0;
        degree[pair[1] as usize] = 0;
    }
}

/// The common case of [`chain_edges`], fast: when every vertex has exactly one edge leaving it
/// and one arriving (as at every silhouette vertex that is not a junction, since the edges of
/// [`silhouette_edges`] run round the front-facing region), the edges form loops, found by
/// following the edge leaving each vertex. Writes them and returns `true` then; otherwise
/// writes nothing and returns `false`. The chains are those the general walk finds: each loop
/// starts at the first vertex of its first edge. `degree` is all zero before and after.
fn chain_loops(
    edges: &[[u32; 2]],
    ends: &[[u32; 2]],
    degree: &mut [u32],
    next: &mut [[u32; 2]],
    out: &mut SilhouetteChains,
) -> bool {
    // Leaving edges count in the low half of `degree`, arriving ones in the high half.
    const ONE_EACH: u32 = 0x1_0001;
    for (&[a, b], &[_, b_id]) in ends.iter().zip(edges) {
        degree[a as usize] += 1;
        degree[b as usize] += 1 << 16;
        next[a as usize] = [b, b_id];
    }
    let loops = ends
        .iter()
        .all(|&[a, b]| degree[a as usize] == ONE_EACH && degree[b as usize] == ONE_EACH);
    if !loops {
        for &[a, b] in ends {
            degree[a as usize] = 0;
            degree[b as usize] = 0;
        }
        return false;
    }
    // `next` is a permutation of the vertices: following it from any vertex comes back. Visited
    // vertices get their degree reset to zero.
    for (&[start, _], &[start_id, _]) in ends.iter().zip(edges) {
        if degree[start as usize] == 0 {
            continue;
        }
        let begin = out.vertices.len();
        let (mut v, mut id) = (start, start_id);
        loop {
            degree[v as usize] = 0;
            out.vertices.push(id);
            [v, id] = next[v as usize];
            if v == start {
                break;
            }
        }
        out.spans.push(ChainSpan {
            start: begin,
            end: out.vertices.len(),
            closed: true,
        });
    }
    true
}

/// The state of [`chain_edges`] while it walks the chains.
struct Walker<'a> {
    edges: &'a [[u32; 2]],
    ends: &'a [[u32; 2]],
    degree: &'a [u32],
    slots: &'a [[Slot; 2]],
    used: &'a mut [bool],
    out: &'a mut SilhouetteChains,
}

impl Walker<'_> {
    /// Walks a chain from compact vertex `start` along unused edge `first`, through vertices of
    /// degree two, until a vertex of another degree, a dead end or `start` again.
    fn walk(&mut self, start: u32, first: u32) {
        let begin = self.out.vertices.len();
        let [a, b] = self.ends[first as usize];
        let forward = a == start;
        let [a_id, b_id] = self.edges[first as usize];
        let (start_id, mut current, mut current_id) = if forward {
            (a_id, b, b_id)
        } else {
            (b_id, a, a_id)
        };
        self.out.vertices.push(start_id);
        self.used[first as usize] = true;
        let mut edge = first;
        let mut closed = false;
        loop {
            if current == start {
                closed = true;
                break;
            }
            self.out.vertices.push(current_id);
            if self.degree[current as usize] != 2 {
                break;
            }
            let [s0, s1] = self.slots[current as usize];
            let next = if s0.edge == edge { s1 } else { s0 };
            if self.used[next.edge as usize] {
                break;
            }
            self.used[next.edge as usize] = true;
            (edge, current, current_id) = (next.edge, next.far, next.far_id);
        }
        if !forward {
            self.out.vertices[begin..].reverse();
        }
        self.out.spans.push(ChainSpan {
            start: begin,
            end: self.out.vertices.len(),
            closed,
        });
    }
}

/// How silhouette polylines become strokes; the widths are in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeParams {
    /// Stroke width in pixels (at depth `1` when `depth_scale` is not `0`). Default `2.0`.
    pub width_px: f32,
    /// Angle scaling in `[0, 1]`: how much of the miter compensation `1 / cos(half the turn)` is
    /// applied at corners, so that a corner keeps the stroke's width across each segment (`1`)
    /// or is drawn with a plain, thinner joint (`0`). The compensation is capped at 4x (turns
    /// sharper than about 150°). Default `1.0`.
    pub angle_scale: f32,
    /// Depth scaling: the width is multiplied by `(1 / w)^depth_scale`, `w` the clip-space `w`
    /// (the view depth for a perspective camera; always `1` for an orthographic one). `0` keeps
    /// a constant pixel width, `1` shrinks far strokes like world-space geometry. Default `0.0`.
    pub depth_scale: f32,
    /// A global multiplier on the width. Default `1.0`.
    pub stroke_scale: f32,
    /// The most a stroke may be wide, in pixels, after every scaling: each side's half-width is
    /// clamped to half of it. Default `8.0`.
    pub stroke_limit_px: f32,
    /// The **E** curve `[a, b, c]`: alpha `a*x^2 + b*x + c` (clamped to `[0, 1]`) at `x` from `0`
    /// at the root to `1` at the tip. Default `[0, 0, 1]` (opaque).
    pub fade: [f32; 3],
    /// Pixels of stroke per texture repeat: `u = arc length in px / texture_length_px`.
    /// Default `64.0`.
    pub texture_length_px: f32,
    /// World-space distance each stroke point is pulled toward the camera's viewer (see
    /// [`StrokeCamera::with_viewer`]; nothing is pulled without one) before it is projected. A
    /// point moved along its eye ray keeps its place on screen, so the stroke keeps its shape and
    /// pixel width, but it is drawn in front of the surface it outlines. Default `0.0`.
    pub depth_bias: f32,
    /// Linear RGBA stroke colour; each vertex gets it with its alpha multiplied by the **E**
    /// curve. Default opaque black.
    pub color: [f32; 4],
}

impl Default for StrokeParams {
    fn default() -> Self {
        Self {
            width_px: 2.0,
            angle_scale: 1.0,
            depth_scale: 0.0,
            stroke_scale: 1.0,
            stroke_limit_px: 8.0,
            fade: [0.0, 0.0, 1.0],
            texture_length_px: 64.0,
            depth_bias: 0.0,
            color: [0.0, 0.0, 0.0, 1.0],
        }
    }
}

/// The camera strokes are built for: the view-projection matrix, its inverse and the viewport.
/// Build it once per frame and camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeCamera {
    view_proj: Mat4,
    /// World-space (homogeneous) offset per pixel along screen x and y, per unit clip `w`.
    unproject_x: Vec4,
    unproject_y: Vec4,
    half_viewport: Vec2,
    viewer: Option<Viewer>,
}

impl StrokeCamera {
    /// A camera with `view_proj` (clip from world; wgpu conventions: NDC `y` up) and a viewport
    /// `viewport` pixels in size. A singular matrix gives zero-width strokes; a non-positive
    /// viewport size counts as one pixel.
    pub fn new(view_proj: Mat4, viewport: Vec2) -> Self {
        let half_viewport = (viewport * 0.5).max(Vec2::splat(0.5));
        let half_viewport = if half_viewport.is_finite() {
            half_viewport
        } else {
            Vec2::splat(0.5)
        };
        let inverse = view_proj.inverse();
        let (unproject_x, unproject_y) = if inverse.is_finite() && view_proj.determinant() != 0.0 {
            (
                inverse.x_axis / half_viewport.x,
                inverse.y_axis / half_viewport.y,
            )
        } else {
            (Vec4::ZERO, Vec4::ZERO)
        };
        Self {
            view_proj,
            unproject_x,
            unproject_y,
            half_viewport,
            viewer: None,
        }
    }

    /// The camera whose view (the camera's world transform) and projection are given: its
    /// viewer is the camera's position for a perspective projection (the projection's last row
    /// depends on depth) and its backward direction otherwise.
    pub fn from_view(world_from_view: Mat4, clip_from_view: Mat4, viewport: Vec2) -> Self {
        let view_from_world = world_from_view.inverse();
        let orthographic = clip_from_view.row(3) == Vec4::W;
        let viewer = if orthographic {
            Viewer::Direction(world_from_view.z_axis.truncate())
        } else {
            Viewer::Point(world_from_view.w_axis.truncate())
        };
        Self::new(clip_from_view * view_from_world, viewport).with_viewer(viewer)
    }

    /// This camera, seen from `viewer`: the eye point of a perspective camera, or the direction
    /// toward an orthographic one. It is what [`StrokeParams::depth_bias`] pulls toward and
    /// what the facing test of [`silhouette_edges`] should be given.
    pub fn with_viewer(mut self, viewer: Viewer) -> Self {
        let finite = match viewer {
            Viewer::Point(p) => p.is_finite(),
            Viewer::Direction(d) => d.is_finite() && d != Vec3::ZERO,
        };
        self.viewer = finite.then_some(viewer);
        self
    }

    /// The viewer given by [`StrokeCamera::with_viewer`] or [`StrokeCamera::from_view`].
    pub fn viewer(&self) -> Option<Viewer> {
        self.viewer
    }

    /// The viewport size in pixels.
    pub fn viewport(&self) -> Vec2 {
        self.half_viewport * 2.0
    }

    /// `p` in pixels from the viewport centre (`y` up) and its clip `w`.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        let clip = self.view_proj * p.extend(1.0);
        (
            clip.truncate().truncate() / clip.w * self.half_viewport,
            clip.w,
        )
    }
}

/// The points of a stroke being built, one array per quantity so that the passes over them
/// vectorise.
#[derive(Clone, Debug, Default)]
struct Run {
    /// World position (after the depth bias).
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Pixels from the viewport centre, `y` up.
    sx: Vec<f32>,
    sy: Vec<f32>,
    /// Clip-space `w`; NaN for a point behind the camera or not finite.
    w: Vec<f32>,
    /// Position along the strand on input, alpha after projection.
    alpha: Vec<f32>,
    /// Unit screen direction to the next point (to the first for the last point of a loop) and
    /// the screen distance to it in pixels.
    dx: Vec<f32>,
    dy: Vec<f32>,
    length: Vec<f32>,
    /// Width factor of depth scaling.
    depth: Vec<f32>,
    /// The stroke's left and right vertices (world space).
    left: [Vec<f32>; 3],
    right: [Vec<f32>; 3],
}

impl Run {
    /// Makes every array at least `n` long (contents unspecified): the passes use the first `n`
    /// entries, so arrays never shrink and refill between strokes.
    fn reserve_points(&mut self, n: usize) {
        if self.x.len() >= n {
            return;
        }
        for v in self.point_arrays() {
            v.resize(n, 0.0);
        }
        for v in [
            &mut self.dx,
            &mut self.dy,
            &mut self.length,
            &mut self.depth,
        ]
        .into_iter()
        .chain(&mut self.left)
        .chain(&mut self.right)
        {
            v.resize(n, 0.0);
        }
    }

    /// The per-point arrays that survive projection.
    fn point_arrays(&mut self) -> [&mut Vec<f32>; 7] {
        [
            &mut self.x,
            &mut self.y,
            &mut self.z,
            &mut self.sx,
            &mut self.sy,
            &mut self.w,
            &mut self.alpha,
        ]
    }

    fn valid(&self, i: usize) -> bool {
        !self.w[i].is_nan()
    }

    fn screen_distance_squared(&self, i: usize, j: usize) -> f32 {
        let (dx, dy) = (self.sx[i] - self.sx[j], self.sy[i] - self.sy[j]);
        dx * dx + dy * dy
    }
}

/// Stroke geometry: world-space triangles of screen-space strokes, appended to by
/// [`build_stroke_strip`] and [`build_chain_strip`].
#[derive(Clone, Debug, Default)]
pub struct StrokeVertices {
    /// World-space positions.
    pub positions: Vec<[f32; 3]>,
    /// `u` along the stroke (arc length in pixels / [`StrokeParams::texture_length_px`]), `v`
    /// across it: `0` on the left side, `1` on the right side (seen from the camera, walking the
    /// stroke forward).
    pub uvs: Vec<[f32; 2]>,
    /// [`StrokeParams::color`] per vertex, its alpha multiplied by the **E** curve.
    pub colors: Vec<[f32; 4]>,
    /// Triangle list into the vertices, counter-clockwise as seen from the camera.
    pub indices: Vec<u32>,
    run: Run,
}

impl StrokeVertices {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Removes every vertex and index, keeping the buffers.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.uvs.clear();
        self.colors.clear();
        self.indices.clear();
    }
}

/// Points closer than this on screen (pixels) are merged.
const MIN_SEGMENT_PX: f32 = 1e-3;
/// Points with a clip `w` at most this are behind the camera (or on its plane) and skipped.
const MIN_CLIP_W: f32 = 1e-6;
/// The largest miter compensation.
const MAX_MITER: f32 = 4.0;

/// Appends a screen-space stroke along the world-space polyline `points_world` to `out`.
///
/// The points are projected to pixels. At each point the stroke is offset both ways
/// perpendicular to the normalised sum of the adjacent segment directions (a miter), by half the
/// width times: the miter compensation (see [`StrokeParams::angle_scale`]), the depth scaling,
/// and [`StrokeParams::stroke_scale`], then clamped by [`StrokeParams::stroke_limit_px`]. The
/// offset points are unprojected back to world space at the original point's depth, so the
/// stroke keeps its pixel width wherever it is drawn from this camera. `along_strand[i]` (`0` at
/// the root, `1` at the tip; missing values count as `0`) gives point `i`'s alpha from the
/// **E** curve. A closed polyline wraps around (its first vertex pair is repeated at the end so
/// that `u` runs on).
///
/// Points behind the camera (clip `w` near or below zero) or not finite split the stroke into
/// pieces; points within a thousandth of a pixel of the previous one are merged. Pieces of fewer
/// than two points add nothing. The output is always finite for finite cameras.
pub fn build_stroke_strip(
    points_world: &[Vec3],
    along_strand: &[f32],
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    build_strip(
        points_world.len(),
        |i| (points_world[i], along_strand.get(i).copied().unwrap_or(0.0)),
        closed,
        camera,
        params,
        out,
    );
}

/// [`build_stroke_strip`] for a chain of mesh vertices, without copying them out first:
/// `positions` and `along_strand` are indexed by the chain's vertex indices (for a strand tube,
/// `along_strand` is the `v` of [`TubeTopology::uvs`](crate::mesh::tube::TubeTopology::uvs);
/// missing values count as `0`).
///
/// # Panics
///
/// If a chain vertex is out of range of `positions`.
pub fn build_chain_strip(
    chain: SilhouetteChain<'_>,
    positions: &[[f32; 3]],
    along_strand: &[f32],
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    build_strip(
        chain.vertices.len(),
        |i| {
            let v = chain.vertices[i] as usize;
            (
                Vec3::from_array(positions[v]),
                along_strand.get(v).copied().unwrap_or(0.0),
            )
        },
        chain.closed,
        camera,
        params,
        out,
    );
}

/// The stroke along `n` points given by `point(i) = (world position, along strand)`.
fn build_strip(
    n: usize,
    point: impl Fn(usize) -> (Vec3, f32),
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    if n < 2 {
        return;
    }
    let mut run = std::mem::take(&mut out.run);
    run.reserve_points(n);
    {
        let (x, y, z, a) = (
            &mut run.x[..n],
            &mut run.y[..n],
            &mut run.z[..n],
            &mut run.alpha[..n],
        );
        for i in 0..n {
            let (p, along) = point(i);
            (x[i], y[i], z[i], a[i]) = (p.x, p.y, p.z, along);
        }
    }
    project(&mut run, n, camera, params);
    // A closed polyline with a bad point is cut open just after its last bad point.
    let mut wrap = closed;
    if closed && let Some(bad) = (0..n).rposition(|i| !run.valid(i)) {
        for v in run.point_arrays() {
            v[..n].rotate_left(bad + 1);
        }
        wrap = false;
    }
    // Emit each stretch of valid points, merging near-duplicates in place.
    let mut i = 0;
    while i < n {
        if !run.valid(i) {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && run.valid(i) {
            i += 1;
        }
        let kept = merge_duplicates(&mut run, start, i);
        let len = kept - start;
        // Only a closed polyline without bad points (one stretch) wraps; its end may repeat its
        // start.
        let len = if wrap
            && len > 2
            && run.screen_distance_squared(start, kept - 1) < MIN_SEGMENT_PX * MIN_SEGMENT_PX
        {
            len - 1
        } else {
            len
        };
        emit_run(&mut run, start, len, wrap, camera, params, out);
    }
    out.run = run;
}

/// Drops the points of `start..end` closer than [`MIN_SEGMENT_PX`] on screen to the point kept
/// before them, moving the rest down; returns the new end.
fn merge_duplicates(run: &mut Run, start: usize, end: usize) -> usize {
    let close = |run: &Run, i: usize, j: usize| {
        run.screen_distance_squared(i, j) < MIN_SEGMENT_PX * MIN_SEGMENT_PX
    };
    // Usually there are none: then nothing moves (tested without an early exit, which
    // vectorises).
    let any = (start + 1..end).fold(false, |any, i| any | close(run, i, i - 1));
    if !any {
        return end;
    }
    let Some(first) = (start + 1..end).find(|&i| close(run, i, i - 1)) else {
        return end;
    };
    let mut kept = first;
    for i in first + 1..end {
        if !close(run, i, kept - 1) {
            for v in run.point_arrays() {
                v[kept] = v[i];
            }
            kept += 1;
        }
    }
    kept
}

/// `a*x^2 + b*x + c` at `x` clamped to `[0, 1]`, clamped to `[0, 1]`; `0` when not finite.
#[inline(always)]
fn eval_unit([a, b, c]: [f32; 3], x: f32) -> f32 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let v = (a * x + b) * x + c;
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Moves the run's points toward the viewer by the depth bias, projects them, and turns their
/// position along the strand into alpha.
fn project(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { project_avx2(run, n, camera, params) };
        return;
    }
    project_portable(run, n, camera, params);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn project_avx2(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    project_portable(run, n, camera, params);
}

/// The projection pass: straight-line arithmetic per point, so that it vectorises.
#[inline(always)]
fn project_portable(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    let bias = if params.depth_bias.is_finite() {
        params.depth_bias
    } else {
        0.0
    };
    // Pull toward an eye point (`eye_weight = 1`) or along a direction (`0`).
    let (eye, eye_weight, direction) = match camera.viewer {
        _ if bias == 0.0 => (Vec3::ZERO, 0.0, Vec3::ZERO),
        Some(Viewer::Point(eye)) => (eye, 1.0, Vec3::ZERO),
        Some(Viewer::Direction(d)) => (Vec3::ZERO, 0.0, d.normalize_or_zero() * bias),
        None => (Vec3::ZERO, 0.0, Vec3::ZERO),
    };
    let m = camera.view_proj;
    let (hx, hy) = (camera.half_viewport.x, camera.half_viewport.y);
    let fade = params.fade;
    let Run {
        x,
        y,
        z,
        sx,
        sy,
        w,
        alpha,
        ..
    } = run;
    let (x, y, z) = (&mut x[..n], &mut y[..n], &mut z[..n]);
    let (sx, sy, w, alpha) = (&mut sx[..n], &mut sy[..n], &mut w[..n], &mut alpha[..n]);
    for i in 0..n {
        let (mut px, mut py, mut pz) = (x[i], y[i], z[i]);
        // Toward the eye: (eye - p) / |eye - p| * bias (nothing at the eye itself).
        let (tx, ty, tz) = (eye.x - px, eye.y - py, eye.z - pz);
        let d2 = tx * tx + ty * ty + tz * tz;
        let k = if d2 > 0.0 {
            eye_weight * bias / d2.sqrt()
        } else {
            0.0
        };
        px += tx * k + direction.x;
        py += ty * k + direction.y;
        pz += tz * k + direction.z;
        let cx = m.x_axis.x * px + m.y_axis.x * py + m.z_axis.x * pz + m.w_axis.x;
        let cy = m.x_axis.y * px + m.y_axis.y * py + m.z_axis.y * pz + m.w_axis.y;
        let cz = m.x_axis.z * px + m.y_axis.z * py + m.z_axis.z * pz + m.w_axis.z;
        let cw = m.x_axis.w * px + m.y_axis.w * py + m.z_axis.w * pz + m.w_axis.w;
        // Non-finite points give non-finite clip coordinates.
        let finite = cx.is_finite() & cy.is_finite() & cz.is_finite() & cw.is_finite();
        let valid = finite & (cw > MIN_CLIP_W);
        (x[i], y[i], z[i]) = (px, py, pz);
        let inv_w = cw.recip();
        sx[i] = cx * hx * inv_w;
        sy[i] = cy * hy * inv_w;
        w[i] = if valid { cw } else { f32::NAN };
        alpha[i] = eval_unit(fade, alpha[i]);
    }
}

/// Appends the strip of the `m` valid, distinct points of `run` from `start`.
fn emit_run(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    if m < 2 {
        return;
    }
    let closed = closed && m > 2;
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2, checked just above.
        unsafe { emit_run_avx2(run, start, m, closed, camera, params, out) };
        return;
    }
    emit_run_portable(run, start, m, closed, camera, params, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn emit_run_avx2(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    emit_run_portable(run, start, m, closed, camera, params, out);
}

/// What every stroke point's offset needs.
#[derive(Clone, Copy)]
struct OffsetParams {
    half_width: f32,
    half_limit: f32,
    angle_scale: f32,
    /// Whether offsets leave the homogeneous `w` alone (the usual cameras): no division.
    affine: bool,
    unproject_x: Vec4,
    unproject_y: Vec4,
}

/// The left and right stroke vertices of a point at world `p` with clip `w` and depth-scaling
/// factor `depth`, between screen directions `incoming` and `outgoing`: offset both ways
/// perpendicular to the miter, unprojected at the point's depth.
#[inline(always)]
fn offset_point(
    o: &OffsetParams,
    incoming: (f32, f32),
    outgoing: (f32, f32),
    p: (f32, f32, f32),
    w: f32,
    depth: f32,
) -> ([f32; 3], [f32; 3]) {
    let (sx, sy) = (incoming.0 + outgoing.0, incoming.1 + outgoing.1);
    let sum_length = (sx * sx + sy * sy).sqrt();
    // cos of the angle between the miter and each segment's normal is |sum| / 2.
    let turned = sum_length > 1e-6;
    let inv = if turned { sum_length.recip() } else { 0.0 };
    let (tx, ty) = if turned {
        (sx * inv, sy * inv)
    } else {
        incoming
    };
    // 1 / cos, with cos = max(|sum| / 2, 1 / MAX_MITER).
    let inv_cos = (2.0 * inv).min(MAX_MITER);
    let miter = if turned {
        1.0 + o.angle_scale * (inv_cos - 1.0)
    } else {
        1.0
    };
    let hw = o.half_width * miter * depth;
    let hw = if hw.is_finite() {
        hw.clamp(0.0, o.half_limit)
    } else {
        0.0
    };
    // The perpendicular (-ty, tx) scaled to the half-width, in pixels, then in world units at
    // clip depth `w` (homogeneous: the `w` offset is zero for the usual cameras, and dividing by
    // exactly one changes nothing).
    let (ox, oy) = (-ty * hw * w, tx * hw * w);
    let (ux, uy) = (o.unproject_x, o.unproject_y);
    let (kx, ky, kz, kw) = (
        ux.x * ox + uy.x * oy,
        ux.y * ox + uy.y * oy,
        ux.z * ox + uy.z * oy,
        ux.w * ox + uy.w * oy,
    );
    let (lw, rw) = if o.affine {
        (1.0, 1.0)
    } else {
        ((1.0 + kw).recip(), (1.0 - kw).recip())
    };
    let left = [(p.0 + kx) * lw, (p.1 + ky) * lw, (p.2 + kz) * lw];
    let right = [(p.0 - kx) * rw, (p.1 - ky) * rw, (p.2 - kz) * rw];
    let finite = left[0].is_finite()
        & left[1].is_finite()
        & left[2].is_finite()
        & right[0].is_finite()
        & right[1].is_finite()
        & right[2].is_finite();
    let pick = |a: f32, b: f32| if finite { a } else { b };
    (
        [pick(left[0], p.0), pick(left[1], p.1), pick(left[2], p.2)],
        [
            pick(right[0], p.0),
            pick(right[1], p.1),
            pick(right[2], p.2),
        ],
    )
}

/// The strip of one run; inlined into each target-feature variant.
#[inline(always)]
fn emit_run_portable(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    let end = start + m;
    let Run {
        x,
        y,
        z,
        sx,
        sy,
        w,
        alpha,
        dx,
        dy,
        length,
        depth,
        left,
        right,
    } = run;
    let (x, y, z, w, alpha) = (
        &x[start..end],
        &y[start..end],
        &z[start..end],
        &w[start..end],
        &alpha[start..end],
    );
    let (sx, sy) = (&sx[start..end], &sy[start..end]);
    let (dx, dy, length) = (
        &mut dx[start..end],
        &mut dy[start..end],
        &mut length[start..end],
    );
    // Segment directions and lengths; the last point's segment closes the loop (unused when
    // open).
    let segment = |i: usize, j: usize| {
        let (ex, ey) = (sx[j] - sx[i], sy[j] - sy[i]);
        let l = (ex * ex + ey * ey).sqrt();
        let inv = l.recip();
        if l > 0.0 {
            (ex * inv, ey * inv, l)
        } else {
            (1.0, 0.0, l)
        }
    };
    for i in 0..m - 1 {
        (dx[i], dy[i], length[i]) = segment(i, i + 1);
    }
    (dx[m - 1], dy[m - 1], length[m - 1]) = segment(m - 1, 0);
    let (dx, dy) = (&*dx, &*dy);
    let depth = &mut depth[start..end];
    if params.depth_scale == 0.0 {
        depth.fill(1.0);
    } else {
        for (d, &w) in depth.iter_mut().zip(w) {
            *d = w.recip().powf(params.depth_scale);
        }
    }
    let depth = &*depth;
    let o = OffsetParams {
        half_width: 0.5 * params.width_px * params.stroke_scale,
        half_limit: (0.5 * params.stroke_limit_px).max(0.0),
        angle_scale: params.angle_scale,
        affine: camera.unproject_x.w == 0.0 && camera.unproject_y.w == 0.0,
        unproject_x: camera.unproject_x,
        unproject_y: camera.unproject_y,
    };
    let [lx, ly, lz] = left;
    let [rx, ry, rz] = right;
    let (lx, ly, lz) = (
        &mut lx[start..end],
        &mut ly[start..end],
        &mut lz[start..end],
    );
    let (rx, ry, rz) = (
        &mut rx[start..end],
        &mut ry[start..end],
        &mut rz[start..end],
    );
    let dir = |i: usize| (dx[i], dy[i]);
    let at = |i: usize| (x[i], y[i], z[i]);
    // Open ends use their one segment twice: a plain perpendicular, no miter.
    let last = m - 1;
    let first_in = if closed { dir(last) } else { dir(0) };
    let last_out = if closed { dir(last) } else { dir(last - 1) };
    let ends = [
        offset_point(&o, first_in, dir(0), at(0), w[0], depth[0]),
        offset_point(&o, dir(last - 1), last_out, at(last), w[last], depth[last]),
    ];
    // The inner points: one straight loop over equally long slices, which vectorises.
    let k = last - 1;
    let (ix, iy, ox, oy) = (&dx[..k], &dy[..k], &dx[1..=k], &dy[1..=k]);
    let (px, py, pz) = (&x[1..=k], &y[1..=k], &z[1..=k]);
    let (pw, pd) = (&w[1..=k], &depth[1..=k]);
    {
        let (lx, ly, lz) = (&mut lx[1..=k], &mut ly[1..=k], &mut lz[1..=k]);
        let (rx, ry, rz) = (&mut rx[1..=k], &mut ry[1..=k], &mut rz[1..=k]);
        for j in 0..k {
            let (l, r) = offset_point(
                &o,
                (ix[j], iy[j]),
                (ox[j], oy[j]),
                (px[j], py[j], pz[j]),
                pw[j],
                pd[j],
            );
            [lx[j], ly[j], lz[j]] = l;
            [rx[j], ry[j], rz[j]] = r;
        }
    }
    for (i, (l, r)) in [(0, ends[0]), (last, ends[1])] {
        [lx[i], ly[i], lz[i]] = l;
        [rx[i], ry[i], rz[i]] = r;
    }
    // Sized first, then written by index: no capacity check per element.
    let base = out.positions.len();
    let pairs = m + usize::from(closed);
    let vertices = base..base + 2 * pairs;
    out.positions.resize(vertices.end, [0.0; 3]);
    out.colors.resize(vertices.end, [0.0; 4]);
    out.uvs.resize(vertices.end, [0.0; 2]);
    let positions = &mut out.positions[vertices.clone()];
    let colors = &mut out.colors[vertices.clone()];
    let [red, green, blue, opacity] = params.color;
    let uvs = &mut out.uvs[vertices];
    let (lx, ly, lz, rx, ry, rz) = (&lx[..m], &ly[..m], &lz[..m], &rx[..m], &ry[..m], &rz[..m]);
    let alpha = &alpha[..m];
    for (i, (pair, colour)) in positions
        .chunks_exact_mut(2)
        .zip(colors.chunks_exact_mut(2))
        .enumerate()
        .take(m)
    {
        pair.copy_from_slice(&[[lx[i], ly[i], lz[i]], [rx[i], ry[i], rz[i]]]);
        let c = [red, green, blue, opacity * alpha[i]];
        colour.copy_from_slice(&[c, c]);
    }
    let inv_texture = if params.texture_length_px > 0.0 {
        params.texture_length_px.recip()
    } else {
        0.0
    };
    let mut arc = 0.0;
    for (pair, &l) in uvs.chunks_exact_mut(2).zip(&length[..m]) {
        let u = arc * inv_texture;
        pair.copy_from_slice(&[[u, 0.0], [u, 1.0]]);
        arc += l;
    }
    if closed {
        let u = arc * inv_texture;
        positions.copy_within(0..2, 2 * m);
        colors.copy_within(0..2, 2 * m);
        uvs[2 * m..].copy_from_slice(&[[u, 0.0], [u, 1.0]]);
    }
    let base = base as u32;
    let first_index = out.indices.len();
    out.indices.resize(first_index + 6 * (pairs - 1), 0);
    for (i, quad) in (0..).zip(out.indices[first_index..].chunks_exact_mut(6)) {
        let l0 = base + 2 * i;
        let (r0, l1, r1) = (l0 + 1, l0 + 2, l0 + 3);
        quad.copy_from_slice(&[r0, r1, l1, r0, l1, l0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tube::{FrameReference, TubeParams, TubeScratch, TubeTopology, build_tube};
    use std::collections::HashMap;

    struct Tube {
        topology: TubeTopology,
        positions: Vec<[f32; 3]>,
    }

    fn tube(rings: usize, sides: usize, particles: &[Vec3], radius: f32) -> Tube {
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
        let tube = tube(16, 8, &particles, 0.03);
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
        let view = Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        let proj = Mat4::perspective_infinite_reverse_rh(1.0, 16.0 / 9.0, 0.1);
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
        let perspective = Mat4::perspective_infinite_reverse_rh(1.0, 4.0 / 3.0, 0.1);
        let camera = StrokeCamera::from_view(world_from_view, perspective, viewport);
        assert_eq!(camera.viewer(), Some(Viewer::Point(eye)));
        let orthographic = Mat4::orthographic_rh(-2.0, 2.0, -1.5, 1.5, 100.0, 0.1);
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
            fade: [0.0, -1.0, 1.0],
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
}
