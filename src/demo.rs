//! The ninja-head demo scene and the headless clip recorder.
//!
//! [`NinjaScenePlugin`] builds the scene of the `ninja_head` example: the bundled ninja
//! (`assets/ninja/`) playing its idle animation, spiky hair attached to its `head` bone with the
//! example's toon material, a ground disc, a sun and an orbit camera ([`NinjaOrbit`]). The
//! example adds keys and a window; [`record_clip`] renders the same scene without a window, one
//! PNG per simulation frame, at a fixed time step, so a clip is the same on every run.
//!
//! ```no_run
//! use bevy_cartoon_hair::demo::{ClipSettings, record_clip};
//!
//! let frames = record_clip(&ClipSettings {
//!     frames: 90,
//!     out: "clip".into(),
//!     ..Default::default()
//! })
//! .unwrap();
//! println!("wrote {} frames", frames.len());
//! ```

use std::path::PathBuf;
use std::time::Duration;

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::world_serialization::{WorldAsset, WorldAssetRoot, WorldInstanceReady};

use crate::headless::{CaptureSettings, HeadlessError, HeadlessRenderer};
use crate::mesh::ComputedHairMesh;
use crate::plugins::CartoonHairPlugins;
use crate::preset::HairPreset;
use crate::render::{HairMaterial, ToonHairMaterial, ToonRamps, ToonShading};
use crate::sim::{
    AttachToBone, BoneNotFound, ComputedHair, Hair, HairAssetFailed, HairCollider,
    HairColliderMode, HairSimSettings,
};

/// The demo hair's colour (orange).
pub const HAIR_COLOR: Color = Color::srgb(0.98, 0.62, 0.12);

/// The ninja-head scene. Add it after `DefaultPlugins` and [`CartoonHairPlugins`].
#[derive(Clone, Debug, Default)]
pub struct NinjaScenePlugin {
    /// Render the camera into this image instead of the primary window.
    pub target: Option<Handle<Image>>,
    /// Start the hair from this preset instead of the demo's own tuning.
    pub preset: Option<HairPreset>,
    /// The hair the ninja wears.
    pub hairstyle: NinjaHairstyle,
}

/// The hairstyles the ninja can wear, each a groom in `assets/ninja/` made by a script in
/// Blender (`tools/blender/author_ninja.py`, `tools/blender/author_hairstyles.py`).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Debug, PartialEq)]
pub enum NinjaHairstyle {
    /// Short anime spikes, keyframe-animated between three styles (`ninja.hair.xml`).
    #[default]
    Spiky,
    /// Long straight hair falling over the shoulders and down the back (`ninja_long.hair.xml`).
    Long,
    /// A bob to the jaw with bangs over the eyes (`ninja_bangs.hair.xml`).
    Bangs,
    /// Two long tails tied above the ears (`ninja_twin_tails.hair.xml`).
    TwinTails,
}

impl NinjaHairstyle {
    /// Every hairstyle, in menu order.
    pub const ALL: [NinjaHairstyle; 4] = [Self::Spiky, Self::Long, Self::Bangs, Self::TwinTails];

    /// Its name on the command line and in file names: `spiky`, `long`, `bangs`, `twin_tails`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Spiky => "spiky",
            Self::Long => "long",
            Self::Bangs => "bangs",
            Self::TwinTails => "twin_tails",
        }
    }

    /// The hairstyle called `name` (see [`NinjaHairstyle::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// Its groom, relative to the asset folder.
    pub fn groom_path(self) -> &'static str {
        match self {
            Self::Spiky => "ninja/ninja.hair.xml",
            Self::Long => "ninja/ninja_long.hair.xml",
            Self::Bangs => "ninja/ninja_bangs.hair.xml",
            Self::TwinTails => "ninja/ninja_twin_tails.hair.xml",
        }
    }

    /// Its keyframe animation, if it has one.
    pub fn animation_path(self) -> Option<&'static str> {
        (self == Self::Spiky).then_some("ninja/ninja.hairanim.xml")
    }
}

/// Where the demo camera looks from: an orbit around the head. Change it and the camera follows
/// in the same frame.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct NinjaOrbit {
    /// Turn around the vertical axis, radians (0 looks at the face).
    pub yaw: f32,
    /// Height angle, radians, clamped to `[-1.3, 1.3]`.
    pub pitch: f32,
    /// Distance from the target, metres, clamped to `[0.3, 6]`.
    pub distance: f32,
    /// The point looked at.
    pub target: Vec3,
}

impl Default for NinjaOrbit {
    fn default() -> Self {
        Self {
            yaw: 0.5,
            pitch: 0.15,
            distance: 1.1,
            target: Vec3::new(0.0, 1.68, 0.0),
        }
    }
}

impl NinjaOrbit {
    /// The camera transform of this orbit.
    pub fn transform(&self) -> Transform {
        let pitch = self.pitch.clamp(-1.3, 1.3);
        let distance = self.distance.clamp(0.3, 6.0);
        let offset =
            Quat::from_euler(EulerRot::YXZ, self.yaw, -pitch, 0.0) * Vec3::new(0.0, 0.0, distance);
        Transform::from_translation(self.target + offset).looking_at(self.target, Vec3::Y)
    }
}

/// The demo's handles: the character's glTF scene and the hair's material.
#[derive(Resource, Reflect, Clone, Debug)]
#[reflect(Resource, Debug)]
pub struct NinjaScene {
    /// The character's scene.
    pub scene: Handle<WorldAsset>,
    /// The material the demo hair is drawn with.
    pub hair_material: Handle<ToonHairMaterial>,
}

/// What the startup system needs from the plugin.
#[derive(Resource, Clone)]
struct NinjaSceneConfig(NinjaScenePlugin);

/// The idle animation to start once the character's scene is spawned.
#[derive(Component)]
struct IdleAnimation {
    graph: Handle<AnimationGraph>,
    node: AnimationNodeIndex,
}

impl Plugin for NinjaScenePlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(NinjaSceneConfig(self.clone()))
            .insert_resource(ClearColor(Color::srgb(0.80, 0.86, 0.95)))
            .insert_resource(GlobalAmbientLight {
                color: Color::WHITE,
                brightness: 600.0,
                ..default()
            })
            .add_systems(
                Startup,
                (stop_without_assets, spawn_ninja_scene, spawn_ninja_stage).chain(),
            )
            .add_observer(stop_on_failed_hair_asset)
            .init_resource::<NinjaProps>()
            .register_type::<NinjaProps>()
            .add_systems(
                Update,
                (
                    place_orbit_cameras,
                    show_ninja_props.run_if(resource_changed::<NinjaProps>),
                    sweep_board,
                ),
            );
    }
}

/// Without the scene's files, say which one is missing and exit with an error (code 3).
fn stop_without_assets(mut exit: MessageWriter<AppExit>) {
    if let Err(path) = check_ninja_assets() {
        error!(
            "{} is missing: run the example from the repository (or set BEVY_ASSET_ROOT to the \
             folder that holds assets/)",
            path.display()
        );
        exit.write(AppExit::from_code(3));
    }
}

/// A hair file of the demo that fails to load ends the demo with the loader's error (code 4).
fn stop_on_failed_hair_asset(failed: On<HairAssetFailed>, mut exit: MessageWriter<AppExit>) {
    error!(
        "the demo cannot run: {:?} {} failed: {}",
        failed.asset, failed.path, failed.error
    );
    exit.write(AppExit::from_code(4));
}

fn spawn_ninja_scene(
    mut commands: Commands,
    config: Res<NinjaSceneConfig>,
    assets: Res<AssetServer>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
    mut hair_materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
) {
    let config = &config.0;
    let (graph, node) = AnimationGraph::from_clip(
        assets.load(GltfAssetLabel::Animation(0).from_asset("ninja/ninja.glb")),
    );
    let style = config.hairstyle;
    let hair = Hair {
        groom: assets.load(style.groom_path()),
        animation: style.animation_path().map(|path| assets.load(path)),
        collision: Some(assets.load("ninja/ninja.collision.xml")),
    };
    let mut material = ToonHairMaterial::new(
        ToonShading {
            base_color: HAIR_COLOR,
            specular_strength: 0.35,
            shininess: 60.0,
            back_light_strength: 0.25,
            back_light_power: 0.6,
            ..default()
        },
        ramps.three_tone.clone(),
    );
    let mut settings = HairSimSettings::default();
    if let Some(preset) = &config.preset {
        preset.material.apply(&mut material, &ramps);
        settings = preset.simulation.clone();
    }
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset("ninja/ninja.glb"));
    let ninja = commands
        .spawn((
            Name::new("ninja"),
            WorldAssetRoot(scene.clone()),
            IdleAnimation {
                graph: graphs.add(graph),
                node,
            },
            // The fringe's shadow on the face and neck (the camera has the prepasses it reads).
            crate::render::FringeShadowMeshes::matching(
                |name| name == "skin",
                crate::render::FringeShadow {
                    width: 0.015,
                    ..default()
                },
            ),
            // The eyes show through the bangs, as anime draws them.
            crate::render::ShowThroughHairNamed::new(["eyes"]),
        ))
        .observe(play_idle_when_ready)
        .observe(shade_scalp_as_hair)
        .observe(add_shoulder_collider)
        .id();
    let hair_material = hair_materials.add(material);
    // The hair is built with everything on it; the plugin hangs it on the ninja's head bone.
    let mut hair_entity = commands.spawn((
        Name::new("ninja hair"),
        hair,
        settings,
        HairMaterial(hair_material.clone()),
        AttachToBone::named(ninja, "head"),
    ));
    if let Some(preset) = &config.preset {
        hair_entity.insert(preset.mesh.clone());
        if let Some(silhouettes) = &preset.silhouettes {
            hair_entity.insert(silhouettes.clone());
        }
    }
    commands.insert_resource(NinjaScene {
        scene,
        hair_material,
    });
}

/// Ground, sun and camera.
fn spawn_ninja_stage(
    mut commands: Commands,
    config: Res<NinjaSceneConfig>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Name::new("ground"),
        Mesh3d(meshes.add(Circle::new(2.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.55, 0.6, 0.5))),
        Transform::from_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)),
    ));
    commands.spawn((
        Name::new("sun"),
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(1.5, 3.0, 2.0).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
    ));
    let orbit = NinjaOrbit::default();
    let mut camera = commands.spawn((
        Name::new("camera"),
        Camera3d::default(),
        // The hair mask and depth the fringe shadow reads.
        bevy::core_pipeline::prepass::DepthPrepass,
        bevy::core_pipeline::prepass::NormalPrepass,
        orbit.transform(),
        orbit,
    ));
    if let Some(target) = &config.0.target {
        camera.insert(RenderTarget::Image(target.clone().into()));
    }
    if let Some(outline) = config.0.preset.as_ref().and_then(|p| p.outline.clone()) {
        camera.insert(outline);
    }
}

fn play_idle_when_ready(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    idle: Query<&IdleAnimation>,
    mut players: Query<&mut AnimationPlayer>,
) {
    let Ok(idle) = idle.get(ready.entity) else {
        return;
    };
    for child in children.iter_descendants(ready.entity) {
        if let Ok(mut player) = players.get_mut(child) {
            player.play(idle.node).repeat();
            commands
                .entity(child)
                .insert(AnimationGraphHandle(idle.graph.clone()));
        }
    }
}

/// The head's scalp (glTF material `scalp`) is drawn with the hair's own toon material: it
/// shades like the hair between the locks, and it is part of the hair mask, so the mass outline
/// draws no line where the hair meets it.
fn shade_scalp_as_hair(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    names: Query<&bevy::gltf::GltfMaterialName, With<MeshMaterial3d<StandardMaterial>>>,
    scene: Option<Res<NinjaScene>>,
) {
    let Some(scene) = scene else {
        return;
    };
    for child in children.iter_descendants(ready.entity) {
        if names.get(child).is_ok_and(|name| name.0 == "scalp") {
            commands
                .entity(child)
                .remove::<MeshMaterial3d<StandardMaterial>>()
                .insert(MeshMaterial3d(scene.hair_material.clone()));
        }
    }
}

/// The ninja's shoulders, chest and back as capsules on its `spine` bone, so long hair rests on
/// them instead of passing into the body (the head's own spheres come from the collision file).
/// The same shapes drape the long hairstyles in `tools/blender/author_hairstyles.py`.
fn add_shoulder_collider(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    names: Query<&Name>,
) {
    for child in children.iter_descendants(ready.entity) {
        if names.get(child).is_ok_and(|name| name.as_str() == "spine") {
            // The spine bone runs up from the hips (0.9 m) to the neck (1.42 m) along its +Y,
            // its other axes the character's; the shoulders are at 1.395 m, 0.195 m out, the
            // chest about 0.2 m wide and 0.115 m deep (`tools/blender/author_ninja.py`).
            let capsule = |x: f32, height: f32, radius: f32| crate::asset::CollisionCapsule {
                a: Vec3::new(-x, height - 0.9, 0.0),
                b: Vec3::new(x, height - 0.9, 0.0),
                radius,
            };
            commands.spawn((
                Name::new("ninja shoulders, chest and back"),
                crate::sim::HairCollider {
                    capsules: vec![
                        capsule(0.195, 1.395, 0.06),
                        capsule(0.09, 1.32, 0.115),
                        capsule(0.06, 1.20, 0.11),
                    ],
                    ..default()
                },
                Transform::default(),
                ChildOf(child),
            ));
        }
    }
}

/// Props that show the collider kinds on the ninja; each is in the scene while its flag is on
/// (the example's H, W and B keys, its `--hood`, `--wall` and `--board` flags, and
/// [`ClipSettings::props`]).
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub struct NinjaProps {
    /// A hood: a sphere of radius 0.2 m around the head in [`HairColliderMode::Inside`] mode,
    /// so the spikes (up to 0.31 m out) fold in under it.
    pub hood: bool,
    /// A wall 0.2 m behind the head: a plane; the spikes swept back flatten against it as the
    /// head turns.
    pub wall: bool,
    /// A board sweeping over the head, 0.6 m either side at 0.5 Hz (up to 1.9 m/s): a box; the
    /// top spikes bend as it passes.
    pub board: bool,
}

/// Which [`NinjaProps`] prop an entity is.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub enum NinjaProp {
    /// The hood (a child of the hair).
    Hood,
    /// The wall.
    Wall,
    /// The board.
    Board,
}

/// Where the board sweeps: above the head's rest position, across the character.
const BOARD_CENTRE: Vec3 = Vec3::new(0.0, 1.92, -0.01);

/// Spawns and despawns the props as [`NinjaProps`] says.
fn show_ninja_props(
    props: Res<NinjaProps>,
    mut commands: Commands,
    existing: Query<(Entity, &NinjaProp)>,
    hairs: Query<Entity, With<Hair>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let want = [
        (NinjaProp::Hood, props.hood),
        (NinjaProp::Wall, props.wall),
        (NinjaProp::Board, props.board),
    ];
    for (prop, on) in want {
        let have: Vec<Entity> = existing
            .iter()
            .filter(|(_, p)| **p == prop)
            .map(|(e, _)| e)
            .collect();
        if !on {
            for e in have {
                commands.entity(e).despawn();
            }
            continue;
        }
        if !have.is_empty() {
            continue;
        }
        let wood = Color::srgb(0.55, 0.42, 0.3);
        match prop {
            // The head's centre in the hair's space (bone `head`), as in its collision file.
            NinjaProp::Hood => {
                for hair in &hairs {
                    commands.spawn((
                        Name::new("hood (inside sphere)"),
                        prop,
                        HairCollider {
                            spheres: vec![crate::asset::CollisionSphere {
                                center: Vec3::new(0.0, 0.09, -0.01),
                                radius: 0.2,
                            }],
                            mode: HairColliderMode::Inside,
                            ..default()
                        },
                        ChildOf(hair),
                    ));
                }
            }
            NinjaProp::Wall => {
                commands.spawn((
                    Name::new("wall (plane)"),
                    prop,
                    HairCollider {
                        planes: vec![crate::asset::CollisionPlane {
                            point: Vec3::ZERO,
                            normal: Vec3::Z,
                        }],
                        ..default()
                    },
                    Mesh3d(meshes.add(Cuboid::new(0.8, 0.9, 0.02))),
                    MeshMaterial3d(materials.add(wood)),
                    Transform::from_xyz(0.0, 1.55, -0.21),
                ));
            }
            NinjaProp::Board => {
                let half = Vec3::new(0.25, 0.04, 0.15);
                commands.spawn((
                    Name::new("board (box)"),
                    prop,
                    HairCollider {
                        boxes: vec![crate::asset::CollisionBox {
                            center: Vec3::ZERO,
                            half_extents: half,
                            rotation: Quat::IDENTITY,
                        }],
                        ..default()
                    },
                    Mesh3d(meshes.add(Cuboid::from_size(2.0 * half))),
                    MeshMaterial3d(materials.add(wood)),
                    Transform::from_translation(BOARD_CENTRE + Vec3::X * 0.6),
                ));
            }
        }
    }
}

/// Moves the board across the head.
fn sweep_board(time: Res<Time>, mut boards: Query<(&NinjaProp, &mut Transform)>) {
    for (prop, mut t) in &mut boards {
        if *prop == NinjaProp::Board {
            let phase = std::f32::consts::TAU * 0.5 * time.elapsed_secs();
            t.translation = BOARD_CENTRE + Vec3::X * (0.6 * phase.cos());
        }
    }
}

fn place_orbit_cameras(mut cameras: Query<(&NinjaOrbit, &mut Transform), Changed<NinjaOrbit>>) {
    for (orbit, mut transform) in &mut cameras {
        *transform = orbit.transform();
    }
}

/// What [`record_clip`] renders.
#[derive(Clone, Debug)]
pub struct ClipSettings {
    /// Frames to write. Default: `90` (3 s).
    pub frames: u32,
    /// Folder for `frame_0000.png`, `frame_0001.png`, ...; created if missing.
    /// Default: `"clip"`.
    pub out: PathBuf,
    /// Tuning to start the hair from. Default: `None` (the demo's own).
    pub preset: Option<HairPreset>,
    /// Image width in pixels. Default: `640`.
    pub width: u32,
    /// Image height in pixels. Default: `360`.
    pub height: u32,
    /// Simulated seconds per frame. Default: `1/30`.
    pub frame_time: f32,
    /// Draw the tuning panel into the frames (feature `ui`). Default: `false`.
    pub show_ui: bool,
    /// Props in the scene (a hood, a wall, a board). Default: none.
    pub props: NinjaProps,
    /// The hair the ninja wears. Default: [`NinjaHairstyle::Spiky`].
    pub hairstyle: NinjaHairstyle,
    /// Where the camera looks from. Default: [`NinjaOrbit::default`] (the face, from its left).
    pub orbit: NinjaOrbit,
    /// The asset folder holding `ninja/`, when it is not the default `assets` (relative to
    /// `BEVY_ASSET_ROOT`, or absolute). Default: `None`.
    pub asset_folder: Option<PathBuf>,
}

impl Default for ClipSettings {
    fn default() -> Self {
        Self {
            frames: 90,
            out: "clip".into(),
            preset: None,
            width: 640,
            height: 360,
            frame_time: 1.0 / 30.0,
            show_ui: false,
            props: NinjaProps::default(),
            hairstyle: NinjaHairstyle::Spiky,
            orbit: NinjaOrbit::default(),
            asset_folder: None,
        }
    }
}

/// The files the ninja scene loads, relative to the asset folder.
pub const NINJA_ASSETS: [&str; 7] = [
    "ninja/ninja.glb",
    "ninja/ninja.hair.xml",
    "ninja/ninja.hairanim.xml",
    "ninja/ninja.collision.xml",
    "ninja/ninja_long.hair.xml",
    "ninja/ninja_bangs.hair.xml",
    "ninja/ninja_twin_tails.hair.xml",
];

/// Checks that the ninja scene's files are in the asset folder Bevy will read (`assets/` next to
/// the executable, or under `BEVY_ASSET_ROOT` / `CARGO_MANIFEST_DIR` when set). Returns the first
/// missing path, so the example and the recorder stop at once with it instead of waiting for
/// files that will never load.
pub fn check_ninja_assets() -> Result<(), PathBuf> {
    check_ninja_assets_in(&bevy::asset::io::file::FileAssetReader::get_base_path().join("assets"))
}

/// [`check_ninja_assets`] for the asset folder `root`.
pub fn check_ninja_assets_in(root: &std::path::Path) -> Result<(), PathBuf> {
    for file in NINJA_ASSETS {
        let path = root.join(file);
        if !path.is_file() {
            return Err(path);
        }
    }
    Ok(())
}

/// Every asset failure seen while a clip is recorded, in order.
#[derive(Resource, Default)]
struct ClipFailures(Vec<String>);

/// Whether every hair's groom, animation and collision file has loaded or failed.
fn hair_files_settled(world: &mut World) -> bool {
    use bevy::asset::LoadState;
    let server = world.resource::<AssetServer>().clone();
    let settled = |id: bevy::asset::UntypedAssetId| {
        matches!(
            server.get_load_state(id),
            Some(LoadState::Loaded | LoadState::Failed(_))
        )
    };
    let mut hairs = world.query::<&Hair>();
    hairs.iter(world).all(|hair| {
        settled(hair.groom.id().untyped())
            && hair.animation.iter().all(|h| settled(h.id().untyped()))
            && hair.collision.iter().all(|h| settled(h.id().untyped()))
    })
}

/// [`ClipError::AssetsFailed`] with the failures so far, if any.
fn take_failures(world: &mut World) -> Result<(), ClipError> {
    let failures = std::mem::take(&mut world.resource_mut::<ClipFailures>().0);
    if failures.is_empty() {
        Ok(())
    } else {
        Err(ClipError::AssetsFailed(failures))
    }
}

/// Why a clip could not be recorded.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ClipError {
    /// Files of the scene failed to load (the loader's `file:line:col` message for each): the
    /// clip would not show what was asked for, so none is written.
    #[error(
        "{} of the scene's files failed to load (no clip written):\n{}",
        .0.len(),
        .0.join("\n")
    )]
    AssetsFailed(Vec<String>),
    /// A file of the scene is not in the asset folder.
    #[error(
        "{} is missing: run from the repository (or set BEVY_ASSET_ROOT to the folder that \
         holds assets/)",
        .0.display()
    )]
    MissingAsset(PathBuf),
    /// The headless renderer failed (no adapter, a pipeline error, a timeout).
    #[error(transparent)]
    Headless(#[from] HeadlessError),
    /// The output folder or a frame could not be written.
    #[error("{}: {message}", path.display())]
    Write {
        /// The folder or file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// Whether the ninja scene is ready to record: the character and its assets are loaded and the
/// hair mesh is drawn with its material. For [`HeadlessRenderer::warm_up`].
pub fn ninja_scene_ready(world: &mut World) -> bool {
    let Some(scene) = world.get_resource::<NinjaScene>() else {
        return false;
    };
    let scene = scene.scene.id();
    if !world
        .resource::<AssetServer>()
        .is_loaded_with_dependencies(scene)
    {
        return false;
    }
    let mut meshes = world.query::<&ComputedHairMesh>();
    let mesh_entities: Vec<Entity> = meshes.iter(world).map(|m| m.entity).collect();
    !mesh_entities.is_empty()
        && mesh_entities
            .iter()
            .all(|&e| world.get::<MeshMaterial3d<ToonHairMaterial>>(e).is_some())
}

/// Renders `settings.frames` consecutive simulation frames of the ninja scene without a window
/// and writes them as PNGs; returns their paths in order.
///
/// Time stands still while assets load and pipelines compile, then every frame advances the
/// app by exactly [`ClipSettings::frame_time`] (`TimeUpdateStrategy::ManualDuration`), so the
/// same settings give the same clip on any machine. Uses [`HeadlessRenderer`]: any Vulkan
/// adapter works, including lavapipe.
///
/// # Errors
///
/// [`ClipError::MissingAsset`] when a file of the scene is not in the asset folder (checked
/// first, so a misplaced binary fails within a second);
/// [`ClipError::Headless`] without an adapter, on a pipeline error or a timeout;
/// [`ClipError::Write`] if the folder or a frame cannot be written.
pub fn record_clip(settings: &ClipSettings) -> Result<Vec<PathBuf>, ClipError> {
    let base = bevy::asset::io::file::FileAssetReader::get_base_path();
    let folder = settings
        .asset_folder
        .clone()
        .unwrap_or_else(|| PathBuf::from("assets"));
    check_ninja_assets_in(&base.join(&folder)).map_err(ClipError::MissingAsset)?;
    std::fs::create_dir_all(&settings.out).map_err(|e| ClipError::Write {
        path: settings.out.clone(),
        message: e.to_string(),
    })?;
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width: settings.width,
        height: settings.height,
        max_frames: 5_000,
        asset_folder: Some(folder.to_string_lossy().into_owned()),
        ..default()
    })?;
    // The recorder runs without Bevy's log: every failure is kept and returned instead.
    renderer
        .app
        .init_resource::<ClipFailures>()
        .add_observer(
            |failed: On<HairAssetFailed>, mut all: ResMut<ClipFailures>| {
                all.0.push(format!(
                    "{:?} file {}: {}",
                    failed.asset, failed.path, failed.error
                ));
            },
        )
        .add_observer(|missing: On<BoneNotFound>, mut all: ResMut<ClipFailures>| {
            all.0
                .push(format!("the character has no bone {:?}", missing.bone));
        });
    renderer.app.add_plugins((
        CartoonHairPlugins,
        NinjaScenePlugin {
            target: Some(renderer.target()),
            preset: settings.preset.clone(),
            hairstyle: settings.hairstyle,
        },
    ));
    #[cfg(feature = "ui")]
    if settings.show_ui {
        renderer.app.add_plugins(crate::ui::HairTuningUiPlugin);
        renderer.app.insert_resource(crate::ui::HairTuningUi {
            visible: true,
            ..default()
        });
    }
    renderer.app.insert_resource(settings.props);
    // Nothing moves until the scene is ready: the clip starts from the same state every time.
    renderer
        .app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    // Ready when every hair file has loaded or failed, and the scene is ready or something
    // failed (without a groom the hair is never ready).
    renderer.warm_up(|world| {
        hair_files_settled(world)
            && (!world.resource::<ClipFailures>().0.is_empty() || ninja_scene_ready(world))
    })?;
    // One more frame reports what failed in the last one.
    renderer.app.update();
    take_failures(renderer.app.world_mut())?;
    // Assets load in a different order from run to run, so the hair may have hung from the bone
    // at rest or in its animated pose first: start it from its style, the same every time.
    let world = renderer.app.world_mut();
    let mut hairs = world.query::<(&GlobalTransform, &mut ComputedHair)>();
    for (bone, mut hair) in hairs.iter_mut(world) {
        hair.reset(bone);
    }
    let mut orbits = world.query::<&mut NinjaOrbit>();
    for mut orbit in orbits.iter_mut(world) {
        orbit.set_if_neq(settings.orbit.clone());
    }
    let step = Duration::from_secs_f32(settings.frame_time.max(0.0));
    renderer
        .app
        .insert_resource(TimeUpdateStrategy::ManualDuration(step));
    let mut paths = Vec::with_capacity(settings.frames as usize);
    let mut failure = None;
    renderer.capture_sequence(settings.frames, |index, frame| {
        let path = settings.out.join(format!("frame_{index:04}.png"));
        match frame.save_png(&path) {
            Ok(()) => paths.push(path),
            Err(e) => {
                failure.get_or_insert(ClipError::Write {
                    path,
                    message: e.to_string(),
                });
            }
        }
    })?;
    // A file that fails while the clip runs (a hot reload, a late key) spoils it too.
    take_failures(renderer.app.world_mut())?;
    match failure {
        Some(e) => Err(e),
        None => {
            paths.sort();
            Ok(paths)
        }
    }
}
