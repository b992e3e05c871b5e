//! Strand tubes, silhouette strokes, specular quads and shadow ribbons built on the GPU.
//!
//! Each frame the main world gathers the particles of every GPU-built hair in view
//! ([`gather`]); the render world batches the hairs whose meshes share a vertex slab (the mesh
//! allocator keeps meshes of one layout together) and runs five compute passes, each one
//! dispatch a batch, however many hairs it holds:
//! - the tube pass ([`tubes`], `tubes.wesl`) sweeps every strand's tube straight into its hair
//!   mesh's vertex buffer and leaves each ring's frame in a buffer;
//! - the stroke pass ([`strokes`], `strokes.wesl`) finds each strand's contours for each camera
//!   from those frames and writes the stroke strips into the cameras' stroke meshes;
//! - the highlight pass ([`highlights`], `highlights.wesl`) writes the specular quads;
//! - both also write the triangles of the quads that draw something at the front of their
//!   meshes' indices and count them, and the main pass draws only those ([`quad_draw`]);
//! - the shadow pass ([`shadows`], `shadows.wesl`) writes the ribbons the hair casts its
//!   shadow with ([`crate::mesh::shadow`]);
//! - the draw-order pass ([`order`], `order.wesl`) rewrites each hair mesh's index buffer so
//!   that its strands are drawn nearest the camera first (the main world sorts them), which
//!   spares the prepass shading the hair behind.
//!
//! The hair mesh stays an ordinary Bevy `Mesh` with its UVs and indices, so the main pass, the
//! prepasses, the shadow passes, the image-space outline and the fringe shadow draw it as
//! before; only its positions, normals and tangents come from the compute pass, and the order
//! of its strands' index blocks from the draw-order pass. Its vertex data
//! is uploaded once, when the mesh is created; each frame the GPU gets the particles (16 bytes
//! each), one 48-byte record per strand and one record per hair and job. The mesh allocator's
//! vertex and index slabs are made usable as storage buffers (`MeshAllocatorSettings::extra_buffer_usages`)
//! so that the passes can write them, as Bevy's `compute_mesh` example does.
//!
//! A hair is built on the GPU when [`HairMeshBuilder::Gpu`] is chosen (the default) and the
//! render device can ([`HairGpuMeshSupport`]); [`HairMeshBuilder::Cpu`] builds every hair, and
//! its strokes, on the CPU: the reference. [`status`] keeps a hair visible and moving when the
//! GPU cannot build it.

use bevy::core_pipeline::core_3d::Transparent3d;
use bevy::core_pipeline::schedule::camera_driver;
use bevy::prelude::*;
use bevy::render::batching::NoAutomaticBatching;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::erased_render_asset::prepare_erased_assets;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::extract_resource::ExtractResourcePlugin;
use bevy::render::mesh::RenderMesh;
use bevy::render::mesh::allocator::{MeshAllocator, MeshAllocatorSettings};
use bevy::render::render_asset::ExtractedAssets;
use bevy::render::render_phase::AddRenderCommand;
use bevy::render::render_resource::{Buffer, BufferUsages, ComputePassDescriptor, PipelineCache};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderQueue};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

use crate::render::{HairHighlightMaterial, HairStrokeMaterial};
use crate::schedule::HairSystems;

mod gather;
mod highlights;
mod order;
mod quad_draw;
mod shadows;
mod status;
mod strokes;
mod toolbox;
mod tubes;

#[cfg(test)]
mod layout_tests;

#[doc(hidden)]
pub use gather::encode_gpu_inputs;
use gather::{GpuTubeInput, gather_gpu_tube_inputs};
use highlights::{
    GpuHighlightPipeline, HighlightBatch, highlight_vertices, init_gpu_highlight_pipeline,
    prepare_highlight_batch,
};
use order::{GpuOrderPipeline, OrderBatch, OrderHairInput, init_gpu_order_pipeline};
pub use quad_draw::HairCompactQuads;
use quad_draw::{
    DrawQuads, GpuQuadDraws, QuadGroup, QuadIndices, group_quads, prepare_view_quad_draws,
    use_quad_draw_function,
};
use shadows::{GpuShadowPipeline, ShadowBatch, init_gpu_shadow_pipeline, shadow_vertices};
use status::{GpuPassIds, choose_mesh_builder, report_pass_state};
pub use status::{
    GpuPassState, HairGpuBuildFailed, HairGpuDispatches, HairGpuFallback, HairGpuMeshSupport,
    HairGpuPasses, HairMeshBuilder, PassDispatches,
};
use strokes::{
    GpuStrokePipeline, StrokeBatch, init_gpu_stroke_pipeline, prepare_stroke_batch, stroke_vertices,
};
#[cfg(test)]
pub(super) use toolbox::shader_defs;
use toolbox::{BindingLimits, PreparedBatch, SlabSpan, dispatch, group_by_slab};
use tubes::{GpuTubePipeline, TubeBatch, TubeHairInput, init_gpu_tube_pipeline};

/// Builds strand tubes, strokes and highlights on the GPU. Part of
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins) (feature `render`).
#[derive(Default)]
pub struct GpuTubesPlugin;

impl Plugin for GpuTubesPlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "tubes.wesl");
        bevy::asset::embedded_asset!(app, "strokes.wesl");
        bevy::asset::embedded_asset!(app, "highlights.wesl");
        bevy::asset::embedded_asset!(app, "order.wesl");
        bevy::asset::embedded_asset!(app, "shadows.wesl");
        let passes = HairGpuPasses::default();
        app.init_resource::<HairMeshBuilder>()
            .init_resource::<HairGpuMeshSupport>()
            .insert_resource(passes.clone())
            .register_type::<HairMeshBuilder>()
            // Each stroke and highlight mesh is a draw of its own (its indirect draw has its own
            // index count and instance).
            .register_required_components::<crate::silhouette::HairStrokesOf, NoAutomaticBatching>()
            .register_required_components::<
                crate::mesh::highlights::HairHighlightsOf,
                NoAutomaticBatching,
            >()
            .init_resource::<HairCompactQuads>()
            .register_type::<HairCompactQuads>()
            .add_plugins((
                ExtractComponentPlugin::<GpuTubeInput>::default(),
                ExtractResourcePlugin::<HairCompactQuads>::default(),
            ))
            .add_systems(
                PostUpdate,
                (
                    choose_mesh_builder.before(HairSystems::BuildMesh),
                    gather_gpu_tube_inputs
                        .after(HairSystems::Silhouettes)
                        .before(HairSystems::Materials),
                ),
            );
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .insert_resource(passes)
            .init_resource::<GpuBatches>()
            .init_resource::<GpuQuadDraws>()
            .add_render_command::<Transparent3d, DrawQuads>()
            .add_systems(
                RenderStartup,
                (
                    (
                        init_gpu_tube_pipeline,
                        init_gpu_stroke_pipeline,
                        init_gpu_highlight_pipeline,
                        init_gpu_order_pipeline,
                        init_gpu_shadow_pipeline,
                    ),
                    name_gpu_passes,
                )
                    .chain(),
            )
            .add_systems(
                Render,
                (
                    report_pass_state.in_set(RenderSystems::Prepare),
                    use_quad_draw_function::<HairStrokeMaterial>
                        .in_set(RenderSystems::PrepareAssets)
                        .after(prepare_erased_assets::<MeshMaterial3d<HairStrokeMaterial>>),
                    use_quad_draw_function::<HairHighlightMaterial>
                        .in_set(RenderSystems::PrepareAssets)
                        .after(prepare_erased_assets::<MeshMaterial3d<HairHighlightMaterial>>),
                    (prepare_gpu_batches, prepare_view_quad_draws)
                        .chain()
                        .in_set(RenderSystems::PrepareBindGroups),
                ),
            )
            .add_systems(RenderGraph, build_gpu_batches.before(camera_driver));
    }

    fn finish(&self, app: &mut App) {
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        let support = match render_app.world().get_resource::<RenderDevice>() {
            Some(device) => gpu_support(device),
            None => HairGpuMeshSupport {
                supported: false,
                reason: Some("no render device".into()),
                ..default()
            },
        };
        // The passes write the mesh allocator's vertex slabs; a device without storage buffers
        // (WebGL 2) would refuse such buffers, so they are asked for only where the passes run.
        if support.supported {
            render_app
                .world_mut()
                .resource_mut::<MeshAllocatorSettings>()
                .extra_buffer_usages |= BufferUsages::STORAGE;
        }
        if let Some(reason) = &support.reason {
            info!("hair tubes are built on the CPU: {reason}");
        }
        app.insert_resource(support);
    }
}

/// The passes' pipelines, for [`report_pass_state`].
fn name_gpu_passes(
    mut commands: Commands,
    tubes: Res<GpuTubePipeline>,
    strokes: Res<GpuStrokePipeline>,
    highlights: Res<GpuHighlightPipeline>,
    order: Res<GpuOrderPipeline>,
    shadows: Res<GpuShadowPipeline>,
) {
    commands.insert_resource(GpuPassIds([
        ("hair_gpu_tubes", tubes.0.pipeline),
        ("hair_gpu_strokes", strokes.0.build.pipeline),
        ("hair_gpu_strokes_compact", strokes.0.compact),
        ("hair_gpu_highlights", highlights.0.build.pipeline),
        ("hair_gpu_highlights_compact", highlights.0.compact),
        ("hair_gpu_draw_order", order.0.pipeline),
        ("hair_gpu_shadows", shadows.0.pipeline),
    ]));
}

/// What the render device allows.
fn gpu_support(device: &RenderDevice) -> HairGpuMeshSupport {
    let limits = device.limits();
    let reason = if limits.max_storage_buffers_per_shader_stage < 7 {
        Some(format!(
            "the device allows {} storage buffers in a shader stage, the passes need 7",
            limits.max_storage_buffers_per_shader_stage
        ))
    } else if limits.max_compute_workgroup_size_x < toolbox::WORKGROUP_SIZE {
        // WebGL has no compute at all; every other backend Bevy runs on has.
        Some(format!(
            "the device has no compute shaders of {} invocations",
            toolbox::WORKGROUP_SIZE
        ))
    } else {
        None
    };
    HairGpuMeshSupport {
        supported: reason.is_none(),
        reason,
        max_binding_bytes: limits.max_storage_buffer_binding_size,
        binding_alignment: u64::from(limits.min_storage_buffer_offset_alignment),
    }
}

/// The five passes' pipelines, as the systems that prepare and run them take them.
type PassPipelines<'w> = (
    Res<'w, GpuTubePipeline>,
    Res<'w, GpuStrokePipeline>,
    Res<'w, GpuHighlightPipeline>,
    Res<'w, GpuOrderPipeline>,
    Res<'w, GpuShadowPipeline>,
);

/// This frame's batches of the five passes (render world), their buffers reused frame to
/// frame.
#[derive(Resource, Default)]
struct GpuBatches {
    tubes: Vec<TubeBatch>,
    strokes: Vec<StrokeBatch>,
    highlights: Vec<HighlightBatch>,
    order: Vec<OrderBatch>,
    shadows: Vec<ShadowBatch>,
    /// Batches in use this frame, of each pass.
    used: [usize; 5],
}

/// Groups the hairs of this frame by vertex slab, uploads each batch's records, strands and
/// particles and makes its bind groups; a hair whose mesh the device cannot bind is refused
/// (it goes back to the CPU).
fn prepare_gpu_batches(
    mut inputs: Query<&mut GpuTubeInput>,
    mut batches: ResMut<GpuBatches>,
    mesh_allocator: Res<MeshAllocator>,
    pipelines: PassPipelines<'_>,
    pipeline_cache: Res<PipelineCache>,
    (device, queue, passes): (Res<RenderDevice>, Res<RenderQueue>, Res<HairGpuPasses>),
    (mut quad_draws, uploaded, compact_quads): (
        ResMut<GpuQuadDraws>,
        Res<ExtractedAssets<RenderMesh>>,
        Res<HairCompactQuads>,
    ),
) {
    let (tube_pipeline, stroke_pipeline, highlight_pipeline, order_pipeline, shadow_pipeline) =
        pipelines;
    let render = (device.as_ref(), queue.as_ref());
    let limits = BindingLimits::of(&device.limits());
    quad_draws.forget_uploaded(&uploaded);
    // Quads are drawn by the count the passes write when asked and where the device takes a
    // first instance in indirect draws; elsewhere their meshes are drawn whole.
    // The passes' second dispatches must be ready too: until then the counts are not written.
    let compact = compact_quads.0
        && device
            .features()
            .contains(bevy::render::settings::WgpuFeatures::INDIRECT_FIRST_INSTANCE)
        && [stroke_pipeline.0.compact, highlight_pipeline.0.compact]
            .into_iter()
            .all(|id| pipeline_cache.get_compute_pipeline(id).is_some());
    let batches = batches.as_mut();
    batches.used = [0; 5];
    let inputs: Vec<_> = inputs.iter_mut().collect();
    // The tube meshes, by slab.
    let mut spans = Vec::with_capacity(inputs.len());
    for (i, input) in inputs.iter().enumerate() {
        let hair = &input.hair;
        let vertices = (hair.strands * (hair.rings * hair.sides + CAP_VERTICES)) as usize;
        if let Some(slice) = mesh_allocator.mesh_vertex_slice(&input.mesh)
            && let Some(span) = SlabSpan::new(i, &slice, hair.stride, vertices)
        {
            spans.push(span);
        }
    }
    let (groups, refused) = group_by_slab(spans, Buffer::id, limits);
    for i in refused {
        let hair = &inputs[i].hair;
        passes.refuse(
            inputs[i].mesh,
            format!(
                "its mesh of {} vertices is larger than this device binds as storage ({} \
                 bytes); it is built on the CPU (fewer strands or a coarser HairMeshSettings fit)",
                hair.strands * (hair.rings * hair.sides + CAP_VERTICES),
                limits.max_bytes
            ),
        );
    }
    let hairs: Vec<TubeHairInput> = inputs
        .iter()
        .map(|input| TubeHairInput {
            mesh: input.mesh,
            hair: input.hair,
            strands: &input.strands,
            particles: &input.particles,
            sections: &input.sections,
        })
        .collect();
    let mut placements = vec![None; inputs.len()];
    if batches.tubes.len() < groups.len() {
        batches.tubes.resize_with(groups.len(), Default::default);
    }
    for (b, group) in groups.iter().enumerate() {
        let placed =
            batches.tubes[b].prepare(b, group, &hairs, render, (&tube_pipeline, &pipeline_cache));
        for (i, placement) in placed {
            placements[i] = Some(placement);
        }
    }
    batches.used[0] = groups.len();
    prepare_order_batches(
        &inputs,
        &placements,
        batches,
        &mesh_allocator,
        limits,
        render,
        (&order_pipeline, &pipeline_cache),
    );
    // The stroke, highlight and shadow jobs of each tube batch, by slab.
    let GpuBatches {
        tubes,
        strokes,
        highlights,
        shadows,
        used,
        ..
    } = batches;
    for (b, tube_batch) in tubes.iter().enumerate().take(used[0]) {
        let Some(buffers) = tube_batch.buffers() else {
            continue;
        };
        let in_batch = || {
            inputs
                .iter()
                .zip(&placements)
                .filter_map(move |(input, p)| p.filter(|p| p.batch == b).map(|p| (input, p)))
        };
        let mut stroke_spans = Vec::new();
        let mut highlight_spans = Vec::new();
        let mut shadow_spans = Vec::new();
        for (input, placement) in in_batch() {
            if let Some(job) = &input.shadows
                && let Some(slice) = mesh_allocator.mesh_vertex_slice(&job.mesh)
                && let Some(span) = SlabSpan::new(
                    (job.record, placement),
                    &slice,
                    job.record.stride,
                    shadow_vertices(&job.record),
                )
            {
                shadow_spans.push(span);
            }
            for job in &input.strokes {
                let vertices = stroke_vertices(&job.record);
                if let Some(slice) = mesh_allocator.mesh_vertex_slice(&job.mesh)
                    && let Some(index_slice) = mesh_allocator.mesh_index_slice(&job.mesh)
                    && let Some(indices) = QuadIndices::of(job.mesh, &slice, &index_slice, vertices)
                    && let Some(span) = SlabSpan::new(
                        (job.record, placement, indices),
                        &slice,
                        job.record.stride,
                        vertices,
                    )
                {
                    stroke_spans.push(span);
                }
            }
            if let Some(job) = &input.highlights
                && let Some(slice) = mesh_allocator.mesh_vertex_slice(&job.mesh)
                && let Some(index_slice) = mesh_allocator.mesh_index_slice(&job.mesh)
                && let Some(indices) = QuadIndices::of(
                    job.mesh,
                    &slice,
                    &index_slice,
                    highlight_vertices(&job.record),
                )
                && let Some(span) = SlabSpan::new(
                    (job.record, placement, indices),
                    &slice,
                    job.record.stride,
                    highlight_vertices(&job.record),
                )
            {
                highlight_spans.push(span);
            }
        }
        // The device binds a hair's stroke or highlight mesh when it binds its tubes
        // (`HairGpuMeshSupport::fits`); should it refuse one, the hair goes back to the CPU
        // rather than lose its strokes.
        let (groups, refused) = group_quads(stroke_spans, limits);
        let (highlight_groups, refused_highlights) = group_quads(highlight_spans, limits);
        let (shadow_groups, refused_shadows) = group_by_slab(shadow_spans, Buffer::id, limits);
        let refused_hairs = refused.iter().map(|(_, h, _)| h);
        for hair in refused_hairs
            .chain(refused_highlights.iter().map(|(_, h, _)| h))
            .chain(refused_shadows.iter().map(|(_, h)| h))
        {
            passes.refuse(
                hair.hair_mesh,
                format!(
                    "its stroke, highlight or shadow mesh is larger than this device binds as \
                     storage ({} bytes); it is built on the CPU",
                    limits.max_bytes
                ),
            );
        }
        for group in &shadow_groups {
            if shadows.len() <= used[4] {
                shadows.push(ShadowBatch::default());
            }
            shadows[used[4]].prepare_frame_job(
                group,
                buffers,
                render,
                (&shadow_pipeline.0, &pipeline_cache),
            );
            used[4] += 1;
        }
        for group in &groups {
            if strokes.len() <= used[1] {
                strokes.push(StrokeBatch::default());
            }
            if !prepare_stroke_batch(
                &mut strokes[used[1]],
                group,
                buffers,
                (&device, &queue, limits),
                (&stroke_pipeline, &pipeline_cache),
                (&mut quad_draws, compact),
            ) {
                refuse_indices(&passes, group, limits);
            }
            used[1] += 1;
        }
        for group in &highlight_groups {
            if highlights.len() <= used[2] {
                highlights.push(HighlightBatch::default());
            }
            if !prepare_highlight_batch(
                &mut highlights[used[2]],
                group,
                buffers,
                (&device, &queue, limits),
                (&highlight_pipeline, &pipeline_cache),
                (&mut quad_draws, compact),
            ) {
                refuse_indices(&passes, group, limits);
            }
            used[2] += 1;
        }
    }
}

/// Puts the hairs of `group` back on the CPU: the device cannot bind their quad meshes'
/// indices.
fn refuse_indices<R>(passes: &HairGpuPasses, group: &QuadGroup<'_, R>, limits: BindingLimits) {
    for ((_, hair, _), _) in &group.members {
        passes.refuse(
            hair.hair_mesh,
            format!(
                "its stroke or highlight meshes' indices are larger than this device binds as \
                 storage ({} bytes); it is built on the CPU",
                limits.max_bytes
            ),
        );
    }
}

/// Groups the hairs built this frame that have a draw order by index slab and prepares one
/// draw-order batch a group. A mesh whose indices the device cannot bind keeps its order (it
/// is drawn as before, only slower).
fn prepare_order_batches(
    inputs: &[Mut<GpuTubeInput>],
    placements: &[Option<toolbox::HairPlacement>],
    batches: &mut GpuBatches,
    mesh_allocator: &MeshAllocator,
    limits: BindingLimits,
    render: (&RenderDevice, &RenderQueue),
    pipeline: (&GpuOrderPipeline, &PipelineCache),
) {
    let mut spans = Vec::new();
    for (i, input) in inputs.iter().enumerate() {
        let hair = &input.hair;
        if placements[i].is_none() || input.draw_order.len() != hair.strands as usize {
            continue;
        }
        let indices = input.indices_per_strand as usize * hair.strands as usize;
        if let Some(slice) = mesh_allocator.mesh_index_slice(&input.mesh)
            && let Some(span) = SlabSpan::new(i, &slice, 1, indices)
        {
            spans.push(span);
        }
    }
    let (groups, _kept_in_order) = group_by_slab(spans, Buffer::id, limits);
    let hairs: Vec<OrderHairInput> = inputs
        .iter()
        .map(|input| OrderHairInput {
            indices_per_strand: input.indices_per_strand,
            vertices_per_strand: input.hair.rings * input.hair.sides + CAP_VERTICES,
            order: &input.draw_order,
        })
        .collect();
    if batches.order.len() < groups.len() {
        batches.order.resize_with(groups.len(), Default::default);
    }
    for (b, group) in groups.iter().enumerate() {
        batches.order[b].prepare(group, &hairs, render, pipeline);
    }
    batches.used[3] = groups.len();
}

/// Vertices after each strand's rings in a tube mesh.
const CAP_VERTICES: u32 = crate::mesh::tube::CAP_VERTICES as u32;

/// Dispatches each batch of `list` with the pass's pipeline, counted into `count`.
fn dispatch_batches(
    pass: &mut bevy::render::render_resource::ComputePass,
    list: &[&PreparedBatch],
    count: &mut PassDispatches,
    max_per_dimension: u32,
) {
    for batch in list {
        pass.set_bind_group(0, &batch.bind_group, &[]);
        if dispatch(pass, batch.invocations, max_per_dimension) {
            count.dispatches += 1;
            count.invocations += batch.invocations;
        }
    }
}

/// Runs the tube pass over every batch, then the stroke, highlight, draw-order and shadow
/// passes, before any camera or light draws: five compute passes of one dispatch a batch, each timed by `RenderDiagnosticsPlugin`
/// where a game adds it (`render/hair_gpu_tubes/elapsed_gpu` and its pipeline statistics). The
/// dispatches go to [`HairGpuPasses::dispatches`].
fn build_gpu_batches(
    mut render_context: RenderContext,
    batches: Res<GpuBatches>,
    pipelines: PassPipelines<'_>,
    pipeline_cache: Res<PipelineCache>,
    (device, passes, quad_draws): (Res<RenderDevice>, Res<HairGpuPasses>, Res<GpuQuadDraws>),
) {
    let (tube_pipeline, stroke_pipeline, highlight_pipeline, order_pipeline, shadow_pipeline) =
        pipelines;
    let mut dispatches = HairGpuDispatches::default();
    let tubes: Vec<&PreparedBatch> = batches.tubes[..batches.used[0]]
        .iter()
        .filter_map(|b| b.prepared.as_ref())
        .collect();
    if tubes.is_empty()
        || pipeline_cache
            .get_compute_pipeline(tube_pipeline.0.pipeline)
            .is_none()
    {
        // Views that began drawing a quad mesh built before still get its count.
        quad_draws.copy_to_views(render_context.command_encoder());
        passes.set_dispatches(dispatches);
        return;
    }
    // Strokes and highlights read the frames the tube pass wrote (wgpu orders the passes).
    let strokes: Vec<&PreparedBatch> = batches.strokes[..batches.used[1]]
        .iter()
        .filter_map(|b| b.jobs.prepared.as_ref())
        .collect();
    let highlights: Vec<&PreparedBatch> = batches.highlights[..batches.used[2]]
        .iter()
        .filter_map(|b| b.jobs.prepared.as_ref())
        .collect();
    let compact_strokes: Vec<&PreparedBatch> = batches.strokes[..batches.used[1]]
        .iter()
        .filter(|b| b.compacts())
        .filter_map(|b| b.jobs.prepared.as_ref())
        .collect();
    let compact_highlights: Vec<&PreparedBatch> = batches.highlights[..batches.used[2]]
        .iter()
        .filter(|b| b.compacts())
        .filter_map(|b| b.jobs.prepared.as_ref())
        .collect();
    let order: Vec<&PreparedBatch> = batches.order[..batches.used[3]]
        .iter()
        .filter_map(|b| b.prepared.as_ref())
        .collect();
    let shadows: Vec<&PreparedBatch> = batches.shadows[..batches.used[4]]
        .iter()
        .filter_map(|b| b.prepared.as_ref())
        .collect();
    let max_per_dimension = device.limits().max_compute_workgroups_per_dimension;
    let diagnostics = render_context.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let HairGpuDispatches {
        tubes: tube_count,
        strokes: stroke_count,
        highlights: highlight_count,
        draw_order: order_count,
        shadows: shadow_count,
        compact: compact_count,
    } = &mut dispatches;
    // Each pass: its pipeline and batches, then, for the quad passes, the second dispatch over
    // the batches drawn by count (after the first in the same pass; wgpu orders dispatches).
    for (count, name, (id, list), (compact_id, compact_list)) in [
        (
            tube_count,
            "hair_gpu_tubes",
            (tube_pipeline.0.pipeline, tubes),
            (None, Vec::new()),
        ),
        (
            stroke_count,
            "hair_gpu_strokes",
            (stroke_pipeline.0.build.pipeline, strokes),
            (Some(stroke_pipeline.0.compact), compact_strokes),
        ),
        (
            highlight_count,
            "hair_gpu_highlights",
            (highlight_pipeline.0.build.pipeline, highlights),
            (Some(highlight_pipeline.0.compact), compact_highlights),
        ),
        (
            order_count,
            "hair_gpu_draw_order",
            (order_pipeline.0.pipeline, order),
            (None, Vec::new()),
        ),
        (
            shadow_count,
            "hair_gpu_shadows",
            (shadow_pipeline.0.pipeline, shadows),
            (None, Vec::new()),
        ),
    ] {
        let Some(compute) = pipeline_cache.get_compute_pipeline(id) else {
            continue;
        };
        if list.is_empty() {
            continue;
        }
        let mut pass =
            render_context
                .command_encoder()
                .begin_compute_pass(&ComputePassDescriptor {
                    label: Some(name),
                    ..default()
                });
        let span = diagnostics.pass_span(&mut pass, name);
        pass.set_pipeline(compute);
        dispatch_batches(&mut pass, &list, count, max_per_dimension);
        if let Some(compact) = compact_id.and_then(|id| pipeline_cache.get_compute_pipeline(id))
            && !compact_list.is_empty()
        {
            pass.set_pipeline(compact);
            dispatch_batches(&mut pass, &compact_list, compact_count, max_per_dimension);
        }
        span.end(&mut pass);
    }
    // The quads the stroke and highlight passes counted, into their meshes' draws (of the
    // passes that ran).
    let ran = [
        dispatches.strokes.dispatches > 0,
        dispatches.highlights.dispatches > 0,
    ];
    let encoder = render_context.command_encoder();
    if ran[0] {
        for batch in &batches.strokes[..batches.used[1]] {
            batch.copy_counts(encoder, &quad_draws);
        }
    }
    if ran[1] {
        for batch in &batches.highlights[..batches.used[2]] {
            batch.copy_counts(encoder, &quad_draws);
        }
    }
    quad_draws.copy_to_views(encoder);
    passes.set_dispatches(dispatches);
}
