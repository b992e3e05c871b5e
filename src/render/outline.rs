//! [`ImageSpaceOutline`]: image-space silhouette edges (thesis 4.3.7; Redmond et al., Shin et
//! al.), a post-process pass that inks the outline of the hair and the character.
//!
//! Edges come from a buffer in which objects are flat, Bevy's depth and normal prepass, never
//! from the lit colour: the toon ramp's bands inside the hair are not edges. Per frame, on each
//! camera with an enabled [`ImageSpaceOutline`], three fullscreen passes in the `Core3d` schedule
//! (`outline.wgsl`):
//!
//! 1. `detect`: Sobel (both kernels, magnitude `sqrt(gx^2 + gy^2)`) on the prepass depth and/or
//!    normals, thresholded with [`ImageSpaceOutline::threshold`] into an edge mask;
//! 2. `dilate_x`: a pixel becomes edge if an edge lies within
//!    [`ImageSpaceOutline::dilation_x`] pixels horizontally;
//! 3. `composite`: the same vertically with [`ImageSpaceOutline::dilation_y`], then the
//!    [`ImageSpaceOutline::color`] is mixed over the frame.
//!
//! The pass runs after tone mapping, so the ink is exactly the colour asked for.
//!
//! The thesis could not switch its outline back on once off. Here
//! [`ImageSpaceOutline::enabled`] may change any number of times: while off the component is not
//! extracted, so the pass is skipped, and the prepasses the plugin added for it are removed.

use bevy::asset::load_embedded_asset;
use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass, ViewPrepassTextures};
use bevy::core_pipeline::tonemapping::tonemapping;
use bevy::core_pipeline::{Core3d, Core3dSystems, FullscreenShader};
use bevy::ecs::query::QueryItem;
use bevy::ecs::system::lifetimeless::Read;
use bevy::image::ToExtents;
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::extract_component::{
    ComponentUniforms, DynamicUniformIndex, ExtractComponent, ExtractComponentPlugin,
    UniformComponentPlugin,
};
use bevy::render::render_resource::binding_types::{
    texture_2d, texture_2d_multisampled, texture_depth_2d, texture_depth_2d_multisampled,
    uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries,
    CachedRenderPipelineId, Canonical, ColorTargetState, ColorWrites, DynamicBindGroupEntries,
    DynamicBindGroupLayoutEntries, FragmentState, Operations, PipelineCache,
    RenderPassColorAttachment, RenderPassDescriptor, RenderPipeline, RenderPipelineDescriptor,
    ShaderStages, ShaderType, Specializer, SpecializerKey, TextureDescriptor, TextureDimension,
    TextureFormat, TextureSampleType, TextureUsages, TextureView, TextureViewId, Variants,
};
use bevy::render::renderer::{RenderContext, RenderDevice, ViewQuery};
use bevy::render::sync_component::SyncComponent;
use bevy::render::texture::{CachedTexture, TextureCache};
use bevy::render::view::{ExtractedView, ViewTarget};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

/// The most pixels [`ImageSpaceOutline::dilation_x`] and [`ImageSpaceOutline::dilation_y`] reach;
/// larger values are clamped to it (the shader's loops are bounded).
pub const MAX_OUTLINE_DILATION: u32 = 32;

/// Which flat buffer the edges are detected in. Each choice is its own pipeline (shader defs
/// `EDGE_DEPTH`, `EDGE_NORMALS`), and adds only the prepasses it reads.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum OutlineSource {
    /// Depth and normals: silhouettes against the background and against objects behind
    /// (depth), and creases where a strand crosses another at the same depth (normals).
    #[default]
    DepthAndNormals,
    /// Depth only (`DepthPrepass`): silhouettes, no creases; the cheapest.
    Depth,
    /// Normals only (`NormalPrepass`): creases and silhouettes, but strands parallel to each
    /// other at different depths merge.
    Normals,
}

impl OutlineSource {
    /// Reads the depth prepass.
    pub fn uses_depth(self) -> bool {
        matches!(self, Self::DepthAndNormals | Self::Depth)
    }

    /// Reads the normal prepass.
    pub fn uses_normals(self) -> bool {
        matches!(self, Self::DepthAndNormals | Self::Normals)
    }
}

/// Image-space outline on a camera (`Camera3d`): an ink line wherever the depth or normals jump.
///
/// Add it to the camera; the [`ImageSpaceOutlinePlugin`] adds the `DepthPrepass` and
/// `NormalPrepass` it needs while enabled (and removes them again when disabled, unless they
/// were there before). Every field can change every frame.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq, Clone)]
pub struct ImageSpaceOutline {
    /// Draw the outline. Switch it off and on as often as you like; while off the pass costs one
    /// check per frame and the prepasses added for it are removed. Default: `true`.
    pub enabled: bool,
    /// Edge Threshold: the Sobel magnitude above which a pixel is an edge. A jump from an object
    /// to the background measures about 1; lower values also ink creases and strands close in
    /// front of others, higher values only the outer silhouette. Default: `0.3`.
    pub threshold: f32,
    /// X Dilation: a pixel becomes edge if an edge lies within this many pixels horizontally.
    /// Wider lines cost a longer loop; clamped to [`MAX_OUTLINE_DILATION`]. Default: `1`.
    pub dilation_x: u32,
    /// Y Dilation: a pixel becomes edge if an edge lies within this many pixels vertically.
    /// Clamped to [`MAX_OUTLINE_DILATION`]. Default: `1`.
    pub dilation_y: u32,
    /// Ink colour; its alpha is the ink's opacity over the frame. Default: black.
    pub color: Color,
    /// The flat buffer edges are found in. Default: [`OutlineSource::DepthAndNormals`].
    pub source: OutlineSource,
}

impl Default for ImageSpaceOutline {
    fn default() -> Self {
        Self {
            enabled: true,
            threshold: 0.3,
            dilation_x: 1,
            dilation_y: 1,
            color: Color::BLACK,
            source: OutlineSource::DepthAndNormals,
        }
    }
}

/// The uniform block of an enabled [`ImageSpaceOutline`] (`outline.wgsl`), on the render world's
/// view entity.
#[derive(Component, Clone, Copy, Debug, Default, ShaderType)]
pub struct GpuImageSpaceOutline {
    /// Linear RGBA ink.
    pub color: Vec4,
    /// Sobel magnitude threshold.
    pub threshold: f32,
    /// Horizontal dilation in pixels, clamped.
    pub dilation_x: u32,
    /// Vertical dilation in pixels, clamped.
    pub dilation_y: u32,
}

/// Which detection pipeline a view needs: its [`OutlineSource`], on the render world's view
/// entity.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct OutlineSourceKey(pub OutlineSource);

impl SyncComponent for ImageSpaceOutline {
    // Everything the pass keeps on a view goes when the outline is disabled or removed.
    type Target = (
        GpuImageSpaceOutline,
        OutlineSourceKey,
        DynamicUniformIndex<GpuImageSpaceOutline>,
        OutlinePipelineIds,
        OutlineTextures,
        OutlineBindGroups,
    );
}

impl ExtractComponent for ImageSpaceOutline {
    type QueryData = Read<ImageSpaceOutline>;
    type QueryFilter = With<Camera3d>;
    type Out = (GpuImageSpaceOutline, OutlineSourceKey);

    fn extract_component(outline: QueryItem<'_, '_, Self::QueryData>) -> Option<Self::Out> {
        // Disabled: not extracted, so the render world has nothing to run the pass on.
        if !outline.enabled {
            return None;
        }
        let threshold = if outline.threshold.is_finite() {
            outline.threshold.max(0.0)
        } else {
            ImageSpaceOutline::default().threshold
        };
        Some((
            GpuImageSpaceOutline {
                color: outline.color.to_linear().to_vec4(),
                threshold,
                dilation_x: outline.dilation_x.min(MAX_OUTLINE_DILATION),
                dilation_y: outline.dilation_y.min(MAX_OUTLINE_DILATION),
            },
            OutlineSourceKey(outline.source),
        ))
    }
}

/// Draws [`ImageSpaceOutline`]s. Part of [`CartoonHairPlugins`](crate::CartoonHairPlugins)
/// (feature `render`).
#[derive(Default)]
pub struct ImageSpaceOutlinePlugin;

impl Plugin for ImageSpaceOutlinePlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "outline.wgsl");
        app.register_type::<ImageSpaceOutline>()
            .add_plugins((
                ExtractComponentPlugin::<ImageSpaceOutline>::default(),
                UniformComponentPlugin::<GpuImageSpaceOutline>::default(),
            ))
            // Extraction reads the prepass components after the main schedule, so anywhere in
            // PostUpdate is in time for this frame.
            .add_systems(PostUpdate, sync_outline_prepasses);

        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .add_systems(RenderStartup, init_outline_pipelines)
            .add_systems(
                Render,
                (
                    prepare_outline_pipelines.in_set(RenderSystems::Prepare),
                    prepare_outline_textures.in_set(RenderSystems::PrepareResources),
                    prepare_outline_bind_groups.in_set(RenderSystems::PrepareBindGroups),
                ),
            )
            .add_systems(
                Core3d,
                image_space_outline
                    .in_set(Core3dSystems::PostProcess)
                    // Ink after tone mapping keeps its exact colour.
                    .after(tonemapping),
            );
    }
}

/// The prepasses [`sync_outline_prepasses`] added to a camera (and so may remove).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
struct OutlinePrepasses {
    depth: bool,
    normal: bool,
}

/// Keeps the prepasses an outline reads on its camera while it is enabled, and removes those it
/// added when it is disabled or removed. Prepasses the user added stay.
#[allow(clippy::type_complexity)]
fn sync_outline_prepasses(
    mut commands: Commands,
    cameras: Query<(
        Entity,
        Option<&ImageSpaceOutline>,
        Has<DepthPrepass>,
        Has<NormalPrepass>,
        Option<&OutlinePrepasses>,
    )>,
) {
    for (camera, outline, has_depth, has_normal, added) in &cameras {
        if outline.is_none() && added.is_none() {
            continue;
        }
        let enabled = outline.filter(|o| o.enabled);
        let want_depth = enabled.is_some_and(|o| o.source.uses_depth());
        let want_normal = enabled.is_some_and(|o| o.source.uses_normals());
        let before = added.copied().unwrap_or_default();
        let mut now = before;
        let mut entity = commands.entity(camera);
        if want_depth && !has_depth {
            entity.insert(DepthPrepass);
            now.depth = true;
        } else if !want_depth && before.depth {
            entity.remove::<DepthPrepass>();
            now.depth = false;
        }
        if want_normal && !has_normal {
            entity.insert(NormalPrepass);
            now.normal = true;
        } else if !want_normal && before.normal {
            entity.remove::<NormalPrepass>();
            now.normal = false;
        }
        if outline.is_none() {
            entity.remove::<OutlinePrepasses>();
        } else if added != Some(&now) {
            entity.insert(now);
        }
    }
}

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
    fn layout(&self) -> BindGroupLayoutDescriptor {
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
        BindGroupLayoutDescriptor::new("image_space_outline_detect_layout", &entries)
    }
}

struct DetectSpecializer;

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
struct CompositeKey {
    target_format: TextureFormat,
}

struct CompositeSpecializer;

impl Specializer<RenderPipeline> for CompositeSpecializer {
    type Key = CompositeKey;

    fn specialize(
        &self,
        key: Self::Key,
        descriptor: &mut RenderPipelineDescriptor,
    ) -> Result<Canonical<Self::Key>, BevyError> {
        descriptor.fragment_mut()?.set_target(
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
const MASK_FORMAT: TextureFormat = TextureFormat::R8Unorm;

/// The outline's pipelines, made in `RenderStartup`: the dilation pass outright, the detection
/// and composite passes as variants specialised per view key.
#[derive(Resource)]
pub struct OutlinePipelines {
    dilate_layout: BindGroupLayoutDescriptor,
    composite_layout: BindGroupLayoutDescriptor,
    dilate: CachedRenderPipelineId,
    detect: Variants<RenderPipeline, DetectSpecializer>,
    composite: Variants<RenderPipeline, CompositeSpecializer>,
}

fn init_outline_pipelines(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen_shader: Res<FullscreenShader>,
    pipeline_cache: Res<PipelineCache>,
) {
    let shader = load_embedded_asset!(asset_server.as_ref(), "outline.wgsl");
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
    let composite_layout = BindGroupLayoutDescriptor::new(
        "image_space_outline_composite_layout",
        &BindGroupLayoutEntries::with_indices(
            ShaderStages::FRAGMENT,
            (
                (0, uniform_buffer::<GpuImageSpaceOutline>(true)),
                (4, texture_2d(float)),
                (5, texture_2d(float)),
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
            pass(
                "image_space_outline_composite",
                "composite",
                vec![composite_layout.clone()],
            ),
        ),
        dilate_layout,
        composite_layout,
    });
}

/// The three pipelines of a view's outline, and the detection key its bind group follows.
#[derive(Component)]
pub struct OutlinePipelineIds {
    key: OutlinePipelineKey,
    detect: CachedRenderPipelineId,
    dilate: CachedRenderPipelineId,
    composite: CachedRenderPipelineId,
}

fn prepare_outline_pipelines(
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

/// The view's two edge masks: detected, and dilated in x.
#[derive(Component)]
pub struct OutlineTextures {
    edges: CachedTexture,
    dilated: CachedTexture,
}

fn prepare_outline_textures(
    mut commands: Commands,
    mut texture_cache: ResMut<TextureCache>,
    render_device: Res<RenderDevice>,
    views: Query<(Entity, &ExtractedCamera), With<GpuImageSpaceOutline>>,
) {
    for (entity, camera) in &views {
        let Some(size) = camera.physical_target_size else {
            continue;
        };
        let mut mask = |label: &'static str| {
            texture_cache.get(
                &render_device,
                TextureDescriptor {
                    label: Some(label),
                    size: size.to_extents(),
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: TextureDimension::D2,
                    format: MASK_FORMAT,
                    usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
            )
        };
        let edges = mask("image_space_outline_edges");
        let dilated = mask("image_space_outline_dilated");
        commands
            .entity(entity)
            .insert(OutlineTextures { edges, dilated });
    }
}

/// A view's bind groups; the composite one exists for both main textures, since which is the
/// source is only known when the pass runs.
#[derive(Component)]
pub struct OutlineBindGroups {
    detect: BindGroup,
    dilate: BindGroup,
    composite_a: (TextureViewId, BindGroup),
    composite_b: (TextureViewId, BindGroup),
}

fn prepare_outline_bind_groups(
    mut commands: Commands,
    views: Query<(
        Entity,
        &ViewTarget,
        &ViewPrepassTextures,
        &OutlineTextures,
        &OutlinePipelineIds,
    )>,
    pipelines: Res<OutlinePipelines>,
    pipeline_cache: Res<PipelineCache>,
    uniforms: Res<ComponentUniforms<GpuImageSpaceOutline>>,
    render_device: Res<RenderDevice>,
) {
    let Some(uniform) = uniforms.uniforms().binding() else {
        return;
    };
    for (entity, target, prepass, textures, ids) in &views {
        let mut entries = DynamicBindGroupEntries::new_with_indices(((0, uniform.clone()),));
        if ids.key.source.uses_depth() {
            let Some(depth) = prepass.depth_view() else {
                continue;
            };
            entries = entries.extend_with_indices(((1, depth),));
        }
        if ids.key.source.uses_normals() {
            let Some(normal) = prepass.normal_view() else {
                continue;
            };
            entries = entries.extend_with_indices(((2, normal),));
        }
        let detect = render_device.create_bind_group(
            "image_space_outline_detect",
            &pipeline_cache.get_bind_group_layout(&ids.key.layout()),
            &entries,
        );
        let dilate = render_device.create_bind_group(
            "image_space_outline_dilate",
            &pipeline_cache.get_bind_group_layout(&pipelines.dilate_layout),
            &BindGroupEntries::with_indices((
                (0, uniform.clone()),
                (3, &textures.edges.default_view),
            )),
        );
        let composite = |screen: &TextureView| {
            (
                screen.id(),
                render_device.create_bind_group(
                    "image_space_outline_composite",
                    &pipeline_cache.get_bind_group_layout(&pipelines.composite_layout),
                    &BindGroupEntries::with_indices((
                        (0, uniform.clone()),
                        (4, &textures.dilated.default_view),
                        (5, screen),
                    )),
                ),
            )
        };
        commands.entity(entity).insert(OutlineBindGroups {
            detect,
            dilate,
            composite_a: composite(target.main_texture_view()),
            composite_b: composite(target.main_texture_other_view()),
        });
    }
}

/// The outline pass of one view (a system in `Core3d`): detect, dilate in x, dilate in y and
/// composite. Views without an enabled outline do not match the query, so it is skipped.
fn image_space_outline(
    view: ViewQuery<(
        &ViewTarget,
        &OutlinePipelineIds,
        &OutlineBindGroups,
        &OutlineTextures,
        &DynamicUniformIndex<GpuImageSpaceOutline>,
    )>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, ids, bind_groups, textures, uniform_index) = view.into_inner();
    // Until all three have compiled, leave the frame as it is (post_process_write would flip
    // the main texture and lose it).
    let (Some(detect), Some(dilate), Some(composite)) = (
        pipeline_cache.get_render_pipeline(ids.detect),
        pipeline_cache.get_render_pipeline(ids.dilate),
        pipeline_cache.get_render_pipeline(ids.composite),
    ) else {
        return;
    };
    let offset = [uniform_index.index()];
    let post_process = target.post_process_write();
    let (_, composite_group) = if bind_groups.composite_a.0 == post_process.source.id() {
        &bind_groups.composite_a
    } else {
        &bind_groups.composite_b
    };
    let edges = &textures.edges.default_view;
    let dilated = &textures.dilated.default_view;
    for (label, pipeline, bind_group, destination) in [
        ("outline_detect", detect, &bind_groups.detect, edges),
        ("outline_dilate_x", dilate, &bind_groups.dilate, dilated),
        (
            "outline_composite",
            composite,
            composite_group,
            post_process.destination,
        ),
    ] {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some(label),
                color_attachments: &[Some(RenderPassColorAttachment {
                    view: destination,
                    depth_slice: None,
                    resolve_target: None,
                    ops: Operations::default(),
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &offset);
        pass.draw(0..3, 0..1);
    }
}
