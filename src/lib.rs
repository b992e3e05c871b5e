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
//! Add the plugin group next to `DefaultPlugins`, spawn your character, and spawn the hair as your
//! own entity hung on one of its bones ([`sim::AttachToBone`] waits for the glTF scene to spawn,
//! finds the bone by name, and reports a missing one as an error and a [`sim::BoneNotFound`]
//! event):
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_cartoon_hair::prelude::*;
//!
//! fn main() {
//!     App::new()
//!         .add_plugins((DefaultPlugins, CartoonHairPlugins))
//!         .add_systems(Startup, setup)
//!         .run();
//! }
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     let hair = Hair {
//!         groom: assets.load("ninja/ninja.hair.xml"),
//!         animation: Some(assets.load("ninja/ninja.hairanim.xml")),
//!         collision: Some(assets.load("ninja/ninja.collision.xml")),
//!     };
//!     let ninja = commands
//!         .spawn(bevy::world_serialization::WorldAssetRoot(
//!             assets.load(GltfAssetLabel::Scene(0).from_asset("ninja/ninja.glb")),
//!         ))
//!         .id();
//!     commands.spawn((hair, AttachToBone::named(ninja, "head")));
//!     commands.spawn((
//!         Camera3d::default(),
//!         Transform::from_xyz(0.0, 1.7, 1.2).looking_at(Vec3::new(0.0, 1.7, 0.0), Vec3::Y),
//!     ));
//!     commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 3.0, 2.0)));
//! }
//! ```
//!
//! Tune a hair through the components on its entity: [`sim::HairSimSettings`] (springs, anchors,
//! gravity, damping, margins), [`mesh::HairMeshSettings`] (resolutions, radius, the H curve),
//! [`silhouette::SilhouetteSettings`] (strokes, the E curve), [`mesh::highlights::SpecularQuads`],
//! and the `render::HairMaterial` handle to a `render::ToonHairMaterial`. The `ui` feature's panel
//! edits the same components live.
//!
//! ## Contents
//!
//! | module | stage |
//! |--------|-------|
//! | [`schedule`] | when hair runs: the [`HairSystems`] sets in `PostUpdate` and their order |
//! | [`asset`] | XML grooms, collision shapes and hair animations, and their loaders (`docs/formats.md`) |
//! | [`sim`] | bone attachment, strand entities, the XPBD solver with Selle's structural springs, anchors, collisions (own colliders; rapier's and avian's behind features) |
//! | [`mesh`] | tapered tubes swept along a spline through each strand; specular sampling quads |
//! | [`silhouette`] | object-space silhouette strokes: edge adjacency of any closed mesh, tube edges, chains, screen-space strips |
//! | `render` | toon material (`toon`), ramps, image-space outlines (`outline/`: component, prepasses, pipelines, pass), the WESL shader library (feature `render`) |
//! | [`hatching`] | the tonal art map generator (settings, stroke image, rasteriser, generator) and its texture |
//! | `headless` | rendering without a window into an image, reading pixels back (feature `demo`) |
//! | [`curve`] | the quadratic curves (H, S, E) shared by all stages |
//! | [`debug`](mod@debug) | debug drawing (gizmos) and stage timings in Bevy's `DiagnosticsStore`, no egui needed |
//!
//! ## Feature flags
//!
//! `render` and `rapier` are on by default; `avian`, `ui` and `demo` are opt-in. What each adds:
//! the README's Cargo features table (one copy, there).
//!
//! ## Plugins
//!
//! [`CartoonHairPlugins`] is a [`PluginGroup`](bevy::app::PluginGroup); every member can be disabled or replaced with
//! [`PluginGroupBuilder::disable`](bevy::app::PluginGroupBuilder::disable) / [`PluginGroupBuilder::set`](bevy::app::PluginGroupBuilder::set).
//!
//! | plugin | what it does | disable or replace when |
//! |--------|--------------|-------------------------|
//! | [`HairSchedulePlugin`] | Configures the chained [`HairSystems`] sets in `PostUpdate`, after animation and transform propagation. | Never: every other plugin puts its systems in these sets. |
//! | [`asset::HairAssetPlugin`] | Registers `HairGroom`, `HeadCollision`, `HairAnimation` and their XML loaders, and reads the VRM spring bones of every glTF any glTF loader opens. | Replace to load hair from another format: insert the same asset types yourself. |
//! | [`asset::VrmLoaderPlugin`] | Opens `*.vrm` files with Bevy's glTF loader. | Disable when another VRM crate (bevy_vrm1) registers its own `.vrm` loader: see the VRM guide. |
//! | [`sim::HairSimulationPlugin`] | Attaches `Hair` to bones, spawns strand entities, steps springs, anchors and collisions. | Disable to drive `StrandParticles` yourself. |
//! | [`mesh::HairMeshPlugin`] | Builds one tube mesh per hair from the strands each frame. | Disable to draw strands your own way from `StrandParticles`. |
//! | [`silhouette::HairSilhouettePlugin`] | Extracts object-space silhouette strokes per strand each frame (`SilhouetteSettings`). | Disable for image-space outlines only, or none. |
//! | `render::ToonHairMaterialPlugin` | `ToonHairMaterial` (ramps, depth detail, back light, specular, hatching) and default ramps; draws hair meshes with each hair's `HairMaterial`. | Replace to draw hair with another material. |
//! | `render::HairShaderLibraryPlugin` | Registers the WESL modules (`bevy_cartoon_hair::render::curves`) the materials import. | Replace it only together with the materials. |
//! | `render::ImageSpaceOutlinePlugin` | Image-space silhouette edges: Sobel on the depth/normal prepass, threshold, X/Y dilation, ink over the frame, on cameras with an `ImageSpaceOutline` (switch it off and on any time). | Disable if you never outline on screen, or to use another outline post-process. |
//! | `ui::HairTuningUiPlugin` | The egui tuning panel (Debug, Hair properties, Effects windows; presets), stage timings, debug drawing; adds `bevy_egui`'s `EguiPlugin` if missing. Hidden until `HairTuningUi::visible` is set. | Disable in a shipped game, or when you configure egui yourself differently; it needs an egui context on a camera. |
//!
//! ## Frame order
//!
//! See [`HairSystems`]: attach, simulate, build meshes, silhouettes, materials, all in
//! `PostUpdate` after transform propagation (so the bone the hair hangs on has its final pose
//! for the frame) and before Bevy's visibility systems (so what hair spawns or hides is culled
//! in the same frame).
//!
//! ## FAQ
//!
//! **Why does the hair jitter?** Usually two constraints fight: a stiff anchor (S curve near 1)
//! pulling toward a keyframe pose that intersects the head collider, or margins larger than the
//! gap between the styled hair and the head. Lower the anchor stiffness at the root, or the
//! margins (`margin_min`, `margin_max`). A very low `substep_rate` also makes stiff hair ring.
//!
//! **Why does the hair look the same at 30 and 144 fps?** The solver runs fixed-length substeps
//! (`substep_rate`) and interpolates the bone between frames, so the frame rate only decides how
//! many substeps a frame takes.
//!
//! **My character teleported and the hair whipped across the level.** It should not: a bone that
//! moves farther than `teleport_distance` (1 m) or turns more than `teleport_angle` (90 degrees)
//! in one frame carries the hair with it. Lower those if your game moves characters in smaller
//! jumps.
//!
//! **Hair uses only one core.** The solver, the mesh builder and silhouette extraction spread
//! strands over Bevy's compute task pool. On a 2-core machine Bevy's default gives that pool a
//! single thread (the IO and async pools take the rest). [`compute_on_every_core`] gives compute
//! every core:
//!
//! ```no_run
//! use bevy::prelude::*;
//!
//! App::new().add_plugins(DefaultPlugins.set(bevy_cartoon_hair::compute_on_every_core()));
//! ```
//!
//! **A keyframe groom fails to load.** Every groom in a `.hairanim.xml` must have the strand and
//! particle counts of the first; the error names the key, the strand and both counts. Export all
//! styles from the same base hair object.
//!
//! **Outlines: object space or image space?** Object-space strokes ([`silhouette`]) follow the
//! strands, can be textured and fade toward the roots; image-space edges (`render::ImageSpaceOutline`
//! on the camera) outline everything on screen at a constant cost. Both can be switched off and
//! on at any time.
//!
//! **Several cameras (split screen, picture in picture).** Strokes depend on the camera. Mark
//! every camera that should show them with [`SilhouetteCamera`](silhouette::SilhouetteCamera):
//! each gets strokes of its own on a render layer of its own (from
//! [`FIRST_STROKE_LAYER`](silhouette::strokes::FIRST_STROKE_LAYER)), added to the camera's
//! `RenderLayers`. Unmarked, the first active camera gets them.

#![warn(missing_docs)]

pub mod asset;
pub mod curve;
pub mod debug;
#[cfg(feature = "demo")]
pub mod demo;
pub mod hatching;
#[cfg(feature = "demo")]
pub mod headless;
mod math;
pub mod mesh;
mod parallel;
mod plugins;
#[cfg(feature = "render")]
pub mod preset;
#[cfg(feature = "render")]
pub mod render;
pub mod schedule;
pub mod silhouette;
pub mod sim;
mod simd;
#[cfg(test)]
mod test_support;
#[cfg(feature = "ui")]
pub mod ui;

pub use plugins::{CartoonHairPlugins, compute_on_every_core};
pub use schedule::{HairSchedulePlugin, HairSystems};

/// The things most apps need: `use bevy_cartoon_hair::prelude::*;`.
pub mod prelude {
    pub use crate::asset::{
        CollisionBox, CollisionCapsule, CollisionPlane, CollisionSphere, HairAnimation, HairGroom,
        HeadCollision,
    };
    pub use crate::curve::QuadraticCurve;
    pub use crate::mesh::highlights::SpecularQuads;
    pub use crate::mesh::{
        HairCulling, HairLod, HairMassShape, HairMeshSettings, HairShadowCaster,
        HairStrandSections, LockSection,
    };
    pub use crate::plugins::CartoonHairPlugins;
    #[cfg(feature = "render")]
    pub use crate::preset::HairPreset;
    #[cfg(feature = "render")]
    pub use crate::render::{
        FringeShadow, FringeShadowMeshes, HairGpuBuildFailed, HairMaterial, HairPaint,
        ImageSpaceOutline, LockLines, OutlineSource, RampMode, ShowThroughHair,
        ShowThroughHairNamed, ToonHairMaterial, ToonHairMeshes, ToonLighting, ToonRamps,
        ToonShading,
    };
    pub use crate::schedule::HairSystems;
    pub use crate::silhouette::{SilhouetteCamera, SilhouetteSettings, StrokeScope};
    #[cfg(feature = "rapier")]
    pub use crate::sim::HairCollisionGroups;
    #[cfg(feature = "avian")]
    pub use crate::sim::HairCollisionLayers;
    pub use crate::sim::{
        AttachToBone, BoneNotFound, ChainSelect, Hair, HairAssetFailed, HairBoneChains,
        HairCollider, HairColliderMode, HairCollidesOnly, HairForceField, HairForceFieldKind,
        HairReady, HairSimControl, HairSimSettings, HairTime, HairTimeExt, HairWind,
        HairWindOverride, Strand, StrandParticles, VrmSpringChains, VrmSpringsFailed,
    };
    #[cfg(feature = "ui")]
    pub use crate::ui::{HairTuningUi, HairTuningUiPlugin};
}
