//! Whether a hair is culled: the components the simulation reads (a culled hair simulates at a
//! coarser rate) and the mesh stage sets (see `mesh::culling`, where the test against the cameras
//! is made).

use bevy::prelude::*;

/// Whether a hair's mesh, strokes and specular quads are skipped while no camera sees it (see
/// `mesh::culling`). A component on the [`Hair`](crate::sim::Hair) entity, inserted with
/// defaults when missing.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairCulling {
    /// Skip the work of hair outside every camera's view. Default: `true`.
    pub enabled: bool,
    /// Substeps per second while the hair is culled: hair no camera sees keeps simulating, so it
    /// is in place when it comes back, but coarser (its mesh is not rebuilt meanwhile, so the
    /// difference is never drawn). At or above the hair's own
    /// [`HairSimSettings::substep_rate`](crate::sim::HairSimSettings::substep_rate), or not
    /// finite: the full rate. Default: `60.0` (one substep a 60 Hz frame, a quarter of the
    /// default 240).
    pub culled_substep_rate: f32,
}

impl Default for HairCulling {
    fn default() -> Self {
        Self {
            enabled: true,
            culled_substep_rate: 60.0,
        }
    }
}

/// Whether any active 3D camera saw the hair this frame (always `true` with culling off, or
/// before its bounds are known). Set in [`HairSystems::BuildMesh`](crate::HairSystems), read by
/// the stages after it.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairInView(pub bool);

impl Default for HairInView {
    fn default() -> Self {
        Self(true)
    }
}
