//! The depth and normal prepasses an outline reads, added to and removed from its camera.

use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
use bevy::prelude::*;

use super::ImageSpaceOutline;

/// The prepasses [`sync_outline_prepasses`] added to a camera (and so may remove).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct OutlinePrepasses {
    depth: bool,
    normal: bool,
}

/// Keeps the prepasses an outline reads on its camera while it is enabled, and removes those it
/// added when it is disabled or removed. Prepasses the user added stay.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(super) fn sync_outline_prepasses(
    mut commands: Commands,
    cameras: Query<(
        Entity,
        Option<&ImageSpaceOutline>,
        Has<DepthPrepass>,
        Has<NormalPrepass>,
        Option<&OutlinePrepasses>,
    )>,
) {
    for (camera, outline, has_depth, has_normal, added) in &cameras {
        if outline.is_none() && added.is_none() {
            continue;
        }
        let enabled = outline.filter(|o| o.enabled);
        let want_depth = enabled.is_some_and(|o| o.source.uses_depth());
        let want_normal = enabled.is_some_and(|o| o.source.uses_normals());
        let before = added.copied().unwrap_or_default();
        let mut now = before;
        let mut entity = commands.entity(camera);
        if want_depth && !has_depth {
            entity.insert(DepthPrepass);
            now.depth = true;
        } else if !want_depth && before.depth {
            entity.remove::<DepthPrepass>();
            now.depth = false;
        }
        if want_normal && !has_normal {
            entity.insert(NormalPrepass);
            now.normal = true;
        } else if !want_normal && before.normal {
            entity.remove::<NormalPrepass>();
            now.normal = false;
        }
        if outline.is_none() {
            entity.remove::<OutlinePrepasses>();
        } else if added != Some(&now) {
            entity.insert(now);
        }
    }
}
