//! Silhouettes (thesis 4.3.7): object-space stroke geometry.
//!
//! [`edges`] holds the CPU side: an edge-adjacency table of the strand topology built once and
//! shared by all strands, per-frame extraction of the edges between front- and back-facing
//! triangles, chaining into ordered polylines (several loops and open chains per strand, no edge
//! ever dropped, odd vertices split rather than lost), and screen-space stroke strips with the
//! thesis's angle, depth and stroke scaling, stroke limit and E-curve fade.
//!
//! [`strokes`] is the ECS side: [`SilhouetteSettings`] per hair, the [`extract_silhouettes`]
//! system, and the stroke mesh entity (drawn by the render plugin with a textured, unlit,
//! depth-tested material; the module docs explain how that handles self-overlapping strands).

pub mod edges;
pub mod strokes;
pub mod tube_edges;

pub use strokes::{
    ComputedSilhouettes, HairStrokes, HairStrokesOf, SilhouetteCamera, SilhouetteSettings,
    extract_silhouettes,
};

use bevy::prelude::*;

use crate::HairSystems;
use crate::sim::Hair;

/// Extracts object-space silhouette strokes every frame. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairSilhouettePlugin;

impl Plugin for HairSilhouettePlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<SilhouetteSettings>()
            .register_type::<SilhouetteCamera>()
            .register_required_components::<Hair, SilhouetteSettings>()
            .add_systems(
                PostUpdate,
                extract_silhouettes.in_set(HairSystems::Silhouettes),
            );
    }
}
