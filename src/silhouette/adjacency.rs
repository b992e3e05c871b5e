//! Silhouette edges of any closed triangle mesh (thesis 4.3.7): an [`EdgeAdjacency`] built once
//! per topology, and per frame [`silhouette_edges`], the edges between a front-facing and a
//! back-facing triangle seen from a [`Viewer`].
//!
//! This is the general path: it works on any closed, consistently wound mesh (a hat, a
//! character's body), not only strand tubes. The hair itself uses the faster
//! [`tube_edges`](super::tube_edges), which finds the same edges on tubes and is tested against
//! this path edge for edge. Chain the edges with [`chain_edges`](super::chain::chain_edges) and
//! turn the chains into strokes with [`build_chain_strip`](super::strip::build_chain_strip).
//!
//! ```
//! use bevy::math::Vec3;
//! use bevy_cartoon_hair::silhouette::adjacency::{
//!     EdgeAdjacency, SilhouetteScratch, Viewer, silhouette_edges,
//! };
//! use bevy_cartoon_hair::silhouette::chain::{SilhouetteChains, chain_edges};
//!
//! // A tetrahedron, wound counter-clockwise seen from outside.
//! let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
//! let triangles = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
//! let adjacency = EdgeAdjacency::from_triangles(&triangles).unwrap();
//!
//! let mut scratch = SilhouetteScratch::default();
//! let mut edges = Vec::new();
//! // Only the slanted face turns toward this eye: its three edges are the silhouette.
//! let eye = Viewer::Point(Vec3::new(2.0, 0.3, 0.2));
//! silhouette_edges(&adjacency, &triangles, &positions, eye, &mut scratch, &mut edges);
//! assert_eq!(edges.len(), 3);
//! let mut chains = SilhouetteChains::default();
//! chain_edges(&edges, &mut scratch, &mut chains);
//! assert_eq!(chains.len(), 1);
//! assert!(chains.get(0).unwrap().closed, "one closed loop");
//! ```

use bevy::math::{Vec3, Vec3A};

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
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AdjacencyError {
    /// The index count is not a multiple of three.
    #[error("{len} indices are not a triangle list")]
    NotTriangleList {
        /// The index count.
        len: usize,
    },
    /// A triangle uses one vertex twice.
    #[error("triangle {face} {vertices:?} repeats a vertex")]
    DegenerateTriangle {
        /// The triangle's index.
        face: usize,
        /// Its vertices.
        vertices: [u32; 3],
    },
    /// An edge does not belong to exactly two triangles: the mesh is open or non-manifold.
    #[error("edge {edge:?} belongs to {faces} triangles, not 2: the mesh is not closed")]
    NonManifoldEdge {
        /// The edge's vertices, lower first.
        edge: [u32; 2],
        /// How many triangles it belongs to.
        faces: usize,
    },
    /// Both triangles of an edge run along it in the same direction: inconsistent winding.
    #[error("triangles {faces:?} both run along edge {edge:?} the same way: inconsistent winding")]
    InconsistentWinding {
        /// The edge's vertices, lower first.
        edge: [u32; 2],
        /// The two triangles.
        faces: [u32; 2],
    },
}

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

/// Reusable buffers of [`silhouette_edges`] and [`chain_edges`](super::chain::chain_edges): keep one per thread so that
/// neither allocates once warmed up.
#[derive(Clone, Debug, Default)]
pub struct SilhouetteScratch {
    pub(super) facing: Vec<bool>,
    pub(super) points: Vec<Vec3A>,
    /// Per edge: its ends as compact vertex ids (only when ids are sparse).
    pub(super) ends: Vec<[u32; 2]>,
    /// Per compact vertex id: how many edge ends are at it. All zero between calls: only the
    /// entries a call touches are reset.
    pub(super) degree: Vec<u32>,
    /// Per compact vertex id: its first two edge ends (enough to walk through a vertex of
    /// degree two).
    pub(super) slots: Vec<[Slot; 2]>,
    pub(super) used: Vec<bool>,
    /// Sorted distinct vertex ids, when they are too sparse to index directly.
    pub(super) ids: Vec<u32>,
    /// Per compact vertex id: the far end of the edge leaving it, compact and as a vertex id
    /// (see `chain::chain_loops`).
    pub(super) next: Vec<[u32; 2]>,
}

/// An edge end at a vertex: the edge and its far end.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Slot {
    pub(super) edge: u32,
    /// The far end's compact id.
    pub(super) far: u32,
    /// The far end's vertex id.
    pub(super) far_id: u32,
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
