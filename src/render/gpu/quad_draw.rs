//! Drawing the GPU-built strokes and specular quads only where they exist. A stroke or
//! highlight mesh holds a quad for every place a stroke or highlight may be; the passes mark
//! the quads that draw something and, in a second dispatch, write their triangles at the front
//! of the mesh's indices, strand after strand in the groom's order, and count them, a count per
//! job ([`QuadBatch`]). After the passes each count is
//! copied to its mesh ([`GpuQuadDraws`]), and from there, every frame, into the draw of each
//! view that draws the mesh, whose other words (first index, base vertex, and the first
//! instance: the mesh's place among Bevy's mesh data this frame, from the view's transparent
//! phase) the CPU writes. [`DrawQuadMesh`] issues that draw in the main pass in place of the
//! mesh's whole index range.
//!
//! A mesh the passes have not built since Bevy last uploaded it (one the CPU fills, or one just
//! made) has no draw and is drawn whole, as Bevy draws any mesh. Each quad mesh is a batch of its
//! own (`NoAutomaticBatching`), so its phase item's instance is its own. Only with
//! [`HairCompactQuads`] on and a device with `INDIRECT_FIRST_INSTANCE`; otherwise the meshes
//! are drawn whole.

use std::any::TypeId;
use std::num::NonZeroU64;
use std::sync::Arc;

use bevy::core_pipeline::core_3d::Transparent3d;
use bevy::ecs::query::ROQueryItem;
use bevy::ecs::system::SystemParamItem;
use bevy::ecs::system::lifetimeless::{Read, SRes};
use bevy::material::MaterialProperties;
use bevy::material::labels::{DrawFunctionId, DrawFunctionLabel, InternedDrawFunctionLabel};
use bevy::pbr::{
    DrawMesh, MainPassTransparentDrawFunction, PreparedMaterial, RenderMeshInstances,
    SetMaterialBindGroup, SetMeshBindGroup, SetMeshViewBindGroup, SetMeshViewBindingArrayBindGroup,
};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::erased_render_asset::ErasedRenderAssets;
use bevy::render::extract_resource::ExtractResource;
use bevy::render::mesh::RenderMesh;
use bevy::render::mesh::allocator::{MeshAllocator, MeshBufferSlice};
use bevy::render::render_asset::ExtractedAssets;
use bevy::render::render_phase::{
    DrawFunctions, PhaseItem, RenderCommand, RenderCommandResult, SetItemPipeline,
    TrackedRenderPass, ViewSortedRenderPhases,
};
use bevy::render::render_resource::binding_types::storage_buffer_sized;
use bevy::render::render_resource::encase::internal::WriteInto;
use bevy::render::render_resource::{
    BindGroup, BindGroupLayoutEntry, BindingResource, Buffer, BufferBinding, BufferDescriptor,
    BufferUsages, CachedComputePipelineId, CommandEncoder, IndexFormat, PipelineCache,
    ShaderStages, ShaderType,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::view::{ExtractedView, RetainedViewEntity};

use super::toolbox::{
    BindingLimits, ComputePass, HairPlacement, JobBatch, JobRecord, SlabGroup, SlabSpan,
    group_by_slab,
};
use crate::mesh::tube::{MAX_RINGS, MAX_SIDES};

/// `Job::draw` of a job whose quads are not compacted (its mesh is drawn whole).
pub const NO_DRAW: u32 = u32::MAX;
/// `Job::draw` of a job whose mesh was compacted and is drawn whole from now on: the pass writes
/// every quad's triangles back in place.
pub const RESTORE_DRAW: u32 = u32::MAX - 1;

/// Whether GPU-built strokes and specular quads are drawn only where they exist, by the count
/// of quads the passes find (fewer triangles: W1's strokes 4,286 primitives instead of 6,000).
/// On by default; the triangles are written strand after strand in the groom's order, so
/// overlapping strokes blend the same way in every frame and run. Can be switched at any time
/// (off: the meshes are drawn whole, every quad's triangles written back in place). Needs
/// `INDIRECT_FIRST_INSTANCE` (Vulkan, Metal, DX12); elsewhere the meshes are drawn whole.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq, Reflect, ExtractResource)]
#[extract_app(bevy::render::RenderApp)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub struct HairCompactQuads(pub bool);

impl Default for HairCompactQuads {
    fn default() -> Self {
        Self(true)
    }
}

/// Words of a strand's live quads in a quad batch's scratch buffer (`constants::LIVE_WORDS`): a
/// bit for each of a stroke's at most 2 x (`MAX_RINGS` - 1 + `MAX_SIDES`) quads.
pub const LIVE_WORDS: u32 = (2 * (MAX_RINGS as u32 - 1 + MAX_SIDES as u32)).div_ceil(32);

/// A quad pass's two pipelines: `build` (the quads and which of them draw something) and
/// `compact` (the live quads' triangles and each job's count, `quads.wesl`'s
/// `write_triangles`), which runs after it over the same batch and bind group.
pub(crate) struct QuadPipelines {
    pub build: ComputePass,
    pub compact: CachedComputePipelineId,
}

impl QuadPipelines {
    /// Queues the pass `name` from `shader` (entry points `build` and `compact`) with a bind
    /// group of `entries` followed by [`quad_entries`].
    pub fn queue(
        pipeline_cache: &PipelineCache,
        (name, compact_name): (&'static str, &'static str),
        mut entries: Vec<BindGroupLayoutEntry>,
        shader: Handle<Shader>,
    ) -> Self {
        entries.extend(quad_entries());
        let build = ComputePass::queue(pipeline_cache, name, &entries, shader.clone());
        let compact = build.queue_entry(pipeline_cache, compact_name, shader, "compact");
        Self { build, compact }
    }
}

/// Bytes of an indexed indirect draw: index count, instance count, first index, base vertex,
/// first instance.
const DRAW_BYTES: u64 = 20;

/// The bindings a quad pass adds to its layout (`quads.wesl`): the meshes' indices (6) and the
/// batch's scratch words (7: each job's index count, then each strand's live quads), both written.
pub(crate) fn quad_entries() -> [BindGroupLayoutEntry; 2] {
    [6, 7].map(|b| storage_buffer_sized(false, None).build(b, ShaderStages::COMPUTE))
}

/// Where a quad mesh's indices lie.
#[derive(Clone, Copy, Debug)]
pub(crate) struct QuadIndices<'a> {
    /// The mesh.
    pub mesh: AssetId<Mesh>,
    /// The index slab it lies in.
    pub slab: &'a Buffer,
    /// Its first index in the slab.
    pub first_index: u32,
    /// Its indices (six a quad).
    pub count: u32,
    /// Its first vertex in its vertex slab.
    pub base_vertex: u32,
}

impl<'a> QuadIndices<'a> {
    /// The indices of `mesh` of `vertices` vertices (`None` when its slice holds fewer).
    pub fn of(
        mesh: AssetId<Mesh>,
        vertices: &MeshBufferSlice<'a>,
        indices: &MeshBufferSlice<'a>,
        vertex_count: usize,
    ) -> Option<Self> {
        let count = vertex_count / 4 * 6;
        (indices.range.len() >= count && count > 0).then_some(Self {
            mesh,
            slab: indices.buffer,
            first_index: indices.range.start,
            count: count as u32,
            base_vertex: vertices.range.start,
        })
    }
}

/// A job record of a pass that writes quads and their live triangles.
pub(crate) trait QuadRecord: JobRecord {
    /// The record with its mesh's first index in the batch's index binding (in words) and its
    /// index count's word in the batch's counts (or [`NO_DRAW`]).
    fn with_indices(self, index_base: u32, draw: u32) -> Self;
}

/// A quad job with its hair's place and its mesh's indices, as the batches group them.
pub(crate) type QuadMember<'a, R> = (R, HairPlacement, QuadIndices<'a>);

/// Quad meshes of one vertex slab and one index slab, bound together.
pub(crate) type QuadGroup<'a, R> = SlabGroup<&'a Buffer, QuadMember<'a, R>>;

/// Groups quad meshes (strokes, highlights) by their vertex slab within each index slab (the
/// passes write both); those the device refuses come back second.
pub(crate) fn group_quads<'a, R>(
    mut spans: Vec<SlabSpan<&'a Buffer, QuadMember<'a, R>>>,
    limits: BindingLimits,
) -> (Vec<QuadGroup<'a, R>>, Vec<QuadMember<'a, R>>) {
    spans.sort_by_key(|s| s.key.2.slab.id());
    let (mut groups, mut refused) = (Vec::new(), Vec::new());
    while !spans.is_empty() {
        let slab = spans[0].key.2.slab.id();
        let end = spans
            .iter()
            .position(|s| s.key.2.slab.id() != slab)
            .unwrap_or(spans.len());
        let rest = spans.split_off(end);
        let (g, r) = group_by_slab(spans, Buffer::id, limits);
        groups.extend(g);
        refused.extend(r);
        spans = rest;
    }
    (groups, refused)
}

/// One batch of a quad pass in the render world, reused frame to frame: its jobs, its scratch
/// words (each job's index count, which the pass's `compact` dispatch writes, then each
/// strand's live quads) and which mesh each count goes to.
pub(crate) struct QuadBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    /// The jobs' table and this frame's bind group.
    pub jobs: JobBatch<R>,
    /// The scratch words (`quads.wesl`'s binding 7).
    index_counts: Option<Buffer>,
    /// Each job's index count: its byte offset in `index_counts`, its mesh.
    counts: Vec<(u64, AssetId<Mesh>)>,
    /// Zeros to clear the counts with, kept between frames.
    zeros: Vec<u8>,
}

impl<R> Default for QuadBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    fn default() -> Self {
        Self {
            jobs: JobBatch::default(),
            index_counts: None,
            counts: Vec::new(),
            zeros: Vec::new(),
        }
    }
}

/// The bindings a quad pass adds to its bind group: the indices of its meshes and its index
/// counts.
pub(crate) struct QuadBindings<'a> {
    pub indices: BufferBinding<'a>,
    pub counts: BufferBinding<'a>,
}

impl<R: QuadRecord> QuadBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    /// Fills and uploads the batch from `group` (its meshes' indices all in one index slab);
    /// each job's index count starts at 0; with `compact`, each mesh gets its draw in
    /// `quad_draws`. `bind` makes the bind group. Returns `false` when the device cannot bind
    /// the group's indices.
    pub fn prepare(
        &mut self,
        group: &QuadGroup<'_, R>,
        (device, queue, limits): (&RenderDevice, &RenderQueue, BindingLimits),
        (quad_draws, compact): (&mut GpuQuadDraws, bool),
        bind: impl FnOnce(
            BindingResource<'_>,
            BindingResource<'_>,
            BufferBinding<'_>,
            QuadBindings<'_>,
        ) -> BindGroup,
    ) -> bool {
        self.jobs.prepared = None;
        self.counts.clear();
        let Some(index_slab) = group.members.first().map(|((_, _, i), _)| i.slab) else {
            return true;
        };
        let (lo, hi) = group
            .members
            .iter()
            .fold((u64::MAX, 0), |(lo, hi), (m, _)| {
                let i = m.2;
                (
                    lo.min(u64::from(i.first_index) * 4),
                    hi.max(u64::from(i.first_index + i.count) * 4),
                )
            });
        let lo = lo / limits.alignment * limits.alignment;
        if hi - lo > limits.max_bytes {
            return false;
        }
        let jobs_in_group = group.members.len();
        let members = group
            .members
            .iter()
            .enumerate()
            .map(|(j, &((record, hair, indices), vertex_base))| {
                let mut draw = NO_DRAW;
                if compact {
                    draw = j as u32;
                    self.counts.push((u64::from(draw) * 4, indices.mesh));
                    quad_draws.place(device, indices);
                } else if quad_draws.0.remove(&indices.mesh).is_some() {
                    // Compacted until now: its indices are put back whole this frame, as it is
                    // drawn whole.
                    draw = RESTORE_DRAW;
                }
                let index_base = ((u64::from(indices.first_index) * 4 - lo) / 4) as u32;
                ((record.with_indices(index_base, draw), hair), vertex_base)
            })
            .collect();
        let jobs = SlabGroup {
            slab: group.slab,
            offset: group.offset,
            size: group.size,
            members,
        };
        // Each job's count word; when the jobs are compacted, also each strand's live quads
        // (`quads.wesl`'s scratch words).
        let count_bytes = (jobs_in_group * 4) as u64;
        let strands: u64 = group
            .members
            .iter()
            .map(|((record, _, _), _)| u64::from(record.strands()))
            .sum();
        let bytes = if self.counts.is_empty() {
            count_bytes
        } else {
            count_bytes + strands * u64::from(1 + LIVE_WORDS) * 4
        };
        if self.index_counts.as_ref().is_none_or(|b| b.size() < bytes) {
            self.index_counts = Some(device.create_buffer(&BufferDescriptor {
                label: Some("hair_gpu_quad_counts"),
                size: bytes.next_power_of_two(),
                usage: BufferUsages::STORAGE | BufferUsages::COPY_SRC | BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let Some(count_buffer) = self.index_counts.as_ref() else {
            return true;
        };
        self.zeros.resize(count_bytes as usize, 0);
        queue.write_buffer(count_buffer, 0, &self.zeros);
        self.jobs
            .prepare(&jobs, (device, queue), |header, records, slab| {
                bind(
                    header,
                    records,
                    slab,
                    QuadBindings {
                        indices: BufferBinding {
                            buffer: index_slab,
                            offset: lo,
                            size: NonZeroU64::new(hi - lo),
                        },
                        counts: BufferBinding {
                            buffer: count_buffer,
                            offset: 0,
                            size: NonZeroU64::new(bytes),
                        },
                    },
                )
            });
        true
    }

    /// Whether the batch's jobs are drawn by count (the pass's `compact` dispatch runs).
    pub fn compacts(&self) -> bool {
        !self.counts.is_empty()
    }

    /// Copies the index counts the pass wrote to their meshes (after the pass).
    pub fn copy_counts(&self, encoder: &mut CommandEncoder, quad_draws: &GpuQuadDraws) {
        let (Some(from), Some(_)) = (&self.index_counts, &self.jobs.prepared) else {
            return;
        };
        for &(at, mesh) in &self.counts {
            if let Some(to) = quad_draws.0.get(&mesh) {
                encoder.copy_buffer_to_buffer(from, at, &to.count, 0, 4);
            }
        }
    }
}

/// Each GPU-built quad mesh's draws (render world).
#[derive(Resource, Default)]
pub(crate) struct GpuQuadDraws(HashMap<AssetId<Mesh>, QuadDraw>);

/// A quad mesh's draws.
struct QuadDraw {
    /// The index count the passes last counted for it.
    count: Buffer,
    /// Its first index and first vertex in their slabs when it was built.
    first_index: u32,
    base_vertex: u32,
    /// Each view's indexed indirect draw of it (this frame's views that draw it).
    views: HashMap<RetainedViewEntity, Buffer>,
}

impl GpuQuadDraws {
    /// Makes sure the mesh of `indices` has a draw, for where it lies now.
    fn place(&mut self, device: &RenderDevice, indices: QuadIndices<'_>) {
        let draw = self.0.entry(indices.mesh).or_insert_with(|| QuadDraw {
            count: device.create_buffer(&BufferDescriptor {
                label: Some("hair_gpu_quad_count"),
                size: 4,
                usage: BufferUsages::COPY_SRC | BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            first_index: indices.first_index,
            base_vertex: indices.base_vertex,
            views: HashMap::default(),
        });
        draw.first_index = indices.first_index;
        draw.base_vertex = indices.base_vertex;
    }

    /// Drops the draws of meshes that Bevy uploaded (their indices are whole again until a pass
    /// builds them) or dropped this frame.
    pub fn forget_uploaded(&mut self, meshes: &ExtractedAssets<RenderMesh>) {
        for id in meshes
            .added
            .iter()
            .chain(&meshes.modified)
            .chain(&meshes.removed)
        {
            self.0.remove(id);
        }
    }

    /// Copies each mesh's count into its views' draws (after the passes, every frame).
    pub fn copy_to_views(&self, encoder: &mut CommandEncoder) {
        for draw in self.0.values() {
            for view in draw.views.values() {
                encoder.copy_buffer_to_buffer(&draw.count, 0, view, 0, 4);
            }
        }
    }
}

/// Writes each view's draw of each quad mesh its transparent phase draws this frame: one
/// instance, the mesh's first index and base vertex, and the item's instance (after Bevy has
/// batched the phases).
pub(crate) fn prepare_view_quad_draws(
    mut quad_draws: ResMut<GpuQuadDraws>,
    phases: Res<ViewSortedRenderPhases<Transparent3d>>,
    instances: Res<RenderMeshInstances>,
    (device, queue): (Res<RenderDevice>, Res<RenderQueue>),
) {
    if quad_draws.0.is_empty() {
        return;
    }
    let mut seen: HashMap<AssetId<Mesh>, Vec<RetainedViewEntity>> = HashMap::default();
    for (view, phase) in &phases.0 {
        for item in phase.items.values() {
            let range = item.batch_range();
            if range.is_empty() {
                continue;
            }
            let Some(mesh) = instances.mesh_asset_id(item.main_entity()) else {
                continue;
            };
            let Some(draw) = quad_draws.0.get_mut(&mesh) else {
                continue;
            };
            let buffer = draw.views.entry(*view).or_insert_with(|| {
                device.create_buffer(&BufferDescriptor {
                    label: Some("hair_gpu_quad_draw"),
                    size: DRAW_BYTES,
                    usage: BufferUsages::INDIRECT | BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            });
            let mut words = [0u8; 16];
            for (bytes, w) in
                words
                    .chunks_exact_mut(4)
                    .zip([1, draw.first_index, draw.base_vertex, range.start])
            {
                bytes.copy_from_slice(&w.to_le_bytes());
            }
            queue.write_buffer(buffer, 4, &words);
            seen.entry(mesh).or_default().push(*view);
        }
    }
    for (mesh, draw) in &mut quad_draws.0 {
        let views = seen.get(mesh);
        draw.views
            .retain(|view, _| views.is_some_and(|v| v.contains(view)));
    }
}

/// The transparent phase's draw function of the quad materials: Bevy's material draw with
/// [`DrawQuadMesh`] in place of `DrawMesh`.
pub(crate) type DrawQuads = (
    SetItemPipeline,
    SetMeshViewBindGroup<0>,
    SetMeshViewBindingArrayBindGroup<1>,
    SetMeshBindGroup<2>,
    SetMaterialBindGroup<{ bevy::pbr::MATERIAL_BIND_GROUP_INDEX }>,
    DrawQuadMesh,
);

/// Draws a GPU-built quad mesh by its view's indirect draw (its live quads only), any other
/// mesh as Bevy's `DrawMesh` does.
pub(crate) struct DrawQuadMesh;

impl<P: PhaseItem> RenderCommand<P> for DrawQuadMesh {
    type Param = (
        SRes<GpuQuadDraws>,
        SRes<RenderMeshInstances>,
        SRes<MeshAllocator>,
        <DrawMesh as RenderCommand<P>>::Param,
    );
    type ViewQuery = (
        Read<ExtractedView>,
        <DrawMesh as RenderCommand<P>>::ViewQuery,
    );
    type ItemQuery = <DrawMesh as RenderCommand<P>>::ItemQuery;

    fn render<'w>(
        item: &P,
        (view, mesh_view): ROQueryItem<'w, '_, Self::ViewQuery>,
        entity: Option<ROQueryItem<'w, '_, Self::ItemQuery>>,
        (draws, instances, allocator, mesh_param): SystemParamItem<'w, '_, Self::Param>,
        pass: &mut TrackedRenderPass<'w>,
    ) -> RenderCommandResult {
        let (draws, allocator) = (draws.into_inner(), allocator.into_inner());
        if let Some(mesh) = instances.mesh_asset_id(item.main_entity())
            && let Some(draw) = draws.0.get(&mesh)
            && let Some(buffer) = draw.views.get(&view.retained_view_entity)
            && item.batch_range().start < item.batch_range().end
            && let Some(vertices) = allocator.mesh_vertex_slice(&mesh)
            && let Some(indices) = allocator.mesh_index_slice(&mesh)
            && vertices.range.start == draw.base_vertex
            && indices.range.start == draw.first_index
        {
            pass.set_vertex_buffer(0, vertices.buffer.slice(..));
            pass.set_index_buffer(indices.buffer.slice(..), IndexFormat::Uint32);
            pass.draw_indexed_indirect(buffer, 0);
            return RenderCommandResult::Success;
        }
        DrawMesh::render(item, mesh_view, entity, mesh_param, pass)
    }
}

/// Makes [`DrawQuads`] the transparent draw function of every prepared material of type `M`
/// (after Bevy prepares materials, before it queues meshes).
pub(crate) fn use_quad_draw_function<M: Asset>(
    mut materials: ResMut<ErasedRenderAssets<PreparedMaterial>>,
    draw_functions: Res<DrawFunctions<Transparent3d>>,
) {
    let Some(ours) = draw_functions.read().get_id::<DrawQuads>() else {
        return;
    };
    let label = MainPassTransparentDrawFunction.intern();
    for (id, material) in materials.iter_mut() {
        if id.type_id() != TypeId::of::<M>()
            || material
                .properties
                .draw_functions
                .iter()
                .any(|&(l, f)| l == label && f == ours)
        {
            continue;
        }
        match Arc::get_mut(&mut material.properties) {
            Some(properties) => set_draw_function(properties, label, ours),
            None => {
                // Shared: replaced by a copy with the quad draw.
                let mut properties = copy_properties(&material.properties);
                set_draw_function(&mut properties, label, ours);
                material.properties = Arc::new(properties);
            }
        }
    }
}

fn set_draw_function(
    properties: &mut MaterialProperties,
    label: InternedDrawFunctionLabel,
    ours: DrawFunctionId,
) {
    match properties
        .draw_functions
        .iter_mut()
        .find(|(l, _)| *l == label)
    {
        Some((_, f)) => *f = ours,
        None => properties.draw_functions.push((label, ours)),
    }
}

/// A copy of `p` (`MaterialProperties` is not `Clone`; every field is).
fn copy_properties(p: &MaterialProperties) -> MaterialProperties {
    MaterialProperties {
        render_method: p.render_method,
        alpha_mode: p.alpha_mode,
        mesh_pipeline_key_bits: p.mesh_pipeline_key_bits,
        depth_bias: p.depth_bias,
        reads_view_transmission_texture: p.reads_view_transmission_texture,
        render_phase_type: p.render_phase_type,
        material_layout: p.material_layout.clone(),
        draw_functions: p.draw_functions.clone(),
        shaders: p.shaders.clone(),
        bindless: p.bindless,
        base_specialize: p.base_specialize,
        prepass_specialize: p.prepass_specialize,
        user_specialize: p.user_specialize,
        material_key: p.material_key.clone(),
        shadows_enabled: p.shadows_enabled,
        prepass_enabled: p.prepass_enabled,
        oit_enabled: p.oit_enabled,
    }
}
