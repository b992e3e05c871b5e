//! The hair's shadow ribbons in the render world's eyes (see [`crate::mesh::shadow`]): a plain
//! double-sided material, so the shadow passes draw both faces, and no camera's visible
//! entities, so neither the prepass nor the main pass draws them.

use bevy::camera::visibility::{VisibilitySystems, VisibleEntities};
use bevy::prelude::*;

use crate::mesh::shadow::HairShadowMeshOf;
use crate::schedule::HairSystems;

/// The material the shadow ribbons are drawn into the shadow maps with (both faces, opaque).
#[derive(Resource, Clone, Debug)]
pub struct HairShadowMaterial(pub Handle<StandardMaterial>);

/// Registers the ribbons' material and keeps them out of the cameras.
pub(super) fn build(app: &mut App) {
    let material = app
        .world_mut()
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::BLACK,
            unlit: true,
            cull_mode: None,
            double_sided: true,
            ..default()
        });
    app.insert_resource(HairShadowMaterial(material))
        .add_systems(
            PostUpdate,
            apply_shadow_material.in_set(HairSystems::Materials),
        )
        .add_systems(
            PostUpdate,
            keep_ribbons_out_of_cameras
                .after(VisibilitySystems::CheckVisibility)
                .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible),
        );
}

fn apply_shadow_material(
    mut commands: Commands,
    ribbons: Query<
        Entity,
        (
            With<HairShadowMeshOf>,
            Without<MeshMaterial3d<StandardMaterial>>,
        ),
    >,
    material: Res<HairShadowMaterial>,
) {
    for e in &ribbons {
        commands
            .entity(e)
            .insert(MeshMaterial3d(material.0.clone()));
    }
}

/// Takes the shadow ribbons out of every camera's visible entities: the lights' visibility is
/// worked out apart, so the shadow passes still draw them.
fn keep_ribbons_out_of_cameras(
    mut views: Query<&mut VisibleEntities, With<Camera>>,
    ribbons: Query<(), With<HairShadowMeshOf>>,
) {
    if ribbons.is_empty() {
        return;
    }
    for mut visible in &mut views {
        let seen = visible
            .entities
            .values()
            .any(|list| list.iter().any(|&e| ribbons.contains(e)));
        if seen {
            for list in visible.entities.values_mut() {
                list.retain(|&e| !ribbons.contains(e));
            }
        }
    }
}
