//! The outline pass of a view: its edge-mask textures, bind groups, and the three fullscreen
//! passes in `Core3d`.

use bevy::core_pipeline::prepass::ViewPrepassTextures;
use bevy::image::ToExtents;
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::{ComponentUniforms, DynamicUniformIndex};
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, DynamicBindGroupEntries, Operations, PipelineCache,
    RenderPassColorAttachment, RenderPassDescriptor, TextureDescriptor, TextureDimension,
    TextureUsages, TextureView, TextureViewId,
};
use bevy::render::renderer::{RenderContext, RenderDevice, ViewQuery};
use bevy::render::texture::{CachedTexture, TextureCache};
use bevy::render::view::ViewTarget;

use super::GpuImageSpaceOutline;
use super::pipeline::{MASK_FORMAT, OutlinePipelineIds, OutlinePipelines};

/// The view's two edge masks: detected, and dilated in x.
#[derive(Component)]
pub struct OutlineTextures {
    pub(super) edges: CachedTexture,
    pub(super) dilated: CachedTexture,
}

pub(super) fn prepare_outline_textures(
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
    pub(super) detect: BindGroup,
    pub(super) dilate: BindGroup,
    pub(super) composite_a: (TextureViewId, BindGroup),
    pub(super) composite_b: (TextureViewId, BindGroup),
}

pub(super) fn prepare_outline_bind_groups(
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
        let depth = prepass.depth_only_view();
        let normal = prepass.normal_view();
        if (ids.key.source.uses_depth() && depth.is_none())
            || (ids.key.source.uses_normals() && normal.is_none())
        {
            continue;
        }
        // The uniform and the prepass textures the source reads.
        let prepass_entries = || {
            let mut entries = DynamicBindGroupEntries::new_with_indices(((0, uniform.clone()),));
            if let Some(depth) = depth.filter(|_| ids.key.source.uses_depth()) {
                entries = entries.extend_with_indices(((1, depth),));
            }
            if let Some(normal) = normal.filter(|_| ids.key.source.uses_normals()) {
                entries = entries.extend_with_indices(((2, normal),));
            }
            entries
        };
        let detect = render_device.create_bind_group(
            "image_space_outline_detect",
            &pipeline_cache.get_bind_group_layout(&ids.key.layout()),
            &prepass_entries(),
        );
        let composite_layout = pipeline_cache.get_bind_group_layout(&ids.key.composite_layout());
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
                    &composite_layout,
                    &prepass_entries()
                        .extend_with_indices(((4, &textures.dilated.default_view), (5, screen))),
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
pub(super) fn image_space_outline(
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
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
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
        let span = diagnostics.pass_span(&mut pass, label);
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &offset);
        pass.draw(0..3, 0..1);
        span.end(&mut pass);
    }
}
