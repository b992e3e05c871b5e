//! [`HairStrokeMaterial`]: how object-space silhouette strokes are drawn (`stroke.wesl`).

use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{AsBindGroup, AsBindGroupShaderType, ShaderType};
use bevy::render::texture::GpuImage;
use bevy::shader::ShaderRef;

use crate::math::finite_or;
use crate::silhouette::StrokeScope;

/// The material of silhouette stroke meshes: the stroke texture times the vertex colour (the
/// stroke colour, and the E-curve fade in alpha), unlit, alpha-blended, depth-tested, both
/// sides. With [`StrokeScope::Mass`] a stroke is kept only where it outlines the hair mass: a
/// pixel stays when something other than hair lies within the stroke's own width plus
/// [`HairStrokeMaterial::reach_px`], read from the hair mask the hair's prepass writes into the
/// normal prepass (so the camera needs a `NormalPrepass`; the silhouette plugin adds one to
/// the cameras that draw such strokes).
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug)]
#[uniform(2, HairStrokeUniform)]
#[reflect(Debug)]
pub struct HairStrokeMaterial {
    /// The stroke texture (ink across the strip's `v`, repeating along its `u`).
    #[texture(0)]
    #[sampler(1)]
    pub texture: Handle<Image>,
    /// Which strokes show (see the type's docs).
    pub scope: StrokeScope,
    /// With [`StrokeScope::Mass`]: how far beyond the stroke's own width (pixels) something
    /// other than hair may lie for the stroke to stay. Default: `1.0`.
    pub reach_px: f32,
}

impl HairStrokeMaterial {
    /// A stroke material with `texture` and `scope`.
    pub fn new(texture: Handle<Image>, scope: StrokeScope) -> Self {
        Self {
            texture,
            scope,
            reach_px: 1.0,
        }
    }
}

/// The uniform block of [`HairStrokeMaterial`]: x = 1 for the mass scope, y = the reach.
#[derive(Clone, Default, ShaderType)]
pub struct HairStrokeUniform {
    settings: Vec4,
}

impl AsBindGroupShaderType<HairStrokeUniform> for HairStrokeMaterial {
    fn as_bind_group_shader_type(&self, _images: &RenderAssets<GpuImage>) -> HairStrokeUniform {
        HairStrokeUniform {
            settings: Vec4::new(
                f32::from(u8::from(self.scope == StrokeScope::Mass)),
                finite_or(self.reach_px, 1.0).clamp(0.0, 64.0),
                0.0,
                0.0,
            ),
        }
    }
}

impl Material for HairStrokeMaterial {
    fn fragment_shader() -> ShaderRef {
        ShaderRef::Path(
            bevy::asset::AssetPath::from_path_buf(bevy::asset::embedded_path!("stroke.wesl"))
                .with_source("embedded"),
        )
    }

    fn alpha_mode(&self) -> AlphaMode {
        AlphaMode::Blend
    }

    /// Strokes take no part in the prepass: they must not mark the hair mask they read.
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
        // Strips are seen from either side.
        descriptor.primitive.cull_mode = None;
        Ok(())
    }
}
