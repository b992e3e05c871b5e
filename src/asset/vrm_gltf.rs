//! VRM characters through Bevy's own glTF loader: a glTF extension handler that reads the
//! spring bones of any glTF or VRM file as it loads, and a loader that opens `*.vrm` files with
//! Bevy's glTF loader (a `.vrm` is a binary glTF).
//!
//! The handler marks each node of a file with spring bones with its glTF index ([`VrmNode`])
//! and puts what the file says ([`VrmSpringBones`]) on the scene's root, so the simulation
//! can find the bones once the scene spawns. A file with broken spring-bone JSON still loads
//! (its meshes and skeleton are fine); [`VrmSpringBones::error`] says what is wrong, and the
//! simulation reports it.
//!
//! The handler also puts each MToon material's shade colour, shading band and rim light on the
//! mesh entities that wear it ([`VrmShadeColor`], [`VrmShading`], [`VrmRim`]); a broken value
//! is a warning naming the file and the JSON path, and that material's meshes get none of that
//! kind.

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, LoadContext};
use bevy::gltf::extensions::{
    ErasedGltfExtensionHandler, GltfExtensionHandler, GltfExtensionHandlers,
};
use bevy::gltf::{Gltf, GltfError, GltfLoader, GltfLoaderSettings, GltfPlugin, gltf};
use bevy::image::CompressedImageFormatSupport;
use bevy::prelude::*;

use super::vrm::{VrmSprings, parse_vrm_springs};
use super::vrm_mtoon::{VrmShadeColor, parse_vrm_shade_colors};
use super::vrm_mtoon_rim::{VrmRim, parse_vrm_rims};
use super::vrm_mtoon_shading::{VrmShading, parse_vrm_shading};

/// On each node entity of a glTF scene whose file has VRM spring bones: the node's glTF index.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub struct VrmNode(pub u32);

/// On the root of a glTF scene whose file has VRM spring bones (`VRMC_springBone` or VRM 0.x
/// `secondaryAnimation`): what it says, or what is wrong with it.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub struct VrmSpringBones {
    /// The file.
    pub file: String,
    /// Its springs and colliders (empty when [`VrmSpringBones::error`] is set).
    pub springs: VrmSprings,
    /// Why the spring bones could not be read, naming the JSON path and what to do.
    pub error: Option<String>,
}

/// Reads spring bones while Bevy loads a glTF file (one clone per load).
#[derive(Clone, Default)]
struct VrmExtensionHandler {
    found: Option<VrmSpringBones>,
    /// Each material's MToon shade colour, by glTF material index.
    shades: Vec<Option<Color>>,
    /// Each material's MToon shading band, by glTF material index.
    bands: Vec<Option<VrmShading>>,
    /// Each material's MToon rim light, by glTF material index.
    rims: Vec<Option<VrmRim>>,
}

impl GltfExtensionHandler for VrmExtensionHandler {
    fn dyn_clone(&self) -> Box<dyn ErasedGltfExtensionHandler> {
        Box::new(self.clone())
    }

    fn on_root(
        &mut self,
        load_context: &mut LoadContext<'_>,
        gltf: &gltf::Gltf,
        _settings: &GltfLoaderSettings,
    ) {
        let file = load_context.path().to_string();
        let (shades, errors) = parse_vrm_shade_colors(&file, &gltf.document);
        for e in &errors {
            warn!("{e}; the meshes with that material take their toon look's shade colour");
        }
        self.shades = shades;
        let (bands, band_errors) = parse_vrm_shading(&file, &gltf.document);
        // Every reader reports a broken `materialProperties` list: said once.
        for e in band_errors.iter().filter(|e| !errors.contains(e)) {
            warn!("{e}; the meshes with that material take their toon look's shade threshold");
        }
        let (rims, rim_errors) = parse_vrm_rims(&file, &gltf.document);
        for e in rim_errors
            .iter()
            .filter(|e| !errors.contains(e) && !band_errors.contains(e))
        {
            warn!("{e}; the meshes with that material are drawn without a rim light");
        }
        self.bands = bands;
        self.rims = rims;
        self.found = match parse_vrm_springs(&file, &gltf.document) {
            Ok(None) => None,
            Ok(Some(springs)) => Some(VrmSpringBones {
                file,
                springs,
                error: None,
            }),
            Err(e) => {
                error!("{e}; the character loads without simulated spring bones");
                Some(VrmSpringBones {
                    file,
                    springs: VrmSprings::default(),
                    error: Some(e.to_string()),
                })
            }
        };
    }

    fn on_gltf_node(
        &mut self,
        _load_context: &mut LoadContext<'_>,
        gltf_node: &gltf::Node,
        entity: &mut EntityWorldMut,
    ) {
        if self.found.is_some()
            && let Ok(index) = u32::try_from(gltf_node.index())
        {
            entity.insert(VrmNode(index));
        }
    }

    fn on_spawn_mesh_and_material(
        &mut self,
        _load_context: &mut LoadContext<'_>,
        _primitive: &gltf::Primitive,
        _mesh: &gltf::Mesh,
        material: &gltf::Material,
        entity: &mut EntityWorldMut,
        _material_label: &str,
    ) {
        let Some(i) = material.index() else {
            return;
        };
        if let Some(shade) = self.shades.get(i).copied().flatten() {
            entity.insert(VrmShadeColor(shade));
        }
        if let Some(band) = self.bands.get(i).copied().flatten() {
            entity.insert(band);
        }
        if let Some(rim) = self.rims.get(i).copied().flatten() {
            entity.insert(rim);
        }
    }

    fn on_scene_completed(
        &mut self,
        _load_context: &mut LoadContext<'_>,
        _scene: &gltf::Scene,
        world_root_id: Entity,
        scene_world: &mut World,
    ) {
        if let Some(found) = &self.found {
            scene_world.entity_mut(world_root_id).insert(found.clone());
        }
    }
}

/// Opens `*.vrm` files with Bevy's glTF loader (same settings and extension handlers).
#[derive(TypePath)]
pub struct VrmLoader(GltfLoader);

impl AssetLoader for VrmLoader {
    type Asset = Gltf;
    type Settings = GltfLoaderSettings;
    type Error = GltfError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        settings: &GltfLoaderSettings,
        load_context: &mut LoadContext<'_>,
    ) -> Result<Gltf, GltfError> {
        self.0.load(reader, settings, load_context).await
    }

    fn extensions(&self) -> &[&str] {
        &["vrm"]
    }
}

/// Registers the handler (in `build`: the glTF loader takes the handler list when it is made).
pub(crate) fn register_handler(app: &mut App) {
    app.register_type::<VrmNode>()
        .register_type::<VrmSpringBones>()
        .register_type::<VrmShadeColor>()
        .register_type::<VrmShading>()
        .register_type::<VrmRim>();
    // Without Bevy's glTF plugin (added before this one) no glTF loads, VRM or not.
    let Some(handlers) = app.world_mut().get_resource_mut::<GltfExtensionHandlers>() else {
        return;
    };
    handlers
        .0
        .write_blocking()
        .push(Box::new(VrmExtensionHandler::default()));
}

/// Registers [`VrmLoader`] for `*.vrm` files. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins).
///
/// A game that loads its avatars with another VRM crate (such as bevy_vrm1, for MToon,
/// expressions and look-at) leaves it out, so that crate's own `.vrm` loader opens the files:
/// `CartoonHairPlugins.build().disable::<VrmLoaderPlugin>()`. The spring bones are read by a glTF
/// extension handler that every glTF loader of the app runs, so the hair still finds them.
#[derive(Default)]
pub struct VrmLoaderPlugin;

impl Plugin for VrmLoaderPlugin {
    fn build(&self, _app: &mut App) {}

    fn finish(&self, app: &mut App) {
        register_vrm_loader(app);
    }
}

/// Registers the `.vrm` loader (in `finish`, after Bevy's glTF loader, whose settings it copies).
fn register_vrm_loader(app: &mut App) {
    let Some(plugin) = app.get_added_plugins::<GltfPlugin>().first().map(|p| {
        (
            p.custom_vertex_attributes.clone(),
            p.convert_coordinates,
            p.skinned_mesh_bounds_policy,
            p.mesh_compression.clone(),
            p.default_sampler.clone(),
        )
    }) else {
        return;
    };
    let (custom_vertex_attributes, convert, bounds, compression, sampler) = plugin;
    let world = app.world();
    let supported_compressed_formats = world
        .get_resource::<CompressedImageFormatSupport>()
        .map_or(bevy::image::CompressedImageFormats::NONE, |s| s.0);
    let default_sampler = world
        .get_resource::<bevy::gltf::DefaultGltfImageSampler>()
        .map_or_else(
            || bevy::gltf::DefaultGltfImageSampler::new(&sampler).get_internal(),
            bevy::gltf::DefaultGltfImageSampler::get_internal,
        );
    let Some(extensions) = world
        .get_resource::<GltfExtensionHandlers>()
        .map(|h| h.0.clone())
    else {
        return;
    };
    app.register_asset_loader(VrmLoader(GltfLoader {
        supported_compressed_formats,
        custom_vertex_attributes,
        default_sampler,
        default_convert_coordinates: convert,
        extensions,
        default_skinned_mesh_bounds_policy: bounds,
        default_mesh_compression: compression,
    }));
}
