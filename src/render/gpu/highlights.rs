//! The highlight pass: the specular sampling quads of every hair of a tube batch whose highlight
//! meshes share a vertex slab, in one dispatch (`highlights.wesl`). It reads the ring frames the
//! tube pass left and writes the highlight strips straight into the hairs' highlight meshes,
//! and the triangles of the quads that show at the front of the meshes' indices
//! ([`quad_draw`](super::quad_draw)).
//! The mesh stage decides what is built
//! ([`GpuHighlightJob`](crate::mesh::highlights::GpuHighlightJob)).

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::render_resource::{BindGroupEntries, PipelineCache, ShaderType};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::quad_draw::{GpuQuadDraws, QuadBatch, QuadGroup, QuadPipelines, QuadRecord};
use super::toolbox::{
    BindingLimits, HairPlacement, JobRecord, TubeBatchBuffers, read_write_entries, vertex_offsets,
};

use crate::math::finite_or;
use crate::mesh::highlights::{GpuHighlights, gpu_highlight_vertex_count};

/// One hair's highlights (`highlights.wesl`'s `Job`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuHighlightRecord {
    /// The eye.
    pub eye: Vec4,
    /// The direction toward the light.
    pub to_light: Vec4,
    /// Threshold, shininess, strip width as a fraction of the radius.
    pub settings: Vec4,
    /// The mesh's first vertex in the batch's binding, in 4-byte words (set in the render
    /// world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position and the UV.
    pub position_offset: u32,
    /// See [`GpuHighlightRecord::position_offset`].
    pub uv_offset: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Strands in the hair.
    pub strands: u32,
    /// The hair's first ring frame in its tube batch, in vec4 (set in the render world).
    pub frame_base: u32,
    /// The job's first invocation in its dispatch (set in the render world).
    pub first_invocation: u32,
    /// The mesh's first index in the batch's index binding, in 4-byte words (set in the render
    /// world).
    pub index_base: u32,
    /// The word of the batch's counts that counts the job's indices, or `quad_draw::NO_DRAW`
    /// (set in the render world).
    pub draw: u32,
    /// Padding.
    pub pad: UVec2,
}

/// A hair's highlights, as the main world gathers them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct GpuHighlightInput {
    /// The highlight mesh.
    pub mesh: AssetId<Mesh>,
    /// Its record (the render world fills in where it lies).
    pub record: GpuHighlightRecord,
}

/// The highlight pass input of `job` for a hair of `strands` strands of `rings` rings; `None`
/// when the job's mesh is not a GPU highlight mesh of that size.
pub(crate) fn highlight_input(
    job: &GpuHighlights,
    meshes: &Assets<Mesh>,
    rings: usize,
    strands: usize,
) -> Option<GpuHighlightInput> {
    let mesh = meshes.get(job.mesh)?;
    if mesh.count_vertices() != gpu_highlight_vertex_count(strands, rings) || rings < 2 {
        return None;
    }
    let [position, uv, _, stride] = vertex_offsets(
        mesh,
        [
            Mesh::ATTRIBUTE_POSITION.id,
            Mesh::ATTRIBUTE_UV_0.id,
            Mesh::ATTRIBUTE_NORMAL.id,
        ],
    )?;
    let s = &job.settings;
    Some(GpuHighlightInput {
        mesh: job.mesh,
        record: GpuHighlightRecord {
            eye: job.eye.extend(1.0),
            to_light: job.to_light.extend(0.0),
            settings: Vec4::new(
                finite_or(s.threshold, 0.6),
                finite_or(s.shininess, 30.0),
                finite_or(s.width, 0.5),
                0.0,
            ),
            vertex_base: 0,
            stride,
            position_offset: position,
            uv_offset: uv,
            rings: rings as u32,
            strands: strands as u32,
            ..default()
        },
    })
}

/// The highlight pass's pipelines, made in `RenderStartup`.
#[derive(Resource)]
pub(crate) struct GpuHighlightPipeline(pub QuadPipelines);

/// Queues the highlight pass's pipelines.
pub(crate) fn init_gpu_highlight_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuHighlightPipeline(QuadPipelines::queue(
        &pipeline_cache,
        ("hair_gpu_highlights", "hair_gpu_highlights_compact"),
        read_write_entries(),
        load_embedded_asset!(asset_server.as_ref(), "highlights.wesl"),
    )));
}

/// The vertices a highlight job writes.
pub(crate) fn highlight_vertices(record: &GpuHighlightRecord) -> usize {
    gpu_highlight_vertex_count(record.strands as usize, record.rings as usize)
}

impl JobRecord for GpuHighlightRecord {
    fn strands(&self) -> u32 {
        self.strands
    }

    fn placed(self, vertex_base: u32, hair: HairPlacement, first_invocation: u32) -> Self {
        Self {
            vertex_base,
            frame_base: hair.frame_base,
            first_invocation,
            ..self
        }
    }
}

impl QuadRecord for GpuHighlightRecord {
    fn with_indices(self, index_base: u32, draw: u32) -> Self {
        Self {
            index_base,
            draw,
            ..self
        }
    }
}

/// One highlight batch in the render world.
pub(crate) type HighlightBatch = QuadBatch<GpuHighlightRecord>;

/// Fills and uploads `batch` from `group` (its meshes' indices in one index slab), with its
/// bind group over the tube batch's frames. Returns `false` when the device cannot bind the
/// group's indices.
pub(crate) fn prepare_highlight_batch(
    batch: &mut HighlightBatch,
    group: &QuadGroup<'_, GpuHighlightRecord>,
    tubes: TubeBatchBuffers<'_>,
    render: (&RenderDevice, &RenderQueue, BindingLimits),
    (pipeline, pipeline_cache): (&GpuHighlightPipeline, &PipelineCache),
    draws: (&mut GpuQuadDraws, bool),
) -> bool {
    let device = render.0;
    batch.prepare(group, render, draws, |header, records, slab, quads| {
        device.create_bind_group(
            "hair_gpu_highlights",
            &pipeline_cache.get_bind_group_layout(&pipeline.0.build.layout),
            &BindGroupEntries::with_indices((
                (0, header),
                (1, records),
                (2, tubes.frames.as_entire_binding()),
                (3, slab),
                (6, quads.indices),
                (7, quads.counts),
            )),
        )
    })
}
