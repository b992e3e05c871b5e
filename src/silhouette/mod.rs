//! Silhouettes (thesis 4.3.7): object-space stroke geometry.
//!
//! The CPU side, by stage:
//! - [`adjacency`]: an edge-adjacency table of any closed mesh, built once per topology, and
//!   per-frame extraction of the edges between front- and back-facing triangles (the general
//!   path, public for meshes other than hair; see its example);
//! - [`tube_edges`]: the same edges found faster on strand tubes (what the hair uses);
//! - [`chain`]: chaining into ordered polylines (several loops and open chains per strand, no
//!   edge ever dropped, odd vertices split rather than lost);
//! - [`strip`]: screen-space stroke strips with the thesis's angle, depth and stroke scaling,
//!   stroke limit and E-curve fade.
//!
//! [`tube_edges`] tests the two triangles of every quad in one vectorised pass over coordinate
//! rows; the results become bit masks per ring band, and each class of edge is the exclusive or
//! of two masks. Tests check it against the general path edge for edge.
//!
//! [`gpu_jobs`]: for a hair whose tubes the GPU builds, the strokes are built on the GPU (the
//! render plugin's stroke pass, from the tube pass's ring frames); this stage hands it one job
//! a camera and a stroke mesh of fixed topology.
//!
//! [`strokes`] is the ECS side: [`SilhouetteSettings`] per hair, the [`extract_silhouettes`]
//! system (blocks of strands shared out to threads, each block's strokes moved into a mesh of
//! its own without a copy), and the stroke mesh entities (drawn by the render plugin with a textured, unlit,
//! depth-tested material; the module docs explain how that handles self-overlapping strands).

pub mod adjacency;
pub mod chain;
pub mod gpu_jobs;
pub mod strip;
pub mod strokes;
#[cfg(test)]
mod tests;
pub mod tube_edges;

pub use gpu_jobs::{GpuStrokeJob, GpuStrokeJobs};
pub use strokes::{
    ComputedSilhouettes, HairStrokes, HairStrokesOf, SilhouetteCamera, SilhouetteSettings,
    StrokePrepass, StrokeScope, extract_silhouettes, sync_stroke_prepasses,
};

use bevy::prelude::*;

use crate::schedule::HairSystems;
use crate::sim::Hair;

/// Extracts object-space silhouette strokes every frame. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairSilhouettePlugin;

impl Plugin for HairSilhouettePlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<SilhouetteSettings>()
            .register_type::<SilhouetteCamera>()
            .register_type::<StrokePrepass>()
            .register_required_components::<Hair, SilhouetteSettings>()
            .register_required_components::<Hair, GpuStrokeJobs>()
            .add_systems(
                PostUpdate,
                (extract_silhouettes, sync_stroke_prepasses)
                    .chain()
                    .in_set(HairSystems::Silhouettes),
            );
    }
}
