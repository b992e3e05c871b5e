//! Strand tubes built on the GPU: the hair's particles go to the GPU each frame, and a compute
//! pass (`gpu_tubes.wesl`) sweeps the tubes straight into the hair mesh's own vertex buffer.
//!
//! The hair mesh stays an ordinary Bevy `Mesh` with its UVs and indices, so the main pass, the
//! prepasses, the shadow passes, the image-space outline and the fringe shadow draw it as
//! before; only its positions, normals and tangents come from the compute pass instead of the
//! CPU. Its vertex data is uploaded once, when the mesh is created (the CPU never changes it
//! afterwards, so Bevy never uploads it again); each frame the GPU gets the particles (16 bytes
//! each), one 48-byte record per strand and a small uniform. The mesh allocator's vertex slabs
//! are made usable as storage buffers (`MeshAllocatorSettings::extra_buffer_usages`) so that the
//! pass can write them, as Bevy's `compute_mesh` example does.
//!
//! The pass also leaves each ring's frame in a buffer of its own, from which the object-space
//! strokes of every camera are built on the GPU right after ([`gpu_strokes`](super::gpu_strokes)).
//!
//! A hair is built on the GPU when [`HairMeshBuilder::Gpu`] is chosen (the default) and the
//! render device can ([`HairGpuMeshSupport`]); [`HairMeshBuilder::Cpu`] builds every hair, and
//! its strokes, on the CPU: the reference.

use std::num::NonZeroU64;

use bevy::asset::load_embedded_asset;
use bevy::core_pipeline::schedule::camera_driver;
use bevy::ecs::query::QueryItem;
use bevy::ecs::system::lifetimeless::Read;
use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::mesh::allocator::{MeshAllocator, MeshAllocatorSettings, MeshBufferSlice};
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries,
    BindGroupLayoutEntry, Buffer, BufferBinding, BufferDescriptor, BufferUsages,
    CachedComputePipelineId, ComputePassDescriptor, ComputePipelineDescriptor, PipelineCache,
    ShaderStages, ShaderType, StorageBuffer, UniformBuffer,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderGraph, RenderQueue};
use bevy::render::sync_component::SyncComponent;
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

use super::gpu_highlights::{
    GpuHighlightBuffers, GpuHighlightInput, GpuHighlightPipeline, highlight_input,
    init_gpu_highlight_pipeline,
};
use super::gpu_status::{
    GpuPassIds, HairGpuMeshSupport, HairGpuPasses, HairMeshBuilder, choose_mesh_builder,
    report_pass_state,
};
use super::gpu_strokes::{
    GpuStrokeBuffers, GpuStrokeInput, GpuStrokePipeline, HairGpuBuffers, init_gpu_stroke_pipeline,
    stroke_input,
};
use crate::mesh::highlights::GpuHighlightJob;
use crate::mesh::{
    ComputedHairMesh, HairInView, HairMeshBuiltOnGpu, HairMeshSettings, HairStrandSections,
    LockSection, SectionSide, fill_section, mass_field,
};
use crate::schedule::HairSystems;
use crate::silhouette::GpuStrokeJobs;
use crate::sim::{ComputedHair, Hair, HairStrands, Strand, StrandParticles};

/// The uniform of one hair's compute pass (`gpu_tubes.wesl`'s `Params`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct GpuTubeParams {
    /// The mesh's first vertex in the slab, in 4-byte words (set in the render world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position, the normal and the tangent.
    pub position_offset: u32,
    /// See [`GpuTubeParams::position_offset`].
    pub normal_offset: u32,
    /// See [`GpuTubeParams::position_offset`].
    pub tangent_offset: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Sides per ring.
    pub sides: u32,
    /// Strands in the mesh.
    pub strands: u32,
    /// Radius, then the taper's `a`, `b`, `c`.
    pub shape: Vec4,
    /// The mass field's centre and weight (`0`: no mass normals).
    pub mass_centre: Vec4,
    /// The mass field's metric, by columns.
    pub metric_x: Vec4,
    /// See [`GpuTubeParams::metric_x`].
    pub metric_y: Vec4,
    /// See [`GpuTubeParams::metric_x`].
    pub metric_z: Vec4,
    /// The bone's up axis, for the angel ring's tangents.
    pub up: Vec4,
}

/// One strand of the compute pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct GpuStrand {
    /// The root frame's reference direction, turned with the bone.
    pub reference_direction: Vec4,
    /// The root frame's reference normal, turned with the bone.
    pub reference_normal: Vec4,
    /// Its first particle in the particle buffer.
    pub first: u32,
    /// Its particle count.
    pub count: u32,
    /// Its cross-section's first side in the section table.
    pub section: u32,
    /// Padding.
    pub pad: u32,
}

/// What the GPU needs this frame to build a hair's tubes, on the hair's mesh entity. Written in
/// the main world after the CPU's mesh stage; absent while the hair is on the CPU or out of view
/// (its mesh then keeps the last vertices built).
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct GpuTubeInput {
    /// The hair mesh.
    pub mesh: AssetId<Mesh>,
    /// The pass's uniform (its `vertex_base` is filled in the render world).
    pub params: GpuTubeParams,
    /// The strands, in the mesh's order.
    pub strands: Vec<GpuStrand>,
    /// Every strand's particles, world space.
    pub particles: Vec<Vec4>,
    /// The cross-sections in use, `sides` sides each, two vec4 a side (position and normal,
    /// then the around direction, in the ring's frame).
    pub sections: Vec<Vec4>,
    /// The strokes to build from the tubes, one a camera.
    pub strokes: Vec<GpuStrokeInput>,
    /// The specular quads to build from the tubes.
    pub highlights: Option<GpuHighlightInput>,
}

impl SyncComponent<RenderApp> for GpuTubeInput {
    type Target = (GpuTubeInput, GpuTubeBuffers);
}

impl ExtractComponent<RenderApp> for GpuTubeInput {
    type QueryData = Read<GpuTubeInput>;
    type QueryFilter = ();
    type Out = GpuTubeInput;

    fn extract_component(input: QueryItem<'_, '_, Self::QueryData>) -> Option<Self::Out> {
        Some(input.clone())
    }
}

/// A hair mesh's buffers and bind group in the render world.
#[derive(Component, Default)]
pub struct GpuTubeBuffers {
    params: UniformBuffer<GpuTubeParams>,
    strands: StorageBuffer<Vec<GpuStrand>>,
    particles: StorageBuffer<Vec<Vec4>>,
    sections: StorageBuffer<Vec<Vec4>>,
    /// The ring frames the pass writes for the stroke passes (GPU only).
    frames: Option<Buffer>,
    strokes: GpuStrokeBuffers,
    highlights: GpuHighlightBuffers,
    /// This frame's bind group and strand count; `None` when the mesh is not allocated yet.
    ready: Option<(BindGroup, u32)>,
}

/// Builds strand tubes on the GPU. Part of [`CartoonHairPlugins`](crate::CartoonHairPlugins)
/// (feature `render`).
#[derive(Default)]
pub struct GpuTubesPlugin;

impl Plugin for GpuTubesPlugin {
    fn build(&self, app: &mut App) {
        bevy::asset::embedded_asset!(app, "gpu_tubes.wesl");
        bevy::asset::embedded_asset!(app, "gpu_strokes.wesl");
        bevy::asset::embedded_asset!(app, "gpu_highlights.wesl");
        let passes = HairGpuPasses::default();
        app.init_resource::<HairMeshBuilder>()
            .init_resource::<HairGpuMeshSupport>()
            .insert_resource(passes.clone())
            .register_type::<HairMeshBuilder>()
            .add_plugins(ExtractComponentPlugin::<GpuTubeInput>::default())
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
            .add_systems(
                RenderStartup,
                (
                    (
                        init_gpu_tube_pipeline,
                        init_gpu_stroke_pipeline,
                        init_gpu_highlight_pipeline,
                    ),
                    name_gpu_passes,
                )
                    .chain(),
            )
            .add_systems(
                Render,
                (
                    report_pass_state.in_set(RenderSystems::Prepare),
                    prepare_gpu_tubes.in_set(RenderSystems::PrepareBindGroups),
                ),
            )
            .add_systems(RenderGraph, build_gpu_tubes.before(camera_driver));
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
        // The pass writes the mesh allocator's vertex slabs; a device without storage buffers
        // (WebGL 2) would refuse such buffers, so they are asked for only where the pass runs.
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

/// The three passes' pipelines, for [`report_pass_state`].
fn name_gpu_passes(
    mut commands: Commands,
    tubes: Res<GpuTubePipeline>,
    strokes: Res<GpuStrokePipeline>,
    highlights: Res<GpuHighlightPipeline>,
) {
    commands.insert_resource(GpuPassIds([
        ("hair_gpu_tubes", tubes.0.pipeline),
        ("hair_gpu_strokes", strokes.0.pipeline),
        ("hair_gpu_highlights", highlights.0.pipeline),
    ]));
}

/// What the render device allows.
fn gpu_support(device: &RenderDevice) -> HairGpuMeshSupport {
    let limits = device.limits();
    let reason = if limits.max_storage_buffers_per_shader_stage < 5 {
        Some(format!(
            "the device allows {} storage buffers in a shader stage, the passes need 5",
            limits.max_storage_buffers_per_shader_stage
        ))
    } else if limits.max_compute_workgroup_size_x < 64 {
        // WebGL has no compute at all; every other backend Bevy runs on has.
        Some("the device has no compute shaders of 64 invocations".to_string())
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

/// Word offsets of three attributes in `mesh`'s interleaved vertex, then the words per vertex;
/// `None` if one is missing.
pub(super) fn vertex_offsets(
    mesh: &Mesh,
    attributes: [bevy::mesh::MeshVertexAttributeId; 3],
) -> Option<[u32; 4]> {
    let (mut offset, mut found) = (0u64, [None; 3]);
    for (attribute, _) in mesh.attributes() {
        if let Some(slot) = attributes.iter().position(|id| *id == attribute.id) {
            found[slot] = Some((offset / 4) as u32);
        }
        offset += attribute.format.size();
    }
    Some([found[0]?, found[1]?, found[2]?, (offset / 4) as u32])
}

/// Writes each GPU-built hair's [`GpuTubeInput`] from this frame's particles.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
fn gather_gpu_tube_inputs(
    mut commands: Commands,
    hairs: Query<
        (
            &HairMeshSettings,
            Option<&HairStrandSections>,
            &HairStrands,
            &ComputedHairMesh,
            &ComputedHair,
            &HairInView,
            &GlobalTransform,
            Has<HairMeshBuiltOnGpu>,
            (Option<&GpuStrokeJobs>, Option<&GpuHighlightJob>),
        ),
        With<Hair>,
    >,
    strands: Query<(&Strand, &StrandParticles)>,
    meshes: Res<Assets<Mesh>>,
    mut inputs: Query<&mut GpuTubeInput>,
    mut order: Local<Vec<(u32, Entity)>>,
    mut tables: Local<(Vec<LockSection>, Vec<SectionSide>)>,
) {
    let (kinds, table) = &mut *tables;
    for (settings, per_strand, list, computed, sim, in_view, global, on_gpu, (jobs, quads)) in
        &hairs
    {
        let offsets = meshes.get(&computed.mesh).and_then(|mesh| {
            vertex_offsets(
                mesh,
                [
                    Mesh::ATTRIBUTE_POSITION.id,
                    Mesh::ATTRIBUTE_NORMAL.id,
                    Mesh::ATTRIBUTE_TANGENT.id,
                ],
            )
        });
        let (Some([position, normal, tangent, stride]), true, true) = (offsets, on_gpu, in_view.0)
        else {
            if inputs.contains(computed.entity) {
                commands.entity(computed.entity).remove::<GpuTubeInput>();
            }
            continue;
        };
        order.clear();
        order.extend(
            list.iter()
                .filter_map(|e| strands.get(e).ok().map(|(s, _)| (s.index, e))),
        );
        if order.len() != computed.strands {
            continue;
        }
        order.sort_unstable_by_key(|(i, _)| *i);
        let (rings, sides) = (computed.topology.rings(), computed.topology.sides());
        let mut input = GpuTubeInput {
            mesh: computed.mesh.id(),
            ..default()
        };
        if let Ok(mut last) = inputs.get_mut(computed.entity) {
            // Reuse last frame's allocations.
            input.strands = std::mem::take(&mut last.strands);
            input.particles = std::mem::take(&mut last.particles);
            input.sections = std::mem::take(&mut last.sections);
            input.strokes = std::mem::take(&mut last.strokes);
        }
        input.strokes.clear();
        input.strokes.extend(
            jobs.iter()
                .flat_map(|j| &j.0)
                .filter_map(|job| stroke_input(job, &meshes, rings, sides, computed.strands)),
        );
        input.highlights = quads
            .and_then(|q| q.0.as_ref())
            .and_then(|job| highlight_input(job, &meshes, rings, computed.strands));
        input.strands.clear();
        input.particles.clear();
        input.sections.clear();
        // The cross-section tables in use, one per kind, `sides` sides each.
        let section_of = |index: u32| {
            per_strand.map_or(settings.section, |p| {
                p.get(index as usize, settings.section)
            })
        };
        kinds.clear();
        let rotation = global.rotation();
        for &(index, entity) in &*order {
            let Ok((_, particles)) = strands.get(entity) else {
                continue;
            };
            let kind = section_of(index);
            let slot = match kinds.iter().position(|k| *k == kind) {
                Some(slot) => slot,
                None => {
                    kinds.push(kind);
                    fill_section(
                        kind,
                        settings.section_aspect,
                        computed.topology.cos_sin(),
                        table,
                    );
                    input.sections.extend(table.iter().flat_map(|[p, n, a]| {
                        [Vec4::new(p.0, p.1, n.0, n.1), Vec4::new(a.0, a.1, 0.0, 0.0)]
                    }));
                    kinds.len() - 1
                }
            };
            let reference = computed.frame_reference(index, rotation);
            input.strands.push(GpuStrand {
                reference_direction: reference.direction.extend(0.0),
                reference_normal: reference.normal.extend(0.0),
                first: input.particles.len() as u32,
                count: particles.positions.len() as u32,
                section: (slot * sides) as u32,
                pad: 0,
            });
            input
                .particles
                .extend(particles.positions.iter().map(|p| p.extend(1.0)));
        }
        let (centre, metric, up, weight) = mass_field(settings, sim)
            .map_or((Vec3::ZERO, Mat3::IDENTITY, Vec3::Y, 0.0), |m| m.parts());
        let taper = settings.taper;
        input.params = GpuTubeParams {
            vertex_base: 0,
            stride,
            position_offset: position,
            normal_offset: normal,
            tangent_offset: tangent,
            rings: rings as u32,
            sides: sides as u32,
            strands: input.strands.len() as u32,
            shape: Vec4::new(settings.radius * sim.size(), taper.a, taper.b, taper.c),
            mass_centre: centre.extend(weight),
            metric_x: metric.x_axis.extend(0.0),
            metric_y: metric.y_axis.extend(0.0),
            metric_z: metric.z_axis.extend(0.0),
            up: up.extend(0.0),
        };
        match inputs.get_mut(computed.entity) {
            Ok(mut last) => *last = input,
            Err(_) => {
                commands.entity(computed.entity).try_insert(input);
            }
        }
    }
}

/// The part of a mesh's vertex slab a pass writes, bound as storage: from the aligned offset at
/// or before the mesh's first vertex to its last; with the mesh's first vertex in that binding,
/// in 4-byte words. `None` when the mesh has fewer than `vertices` vertices or the binding
/// would be larger than the device allows (`max_storage_buffer_binding_size`).
pub(super) fn slab_binding<'a>(
    slice: &MeshBufferSlice<'a>,
    stride_words: u32,
    vertices: usize,
    device: &RenderDevice,
) -> Option<(BufferBinding<'a>, u32)> {
    if slice.range.len() < vertices || vertices == 0 {
        return None;
    }
    let limits = device.limits();
    let stride = u64::from(stride_words) * 4;
    let align = u64::from(limits.min_storage_buffer_offset_alignment).max(4);
    let start = u64::from(slice.range.start) * stride;
    let offset = start / align * align;
    let size = u64::from(slice.range.end) * stride - offset;
    if size > limits.max_storage_buffer_binding_size {
        return None;
    }
    let binding = BufferBinding {
        buffer: slice.buffer,
        offset,
        size: NonZeroU64::new(size),
    };
    Some((binding, ((start - offset) / 4) as u32))
}

/// A compute pass of the crate: its pipeline and bind group layout, queued in `RenderStartup`.
pub(super) struct ComputePass {
    pub layout: BindGroupLayoutDescriptor,
    pub pipeline: CachedComputePipelineId,
}

impl ComputePass {
    /// Queues the pass `name` (its entry point `build` in `shader`) with a bind group of
    /// `entries`.
    pub fn queue(
        pipeline_cache: &PipelineCache,
        name: &'static str,
        entries: &[BindGroupLayoutEntry],
        shader: Handle<Shader>,
    ) -> Self {
        let layout = BindGroupLayoutDescriptor::new(name, entries);
        let pipeline = pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
            label: Some(name.into()),
            layout: vec![layout.clone()],
            shader,
            entry_point: Some("build".into()),
            ..default()
        });
        Self { layout, pipeline }
    }
}

/// The tube pass.
#[derive(Resource)]
struct GpuTubePipeline(ComputePass);

fn init_gpu_tube_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuTubePipeline(ComputePass::queue(
        &pipeline_cache,
        "hair_gpu_tubes",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<GpuTubeParams>(false),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
        load_embedded_asset!(asset_server.as_ref(), "gpu_tubes.wesl"),
    )));
}

/// Uploads each hair's particles and makes its bind group over its mesh's vertex slab, then its
/// stroke passes' bind groups.
fn prepare_gpu_tubes(
    mut commands: Commands,
    mut inputs: Query<(Entity, &mut GpuTubeInput, Option<&mut GpuTubeBuffers>)>,
    mesh_allocator: Res<MeshAllocator>,
    pipelines: (
        Res<GpuTubePipeline>,
        Res<GpuStrokePipeline>,
        Res<GpuHighlightPipeline>,
    ),
    pipeline_cache: Res<PipelineCache>,
    (device, queue, passes): (Res<RenderDevice>, Res<RenderQueue>, Res<HairGpuPasses>),
) {
    let (pipeline, stroke_pipeline, highlight_pipeline) = pipelines;
    for (entity, mut input, buffers) in &mut inputs {
        // A hair new to the GPU, or back in view, gets its buffers now and is built this frame
        // (the component lands before the render graph runs).
        let mut new_buffers = None;
        let buffers = match buffers {
            Some(buffers) => buffers.into_inner(),
            None => new_buffers.insert(GpuTubeBuffers::default()),
        };
        prepare_hair(
            &mut input,
            buffers,
            (&pipeline, &stroke_pipeline, &highlight_pipeline),
            (&mesh_allocator, &pipeline_cache, &device, &queue),
            &passes,
        );
        if let Some(buffers) = new_buffers {
            commands.entity(entity).insert(buffers);
        }
    }
}

/// One hair's part of [`prepare_gpu_tubes`].
fn prepare_hair(
    input: &mut GpuTubeInput,
    buffers: &mut GpuTubeBuffers,
    (pipeline, stroke_pipeline, highlight_pipeline): (
        &GpuTubePipeline,
        &GpuStrokePipeline,
        &GpuHighlightPipeline,
    ),
    (mesh_allocator, pipeline_cache, device, queue): (
        &MeshAllocator,
        &PipelineCache,
        &RenderDevice,
        &RenderQueue,
    ),
    passes: &HairGpuPasses,
) {
    buffers.ready = None;
    buffers.strokes.ready.clear();
    buffers.highlights.ready = None;
    let params = input.params;
    let per_strand = params.rings * params.sides + 2;
    let Some(slice) = mesh_allocator.mesh_vertex_slice(&input.mesh) else {
        return;
    };
    let vertices = (per_strand * params.strands) as usize;
    let Some((slab, vertex_base)) = slab_binding(&slice, params.stride, vertices, device) else {
        passes.refuse(
            input.mesh,
            format!(
                "its mesh of {vertices} vertices is larger than this device binds as \
                 storage ({} bytes); it is built on the CPU (fewer strands or a coarser \
                 HairMeshSettings fit)",
                device.limits().max_storage_buffer_binding_size
            ),
        );
        return;
    };
    buffers.params.set(GpuTubeParams {
        vertex_base,
        ..params
    });
    buffers.params.write_buffer(device, queue);
    // Never empty: there is a strand, so a particle and a section.
    buffers.particles.set(std::mem::take(&mut input.particles));
    buffers.sections.set(std::mem::take(&mut input.sections));
    buffers.strands.set(std::mem::take(&mut input.strands));
    buffers.particles.write_buffer(device, queue);
    buffers.sections.write_buffer(device, queue);
    buffers.strands.write_buffer(device, queue);
    // Three vec4 a ring.
    let frame_bytes = u64::from(params.strands * params.rings) * 48;
    if buffers.frames.as_ref().map(|b| b.size()) != Some(frame_bytes) {
        buffers.frames = Some(device.create_buffer(&BufferDescriptor {
            label: Some("hair_gpu_tube_frames"),
            size: frame_bytes,
            usage: BufferUsages::STORAGE,
            mapped_at_creation: false,
        }));
    }
    let (Some(p), Some(s), Some(x), Some(c), Some(frames)) = (
        buffers.params.binding(),
        buffers.strands.binding(),
        buffers.particles.binding(),
        buffers.sections.binding(),
        buffers.frames.as_ref(),
    ) else {
        return;
    };
    let bind_group = device.create_bind_group(
        "hair_gpu_tubes",
        &pipeline_cache.get_bind_group_layout(&pipeline.0.layout),
        &BindGroupEntries::sequential((p, s, x, c, slab, frames.as_entire_binding())),
    );
    buffers.ready = Some((bind_group, params.strands));
    let (Some(strands), Some(sections)) = (buffers.strands.buffer(), buffers.sections.buffer())
    else {
        return;
    };
    buffers.strokes.prepare(
        &input.strokes,
        HairGpuBuffers {
            strands,
            sections,
            frames,
        },
        (device, queue, mesh_allocator),
        stroke_pipeline,
        pipeline_cache,
    );
    buffers.highlights.prepare(
        input.highlights.as_ref(),
        frames,
        (device, queue, mesh_allocator),
        highlight_pipeline,
        pipeline_cache,
    );
}

/// Runs the tube pass of every hair ready this frame, then their stroke and highlight passes,
/// before any camera draws: three compute passes, each timed by `RenderDiagnosticsPlugin` where
/// a game adds it (`render/hair_gpu_tubes/elapsed_gpu` and its pipeline statistics).
fn build_gpu_tubes(
    mut render_context: RenderContext,
    hairs: Query<&GpuTubeBuffers>,
    pipeline: Res<GpuTubePipeline>,
    stroke_pipeline: Res<GpuStrokePipeline>,
    highlight_pipeline: Res<GpuHighlightPipeline>,
    pipeline_cache: Res<PipelineCache>,
) {
    let built = || hairs.iter().filter(|b| b.ready.is_some());
    let tubes: Vec<_> = built().filter_map(|b| b.ready.as_ref()).collect();
    if tubes.is_empty()
        || pipeline_cache
            .get_compute_pipeline(pipeline.0.pipeline)
            .is_none()
    {
        return;
    }
    // Strokes and highlights read the frames the tube pass wrote (wgpu orders the passes).
    let strokes: Vec<_> = built().flat_map(|b| &b.strokes.ready).collect();
    let highlights: Vec<_> = built()
        .filter_map(|b| b.highlights.ready.as_ref())
        .collect();
    let diagnostics = render_context.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    for (name, id, groups) in [
        ("hair_gpu_tubes", pipeline.0.pipeline, tubes),
        ("hair_gpu_strokes", stroke_pipeline.0.pipeline, strokes),
        (
            "hair_gpu_highlights",
            highlight_pipeline.0.pipeline,
            highlights,
        ),
    ] {
        let Some(compute) = pipeline_cache.get_compute_pipeline(id) else {
            continue;
        };
        if groups.is_empty() {
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
        for (bind_group, strands) in groups {
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(strands.div_ceil(64), 1, 1);
        }
        span.end(&mut pass);
    }
}
