//! Work skipped for hair that no camera sees.
//!
//! Every frame, after Bevy has updated the cameras' frusta, the hair's bounds (its particles,
//! grown by the thickest tube) are tested against the frustum of every active 3D camera. Hair
//! outside all of them ([`HairInView`] false) keeps simulating, so it is right when it comes
//! back (at [`HairCulling::culled_substep_rate`], a quarter of the default rate), but its tube
//! mesh is not rebuilt and it gets no strokes or specular quads. A hair that
//! comes into view is rebuilt in that same frame (the test uses this frame's bounds and
//! frusta), so nothing stale is ever drawn. In an app with no active 3D camera (a server, a
//! simulation test) nothing is culled.
//!
//! What this costs you: a culled hair's shadow keeps the last pose it was built in. Switch
//! [`HairCulling::enabled`] off for hair whose shadow falls into view from off screen.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::math::Affine3A;
use bevy::prelude::*;

pub use crate::sim::{HairCulling, HairInView};

/// How many hairs were culled in the last frame (shown by the debug panel).
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Resource, Debug, Default)]
pub struct HairCullingStats {
    /// Hairs with a mesh.
    pub hairs: usize,
    /// Of those, hairs no camera saw: not rebuilt, no strokes, no specular quads.
    pub culled: usize,
    /// Of those, hairs drawn at a lower level of detail (see `lod`): at level 1, 2 and 3.
    pub reduced: [usize; 3],
}

/// Whether world-space `bounds` meet the frustum of any of `frusta`.
pub fn seen_by_any<'a>(bounds: &Aabb, mut frusta: impl Iterator<Item = &'a Frustum>) -> bool {
    frusta.any(|f| f.intersects_obb(bounds, &Affine3A::IDENTITY, true, true))
}
