//! When hair runs in a frame: the [`HairSystems`] sets and the plugin that orders them.

use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

/// The stages of a hair frame, run in `PostUpdate` in this order:
///
/// 1. [`HairSystems::Attach`]: spawn strand entities for new `Hair`, follow bones, detach.
/// 2. [`HairSystems::Simulate`]: step particles (sub-stepped springs, anchors, collisions).
/// 3. [`HairSystems::BuildMesh`]: rebuild the swept tube meshes from the particles.
/// 4. [`HairSystems::Silhouettes`]: extract object-space outline strokes from those meshes.
/// 5. [`HairSystems::Materials`]: give new hair, stroke and highlight meshes their materials,
///    and hatching materials their tonal art map.
///
/// The whole chain runs after [`TransformSystems::Propagate`], which itself runs after Bevy's
/// animation systems, so bones already carry this frame's animated pose; and before Bevy's
/// visibility propagation and culling ([`VisibilitySystems`]), so meshes spawned, shown or
/// hidden here are culled in the same frame.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum HairSystems {
    /// Spawn, follow and despawn hair attached to bones.
    Attach,
    /// Advance the strand simulation by the frame's time.
    Simulate,
    /// Rebuild strand meshes from particle positions.
    BuildMesh,
    /// Extract silhouette strokes from strand meshes.
    Silhouettes,
    /// Assign materials (and tonal art maps) to what the stages before spawned.
    Materials,
}

/// Configures the [`HairSystems`] chain. Part of [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairSchedulePlugin;

impl Plugin for HairSchedulePlugin {
    fn build(&self, app: &mut App) {
        app.configure_sets(
            PostUpdate,
            (
                HairSystems::Attach,
                HairSystems::Simulate,
                HairSystems::BuildMesh,
                HairSystems::Silhouettes,
                HairSystems::Materials,
            )
                .chain()
                // Bones must hold this frame's animated, propagated pose before hair reads them.
                .after(TransformSystems::Propagate)
                // Stroke and highlight meshes are spawned and shown or hidden here: Bevy must
                // propagate and cull that in this frame. (Bounds may come a frame later: a mesh
                // without bounds is never culled.)
                .before(VisibilitySystems::VisibilityPropagate)
                .before(VisibilitySystems::CheckVisibility),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hair chain sits between transform propagation and Bevy's visibility systems.
    #[test]
    fn hair_runs_after_propagation_and_before_visibility() {
        #[derive(Resource, Default)]
        struct Order(Vec<&'static str>);
        let mut app = App::new();
        // Only the sets' order is under test: markers stand in for Bevy's systems.
        app.add_plugins((MinimalPlugins, HairSchedulePlugin))
            .init_resource::<Order>();
        let mark = |name: &'static str| move |mut order: ResMut<Order>| order.0.push(name);
        app.add_systems(
            PostUpdate,
            (
                mark("propagate").in_set(TransformSystems::Propagate),
                mark("visibility").in_set(VisibilitySystems::VisibilityPropagate),
                mark("check").in_set(VisibilitySystems::CheckVisibility),
                mark("attach").in_set(HairSystems::Attach),
                mark("materials").in_set(HairSystems::Materials),
            ),
        );
        app.update();
        let order = &app.world().resource::<Order>().0;
        let at = |name| order.iter().position(|n| *n == name).unwrap();
        assert!(at("propagate") < at("attach"), "{order:?}");
        assert!(at("materials") < at("check"), "{order:?}");
        assert!(at("materials") < at("visibility"), "{order:?}");
    }
}
