//! The plugin group and the task pool setting most apps add.

use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;

#[cfg(feature = "render")]
use crate::render;
use crate::schedule::HairSchedulePlugin;
use crate::{asset, mesh, silhouette, sim};

/// A `TaskPoolPlugin` whose compute pool has a thread per core.
///
/// Bevy's default splits small machines between IO, async and compute pools, leaving compute (where
/// systems, `par_iter` and this crate's strand work run) one thread on 2 cores. Hair simulation
/// roughly halves in wall time with this on such machines. Use as
/// `DefaultPlugins.set(compute_on_every_core())`.
pub fn compute_on_every_core() -> bevy::app::TaskPoolPlugin {
    use bevy::app::{TaskPoolOptions, TaskPoolPlugin, TaskPoolThreadAssignmentPolicy};
    let cores = std::thread::available_parallelism().map_or(2, std::num::NonZero::get);
    TaskPoolPlugin {
        task_pool_options: TaskPoolOptions {
            compute: TaskPoolThreadAssignmentPolicy {
                min_threads: cores,
                max_threads: cores,
                percent: 1.0,
                on_thread_spawn: None,
                on_thread_destroy: None,
            },
            ..default()
        },
    }
}

/// All of the crate's plugins. Add it once, next to `DefaultPlugins`.
///
/// | plugin | role |
/// |--------|------|
/// | [`HairSchedulePlugin`] | orders the [`HairSystems`](crate::schedule::HairSystems) sets |
/// | [`asset::HairAssetPlugin`] | groom, collision and animation assets and loaders; VRM spring bones read from any glTF |
/// | [`asset::VrmLoaderPlugin`] | opens `*.vrm` files with Bevy's glTF loader (leave it out when another VRM crate loads them) |
/// | [`sim::HairSimulationPlugin`] | attaches hair to bones and simulates strands |
/// | [`mesh::HairMeshPlugin`] | tapered tube meshes swept along the strands |
/// | [`silhouette::HairSilhouettePlugin`] | object-space outline strokes |
/// | `render::ToonHairMaterialPlugin` | the toon material and its default ramps (feature `render`) |
/// | `render::HairShaderLibraryPlugin` | registers the shared WGSL modules (feature `render`) |
/// | `render::ImageSpaceOutlinePlugin` | image-space silhouette edges on cameras (feature `render`) |
/// | `render::GpuTubesPlugin` | strand tubes built on the GPU where the device allows (feature `render`) |
///
/// The egui tuning panel (`ui::HairTuningUiPlugin`, feature `ui`) is not in the group: a shipped
/// game does not carry a debug panel. Add it yourself during development.
pub struct CartoonHairPlugins;

impl PluginGroup for CartoonHairPlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>()
            .add(HairSchedulePlugin)
            .add(asset::HairAssetPlugin)
            .add(asset::VrmLoaderPlugin)
            .add(sim::HairSimulationPlugin)
            .add(mesh::HairMeshPlugin)
            .add(silhouette::HairSilhouettePlugin);
        #[cfg(feature = "render")]
        let group = group
            .add(render::HairShaderLibraryPlugin)
            .add(render::ToonHairMaterialPlugin)
            .add(render::ImageSpaceOutlinePlugin)
            .add(render::GpuTubesPlugin);
        group
    }
}
