//! The outline's pipelines: detection variants per source and sample count, dilation, and
//! composite variants per target format, specialised per view.

use bevy::asset::load_embedded_asset;
use bevy::core_pipeline::FullscreenShader;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    texture_2d, texture_2d_multisampled, texture_depth_2d, texture_depth_2d_multisampled,
    uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, CachedRenderPipelineId, Canonical,
    ColorTargetState, ColorWrites, DynamicBindGroupLayoutEntries, FragmentState, PipelineCache,
    RenderPipeline, RenderPipelineDescriptor, ShaderStages, Specializer, SpecializerKey,
    TextureFormat, TextureSampleType, Variants,
};
use bevy::render::view::ExtractedView;

use super::{GpuImageSpaceOutline, OutlineSource, OutlineSourceKey};

/// Pipeline variant of the detection pass: which buffers it reads and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, SpecializerKey)]
pub(crate) struct OutlinePipelineKey {
    pub(crate) source: OutlineSource,
    /// The prepass textures are multisampled (the camera has MSAA on).
    pub(crate) multisampled: bool,
}

impl OutlinePipelineKey {
    /// The shader defs of this variant.
    pub(crate) fn shader_defs(&self) -> Vec<&'static str> {
        let mut defs = Vec::new();
        if self.source.uses_depth() {
            defs.push("EDGE_DEPTH");
        }
        if self.source.uses_normals() {
            defs.push("EDGE_NORMALS");
        }
        if self.source == OutlineSource::Mass {
            defs.push("EDGE_MASS");
        }
        if self.multisampled {
            defs.push("MULTISAMPLED");
        }
        defs
    }

    /// Every variant, for validation.
    #[cfg(test)]
    pub(crate) fn all() -> Vec<Self> {
        let mut keys = Vec::new();
        for source in [
            OutlineSource::Mass,
            OutlineSource::DepthAndNormals,
            OutlineSource::Depth,
            OutlineSource::Normals,
        ] {
            for multisampled in [false, true] {
                keys.push(Self {
                    source,
                    multisampled,
                });
            }
        }
        keys
    }

    /// The detection pass's bind group layout: the uniform, then the prepass textures it reads.
    pub(super) fn layout(&self) -> BindGroupLayoutDescriptor {
        BindGroupLayoutDescriptor::new("image_space_outline_detect_layout", &self.entries())
    }

    /// The composite pass's layout: the detection's (the mass's hair mask, for the outline in
    /// the hair's colour) and the dilated mask and the frame.
    pub(super) fn composite_layout(&self) -> BindGroupLayoutDescriptor {
        let float = TextureSampleType::Float { filterable: false };
        let entries = self
            .entries()
            .extend_with_indices(((4, texture_2d(float)), (5, texture_2d(float))));
        BindGroupLayoutDescriptor::new("image_space_outline_composite_layout", &entries)
    }

    /// The uniform and the prepass textures the source reads.
    fn entries(&self) -> DynamicBindGroupLayoutEntries {
        let float = TextureSampleType::Float { filterable: false };
        let mut entries = DynamicBindGroupLayoutEntries::new_with_indices(
            ShaderStages::FRAGMENT,
            ((0, uniform_buffer::<GpuImageSpaceOutline>(true)),),
        );
        if self.source.uses_depth() {
            let depth = match self.multisampled {
                true => texture_depth_2d_multisampled(),
                false => texture_depth_2d(),
            };
            entries = entries.extend_with_indices(((1, depth),));
        }
        if self.source.uses_normals() {
            let normal = match self.multisampled {
                true => texture_2d_multisampled(float),
                false => texture_2d(float),
            };
            entries = entries.extend_with_indices(((2, normal),));
        }
        entries
    }
}

pub(super) struct DetectSpecializer;

impl Specializer<RenderPipeline> for DetectSpecializer {
    type Key = OutlinePipelineKey;

    fn specialize(
        &self,
        key: Self::Key,
        descriptor: &mut RenderPipelineDescriptor,
    ) -> Result<Canonical<Self::Key>, BevyError> {
        descriptor.set_layout(0, key.layout());
        let fragment = descriptor.fragment_mut()?;
        for def in key.shader_defs() {
            fragment.shader_defs.push(def.into());
        }
        Ok(key)
    }
}

/// The composite pass writes the view's main texture, whatever its format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, SpecializerKey)]
pub(super) struct CompositeKey {
    target_format: TextureFormat,
    outline: OutlinePipelineKey,
}

pub(super) struct CompositeSpecializer;

impl Specializer<RenderPipeline> for CompositeSpecializer {
    type Key = CompositeKey;

    fn specialize(
        &self,
        key: Self::Key,
        descriptor: &mut RenderPipelineDescriptor,
    ) -> Result<Canonical<Self::Key>, BevyError> {
        descriptor.set_layout(0, key.outline.composite_layout());
        let fragment = descriptor.fragment_mut()?;
        for def in key.outline.shader_defs() {
            fragment.shader_defs.push(def.into());
        }
        fragment.set_target(
            0,
            ColorTargetState {
                format: key.target_format,
                blend: None,
                write_mask: ColorWrites::ALL,
            },
        );
        Ok(key)
    }
}

/// Format of the edge masks between the passes.
pub(super) const MASK_FORMAT: TextureFormat = TextureFormat::Rgba8Unorm;

/// The outline's pipelines, made in `RenderStartup`: the dilation pass outright, the detection
/// and composite passes as variants specialised per view key.
#[derive(Resource)]
pub(super) struct OutlinePipelines {
    pub(super) dilate_layout: BindGroupLayoutDescriptor,
    pub(super) dilate: CachedRenderPipelineId,
    pub(super) detect: Variants<RenderPipeline, DetectSpecializer>,
    pub(super) composite: Variants<RenderPipeline, CompositeSpecializer>,
}

pub(super) fn init_outline_pipelines(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen_shader: Res<FullscreenShader>,
    pipeline_cache: Res<PipelineCache>,
) {
    let shader = load_embedded_asset!(asset_server.as_ref(), "outline.wesl");
    let float = TextureSampleType::Float { filterable: false };
    let dilate_layout = BindGroupLayoutDescriptor::new(
        "image_space_outline_dilate_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::FRAGMENT,
            (
                (0, uniform_buffer::<GpuImageSpaceOutline>(true)),
                (3, texture_2d(float)),
            ),
        ),
    );
    let pass =
        |label: &'static str, entry: &'static str, layout: Vec<_>| RenderPipelineDescriptor {
            label: Some(label.into()),
            layout,
            vertex: fullscreen_shader.to_vertex_state(),
            fragment: Some(FragmentState {
                shader: shader.clone(),
                entry_point: Some(entry.into()),
                targets: vec![Some(ColorTargetState {
                    format: MASK_FORMAT,
                    blend: None,
                    write_mask: ColorWrites::ALL,
                })],
                ..default()
            }),
            ..default()
        };
    let dilate = pipeline_cache.queue_render_pipeline(pass(
        "image_space_outline_dilate_x",
        "dilate_x",
        vec![dilate_layout.clone()],
    ));
    commands.insert_resource(OutlinePipelines {
        dilate,
        detect: Variants::new(
            DetectSpecializer,
            pass("image_space_outline_detect", "detect", Vec::new()),
        ),
        composite: Variants::new(
            CompositeSpecializer,
            pass("image_space_outline_composite", "composite", Vec::new()),
        ),
        dilate_layout,
    });
}

/// The three pipelines of a view's outline, and the detection key its bind group follows.
#[derive(Component)]
pub struct OutlinePipelineIds {
    pub(super) key: OutlinePipelineKey,
    pub(super) detect: CachedRenderPipelineId,
    pub(super) dilate: CachedRenderPipelineId,
    pub(super) composite: CachedRenderPipelineId,
}

pub(super) fn prepare_outline_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    mut pipelines: ResMut<OutlinePipelines>,
    views: Query<(Entity, &ExtractedView, &Msaa, &OutlineSourceKey)>,
) -> Result<(), BevyError> {
    for (entity, view, msaa, source) in &views {
        let key = OutlinePipelineKey {
            source: source.0,
            multisampled: msaa.samples() > 1,
        };
        let detect = pipelines.detect.specialize(&pipeline_cache, key)?;
        let composite = pipelines.composite.specialize(
            &pipeline_cache,
            CompositeKey {
                target_format: view.target_format,
                outline: key,
            },
        )?;
        commands.entity(entity).insert(OutlinePipelineIds {
            key,
            detect,
            dilate: pipelines.dilate,
            composite,
        });
    }
    Ok(())
}
