//! The tube pass: every hair of a vertex slab in one dispatch (`tubes.wesl`). The batch's
//! buffers hold every hair's record, strands, particles and cross-sections one after another;
//! the pass sweeps each strand's tube into its hair mesh's vertices and leaves each ring's frame
//! for the stroke and highlight passes.

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutEntries, Buffer, BufferDescriptor, BufferUsages,
    PipelineCache, ShaderStages, ShaderType, StorageBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::toolbox::{
    ComputePass, GpuBatch, HairPlacement, PreparedBatch, RING_FRAME_VEC4S, RecordBuffers,
    SlabGroup, TubeBatchBuffers,
};

/// One hair of a tube batch (`tubes.wesl`'s `Hair`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuTubeHair {
    /// The mesh's first vertex in the batch's binding, in 4-byte words (set in the render
    /// world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position, the normal and the tangent.
    pub position_offset: u32,
    /// See [`GpuTubeHair::position_offset`].
    pub normal_offset: u32,
    /// See [`GpuTubeHair::position_offset`].
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
    /// See [`GpuTubeHair::metric_x`].
    pub metric_y: Vec4,
    /// See [`GpuTubeHair::metric_x`].
    pub metric_z: Vec4,
    /// The bone's up axis, for the angel ring's tangents.
    pub up: Vec4,
    /// The eye its half tubes (`w = 1`) or ribbons (`w = 2`) face; `w = 0`: closed tubes (see
    /// [`TubeTopology::facing`](crate::mesh::tube::TubeTopology::facing) and
    /// [`TubeTopology::ribbon`](crate::mesh::tube::TubeTopology::ribbon)).
    pub eye: Vec4,
    /// Its first strand in the batch (set in the render world).
    pub first_strand: u32,
    /// Its first ring frame in the batch, in vec4 (set in the render world).
    pub frame_base: u32,
    /// Sides in its cross-section tables: the closed ring's (a half tube's ring has fewer
    /// vertices).
    pub closed_sides: u32,
    /// Padding.
    pub pad: u32,
}

/// One strand of a batch (`common.wesl`'s `Strand`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuStrand {
    /// The root frame's reference direction, turned with the bone.
    pub reference_direction: Vec4,
    /// The root frame's reference normal, turned with the bone.
    pub reference_normal: Vec4,
    /// Its first particle in the points (the hair's own, until batched).
    pub first: u32,
    /// Its particle count.
    pub count: u32,
    /// Its cross-section's first side in the points, in vec4 (the hair's own sections until
    /// batched).
    pub section: u32,
    /// Its hair in the batch's table (set in the render world).
    pub hair: u32,
}

/// One hair's tube input as the main world gathers it.
pub(crate) struct TubeHairInput<'a> {
    /// Its record (`vertex_base`, `first_strand` and `frame_base` are filled here).
    pub hair: GpuTubeHair,
    /// Its mesh.
    pub mesh: AssetId<Mesh>,
    /// Its strands: `first` into `particles`, `section` into `sections`.
    pub strands: &'a [GpuStrand],
    /// Its particles.
    pub particles: &'a [Vec4],
    /// Its cross-sections, two vec4 a side.
    pub sections: &'a [Vec4],
}

/// The tube pass.
#[derive(Resource)]
pub(crate) struct GpuTubePipeline(pub ComputePass);

pub(crate) fn init_gpu_tube_pipeline(
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
                uniform_buffer::<GpuBatch>(false),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
        load_embedded_asset!(asset_server.as_ref(), "tubes.wesl"),
    )));
}

/// One tube batch's buffers in the render world, reused frame to frame.
#[derive(Default)]
pub(crate) struct TubeBatch {
    records: RecordBuffers<GpuTubeHair>,
    strands: StorageBuffer<Vec<GpuStrand>>,
    points: StorageBuffer<Vec<Vec4>>,
    /// The ring frames the pass writes (GPU only).
    frames: Option<Buffer>,
    /// This frame's bind group.
    pub prepared: Option<PreparedBatch>,
}

impl TubeBatch {
    /// The buffers the stroke and highlight passes read, once prepared.
    pub fn buffers(&self) -> Option<TubeBatchBuffers<'_>> {
        self.prepared.as_ref()?;
        Some(TubeBatchBuffers {
            strands: self.strands.buffer()?,
            points: self.points.buffer()?,
            frames: self.frames.as_ref()?,
        })
    }

    /// Fills the batch from `group` (hairs of one slab: each an index into `hairs` and its first
    /// vertex in the group's binding), uploads it and makes its bind group. Returns each hair's
    /// placement, by index into `hairs`.
    pub fn prepare(
        &mut self,
        index: usize,
        group: &SlabGroup<&Buffer, usize>,
        hairs: &[TubeHairInput<'_>],
        (device, queue): (&RenderDevice, &RenderQueue),
        (pipeline, pipeline_cache): (&GpuTubePipeline, &PipelineCache),
    ) -> Vec<(usize, HairPlacement)> {
        self.prepared = None;
        let (records, strands, points) = (
            self.records.records(),
            self.strands.get_mut(),
            self.points.get_mut(),
        );
        strands.clear();
        points.clear();
        let mut placements = Vec::with_capacity(group.members.len());
        let mut frames = 0u32;
        for &(i, vertex_base) in &group.members {
            let input = &hairs[i];
            let placement = HairPlacement {
                hair_mesh: input.mesh,
                batch: index,
                first_strand: strands.len() as u32,
                frame_base: frames,
            };
            let record = records.len() as u32;
            let first_particle = points.len() as u32;
            points.extend_from_slice(input.particles);
            let first_section = points.len() as u32;
            points.extend_from_slice(input.sections);
            strands.extend(input.strands.iter().map(|s| GpuStrand {
                first: s.first + first_particle,
                section: s.section + first_section,
                hair: record,
                ..*s
            }));
            records.push(GpuTubeHair {
                vertex_base,
                first_strand: placement.first_strand,
                frame_base: placement.frame_base,
                ..input.hair
            });
            frames += input.hair.strands * input.hair.rings * RING_FRAME_VEC4S;
            placements.push((i, placement));
        }
        let invocations = strands.len() as u32;
        if invocations == 0 {
            return Vec::new();
        }
        // `frames` counts vec4s.
        let frame_bytes = u64::from(frames) * 16;
        if self.frames.as_ref().is_none_or(|b| b.size() < frame_bytes) {
            self.frames = Some(device.create_buffer(&BufferDescriptor {
                label: Some("hair_gpu_tube_frames"),
                size: frame_bytes,
                usage: BufferUsages::STORAGE,
                mapped_at_creation: false,
            }));
        }
        self.strands.write_buffer(device, queue);
        self.points.write_buffer(device, queue);
        let Some((header, records)) = self.records.upload(invocations, device, queue) else {
            return Vec::new();
        };
        let (Some(strands), Some(points), Some(frames)) = (
            self.strands.binding(),
            self.points.binding(),
            self.frames.as_ref(),
        ) else {
            return Vec::new();
        };
        let bind_group = device.create_bind_group(
            "hair_gpu_tubes",
            &pipeline_cache.get_bind_group_layout(&pipeline.0.layout),
            &BindGroupEntries::sequential((
                header,
                records,
                strands,
                points,
                group.binding(),
                frames.as_entire_binding(),
            )),
        );
        self.prepared = Some(PreparedBatch {
            bind_group,
            invocations,
        });
        placements
    }
}
