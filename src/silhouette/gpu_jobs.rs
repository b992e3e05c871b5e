//! Strokes of hairs whose tubes the GPU builds ([`HairMeshBuiltOnGpu`]): the CPU has no tube
//! vertices to search, so [`extract_silhouettes`](super::extract_silhouettes) hands the GPU
//! what it needs instead, one [`GpuStrokeJob`] per camera (the camera, the stroke parameters,
//! and a stroke mesh of fixed topology the GPU fills), and the render plugin's stroke pass
//! (the render stage's GPU stroke pass) finds the contours and sweeps the strips.
//!
//! The GPU's strokes follow each strand's two contours ring by ring (where the surface normal
//! turns perpendicular to the view), where the CPU chains the tube mesh's silhouette edges; the
//! strips are made the same way (see [`strip`](super::strip)).
//!
//! [`HairMeshBuiltOnGpu`]: crate::mesh::HairMeshBuiltOnGpu

use bevy::prelude::*;

use super::strip::{StrokeCamera, StrokeParams};
use crate::mesh::StripBuffers;

/// One camera's strokes of a hair, to be built on the GPU this frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuStrokeJob {
    /// The stroke mesh ([`gpu_stroke_mesh`]) the GPU writes.
    pub mesh: AssetId<Mesh>,
    /// The camera the strokes are for.
    pub camera: StrokeCamera,
    /// How the strokes are drawn.
    pub params: StrokeParams,
}

/// The strokes of a hair the GPU builds this frame, one job per camera; empty when the CPU
/// builds them or there are none. On the [`Hair`](crate::sim::Hair) entity (inserted with it).
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct GpuStrokeJobs(pub Vec<GpuStrokeJob>);

/// Vertices of a GPU-built stroke mesh of strands of `rings` rings of `sides` sides: for each
/// strand, a quad per ring segment of each of its two contours, then a quad per rim edge of
/// each cap.
pub fn gpu_stroke_vertex_count(strands: usize, rings: usize, sides: usize) -> usize {
    if rings < 2 {
        return 0;
    }
    strands * 2 * (rings - 1 + sides) * 4
}

/// A stroke mesh that the GPU fills ([`gpu_stroke_vertex_count`]): positions, +Z normals, UVs
/// and colours (all zero until the GPU writes them) and the fixed triangles of every quad.
pub fn gpu_stroke_mesh(strands: usize, rings: usize, sides: usize) -> Mesh {
    StripBuffers::gpu_quads(gpu_stroke_vertex_count(strands, rings, sides) / 4, true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::mesh::Indices;

    #[test]
    fn the_gpu_stroke_mesh_has_a_quad_per_segment_and_rim_edge() {
        // 3 strands of 5 rings of 6 sides: 2 x (4 segments + 6 rim edges) quads each.
        let mesh = gpu_stroke_mesh(3, 5, 6);
        assert_eq!(mesh.count_vertices(), 3 * 2 * 10 * 4);
        let Some(Indices::U32(indices)) = mesh.indices() else {
            panic!("no u32 indices");
        };
        assert_eq!(indices.len(), 3 * 2 * 10 * 6);
        assert_eq!(&indices[6..12], &[4, 5, 6, 5, 7, 6]);
        assert!(
            indices
                .iter()
                .all(|&i| (i as usize) < mesh.count_vertices())
        );
        assert_eq!(gpu_stroke_vertex_count(7, 1, 8), 0);
    }
}
