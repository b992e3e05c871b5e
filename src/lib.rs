//! # bevy_cartoon_hair
//!
//! Real-time, simulated, cartoon (anime-style) hair for [Bevy](https://bevy.org).
//!
//! Hair is styled in Blender and exported (by the add-on in `tools/blender/`) as guide strands in
//! XML. Each guide strand becomes an entity whose particles are simulated with structural springs
//! (Selle et al. 2008) and pulled toward keyframed styles by anchor springs; roots follow an
//! animated skeleton bone and particles collide with the head. Strands are drawn as tapered tubes
//! with toon shading, outlines and hatching.
//!
//! The design follows the 2013 thesis this crate grew from; where that thesis was weak (it crashed
//! on mismatched keyframes, could not re-enable its outline, and drew silhouettes through strands
//! that overlapped themselves) this crate does better, and the relevant module says how.
//!
//! ## Getting started
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_cartoon_hair::prelude::*;
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, CartoonHairPlugins))
//!     .run();
//! ```
//!
//! ## Feature flags
//!
//! | feature  | default | what it adds |
//! |----------|---------|--------------|
//! | `render` | yes     | Headless capture helpers, toon materials and other GPU-side parts, presets (`ron`), the demo scene and clip recorder. |
//! | `ui`     | yes     | The live egui tuning panel (pulls in `bevy_egui`; implies `render`). |
//!
//! ## Plugins
//!
//! [`CartoonHairPlugins`] is a [`PluginGroup`]; every member can be disabled or replaced with
//! [`PluginGroupBuilder::disable`] / [`PluginGroupBuilder::set`].
//!
//! | plugin | what it does | disable or replace when |
//! |--------|--------------|-------------------------|
//! | [`HairSchedulePlugin`] | Configures the chained [`HairSystems`] sets in `PostUpdate`, after animation and transform propagation. | Never: every other plugin puts its systems in these sets. |
//! | [`asset::HairAssetPlugin`] | Registers `HairGroom`, `HeadCollision`, `HairAnimation` and their XML loaders. | Replace to load hair from another format: insert the same asset types yourself. |
//! | [`sim::HairSimulationPlugin`] | Attaches `Hair` to bones, spawns strand entities, steps springs, anchors and collisions. | Disable to drive `StrandParticles` yourself. |
//! | [`mesh::HairMeshPlugin`] | Builds one tube mesh per hair from the strands each frame. | Disable to draw strands your own way from `StrandParticles`. |
//! | `render::ToonHairMaterialPlugin` | `ToonHairMaterial` (ramps, depth detail, back light, specular, hatching) and default ramps; draws hair meshes with each hair's `HairMaterial`. | Replace to draw hair with another material. |
//! | `render::HairShaderLibraryPlugin` | Registers the WGSL modules (`bevy_cartoon_hair::curves`) the materials import. | Replace it only together with the materials. |
//! | `ui::HairTuningUiPlugin` | The egui tuning panel (Debug, Hair properties, Effects windows; presets), stage timings, debug drawing; adds `bevy_egui`'s `EguiPlugin` if missing. Hidden until `HairTuningUi::visible` is set. | Disable in a shipped game, or when you configure egui yourself differently; it needs an egui context on a camera. |
//!
//! ## Frame order
//!
//! See [`HairSystems`]: attach, simulate, build meshes, silhouettes, all in `PostUpdate` after
//! [`TransformSystems::Propagate`] so the bone the hair hangs on has its final pose for the frame.

#![warn(missing_docs)]

pub mod asset;
pub mod curve;
#[cfg(feature = "render")]
pub mod demo;
pub mod hatching;
#[cfg(feature = "render")]
pub mod headless;
pub mod mesh;
#[cfg(feature = "render")]
pub mod preset;
#[cfg(feature = "render")]
pub mod render;
pub mod silhouette;
pub mod sim;
#[cfg(feature = "ui")]
pub mod ui;

use bevy::app::{PluginGroupBuilder, PostUpdate};
use bevy::ecs::schedule::{IntoScheduleConfigs, SystemSet};
use bevy::prelude::*;
use bevy::transform::TransformSystems;

/// The things most apps need: `use bevy_cartoon_hair::prelude::*;`.
pub mod prelude {
    pub use crate::asset::{HairAnimation, HairGroom, HeadCollision};
    pub use crate::curve::QuadraticCurve;
    pub use crate::mesh::HairMeshSettings;
    #[cfg(feature = "render")]
    pub use crate::preset::HairPreset;
    #[cfg(feature = "render")]
    pub use crate::render::{HairMaterial, RampMode, ToonHairMaterial, ToonRamps};
    pub use crate::sim::{
        AttachHair, Hair, HairCollisionGroups, HairSimControl, HairSimSettings, Strand,
        StrandParticles,
    };
    #[cfg(feature = "ui")]
    pub use crate::ui::{HairTuningUi, HairTuningUiPlugin};
    pub use crate::{CartoonHairPlugins, HairSystems};
}

/// All of the crate's plugins. Add it once, next to `DefaultPlugins`.
///
/// | plugin | role |
/// |--------|------|
/// | [`HairSchedulePlugin`] | orders the [`HairSystems`] sets |
/// | [`asset::HairAssetPlugin`] | groom, collision and animation assets and loaders |
/// | [`sim::HairSimulationPlugin`] | attaches hair to bones and simulates strands |
/// | [`mesh::HairMeshPlugin`] | tapered tube meshes swept along the strands |
/// | `render::ToonHairMaterialPlugin` | the toon material and its default ramps (feature `render`) |
/// | `render::HairShaderLibraryPlugin` | registers the shared WGSL modules (feature `render`) |
/// | `ui::HairTuningUiPlugin` | the egui tuning panel, hidden until `HairTuningUi::visible` (feature `ui`) |
pub struct CartoonHairPlugins;

impl PluginGroup for CartoonHairPlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>()
            .add(HairSchedulePlugin)
            .add(asset::HairAssetPlugin)
            .add(sim::HairSimulationPlugin)
            .add(mesh::HairMeshPlugin);
        #[cfg(feature = "render")]
        let group = group
            .add(render::HairShaderLibraryPlugin)
            .add(render::ToonHairMaterialPlugin);
        #[cfg(feature = "ui")]
        let group = group.add(ui::HairTuningUiPlugin);
        group
    }
}

/// The stages of a hair frame, run in `PostUpdate` in this order:
///
/// 1. [`HairSystems::Attach`]: spawn strand entities for new `Hair`, follow bones, detach.
/// 2. [`HairSystems::Simulate`]: step particles (sub-stepped springs, anchors, collisions).
/// 3. [`HairSystems::BuildMesh`]: rebuild the swept tube meshes from the particles.
/// 4. [`HairSystems::Silhouettes`]: extract object-space outline strokes from those meshes.
///
/// The whole chain runs after [`TransformSystems::Propagate`], which itself runs after Bevy's
/// animation systems, so bones already carry this frame's animated pose.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HairSystems {
    /// Spawn, follow and despawn hair attached to bones.
    Attach,
    /// Advance the strand simulation by the frame's time.
    Simulate,
    /// Rebuild strand meshes from particle positions.
    BuildMesh,
    /// Extract silhouette strokes from strand meshes.
    Silhouettes,
}

/// Configures the [`HairSystems`] chain. Part of [`CartoonHairPlugins`].
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
            )
                .chain()
                // Bones must hold this frame's animated, propagated pose before hair reads them.
                .after(TransformSystems::Propagate),
        );
    }
}
