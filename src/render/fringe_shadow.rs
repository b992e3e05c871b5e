//! The fringe shadow: the hair throws a crisp, stylised shadow on the character's face and skin,
//! as anime drawing does, without shadow maps.
//!
//! The face's material is Bevy's `StandardMaterial` extended with [`FringeShadow`]
//! ([`FringeShadowMaterial`]); put a [`FringeShadowMeshes`] on a glTF character to extend the
//! materials of its face meshes in place. Each face fragment looks `width` (in the face mesh's
//! own units) back toward the main directional light, across the view; where the hair's prepass
//! mask shows hair in front of the face there, the fragment is in the fringe's shadow, and
//! [`FringeShadow::tone`] multiplies its base colour before lighting, so the shadow takes the
//! scene's light like the rest of the face.
//!
//! Why a mask and an offset: Bevy's shadow maps give a soft, low-resolution and often absent
//! shadow at face scale; the best toon renderers (StarRailNPRShader's hair depth texture,
//! MooaToon's hair shadow width) sample a hair-only mask one offset away instead. The crate's
//! hair already writes such a mask in its prepass (the normal target's alpha, for the mass
//! outline), so the shadow costs four texture loads a face pixel and no extra pass, and the
//! offset, a length in the scene, keeps the shadow's width in head units at any distance, field
//! of view and window size. The camera needs `NormalPrepass` (the mask) and, so hair behind the
//! face casts nothing, `DepthPrepass`. Hair never receives it: only materials that opt in do.

use bevy::pbr::{ExtendedMaterial, MaterialExtension};
use bevy::prelude::*;
use bevy::render::render_resource::{AsBindGroup, ShaderType};
use bevy::shader::ShaderRef;
use bevy::world_serialization::WorldAssetRoot;

use crate::asset::{VrmRim, VrmShadeColor, VrmShading};
use crate::math::finite_or;
use crate::sim::{BonePredicate, CharacterSpawned};

use super::gltf_paint::{MtoonParts, rim_uniform, shade_tint};
use super::user_mesh::{MeshNames, meshes_passing};

/// A face material that receives the fringe shadow.
pub type FringeShadowMaterial = ExtendedMaterial<StandardMaterial, FringeShadow>;

/// The fringe shadow a face receives: the [`MaterialExtension`] of [`FringeShadowMaterial`].
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug, PartialEq)]
#[uniform(100, FringeShadowUniform)]
#[reflect(Debug, Default, PartialEq)]
pub struct FringeShadow {
    /// The shadow's tone: multiplies the face's base colour where the fringe shades it, before
    /// lighting. Default: a warm rose, `srgb(0.78, 0.55, 0.58)`.
    pub tone: Color,
    /// How strongly the tone applies, `0` (no shadow) to `1`. Default: `1.0`.
    pub strength: f32,
    /// How far the shadow falls from the hair's edge, in the face mesh's own units (metres for
    /// a character at scale 1): larger throws it farther down the face. Default: `0.02`.
    pub width: f32,
    /// Cel shading: the surface drawn in two flat tones under the scene's lights, as the hair's
    /// toon material draws hair, instead of Bevy's PBR shading. The light reaching the surface
    /// (every light, its colour and shadows) is measured as the hair's toon material measures
    /// it ([`ToonLighting::Scene`](super::ToonLighting::Scene)); above
    /// [`FringeShadow::cel_threshold`] the surface shows its base colour in the light's hue,
    /// below it the base colour times [`FringeShadow::cel_shade`]. Where almost no light
    /// reaches (turned away from every light, in a shadow, no ambient light) the hue is the
    /// first directional light's: the surface draws its shade tone there, as MToon draws its
    /// shade colour, not black (black only with no directional light). Default: `false`.
    pub cel: bool,
    /// The shade tone of cel shading: multiplies the base colour where the light is below the
    /// threshold. Default: a warm rose, `srgb(0.80, 0.62, 0.64)`, as skin is drawn. A
    /// [`FringeShadowMeshes`] gives a VRM's MToon meshes their own shade instead (see
    /// [`FringeShadowMeshes::vrm_shades`]).
    pub cel_shade: Color,
    /// The light level, as a share of [`FringeShadow::full_light_lux`], where cel shading turns
    /// from shade to lit (the middle of the turn). Default: `0.3`. A [`FringeShadowMeshes`]
    /// gives a VRM's MToon meshes their own (see [`FringeShadowMeshes::vrm_shades`]).
    pub cel_threshold: f32,
    /// Half the width of the turn from shade to lit, in the same share of full light: a smooth
    /// step from `cel_threshold - cel_softness` to `cel_threshold + cel_softness`. Small is a
    /// crisp line, large a gradient. Clamped to `[0.001, 1]`. Default: `0.015`.
    #[reflect(default = "default_cel_softness")]
    pub cel_softness: f32,
    /// The illuminance (lux) that counts as fully lit, as
    /// [`ToonShading::full_light_lux`](super::ToonShading::full_light_lux). Default: `10000`.
    pub full_light_lux: f32,
    /// A rim light along the silhouette of a cel-shaded surface: MToon's parametric rim
    /// ([`VrmRim`]), its colour times [`VrmRim::strength`] added where the surface turns away
    /// from the viewer, times what cel shading draws a white surface in there (the light's hue,
    /// and the shade tone in shade) as far as [`VrmRim::lighting_mix`] says. Drawn with
    /// [`FringeShadow::cel`] only. A [`FringeShadowMeshes`] gives a VRM's MToon meshes their own
    /// (see [`FringeShadowMeshes::vrm_shades`]). Default: `None`.
    #[reflect(default)]
    pub rim: Option<VrmRim>,
}

impl Default for FringeShadow {
    fn default() -> Self {
        Self {
            tone: Color::srgb(0.78, 0.55, 0.58),
            strength: 1.0,
            width: 0.02,
            cel: false,
            cel_shade: Color::srgb(0.80, 0.62, 0.64),
            cel_threshold: 0.3,
            cel_softness: default_cel_softness(),
            full_light_lux: 10_000.0,
            rim: None,
        }
    }
}

impl FringeShadow {
    /// The default fringe shadow on a cel-shaded surface: a face and body in the toon look.
    pub fn cel() -> Self {
        Self {
            cel: true,
            ..default()
        }
    }
}

/// The uniform block of [`FringeShadow`] (see `fringe_shadow.wesl`).
#[derive(Clone, Default, ShaderType)]
pub struct FringeShadowUniform {
    tone: Vec4,
    params: Vec4,
    cel_shade: Vec4,
    rim: Vec4,
    rim_shape: Vec4,
}

impl bevy::render::render_resource::AsBindGroupShaderType<FringeShadowUniform> for FringeShadow {
    fn as_bind_group_shader_type(
        &self,
        _images: &bevy::render::render_asset::RenderAssets<bevy::render::texture::GpuImage>,
    ) -> FringeShadowUniform {
        let (rim, rim_shape) = rim_uniform(self.rim.as_ref());
        FringeShadowUniform {
            tone: self
                .tone
                .to_linear()
                .to_vec4()
                .truncate()
                .extend(finite_or(self.strength, 1.0).clamp(0.0, 1.0)),
            params: Vec4::new(
                finite_or(self.width, 0.02).clamp(0.0, 1e3),
                if self.cel { 1.0 } else { 0.0 },
                finite_or(self.cel_threshold, 0.3).clamp(0.0, 1.0),
                finite_or(self.full_light_lux, 10_000.0).max(1e-3),
            ),
            cel_shade: self
                .cel_shade
                .to_linear()
                .to_vec4()
                .truncate()
                .extend(finite_or(self.cel_softness, 0.015).clamp(0.001, 1.0)),
            rim,
            rim_shape,
        }
    }
}

impl MaterialExtension for FringeShadow {
    fn fragment_shader() -> ShaderRef {
        ShaderRef::Path(
            bevy::asset::AssetPath::from_path_buf(bevy::asset::embedded_path!(
                "fringe_shadow.wesl"
            ))
            .with_source("embedded"),
        )
    }
}

/// Put on a character (a glTF or VRM scene root): its meshes whose entity name, node name or
/// glTF material name passes `select` (the face, the skin) get their `StandardMaterial`
/// extended with [`FringeShadow`], keeping every setting of the original (colour, textures,
/// alpha).
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::render::{FringeShadow, FringeShadowMeshes};
/// # fn setup(mut commands: Commands, character: Entity) {
/// commands
///     .entity(character)
///     .insert(FringeShadowMeshes::matching(|name| name == "skin", FringeShadow::default()));
/// # }
/// ```
///
/// The toon look on the whole character: every mesh but the hair, cel-shaded, the skin taking
/// the fringe's shadow. Meshes a [`ToonHairMeshes`](super::ToonHairMeshes) on the same character
/// takes are dressed first and left out (they no longer wear a `StandardMaterial`).
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::render::{FringeShadow, FringeShadowMeshes, ToonHairMeshes};
/// # fn setup(mut commands: Commands, character: Entity) {
/// commands.entity(character).insert((
///     ToonHairMeshes::matching(|name| name == "hair"),
///     FringeShadowMeshes::all_except(|name| name == "hair", FringeShadow::cel()),
/// ));
/// # }
/// ```
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component, Debug)]
pub struct FringeShadowMeshes {
    /// Which meshes: tested on the mesh entity's name, its parent's name and its glTF
    /// material's name.
    #[reflect(ignore)]
    pub select: BonePredicate,
    /// The shadow they receive.
    pub shadow: FringeShadow,
    /// When set, the meshes taken are the others: those none of whose names pass `select`.
    pub except: bool,
    /// Whether a mesh whose material is a VRM's MToon with a shade colour ([`VrmShadeColor`])
    /// takes that colour as its [`FringeShadow::cel_shade`] (the shade over its base colour, so
    /// the dark tone draws the MToon shade, times the texture), and one with a shading band
    /// ([`VrmShading`]) takes it as its [`FringeShadow::cel_threshold`] and
    /// [`FringeShadow::cel_softness`] (see [`mtoon_cel_band`]), and one with a rim light
    /// ([`VrmRim`]) takes it as its [`FringeShadow::rim`], instead of the ones `shadow` gives
    /// every mesh. Default: `true`.
    #[reflect(default = "yes")]
    pub vrm_shades: bool,
}

fn yes() -> bool {
    true
}

fn default_cel_softness() -> f32 {
    0.015
}

impl FringeShadowMeshes {
    /// Meshes whose name, node name or material name passes `test`, receiving `shadow`.
    pub fn matching(
        test: impl Fn(&str) -> bool + Send + Sync + 'static,
        shadow: FringeShadow,
    ) -> Self {
        Self {
            select: BonePredicate::new(test),
            shadow,
            except: false,
            vrm_shades: true,
        }
    }

    /// Every mesh (with a `StandardMaterial`) except those whose name, node name or material
    /// name passes `test` (a mesh with none of these names is taken), receiving `shadow`: with
    /// [`FringeShadow::cel`], the toon look on a whole character but its hair.
    pub fn all_except(
        test: impl Fn(&str) -> bool + Send + Sync + 'static,
        shadow: FringeShadow,
    ) -> Self {
        Self {
            except: true,
            ..Self::matching(test, shadow)
        }
    }

    /// These meshes with `shadow`'s cel shade tone, a VRM's MToon shade colours ignored.
    pub fn without_vrm_shades(self) -> Self {
        Self {
            vrm_shades: false,
            ..self
        }
    }
}

/// On a [`FringeShadowMeshes`] character once its meshes are extended: the mesh entities.
#[derive(Component, Clone, Debug, Default, Reflect)]
#[reflect(Component, Debug)]
pub struct FringeShadowMeshesApplied(pub Vec<Entity>);

/// Whether a character is a scene root, has spawned, wants its hair meshes dressed and has them
/// dressed.
type CharacterState = (
    Option<&'static WorldAssetRoot>,
    Has<CharacterSpawned>,
    Has<super::ToonHairMeshes>,
    Has<super::ToonHairMeshesApplied>,
);

/// Extends the selected meshes' materials of every spawned [`FringeShadowMeshes`] character.
/// Cel shading's threshold and softness ([`FringeShadow::cel_threshold`],
/// [`FringeShadow::cel_softness`]) for an MToon shading band: the middle and half the width of
/// [`VrmShading::lit_band`]. Cel shading measures the light that reaches the surface, which is
/// never below 0 (a surface turned away from every light receives none), so the part of the
/// band below 0 cannot be told apart: the band starts at 0 there (MToon 1.0's defaults, `N.L`
/// from -0.1 to 0.1, become 0 to 0.1; what VRoid exports, 0 to 0.1, is kept).
pub fn mtoon_cel_band(shading: &VrmShading) -> (f32, f32) {
    let (lo, hi) = shading.lit_band();
    let lo = finite_or(lo, 0.0).clamp(0.0, 1.0);
    let hi = finite_or(hi, 0.0).clamp(lo, 1.0);
    let half = ((hi - lo) * 0.5).max(0.001);
    (lo + (hi - lo) * 0.5, half)
}

#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn apply_fringe_shadow(
    mut commands: Commands,
    characters: Query<(Entity, &FringeShadowMeshes), Without<FringeShadowMeshesApplied>>,
    roots: Query<CharacterState>,
    children: Query<&Children>,
    meshes: Query<MeshNames, With<Mesh3d>>,
    names: Query<&Name>,
    (standard, shades): (Query<&MeshMaterial3d<StandardMaterial>>, Query<MtoonParts>),
    (standards, mut extended): (
        Res<Assets<StandardMaterial>>,
        ResMut<Assets<FringeShadowMaterial>>,
    ),
    server: Option<Res<AssetServer>>,
) {
    for (character, wanted) in &characters {
        let Ok((scene, spawned, hair, dressed)) = roots.get(character) else {
            continue;
        };
        // A scene that failed to load never spawns: stop waiting, and say so.
        if let Some(scene) = scene.filter(|_| !spawned) {
            if let Some((file, reason)) = crate::sim::scene_failure(server.as_deref(), scene) {
                error!(
                    "FringeShadowMeshes on {character}: its scene {file:?} did not load, so no \
                     face receives the fringe shadow: {reason}"
                );
                commands
                    .entity(character)
                    .insert(FringeShadowMeshesApplied(Vec::new()));
            }
            continue;
        }
        // Not before its hair meshes are dressed.
        if hair && !dressed {
            continue;
        }
        let mut done = Vec::new();
        // Meshes sharing a material share its extension.
        let mut made: Vec<(AssetId<StandardMaterial>, Handle<FringeShadowMaterial>)> = Vec::new();
        let selected = meshes_passing(
            character,
            &wanted.select,
            wanted.except,
            &children,
            &meshes,
            &names,
        );
        for e in selected {
            let Ok(MeshMaterial3d(handle)) = standard.get(e) else {
                continue;
            };
            let material = match made.iter().find(|(id, _)| *id == handle.id()) {
                Some((_, m)) => m.clone(),
                None => {
                    let Some(base) = standards.get(handle) else {
                        continue;
                    };
                    let mut extension = wanted.shadow.clone();
                    let (shade, band, rim) = shades
                        .get(e)
                        .ok()
                        .filter(|_| wanted.vrm_shades)
                        .unwrap_or_default();
                    if let Some(VrmShadeColor(shade)) = shade {
                        extension.cel_shade = shade_tint(*shade, base.base_color, None).into();
                    }
                    if let Some(band) = band {
                        (extension.cel_threshold, extension.cel_softness) = mtoon_cel_band(band);
                    }
                    if let Some(rim) = rim {
                        extension.rim = Some(*rim);
                    }
                    let m = extended.add(ExtendedMaterial {
                        base: base.clone(),
                        extension,
                    });
                    made.push((handle.id(), m.clone()));
                    m
                }
            };
            commands
                .entity(e)
                .remove::<MeshMaterial3d<StandardMaterial>>()
                .insert(MeshMaterial3d(material));
            done.push(e);
        }
        if done.is_empty() {
            warn!(
                "FringeShadowMeshes on {character}: no mesh with a StandardMaterial under it has a \
                 name, node name or material name that passes the test; no face receives the \
                 fringe shadow"
            );
        }
        commands
            .entity(character)
            .insert(FringeShadowMeshesApplied(done));
    }
}

#[cfg(test)]
mod tests {
    use bevy::asset::AssetPlugin;
    use bevy::prelude::*;

    use super::*;

    /// A character with a hair mesh, a named face mesh, a mesh with no name of any kind and a
    /// node that is not a mesh; the entities of those three meshes.
    fn character(app: &mut App, fringe: FringeShadowMeshes) -> (Entity, [Entity; 3]) {
        let material = app
            .world_mut()
            .resource_mut::<Assets<StandardMaterial>>()
            .add(StandardMaterial::default());
        let world = app.world_mut();
        let root = world.spawn((Transform::default(), fringe)).id();
        let mut mesh = |name: Option<&str>| {
            let e = world
                .spawn((
                    Mesh3d(Handle::default()),
                    MeshMaterial3d(material.clone()),
                    ChildOf(root),
                ))
                .id();
            if let Some(name) = name {
                world.entity_mut(e).insert(Name::new(name.to_string()));
            }
            e
        };
        let meshes = [mesh(Some("hair")), mesh(Some("face")), mesh(None)];
        world.spawn((Name::new("head"), Transform::default(), ChildOf(root)));
        (root, meshes)
    }

    fn app() -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<StandardMaterial>()
            .init_asset::<FringeShadowMaterial>()
            .add_systems(Update, apply_fringe_shadow);
        app
    }

    fn extended(app: &App, e: Entity) -> bool {
        app.world()
            .get::<MeshMaterial3d<FringeShadowMaterial>>(e)
            .is_some()
    }

    #[test]
    fn all_except_takes_every_other_mesh_once_nameless_ones_too() {
        let mut app = app();
        let (root, [hair, face, nameless]) = character(
            &mut app,
            FringeShadowMeshes::all_except(|n| n == "hair", FringeShadow::cel()),
        );
        app.update();
        let mut applied = app
            .world()
            .get::<FringeShadowMeshesApplied>(root)
            .expect("the character is marked applied")
            .0
            .clone();
        applied.sort();
        let mut want = vec![face, nameless];
        want.sort();
        assert_eq!(applied, want, "each mesh but the hair, once");
        assert!(extended(&app, face) && extended(&app, nameless));
        assert!(!extended(&app, hair), "the hair keeps its material");
        assert!(
            app.world()
                .get::<MeshMaterial3d<StandardMaterial>>(hair)
                .is_some()
        );
        // Meshes sharing a material share one extension.
        assert_eq!(
            app.world().resource::<Assets<FringeShadowMaterial>>().len(),
            1
        );
    }

    /// A character of two meshes under `FringeShadowMeshes` (cel, with or without VRM
    /// shades): a face wearing a skin material of `skin` base colour and carrying `vrm` (what
    /// the VRM handler puts on an MToon mesh), and a coat of another material; after one update,
    /// the fringe shadows the face's and the coat's materials were extended with.
    fn face_and_coat(
        vrm_shades: bool,
        skin: Color,
        vrm: impl Bundle,
    ) -> (FringeShadow, FringeShadow) {
        let mut app = app();
        let world = app.world_mut();
        let mut standard = world.resource_mut::<Assets<StandardMaterial>>();
        let skin = standard.add(StandardMaterial {
            base_color: skin,
            ..default()
        });
        let cloth = standard.add(StandardMaterial::default());
        let mut fringe = FringeShadowMeshes::all_except(|_| false, FringeShadow::cel());
        if !vrm_shades {
            fringe = fringe.without_vrm_shades();
        }
        let root = world.spawn((Transform::default(), fringe)).id();
        let face = world
            .spawn((
                Mesh3d(Handle::default()),
                MeshMaterial3d(skin),
                vrm,
                ChildOf(root),
            ))
            .id();
        let coat = world
            .spawn((
                Mesh3d(Handle::default()),
                MeshMaterial3d(cloth),
                ChildOf(root),
            ))
            .id();
        app.update();
        let extension = |e: Entity| {
            let handle = &app
                .world()
                .get::<MeshMaterial3d<FringeShadowMaterial>>(e)
                .expect("extended")
                .0;
            let materials = app.world().resource::<Assets<FringeShadowMaterial>>();
            materials.get(handle).unwrap().extension.clone()
        };
        (extension(face), extension(coat))
    }

    /// A VRM's MToon mesh takes its shade over its base colour as its cel shade (so its dark
    /// tone draws the MToon shade); a mesh of another material keeps the shadow's; with
    /// `without_vrm_shades` both keep the shadow's.
    #[test]
    fn an_mtoon_mesh_takes_its_own_cel_shade() {
        let rose = FringeShadow::cel().cel_shade.to_linear();
        for vrm_shades in [true, false] {
            let (face, coat) = face_and_coat(
                vrm_shades,
                Color::linear_rgb(1.0, 0.8, 0.7),
                VrmShadeColor(Color::linear_rgb(0.8, 0.5, 0.5)),
            );
            assert_eq!(coat.cel_shade.to_linear(), rose);
            let face = face.cel_shade.to_linear();
            if vrm_shades {
                let want = [0.8, 0.5 / 0.8, 0.5 / 0.7];
                let got = [face.red, face.green, face.blue];
                for (g, w) in got.into_iter().zip(want) {
                    assert!((g - w).abs() < 1e-6, "{got:?}");
                }
            } else {
                assert_eq!(face, rose);
            }
        }
    }

    /// An MToon mesh with a shading band takes its middle and half width as its cel threshold
    /// and softness (shift -0.5, toony 0.9: `N.L` 0.4 to 0.6); one without keeps the shadow's;
    /// with `without_vrm_shades` both keep it. The band's part below 0 is cut off: MToon 1.0's
    /// defaults (-0.1 to 0.1) become 0 to 0.1, a band wholly below 0 is the lowest light.
    #[test]
    fn an_mtoon_mesh_takes_its_own_shading_band() {
        let near =
            |a: (f32, f32), b: (f32, f32)| (a.0 - b.0).abs() < 1e-6 && (a.1 - b.1).abs() < 1e-6;
        let band = |shift, toony| mtoon_cel_band(&VrmShading { shift, toony });
        assert!(near(band(-0.5, 0.9), (0.5, 0.1)), "{:?}", band(-0.5, 0.9));
        assert!(near(band(0.0, 0.9), (0.05, 0.05)));
        assert!(near(band(0.9, 0.5), (0.0, 0.001)));
        assert!(near(band(-0.3, 1.0), (0.3, 0.001)));
        assert!(near(band(-1.0, 0.0), (0.5, 0.5)));
        let plain = FringeShadow::cel();
        let plain = (plain.cel_threshold, plain.cel_softness);
        for vrm_shades in [true, false] {
            let wide = VrmShading {
                shift: -0.5,
                toony: 0.9,
            };
            let (face, coat) = face_and_coat(vrm_shades, Color::WHITE, wide);
            let turn = |s: &FringeShadow| (s.cel_threshold, s.cel_softness);
            assert_eq!(turn(&coat), plain);
            if vrm_shades {
                assert!(near(turn(&face), (0.5, 0.1)), "{:?}", turn(&face));
            } else {
                assert_eq!(turn(&face), plain);
            }
        }
    }

    /// An MToon mesh with a rim light takes it as its cel rim; one without keeps the shadow's
    /// (none); with `without_vrm_shades` both keep it. The uniform carries the rim's colour and
    /// mix, power and lift, clamped to what the shader can draw (a power of 0 becomes 1e-5, a
    /// NaN colour channel none), and is all zero without a rim.
    #[test]
    fn an_mtoon_mesh_takes_its_own_rim_light() {
        let rim = VrmRim {
            color: Color::linear_rgb(0.5, 0.25, 0.0),
            fresnel_power: 3.0,
            lift: 0.1,
            lighting_mix: 0.5,
        };
        for vrm_shades in [true, false] {
            let (face, coat) = face_and_coat(vrm_shades, Color::WHITE, rim);
            assert_eq!(coat.rim, None);
            assert_eq!(face.rim, vrm_shades.then_some(rim));
        }
        assert_eq!(rim_uniform(None), (Vec4::ZERO, Vec4::ZERO));
        assert_eq!(
            rim_uniform(Some(&rim)),
            (
                Vec4::new(0.5, 0.25, 0.0, 0.5),
                Vec4::new(3.0, 0.1, 0.0, 0.0)
            )
        );
        let broken = VrmRim {
            color: Color::linear_rgb(f32::NAN, -1.0, 2.0),
            fresnel_power: 0.0,
            lift: 5.0,
            lighting_mix: f32::INFINITY,
        };
        assert_eq!(
            rim_uniform(Some(&broken)),
            (
                Vec4::new(0.0, 0.0, 2.0, 1.0),
                Vec4::new(1e-5, 1.0, 0.0, 0.0)
            )
        );
    }

    #[test]
    fn matching_takes_only_the_named_meshes() {
        let mut app = app();
        let (root, [hair, face, nameless]) = character(
            &mut app,
            FringeShadowMeshes::matching(|n| n == "face", FringeShadow::default()),
        );
        app.update();
        let applied = &app
            .world()
            .get::<FringeShadowMeshesApplied>(root)
            .unwrap()
            .0;
        assert_eq!(applied, &vec![face]);
        assert!(!extended(&app, hair) && !extended(&app, nameless));
    }

    /// A character whose scene does not load (here a path with no file) never spawns: neither
    /// its `ToonHairMeshes` nor its `FringeShadowMeshes` waits for it forever; each is marked
    /// done with no mesh (and an error in the log names the file).
    #[test]
    fn a_scene_that_does_not_load_ends_the_wait() {
        let mut app = app();
        app.init_asset::<crate::render::ToonHairMaterial>()
            .init_resource::<super::super::gltf_paint::LookCopies>()
            .init_resource::<super::super::gltf_paint::BandRamps>()
            .insert_resource(crate::render::ToonRamps {
                two_tone: Handle::default(),
                three_tone: Handle::default(),
                depth: Handle::default(),
                back_light: Handle::default(),
                specular: Handle::default(),
            })
            .add_systems(
                Update,
                super::super::user_mesh::apply_toon_to_user_meshes.before(apply_fringe_shadow),
            );
        let scene = crate::test_support::missing_scene(&mut app);
        let root = app
            .world_mut()
            .spawn((
                scene,
                crate::render::ToonHairMeshes::matching(|n| n == "hair"),
                FringeShadowMeshes::all_except(|n| n == "hair", FringeShadow::default()),
            ))
            .id();
        crate::test_support::update_until(&mut app, |app| {
            app.world().get::<FringeShadowMeshesApplied>(root).is_some()
        });
        let toon = app
            .world()
            .get::<crate::render::ToonHairMeshesApplied>(root);
        let fringe = app.world().get::<FringeShadowMeshesApplied>(root);
        assert!(
            toon.is_some_and(|t| t.0.is_empty()),
            "toon meshes still waiting"
        );
        assert!(
            fringe.is_some_and(|f| f.0.is_empty()),
            "fringe shadow still waiting"
        );
    }
}
