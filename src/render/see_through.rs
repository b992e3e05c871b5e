//! Eyes and brows drawn through the fringe, the anime convention: a face part marked with
//! [`ShowThroughHair`] (or found by name under a scene root with [`ShowThroughHairNamed`]) is
//! drawn a second time, over the hair that lies just in front of it, at a chosen opacity.
//!
//! The second drawing is a child mesh with [`SeenThroughHairMaterial`] (`see_through.wesl`),
//! drawn in the transparent pass without a depth test. A pixel of it shows only where the
//! prepasses say hair is the nearest surface (the hair mask the hair's prepass writes in the
//! normal target's alpha) and that hair lies in front of the part by at most
//! [`ShowThroughHair::reach`]: so the eyes show through the fringe, and not through the back of
//! the head seen from behind, the face's own skin, a hand or a hat. The part is drawn unlit in
//! its material's base colour (and texture), which is how the convention draws it; the camera
//! needs a `DepthPrepass` and a `NormalPrepass`, which the hair's cameras have. The outline and
//! strokes still ink the hair's edges across the part, as they do over the face.

use bevy::gltf::GltfMaterialName;
use bevy::light::{NotShadowCaster, NotShadowReceiver};
use bevy::mesh::morph::MeshMorphWeights;
use bevy::mesh::skinning::SkinnedMesh;
use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{AsBindGroup, AsBindGroupShaderType, ShaderType};
use bevy::render::texture::GpuImage;
use bevy::shader::ShaderRef;

use super::FringeShadowMaterial;
use crate::math::finite_or;

/// On a mesh entity (an eye, a brow, lashes): the part shows through hair in front of it. See
/// the module docs. Remove it to stop; changes apply the next frame.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ShowThroughHair {
    /// How much of the part shows through the hair, 0 (none) to 1 (as if the hair were not
    /// there). Default: `0.6`.
    pub opacity: f32,
    /// How far in front of the part, in world units along the view, hair may lie for the part to
    /// show through it. The fringe lies a few centimetres in front of the eyes; the back of the
    /// head is farther. Default: `0.06`.
    pub reach: f32,
    /// The colour it is drawn in; `None` takes its material's base colour and texture (a
    /// `StandardMaterial` or a [`FringeShadowMaterial`]). Default: `None`.
    pub color: Option<Color>,
}

impl Default for ShowThroughHair {
    fn default() -> Self {
        Self {
            opacity: 0.6,
            reach: 0.06,
            color: None,
        }
    }
}

/// On a scene root (a glTF or VRM character): every mesh below it whose entity name, glTF mesh
/// or glTF material name contains one of `names` (ignoring case) gets `settings` as its
/// [`ShowThroughHair`], also when the scene spawns later. For example
/// `ShowThroughHairNamed::new(["eye", "brow", "lash"])`.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct ShowThroughHairNamed {
    /// Parts of names to look for, matched without case.
    pub names: Vec<String>,
    /// What the meshes found get.
    pub settings: ShowThroughHair,
}

impl ShowThroughHairNamed {
    /// The meshes whose names contain any of `names`, with the default settings.
    pub fn new<S: Into<String>>(names: impl IntoIterator<Item = S>) -> Self {
        Self {
            names: names.into_iter().map(Into::into).collect(),
            settings: ShowThroughHair::default(),
        }
    }

    fn matches(&self, name: &str) -> bool {
        let name = name.to_lowercase();
        self.names
            .iter()
            .any(|n| !n.is_empty() && name.contains(&n.to_lowercase()))
    }
}

/// On a part with [`ShowThroughHair`]: the child entity that draws it through the hair.
#[derive(Component, Clone, Copy, Debug)]
pub struct SeenThroughHairOverlay(pub Entity);

/// The material a part is drawn through the hair with (see the module docs): its colour times
/// its texture, unlit, blended at the opacity where hair lies just in front of it.
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug)]
#[uniform(2, SeenThroughHairUniform)]
#[reflect(Debug)]
pub struct SeenThroughHairMaterial {
    /// The part's colour texture, if it has one.
    #[texture(0)]
    #[sampler(1)]
    pub texture: Option<Handle<Image>>,
    /// The part's colour.
    pub color: Color,
    /// See [`ShowThroughHair::opacity`].
    pub opacity: f32,
    /// See [`ShowThroughHair::reach`].
    pub reach: f32,
}

/// The uniform block of [`SeenThroughHairMaterial`]: the linear colour, then opacity and reach.
#[derive(Clone, Default, ShaderType)]
pub struct SeenThroughHairUniform {
    color: Vec4,
    params: Vec4,
}

impl AsBindGroupShaderType<SeenThroughHairUniform> for SeenThroughHairMaterial {
    fn as_bind_group_shader_type(&self, _: &RenderAssets<GpuImage>) -> SeenThroughHairUniform {
        SeenThroughHairUniform {
            color: self.color.to_linear().to_vec4(),
            params: Vec4::new(
                finite_or(self.opacity, 0.0).clamp(0.0, 1.0),
                finite_or(self.reach, 0.0).max(0.0),
                0.0,
                0.0,
            ),
        }
    }
}

impl Material for SeenThroughHairMaterial {
    fn fragment_shader() -> ShaderRef {
        ShaderRef::Path(
            bevy::asset::AssetPath::from_path_buf(bevy::asset::embedded_path!("see_through.wesl"))
                .with_source("embedded"),
        )
    }

    fn alpha_mode(&self) -> AlphaMode {
        AlphaMode::Blend
    }

    /// The overlay reads the prepasses; it must not write them.
    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }

    fn specialize(
        _pipeline: &bevy::pbr::MaterialPipeline,
        descriptor: &mut bevy::render::render_resource::RenderPipelineDescriptor,
        _layout: &bevy::mesh::MeshVertexBufferLayoutRef,
        _key: bevy::pbr::MaterialPipelineKey<Self>,
    ) -> Result<(), bevy::render::render_resource::SpecializedMeshPipelineError> {
        // Drawn over the hair: the shader decides, by the prepass depth, what shows.
        if let Some(depth) = descriptor.depth_stencil.as_mut() {
            depth.depth_compare = Some(bevy::render::render_resource::CompareFunction::Always);
            depth.depth_write_enabled = Some(false);
        }
        Ok(())
    }
}

/// Gives [`ShowThroughHair`] to the meshes under each [`ShowThroughHairNamed`] root whose names
/// match: all of them when the root's setting is new or changed, new meshes otherwise.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn mark_named_parts(
    mut commands: Commands,
    roots: Query<(Entity, Ref<ShowThroughHairNamed>)>,
    meshes: Query<
        (
            Entity,
            Option<&Name>,
            Option<&GltfMaterialName>,
            Option<&ShowThroughHair>,
            Has<SeenThroughOverlayMarker>,
        ),
        With<Mesh3d>,
    >,
    added: Query<Entity, Added<Mesh3d>>,
    parents: Query<&ChildOf>,
    children: Query<&Children>,
) {
    if roots.is_empty() {
        return;
    }
    let mark = |commands: &mut Commands, root: &ShowThroughHairNamed, mesh: Entity| {
        let Ok((entity, name, material, current, overlay)) = meshes.get(mesh) else {
            return;
        };
        if overlay {
            return;
        }
        // A glTF primitive's entity is named after its mesh; its node (the parent) too.
        let parent_name = parents
            .get(entity)
            .ok()
            .and_then(|p| meshes.get(p.parent()).ok())
            .and_then(|m| m.1);
        let found = [
            name.map(Name::as_str),
            material.map(|m| m.0.as_str()),
            parent_name.map(Name::as_str),
        ]
        .into_iter()
        .flatten()
        .any(|n| root.matches(n));
        if found && current != Some(&root.settings) {
            commands.entity(entity).insert(root.settings);
        }
    };
    for (root, named) in &roots {
        if named.is_changed() {
            for mesh in children.iter_descendants(root) {
                mark(&mut commands, &named, mesh);
            }
        }
    }
    for mesh in &added {
        // The nearest root above the new mesh decides.
        let root = parents.iter_ancestors(mesh).find_map(|a| roots.get(a).ok());
        if let Some((_, named)) = root
            && !named.is_changed()
        {
            mark(&mut commands, &named, mesh);
        }
    }
}

/// Marks the overlay's own entity, so it is never taken for a part.
#[derive(Component, Clone, Copy, Debug)]
pub struct SeenThroughOverlayMarker;

/// Spawns, updates and removes the overlays of the parts with [`ShowThroughHair`].
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn sync_overlays(
    mut commands: Commands,
    parts: Query<(
        Entity,
        &ShowThroughHair,
        &Mesh3d,
        Option<&MeshMaterial3d<StandardMaterial>>,
        Option<&MeshMaterial3d<FringeShadowMaterial>>,
        Option<&SkinnedMesh>,
        Option<&MeshMorphWeights>,
        Option<&SeenThroughHairOverlay>,
    )>,
    mut removed: RemovedComponents<ShowThroughHair>,
    linked: Query<&SeenThroughHairOverlay>,
    mut overlays: Query<&mut Mesh3d, (With<SeenThroughOverlayMarker>, Without<ShowThroughHair>)>,
    (standard, fringe): (
        Res<Assets<StandardMaterial>>,
        Res<Assets<FringeShadowMaterial>>,
    ),
    (mut materials, handles): (
        ResMut<Assets<SeenThroughHairMaterial>>,
        Query<&MeshMaterial3d<SeenThroughHairMaterial>>,
    ),
) {
    for part in removed.read() {
        if let Ok(link) = linked.get(part) {
            commands.entity(link.0).despawn();
            commands.entity(part).remove::<SeenThroughHairOverlay>();
        }
    }
    for (part, settings, mesh, std_mat, fringe_mat, skin, morph, overlay) in &parts {
        let base = std_mat
            .and_then(|m| standard.get(&m.0))
            .or_else(|| fringe_mat.and_then(|m| fringe.get(&m.0)).map(|m| &m.base));
        // Wait for the part's material, unless the colour is given.
        let (color, texture) = match (settings.color, base) {
            (Some(c), _) => (c, None),
            (None, Some(b)) => (b.base_color, b.base_color_texture.clone()),
            (None, None) => continue,
        };
        let wanted = SeenThroughHairMaterial {
            texture,
            color,
            opacity: settings.opacity,
            reach: settings.reach,
        };
        match overlay {
            Some(link) => {
                if let Ok(mut m) = overlays.get_mut(link.0)
                    && m.0 != mesh.0
                {
                    m.0 = mesh.0.clone();
                }
                // Follows the setting and the part's material (a colour changed in game).
                if let Ok(handle) = handles.get(link.0)
                    && materials.get(&handle.0).is_some_and(|m| {
                        m.color != wanted.color
                            || m.texture != wanted.texture
                            || m.opacity != wanted.opacity
                            || m.reach != wanted.reach
                    })
                    && let Some(mut m) = materials.get_mut(&handle.0)
                {
                    *m = wanted;
                }
            }
            None => {
                let mut child = commands.spawn((
                    Name::new("seen through hair"),
                    SeenThroughOverlayMarker,
                    Mesh3d(mesh.0.clone()),
                    MeshMaterial3d(materials.add(wanted)),
                    Transform::IDENTITY,
                    NotShadowCaster,
                    NotShadowReceiver,
                    ChildOf(part),
                ));
                if let Some(skin) = skin {
                    child.insert(skin.clone());
                }
                if let Some(morph) = morph {
                    child.insert(morph.clone());
                }
                let child = child.id();
                commands.entity(part).insert(SeenThroughHairOverlay(child));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn app() -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<Image>()
            .init_asset::<StandardMaterial>()
            .init_asset::<FringeShadowMaterial>()
            .init_asset::<SeenThroughHairMaterial>()
            .add_systems(Update, (mark_named_parts, sync_overlays).chain());
        app
    }

    /// A character root named for its eyes; its meshes spawn a frame later (as a scene's do):
    /// the eye primitive, found by its glTF material name, gets the setting and an overlay in
    /// its colour; the skin does not; removing the setting removes the overlay.
    #[test]
    fn named_parts_get_an_overlay_that_follows_the_setting() {
        let mut app = app();
        let root = app
            .world_mut()
            .spawn(ShowThroughHairNamed::new(["EYE"]))
            .id();
        app.update();
        let world = app.world_mut();
        let mesh = world.resource_mut::<Assets<Mesh>>().add(Cuboid::default());
        let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
        let dark = materials.add(Color::srgb(0.1, 0.0, 0.2));
        let skin = materials.add(Color::WHITE);
        let node = world.spawn((Name::new("face"), ChildOf(root))).id();
        let eye = world
            .spawn((
                Mesh3d(mesh.clone()),
                MeshMaterial3d(dark),
                GltfMaterialName("Eyes".into()),
                ChildOf(node),
            ))
            .id();
        let face = world
            .spawn((
                Mesh3d(mesh),
                MeshMaterial3d(skin),
                GltfMaterialName("skin".into()),
                ChildOf(node),
            ))
            .id();
        app.update();
        app.update();
        let world = app.world();
        assert_eq!(
            world.get::<ShowThroughHair>(eye),
            Some(&ShowThroughHair::default())
        );
        assert!(world.get::<ShowThroughHair>(face).is_none());
        let overlay = world
            .get::<SeenThroughHairOverlay>(eye)
            .expect("an overlay")
            .0;
        assert_eq!(
            world.get::<ChildOf>(overlay).map(ChildOf::parent),
            Some(eye)
        );
        let handle = &world
            .get::<MeshMaterial3d<SeenThroughHairMaterial>>(overlay)
            .unwrap()
            .0;
        let material = world
            .resource::<Assets<SeenThroughHairMaterial>>()
            .get(handle)
            .unwrap();
        assert_eq!(material.color, Color::srgb(0.1, 0.0, 0.2));
        assert_eq!(material.opacity, 0.6);
        // A new opacity reaches the overlay's material.
        app.world_mut().entity_mut(eye).insert(ShowThroughHair {
            opacity: 0.3,
            ..default()
        });
        app.update();
        let world = app.world();
        let handle = &world
            .get::<MeshMaterial3d<SeenThroughHairMaterial>>(overlay)
            .unwrap()
            .0;
        let opacity = world
            .resource::<Assets<SeenThroughHairMaterial>>()
            .get(handle)
            .unwrap()
            .opacity;
        assert_eq!(opacity, 0.3);
        app.world_mut().entity_mut(eye).remove::<ShowThroughHair>();
        app.update();
        app.update();
        assert!(
            app.world().get_entity(overlay).is_err(),
            "the overlay is left"
        );
        assert!(app.world().get::<SeenThroughHairOverlay>(eye).is_none());
    }
}
