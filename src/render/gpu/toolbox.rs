//! What the GPU geometry passes share: their constants (given to the shaders as shader defs),
//! queuing a pass's pipeline, the batch header, grouping meshes by the vertex slab they live in
//! and dispatching one pass over a whole batch. Imports none of its sibling passes.

use std::num::NonZeroU64;

use bevy::mesh::MeshVertexAttributeId;
use bevy::prelude::*;
use bevy::render::mesh::allocator::MeshBufferSlice;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer,
};
use bevy::render::render_resource::encase::internal::WriteInto;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries,
    BindGroupLayoutEntry, BindingResource, Buffer, BufferBinding, CachedComputePipelineId,
    ComputePass as WgpuComputePass, ComputePipelineDescriptor, PipelineCache, ShaderStages,
    ShaderType, StorageBuffer, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::settings::WgpuLimits;
use bevy::shader::ShaderDefVal;

use crate::mesh::shadow::SHADOW_RING_STEP;
use crate::mesh::tube::{CAP_VERTICES, MAX_RINGS, MAX_SIDES, MIN_RINGS, MIN_SIDES};

/// Invocations in a workgroup of every pass (`constants::WORKGROUP_SIZE`).
pub const WORKGROUP_SIZE: u32 = 64;
/// Vec4s in a ring's frame as the tube pass leaves it (`constants::RING_FRAME_VEC4S`): centre
/// and radius; normal and radial weight; binormal and axial part.
pub const RING_FRAME_VEC4S: u32 = 3;
/// Vertices of a stroke or highlight quad (`constants::QUAD_VERTICES`).
pub const QUAD_VERTICES: u32 = 4;

/// The constants every pass's shader reads as `constants::NAME`, from the Rust that lays out
/// its buffers and meshes.
pub fn shader_defs() -> Vec<ShaderDefVal> {
    let uint = |name: &'static str, value: u32| ShaderDefVal::UInt(name.into(), value);
    vec![
        uint("WORKGROUP_SIZE", WORKGROUP_SIZE),
        uint("RING_FRAME_VEC4S", RING_FRAME_VEC4S),
        uint("QUAD_VERTICES", QUAD_VERTICES),
        uint("TUBE_CAP_VERTICES", CAP_VERTICES as u32),
        uint("MIN_RINGS", MIN_RINGS as u32),
        uint("MIN_SIDES", MIN_SIDES as u32),
        uint("MAX_RINGS", MAX_RINGS as u32),
        uint("MAX_SIDES", MAX_SIDES as u32),
        uint("NO_DRAW", super::quad_draw::NO_DRAW),
        uint("RESTORE_DRAW", super::quad_draw::RESTORE_DRAW),
        uint("LIVE_WORDS", super::quad_draw::LIVE_WORDS),
        uint("SHADOW_RING_STEP", SHADOW_RING_STEP as u32),
    ]
}

/// The uniform of one dispatch (`common.wesl`'s `Batch`): how many invocations do work and how
/// many records (hairs or jobs) the batch's table holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct GpuBatch {
    /// Invocations that do work (strands of every hair or job of the batch).
    pub invocations: u32,
    /// Records in the batch's table.
    pub records: u32,
    /// Padding.
    pub pad: UVec2,
}

/// A compute pass of the crate: its pipeline and bind group layout, queued in `RenderStartup`.
pub struct ComputePass {
    /// The pass's one bind group.
    pub layout: BindGroupLayoutDescriptor,
    /// Its pipeline.
    pub pipeline: CachedComputePipelineId,
}

impl ComputePass {
    /// Queues a pass whose bind group is the batch header, its job records, one buffer it reads
    /// and one it writes: the shadow pass (the tube batch's ring frames in, a vertex slab out)
    /// and the draw-order pass (the strands' sort keys in, the order out).
    pub fn queue_read_write(
        pipeline_cache: &PipelineCache,
        name: &'static str,
        shader: Handle<Shader>,
    ) -> Self {
        Self::queue(pipeline_cache, name, &read_write_entries(), shader)
    }

    /// Queues the pass `name` (its entry point `build` in `shader`, with [`shader_defs`]) with a
    /// bind group of `entries`.
    pub fn queue(
        pipeline_cache: &PipelineCache,
        name: &'static str,
        entries: &[BindGroupLayoutEntry],
        shader: Handle<Shader>,
    ) -> Self {
        let layout = BindGroupLayoutDescriptor::new(name, entries);
        let pipeline = queue_entry(pipeline_cache, name, &layout, shader, "build");
        Self { layout, pipeline }
    }

    /// Queues another entry point of the pass's shader, `entry`, with the same bind group.
    pub fn queue_entry(
        &self,
        pipeline_cache: &PipelineCache,
        name: &'static str,
        shader: Handle<Shader>,
        entry: &'static str,
    ) -> CachedComputePipelineId {
        queue_entry(pipeline_cache, name, &self.layout, shader, entry)
    }
}

fn queue_entry(
    pipeline_cache: &PipelineCache,
    name: &'static str,
    layout: &BindGroupLayoutDescriptor,
    shader: Handle<Shader>,
    entry: &'static str,
) -> CachedComputePipelineId {
    pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
        label: Some(name.into()),
        layout: vec![layout.clone()],
        shader,
        shader_defs: shader_defs(),
        entry_point: Some(entry.into()),
        ..default()
    })
}

/// The bindings of a [`ComputePass::queue_read_write`] pass: the batch header, its job
/// records, the buffer it reads and the one it writes (0 to 3).
pub fn read_write_entries() -> Vec<BindGroupLayoutEntry> {
    BindGroupLayoutEntries::sequential(
        ShaderStages::COMPUTE,
        (
            uniform_buffer::<GpuBatch>(false),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_sized(false, None),
        ),
    )
    .to_vec()
}

/// Word offsets of three attributes in `mesh`'s interleaved vertex, then the words per vertex;
/// `None` if one is missing. An attribute may be asked for twice.
pub fn vertex_offsets(mesh: &Mesh, attributes: [MeshVertexAttributeId; 3]) -> Option<[u32; 4]> {
    let (mut offset, mut found) = (0u64, [None; 3]);
    for (attribute, _) in mesh.attributes() {
        for (slot, id) in attributes.iter().enumerate() {
            if *id == attribute.id {
                found[slot] = Some((offset / 4) as u32);
            }
        }
        offset += attribute.format.size();
    }
    Some([found[0]?, found[1]?, found[2]?, (offset / 4) as u32])
}

/// A mesh a pass writes: where it lies in its vertex slab `B` (a buffer), bytes.
#[derive(Clone, Copy, Debug)]
pub struct SlabSpan<B, T> {
    /// What the caller wants back with the mesh's place in the binding.
    pub key: T,
    /// The slab.
    pub slab: B,
    /// The mesh's first byte in the slab.
    pub start: u64,
    /// One past its last byte.
    pub end: u64,
}

impl<'a, T> SlabSpan<&'a Buffer, T> {
    /// The span of `vertices` vertices of `stride_words` words at the start of `slice`; `None`
    /// when the mesh has fewer vertices (or none are asked for).
    pub fn new(
        key: T,
        slice: &MeshBufferSlice<'a>,
        stride_words: u32,
        vertices: usize,
    ) -> Option<Self> {
        if slice.range.len() < vertices || vertices == 0 {
            return None;
        }
        let stride = u64::from(stride_words) * 4;
        let start = u64::from(slice.range.start) * stride;
        Some(Self {
            key,
            slab: slice.buffer,
            start,
            end: start + vertices as u64 * stride,
        })
    }
}

/// Meshes of one slab bound together as one storage binding: one dispatch writes all of them.
#[derive(Debug, PartialEq)]
pub struct SlabGroup<B, T> {
    /// The slab.
    pub slab: B,
    /// The binding's offset: the aligned offset at or before the first mesh.
    pub offset: u64,
    /// The binding's size, to the end of the last mesh.
    pub size: u64,
    /// Each mesh's key and its first vertex in the binding, in 4-byte words.
    pub members: Vec<(T, u32)>,
}

impl<'a, T> SlabGroup<&'a Buffer, T> {
    /// The group's storage binding.
    pub fn binding(&self) -> BufferBinding<'a> {
        BufferBinding {
            buffer: self.slab,
            offset: self.offset,
            size: NonZeroU64::new(self.size),
        }
    }
}

/// What the device allows a storage binding.
#[derive(Clone, Copy, Debug)]
pub struct BindingLimits {
    /// `max_storage_buffer_binding_size`.
    pub max_bytes: u64,
    /// `min_storage_buffer_offset_alignment` (at least 4).
    pub alignment: u64,
}

impl BindingLimits {
    /// The limits of a device's `limits`.
    pub fn of(limits: &WgpuLimits) -> Self {
        Self {
            max_bytes: limits.max_storage_buffer_binding_size,
            alignment: u64::from(limits.min_storage_buffer_offset_alignment).max(4),
        }
    }
}

/// Groups `spans` by slab (`slab_key` tells slabs apart), in as few bindings as the device
/// allows: meshes of one slab share a binding until it would be larger than
/// `limits.max_bytes`. A mesh whose own binding would be larger comes back in the second list
/// (the device refuses it).
pub fn group_by_slab<B: Copy, K: Ord, T>(
    mut spans: Vec<SlabSpan<B, T>>,
    slab_key: impl Fn(B) -> K,
    limits: BindingLimits,
) -> (Vec<SlabGroup<B, T>>, Vec<T>) {
    spans.sort_by_key(|s| (slab_key(s.slab), s.start));
    let (mut groups, mut refused) = (Vec::<SlabGroup<B, T>>::new(), Vec::new());
    for span in spans {
        let aligned = span.start / limits.alignment * limits.alignment;
        if span.end - aligned > limits.max_bytes {
            refused.push(span.key);
            continue;
        }
        let group = match groups.last_mut() {
            Some(g)
                if slab_key(g.slab) == slab_key(span.slab)
                    && span.end - g.offset <= limits.max_bytes =>
            {
                g
            }
            _ => {
                groups.push(SlabGroup {
                    slab: span.slab,
                    offset: aligned,
                    size: 0,
                    members: Vec::new(),
                });
                groups.last_mut().expect("just pushed")
            }
        };
        group.size = group.size.max(span.end - group.offset);
        group
            .members
            .push((span.key, ((span.start - group.offset) / 4) as u32));
    }
    (groups, refused)
}

/// Where a hair of a tube batch lies in the batch's buffers, for the passes that read the frames
/// its tube pass leaves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HairPlacement {
    /// Its hair mesh (a stroke or highlight mesh the device refuses puts this hair back on the
    /// CPU).
    pub hair_mesh: AssetId<Mesh>,
    /// Its tube batch.
    pub batch: usize,
    /// Its first strand in the batch's strands.
    pub first_strand: u32,
    /// Its first ring frame in the batch's frames, in vec4.
    pub frame_base: u32,
}

/// A tube batch's buffers that the stroke and highlight passes read.
#[derive(Clone, Copy)]
pub struct TubeBatchBuffers<'a> {
    /// The strands.
    pub strands: &'a Buffer,
    /// The particles, then the cross-sections.
    pub points: &'a Buffer,
    /// The ring frames the tube pass writes.
    pub frames: &'a Buffer,
}

/// One dispatch's header and table of records (hairs or jobs), reused frame to frame.
pub struct RecordBuffers<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    header: UniformBuffer<GpuBatch>,
    records: StorageBuffer<Vec<R>>,
}

impl<R> Default for RecordBuffers<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    fn default() -> Self {
        Self {
            header: UniformBuffer::default(),
            records: StorageBuffer::from(Vec::new()),
        }
    }
}

impl<R> RecordBuffers<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    /// The table, to fill for this frame (cleared).
    pub fn records(&mut self) -> &mut Vec<R> {
        let records = self.records.get_mut();
        records.clear();
        records
    }

    /// Uploads the header (`invocations` and the table's length) and the table; their
    /// bindings, or `None` for an empty table.
    pub fn upload(
        &mut self,
        invocations: u32,
        device: &RenderDevice,
        queue: &RenderQueue,
    ) -> Option<(BindingResource<'_>, BindingResource<'_>)> {
        let records = self.records.get().len() as u32;
        if records == 0 {
            return None;
        }
        self.header.set(GpuBatch {
            invocations,
            records,
            pad: UVec2::ZERO,
        });
        self.header.write_buffer(device, queue);
        self.records.write_buffer(device, queue);
        Some((self.header.binding()?, self.records.binding()?))
    }
}

/// A batch ready to run: its bind group and the invocations that do work.
pub struct PreparedBatch {
    /// The pass's bind group over the batch.
    pub bind_group: BindGroup,
    /// Strands to build (of every hair or job of the batch).
    pub invocations: u32,
}

/// A job of the passes that read a tube batch's frames (a camera's strokes of a hair, a hair's
/// highlights).
pub trait JobRecord: Copy {
    /// Strands the job builds (one invocation each).
    fn strands(&self) -> u32;
    /// The record placed: its first vertex in the binding, its hair in the tube batch, its first
    /// invocation.
    fn placed(self, vertex_base: u32, hair: HairPlacement, first_invocation: u32) -> Self;
}

/// One batch of jobs in the render world, reused frame to frame.
pub struct JobBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    records: RecordBuffers<R>,
    /// This frame's bind group.
    pub prepared: Option<PreparedBatch>,
}

impl<R> Default for JobBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    fn default() -> Self {
        Self {
            records: RecordBuffers::default(),
            prepared: None,
        }
    }
}

impl<R: JobRecord> JobBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    /// Fills the batch from `group` (jobs of one slab, each with its hair's placement and its
    /// first vertex in the group's binding) and uploads it; `bind` makes the bind group from
    /// the header, the table and the slab binding.
    pub fn prepare(
        &mut self,
        group: &SlabGroup<&Buffer, (R, HairPlacement)>,
        (device, queue): (&RenderDevice, &RenderQueue),
        bind: impl FnOnce(BindingResource<'_>, BindingResource<'_>, BufferBinding<'_>) -> BindGroup,
    ) {
        self.prepared = None;
        let records = self.records.records();
        let mut invocations = 0;
        for &((record, hair), vertex_base) in &group.members {
            records.push(record.placed(vertex_base, hair, invocations));
            invocations += record.strands();
        }
        let Some((header, records)) = self.records.upload(invocations, device, queue) else {
            return;
        };
        self.prepared = Some(PreparedBatch {
            bind_group: bind(header, records, group.binding()),
            invocations,
        });
    }
}

impl<R: JobRecord> JobBatch<R>
where
    Vec<R>: ShaderType + WriteInto,
{
    /// Fills and uploads the batch of a [`ComputePass::queue_read_write`] pass from `group`,
    /// with its bind group over the tube batch's frames.
    pub fn prepare_frame_job(
        &mut self,
        group: &SlabGroup<&Buffer, (R, HairPlacement)>,
        tubes: TubeBatchBuffers<'_>,
        (device, queue): (&RenderDevice, &RenderQueue),
        (pass, pipeline_cache): (&ComputePass, &PipelineCache),
    ) {
        self.prepare(group, (device, queue), |header, records, slab| {
            device.create_bind_group(
                pass.layout.label.as_ref(),
                &pipeline_cache.get_bind_group_layout(&pass.layout),
                &BindGroupEntries::sequential((
                    header,
                    records,
                    tubes.frames.as_entire_binding(),
                    slab,
                )),
            )
        });
    }
}

/// Dispatches enough workgroups of [`WORKGROUP_SIZE`] for `invocations` (in two dimensions
/// past the device's `max_per_dimension`; `common.wesl`'s `invocation` reads them back).
/// Returns whether anything was dispatched.
pub fn dispatch(pass: &mut WgpuComputePass, invocations: u32, max_per_dimension: u32) -> bool {
    let groups = invocations.div_ceil(WORKGROUP_SIZE);
    if groups == 0 {
        return false;
    }
    let x = groups.min(max_per_dimension.max(1));
    pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn span(key: &str, slab: u32, start: u64, end: u64) -> SlabSpan<u32, &str> {
        SlabSpan {
            key,
            slab,
            start,
            end,
        }
    }

    #[test]
    fn meshes_of_one_slab_share_a_binding_until_it_would_be_too_large() {
        let limits = BindingLimits {
            max_bytes: 1000,
            alignment: 256,
        };
        let (groups, refused) = group_by_slab(
            vec![
                span("c", 0, 600, 900),
                span("a", 0, 4, 300),
                span("x", 1, 260, 400),
                span("b", 0, 300, 600),
                span("d", 0, 900, 1100),
                span("big", 2, 0, 1001),
                span("far", 2, 5000, 5800),
            ],
            |s| s,
            limits,
        );
        assert_eq!(refused, vec!["big"]);
        let summary: Vec<_> = groups
            .iter()
            .map(|g| (g.slab, g.offset, g.size, g.members.clone()))
            .collect();
        assert_eq!(
            summary,
            vec![
                // a, b, c from offset 0 (a's first byte is 4 bytes, one word, in); d would end
                // 1100 bytes past it, so it starts a binding of its own at 768.
                (0, 0, 900, vec![("a", 1), ("b", 75), ("c", 150)]),
                (0, 768, 332, vec![("d", 33)]),
                (1, 256, 144, vec![("x", 1)]),
                // Its binding starts at 4864, the aligned offset before 5000.
                (2, 4864, 936, vec![("far", 34)]),
            ],
        );
    }

    #[test]
    fn the_shaders_get_every_constant_the_rust_side_lays_out_with() {
        let defs = shader_defs();
        for (name, value) in [
            ("WORKGROUP_SIZE", 64),
            ("RING_FRAME_VEC4S", 3),
            ("TUBE_CAP_VERTICES", 2),
            ("QUAD_VERTICES", 4),
            ("MAX_RINGS", 256),
            ("MAX_SIDES", 64),
            ("LIVE_WORDS", 20),
        ] {
            assert!(
                defs.iter()
                    .any(|d| matches!(d, ShaderDefVal::UInt(n, v) if n == name && *v == value)),
                "{name} = {value} missing from {defs:?}"
            );
        }
    }
}
