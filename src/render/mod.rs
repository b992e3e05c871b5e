//! GPU side: the WESL modules shared by the crate's materials and passes.
//!
//! Shared modules are embedded at `embedded://bevy_cartoon_hair/render/<module>.wesl`, so a shader
//! imports them as `bevy_cartoon_hair::render::<module>`; they are registered by
//! [`HairShaderLibraryPlugin`]. `cargo test` compiles every shader variant through Bevy's own
//! shader cache (WESL, against Bevy's embedded modules) and validates it with naga (see
//! `shader_validation`), so a shader mistake fails the tests, not a user's frame.

use bevy::prelude::*;
use bevy::shader::load_shader_library;

use crate::schedule::HairSystems;
use crate::silhouette::StrokeScope;

mod fringe_shadow;
mod gltf_paint;
mod gpu;
mod highlight;
mod lock_ids;
mod outline;
mod ramps;
mod see_through;
#[cfg(test)]
mod shader_validation;
mod shadow_caster;
mod stroke;
mod tonal_maps;
mod toon;
mod user_mesh;

pub use fringe_shadow::{
    FringeShadow, FringeShadowMaterial, FringeShadowMeshes, FringeShadowMeshesApplied,
    FringeShadowUniform, mtoon_cel_band,
};
pub use gltf_paint::HairPaint;
#[doc(hidden)]
pub use gpu::encode_gpu_inputs;
pub use gpu::{
    GpuPassState, GpuTubesPlugin, HairCompactQuads, HairGpuBuildFailed, HairGpuDispatches,
    HairGpuFallback, HairGpuMeshSupport, HairGpuPasses, HairMeshBuilder, PassDispatches,
};
pub use highlight::{HairHighlightMaterial, HairHighlightQuads, highlight_material};
pub use lock_ids::lock_ids_by_piece;
pub use outline::{
    GpuImageSpaceOutline, ImageSpaceOutline, ImageSpaceOutlinePlugin, LockLines,
    MAX_OUTLINE_DILATION, OutlineSource,
};
pub use ramps::{
    RAMP_HEIGHT, RAMP_WIDTH, ToonRamps, highlight_texture_image, ramp_image, stroke_texture_image,
};
pub use see_through::{
    SeenThroughHairMaterial, SeenThroughHairOverlay, SeenThroughHairUniform,
    SeenThroughOverlayMarker, ShowThroughHair, ShowThroughHairNamed,
};
pub use shadow_caster::HairShadowMaterial;
pub use stroke::{HairStrokeMaterial, HairStrokeUniform};
pub use tonal_maps::{HatchingMapSettings, TonalArtMapCache, assign_tonal_art_maps};
pub use toon::{
    AngelRingProfile, HatchingMode, RampMode, ToonHairMaterial, ToonHairMaterialKey,
    ToonHairUniform, ToonLighting, ToonShading,
};
pub use user_mesh::{
    StrandUvs, ToonHairMeshes, ToonHairMeshesApplied, strand_uvs_from_height, turn_normals_to_mass,
};

/// Every WESL library module of the crate, as `(file, source)`, for validation and tools. A file
/// `f.wesl` is embedded at `embedded://bevy_cartoon_hair/render/f.wesl` and imported as
/// `bevy_cartoon_hair::render::f`.
pub const SHADER_LIBRARY: &[(&str, &str)] = &[
    ("curves.wesl", include_str!("curves.wesl")),
    ("toon_material.wesl", include_str!("toon_material.wesl")),
    ("gpu/common.wesl", include_str!("gpu/common.wesl")),
    ("gpu/quads.wesl", include_str!("gpu/quads.wesl")),
];

/// The entry-point shaders of the crate's materials, as `(name, source)`.
pub const MATERIAL_SHADERS: &[(&str, &str)] = &[
    ("toon.wesl", include_str!("toon.wesl")),
    ("hair_prepass.wesl", include_str!("hair_prepass.wesl")),
    ("stroke.wesl", include_str!("stroke.wesl")),
    ("fringe_shadow.wesl", include_str!("fringe_shadow.wesl")),
    ("see_through.wesl", include_str!("see_through.wesl")),
];

/// The entry-point shaders of the crate's post-process and compute passes, as `(name, source)`.
pub const PASS_SHADERS: &[(&str, &str)] = &[
    ("outline.wesl", include_str!("outline/outline.wesl")),
    ("gpu/tubes.wesl", include_str!("gpu/tubes.wesl")),
    ("gpu/strokes.wesl", include_str!("gpu/strokes.wesl")),
    ("gpu/highlights.wesl", include_str!("gpu/highlights.wesl")),
    ("gpu/shadows.wesl", include_str!("gpu/shadows.wesl")),
];

/// Registers the crate's WESL library modules so materials can `import` them. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairShaderLibraryPlugin;

impl Plugin for HairShaderLibraryPlugin {
    fn build(&self, app: &mut App) {
        load_shader_library!(app, "curves.wesl");
        load_shader_library!(app, "toon_material.wesl");
        load_shader_library!(app, "gpu/common.wesl");
        load_shader_library!(app, "gpu/quads.wesl");
    }
}

/// Registers [`ToonHairMaterial`] and generates the default [`ToonRamps`]. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct ToonHairMaterialPlugin;

impl Plugin for ToonHairMaterialPlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "toon.wesl");
        bevy::asset::embedded_asset!(app, "hair_prepass.wesl");
        bevy::asset::embedded_asset!(app, "stroke.wesl");
        bevy::asset::embedded_asset!(app, "fringe_shadow.wesl");
        bevy::asset::embedded_asset!(app, "see_through.wesl");
        app.add_plugins((
            MaterialPlugin::<ToonHairMaterial>::default(),
            MaterialPlugin::<HairStrokeMaterial>::default(),
            MaterialPlugin::<FringeShadowMaterial>::default(),
            MaterialPlugin::<HairHighlightMaterial>::default(),
            MaterialPlugin::<SeenThroughHairMaterial>::default(),
        ))
        .register_type::<ShowThroughHair>()
        .register_type::<ShowThroughHairNamed>()
        .register_type::<ToonHairMaterial>()
        .register_type::<HairStrokeMaterial>()
        .register_type::<ToonHairMeshes>()
        .register_type::<ToonHairMeshesApplied>()
        .register_type::<FringeShadowMeshes>()
        .register_type::<FringeShadowMeshesApplied>();
        let ramps = ToonRamps::generate(&mut app.world_mut().resource_mut::<Assets<Image>>());
        let texture = app
            .world_mut()
            .resource_mut::<Assets<Image>>()
            .add(stroke_texture_image());
        let mut strokes = app.world_mut().resource_mut::<Assets<HairStrokeMaterial>>();
        let stroke = StrokeMaterials {
            mass: strokes.add(HairStrokeMaterial::new(texture.clone(), StrokeScope::Mass)),
            strands: strokes.add(HairStrokeMaterial::new(texture, StrokeScope::Strands)),
        };
        let highlight_texture = app
            .world_mut()
            .resource_mut::<Assets<Image>>()
            .add(highlight_texture_image());
        let highlight = HighlightMaterial(
            app.world_mut()
                .resource_mut::<Assets<HairHighlightMaterial>>()
                .add(highlight_material(StandardMaterial {
                    base_color: Color::srgba(1.0, 1.0, 0.95, 0.9),
                    base_color_texture: Some(highlight_texture),
                    unlit: true,
                    alpha_mode: AlphaMode::Blend,
                    cull_mode: None,
                    double_sided: true,
                    ..default()
                })),
        );
        shadow_caster::build(app);
        app.insert_resource(ramps)
            .insert_resource(stroke)
            .insert_resource(highlight)
            .init_resource::<HatchingMapSettings>()
            .init_resource::<gltf_paint::LookCopies>()
            .init_resource::<gltf_paint::BandRamps>()
            .init_resource::<TonalArtMapCache>()
            .add_systems(
                PostUpdate,
                (
                    apply_hair_materials,
                    // A character's hair meshes take the toon hair material before its other
                    // meshes are extended, so a selection of "all but the hair" finds them taken.
                    (
                        user_mesh::apply_toon_to_user_meshes,
                        fringe_shadow::apply_fringe_shadow,
                    )
                        .chain(),
                    gltf_paint::follow_look_edits,
                    apply_stroke_material,
                    apply_highlight_material,
                    (see_through::mark_named_parts, see_through::sync_overlays).chain(),
                )
                    .in_set(HairSystems::Materials),
            )
            .add_systems(
                PostUpdate,
                keep_surface_hatched_tubes_closed.before(HairSystems::BuildMesh),
            )
            // Hatching works without the panel: materials that ask for it get a map.
            .add_systems(
                PostUpdate,
                (assign_tonal_art_maps, assign_specular_ramps).in_set(HairSystems::Materials),
            );
    }
}

/// The material a hair is drawn with. Inserted with a shared default (three-tone ramp) when
/// missing; change it (or the material asset) any time.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct HairMaterial(pub Handle<ToonHairMaterial>);

/// Gives every material whose specular layer is on ([`ToonShading::specular_ramp`]) but has no
/// ramp for it the default one ([`ToonRamps::specular`]). Only materials that changed are looked
/// at.
/// A colour's linear RGBA with every channel finite (non-finite ones read as `default`) and
/// within `[0, max]`, so a hostile colour in a preset or a panel never reaches a shader as NaN.
pub(crate) fn linear_color(c: Color, default: f32, max: f32) -> Vec4 {
    Vec4::from_array(
        c.to_linear()
            .to_f32_array()
            .map(|v| crate::math::finite_or(v, default).clamp(0.0, max)),
    )
}

fn assign_specular_ramps(
    mut events: MessageReader<AssetEvent<ToonHairMaterial>>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
) {
    for event in events.read() {
        let (AssetEvent::Added { id } | AssetEvent::Modified { id }) = *event else {
            continue;
        };
        let needs = materials
            .get(id)
            .is_some_and(|m| m.specular_ramp > 0.0 && m.specular_ramp_texture.is_none());
        if needs && let Some(mut m) = materials.get_mut(id) {
            m.specular_ramp_texture = Some(ramps.specular.clone());
        }
    }
}

/// The materials silhouette strokes are drawn with, one per [`StrokeScope`] (see
/// [`HairStrokeMaterial`]); each hair's strokes get the one its
/// [`SilhouetteSettings::scope`](crate::silhouette::SilhouetteSettings::scope) names. Stroke
/// colour and fade come in as vertex colours. Change the assets to restyle every stroke.
#[derive(Resource, Clone, Debug)]
pub struct StrokeMaterials {
    /// For [`StrokeScope::Mass`].
    pub mass: Handle<HairStrokeMaterial>,
    /// For [`StrokeScope::Strands`].
    pub strands: Handle<HairStrokeMaterial>,
}

impl StrokeMaterials {
    /// The material of `scope`.
    pub fn of(&self, scope: StrokeScope) -> &Handle<HairStrokeMaterial> {
        match scope {
            StrokeScope::Mass => &self.mass,
            StrokeScope::Strands => &self.strands,
        }
    }
}

/// Gives new stroke entities, and those of hairs whose settings changed, the material of their
/// hair's stroke scope.
fn apply_stroke_material(
    mut commands: Commands,
    new: Query<
        (Entity, &crate::silhouette::HairStrokesOf),
        Without<MeshMaterial3d<HairStrokeMaterial>>,
    >,
    changed: Query<
        (
            &crate::silhouette::SilhouetteSettings,
            &crate::silhouette::HairStrokes,
        ),
        Changed<crate::silhouette::SilhouetteSettings>,
    >,
    settings: Query<&crate::silhouette::SilhouetteSettings>,
    current: Query<&MeshMaterial3d<HairStrokeMaterial>>,
    materials: Res<StrokeMaterials>,
) {
    for (e, of) in &new {
        let scope = settings.get(of.0).map(|s| s.scope).unwrap_or_default();
        commands
            .entity(e)
            .insert(MeshMaterial3d(materials.of(scope).clone()));
    }
    for (s, strokes) in &changed {
        let want = materials.of(s.scope);
        for e in strokes.iter() {
            if current.get(e).is_ok_and(|m| m.0 != *want) {
                commands.entity(e).insert(MeshMaterial3d(want.clone()));
            }
        }
    }
}

/// The material specular sampling quads are drawn with (unlit, alpha-blended highlight texture;
/// change its `base` to change their look).
#[derive(Resource, Clone, Debug)]
pub struct HighlightMaterial(pub Handle<HairHighlightMaterial>);

fn apply_highlight_material(
    mut commands: Commands,
    quads: Query<
        Entity,
        (
            With<crate::mesh::highlights::HairHighlightsOf>,
            Without<MeshMaterial3d<HairHighlightMaterial>>,
        ),
    >,
    material: Res<HighlightMaterial>,
) {
    for e in &quads {
        commands
            .entity(e)
            .insert(MeshMaterial3d(material.0.clone()));
    }
}

/// Keeps the tubes of hairs whose material hatches on the surface closed
/// ([`HairTubesClosed`](crate::mesh::HairTubesClosed)): the hatching runs around the tube.
fn keep_surface_hatched_tubes_closed(
    mut commands: Commands,
    hairs: Query<(Entity, &HairMaterial, Has<crate::mesh::HairTubesClosed>)>,
    materials: Res<Assets<ToonHairMaterial>>,
) {
    for (hair, material, closed) in &hairs {
        let wanted = materials
            .get(&material.0)
            .is_some_and(|m| m.hatching == HatchingMode::Surface && m.tonal_art_map.is_some());
        if wanted && !closed {
            commands.entity(hair).insert(crate::mesh::HairTubesClosed);
        } else if closed && !wanted {
            commands
                .entity(hair)
                .remove::<crate::mesh::HairTubesClosed>();
        }
    }
}

/// Keeps every hair mesh entity drawn with its hair's [`HairMaterial`].
fn apply_hair_materials(
    mut commands: Commands,
    hairs: Query<(Entity, Option<&HairMaterial>, &crate::mesh::HairMeshes)>,
    mesh_materials: Query<Option<&MeshMaterial3d<ToonHairMaterial>>>,
    ramps: Res<ToonRamps>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    mut default_material: Local<Option<Handle<ToonHairMaterial>>>,
) {
    for (hair, material, meshes) in &hairs {
        let handle = match material {
            Some(m) => m.0.clone(),
            None => {
                let handle = default_material
                    .get_or_insert_with(|| {
                        materials.add(ToonHairMaterial {
                            ramp: ramps.three_tone.clone(),
                            ..default()
                        })
                    })
                    .clone();
                commands.entity(hair).insert(HairMaterial(handle.clone()));
                handle
            }
        };
        for mesh in meshes.iter() {
            let current = mesh_materials.get(mesh).ok().flatten();
            if current.is_none_or(|c| c.0 != handle) {
                commands.entity(mesh).insert(MeshMaterial3d(handle.clone()));
            }
        }
    }
}
