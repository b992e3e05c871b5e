//! The stroke pass: every camera's silhouette strokes of every hair of a tube batch whose stroke
//! meshes share a vertex slab, in one dispatch (`strokes.wesl`). It reads the ring frames the
//! tube pass left, finds each strand's two contours and writes the stroke strips straight into
//! the cameras' stroke meshes (the mesh allocator's slab, as for the tubes). The silhouette
//! stage decides which strokes are built this way and with what camera and parameters
//! ([`GpuStrokeJobs`](crate::silhouette::GpuStrokeJobs)); the stroke meshes keep their material,
//! so the mass scope's test against the hair mask works as for the CPU's.

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutEntries, PipelineCache, ShaderStages, ShaderType,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::quad_draw::{GpuQuadDraws, QuadBatch, QuadGroup, QuadPipelines, QuadRecord};
use super::toolbox::{
    BindingLimits, GpuBatch, HairPlacement, JobRecord, TubeBatchBuffers, vertex_offsets,
};

use crate::silhouette::GpuStrokeJob;
use crate::silhouette::adjacency::Viewer;
use crate::silhouette::gpu_jobs::gpu_stroke_vertex_count;

/// One camera's strokes of one hair (`strokes.wesl`'s `Job`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuStrokeRecord {
    /// Clip from world.
    pub view_proj: Mat4,
    /// World offset per pixel along screen x, per unit clip `w`.
    pub unproject_x: Vec4,
    /// World offset per pixel along screen y, per unit clip `w`.
    pub unproject_y: Vec4,
    /// The eye (`w = 1`) or the direction toward the viewer (`w = 0`).
    pub viewer: Vec4,
    /// Half the viewport in pixels, the depth bias, pixels per texture repeat.
    pub screen: Vec4,
    /// Half the width, half the stroke limit (pixels), angle scaling, depth scaling.
    pub width: Vec4,
    /// The E curve's `a`, `b`, `c`; `w = 1` for a camera whose offsets leave clip `w` alone.
    pub fade: Vec4,
    /// Linear RGBA.
    pub color: Vec4,
    /// The stroke mesh's first vertex in the batch's binding, in 4-byte words (set in the
    /// render world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position, the UV and the colour.
    pub position_offset: u32,
    /// See [`GpuStrokeRecord::position_offset`].
    pub uv_offset: u32,
    /// See [`GpuStrokeRecord::position_offset`].
    pub color_offset: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Sides per ring.
    pub sides: u32,
    /// Strands in the hair.
    pub strands: u32,
    /// The hair's first strand in its tube batch (set in the render world).
    pub first_strand: u32,
    /// The hair's first ring frame in its tube batch, in vec4 (set in the render world).
    pub frame_base: u32,
    /// The job's first invocation in its dispatch (set in the render world).
    pub first_invocation: u32,
    /// The stroke mesh's first index in the batch's index binding, in 4-byte words (set in the
    /// render world).
    pub index_base: u32,
    /// The word of the batch's counts that counts the job's indices, or `quad_draw::NO_DRAW`
    /// (set in the render world).
    pub draw: u32,
    /// Padding.
    pub pad: UVec2,
}

/// One camera's strokes of a hair, as the main world gathers them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct GpuStrokeInput {
    /// The stroke mesh.
    pub mesh: AssetId<Mesh>,
    /// Its record (the render world fills in where it lies).
    pub record: GpuStrokeRecord,
}

/// The stroke pass input of `job` for a hair of `strands` strands of `rings` rings and `sides`
/// sides; `None` when the job's mesh is not a GPU stroke mesh of that size.
pub(crate) fn stroke_input(
    job: &GpuStrokeJob,
    meshes: &Assets<Mesh>,
    rings: usize,
    sides: usize,
    strands: usize,
) -> Option<GpuStrokeInput> {
    let mesh = meshes.get(job.mesh)?;
    if mesh.count_vertices() != gpu_stroke_vertex_count(strands, rings, sides) || rings < 2 {
        return None;
    }
    let [position, uv, color, stride] = vertex_offsets(
        mesh,
        [
            Mesh::ATTRIBUTE_POSITION.id,
            Mesh::ATTRIBUTE_UV_0.id,
            Mesh::ATTRIBUTE_COLOR.id,
        ],
    )?;
    let camera = &job.camera;
    let viewer = match camera.viewer()? {
        Viewer::Point(p) => p.extend(1.0),
        Viewer::Direction(d) => d.extend(0.0),
    };
    let (unproject_x, unproject_y) = camera.unproject();
    let p = &job.params;
    Some(GpuStrokeInput {
        mesh: job.mesh,
        record: GpuStrokeRecord {
            view_proj: camera.view_proj(),
            unproject_x,
            unproject_y,
            viewer,
            screen: Vec4::new(
                camera.viewport().x * 0.5,
                camera.viewport().y * 0.5,
                if p.depth_bias.is_finite() {
                    p.depth_bias
                } else {
                    0.0
                },
                p.texture_length_px.max(1e-3),
            ),
            width: Vec4::new(
                0.5 * p.width_px * p.stroke_scale,
                (0.5 * p.stroke_limit_px).max(0.0),
                p.angle_scale,
                p.depth_scale,
            ),
            fade: Vec4::new(
                p.fade.a,
                p.fade.b,
                p.fade.c,
                f32::from(u8::from(unproject_x.w == 0.0 && unproject_y.w == 0.0)),
            ),
            color: Vec4::from_array(p.color),
            vertex_base: 0,
            stride,
            position_offset: position,
            uv_offset: uv,
            color_offset: color,
            rings: rings as u32,
            sides: sides as u32,
            strands: strands as u32,
            ..default()
        },
    })
}

/// The stroke pass's pipelines, made in `RenderStartup`.
#[derive(Resource)]
pub(crate) struct GpuStrokePipeline(pub QuadPipelines);

/// Queues the stroke pass's pipelines.
pub(crate) fn init_gpu_stroke_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    let entries = BindGroupLayoutEntries::sequential(
        ShaderStages::COMPUTE,
        (
            uniform_buffer::<GpuBatch>(false),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_read_only_sized(false, None),
            storage_buffer_sized(false, None),
        ),
    )
    .to_vec();
    commands.insert_resource(GpuStrokePipeline(QuadPipelines::queue(
        &pipeline_cache,
        ("hair_gpu_strokes", "hair_gpu_strokes_compact"),
        entries,
        load_embedded_asset!(asset_server.as_ref(), "strokes.wesl"),
    )));
}

/// The vertices a stroke job writes.
pub(crate) fn stroke_vertices(record: &GpuStrokeRecord) -> usize {
    gpu_stroke_vertex_count(
        record.strands as usize,
        record.rings as usize,
        record.sides as usize,
    )
}

impl JobRecord for GpuStrokeRecord {
    fn strands(&self) -> u32 {
        self.strands
    }

    fn placed(self, vertex_base: u32, hair: HairPlacement, first_invocation: u32) -> Self {
        Self {
            vertex_base,
            first_strand: hair.first_strand,
            frame_base: hair.frame_base,
            first_invocation,
            ..self
        }
    }
}

impl QuadRecord for GpuStrokeRecord {
    fn with_indices(self, index_base: u32, draw: u32) -> Self {
        Self {
            index_base,
            draw,
            ..self
        }
    }
}

/// One stroke batch in the render world.
pub(crate) type StrokeBatch = QuadBatch<GpuStrokeRecord>;

/// Fills and uploads `batch` from `group` (its meshes' indices in one index slab), with its
/// bind group over the tube batch's buffers. Returns `false` when the device cannot bind the
/// group's indices.
pub(crate) fn prepare_stroke_batch(
    batch: &mut StrokeBatch,
    group: &QuadGroup<'_, GpuStrokeRecord>,
    tubes: TubeBatchBuffers<'_>,
    render: (&RenderDevice, &RenderQueue, BindingLimits),
    (pipeline, pipeline_cache): (&GpuStrokePipeline, &PipelineCache),
    draws: (&mut GpuQuadDraws, bool),
) -> bool {
    let device = render.0;
    batch.prepare(group, render, draws, |header, records, slab, quads| {
        device.create_bind_group(
            "hair_gpu_strokes",
            &pipeline_cache.get_bind_group_layout(&pipeline.0.build.layout),
            &BindGroupEntries::sequential((
                header,
                records,
                tubes.strands.as_entire_binding(),
                tubes.points.as_entire_binding(),
                tubes.frames.as_entire_binding(),
                slab,
                quads.indices,
                quads.counts,
            )),
        )
    })
}
