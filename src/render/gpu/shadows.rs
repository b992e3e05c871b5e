//! The shadow pass: the shadow ribbons of every hair of a tube batch whose ribbon meshes share a
//! vertex slab, in one dispatch (`shadows.wesl`). It reads the ring frames the tube pass left
//! and writes two vertices a ring straight into the hairs' ribbon meshes. The mesh stage decides
//! what is built ([`GpuShadowJob`](crate::mesh::shadow::GpuShadowJob)).

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::render_resource::{PipelineCache, ShaderType};

use super::toolbox::{ComputePass, HairPlacement, JobBatch, JobRecord, vertex_offsets};
use crate::mesh::shadow::{GpuShadowRibbons, shadow_ribbon_vertex_count};

/// One hair's shadow ribbons (`shadows.wesl`'s `Job`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuShadowRecord {
    /// The light: the direction toward it (`w = 0`) or its position (`w = 1`).
    pub light: Vec4,
    /// The mesh's first vertex in the batch's binding, in 4-byte words (set in the render
    /// world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offset in a vertex of the position.
    pub position_offset: u32,
    /// Keeps the record a whole number of 16 bytes.
    pub pad: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Strands in the hair.
    pub strands: u32,
    /// The hair's first ring frame in its tube batch, in vec4 (set in the render world).
    pub frame_base: u32,
    /// The job's first invocation in its dispatch (set in the render world).
    pub first_invocation: u32,
}

/// A hair's shadow ribbons, as the main world gathers them.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct GpuShadowInput {
    /// The ribbon mesh.
    pub mesh: AssetId<Mesh>,
    /// Its record (the render world fills in where it lies).
    pub record: GpuShadowRecord,
}

/// The shadow pass input of `job` for a hair of `strands` strands of `rings` rings; `None` when
/// the job's mesh is not a ribbon mesh of that size.
pub(crate) fn shadow_input(
    job: &GpuShadowRibbons,
    meshes: &Assets<Mesh>,
    rings: usize,
    strands: usize,
) -> Option<GpuShadowInput> {
    let mesh = meshes.get(job.mesh)?;
    if mesh.count_vertices() != shadow_ribbon_vertex_count(strands, rings) || rings < 2 {
        return None;
    }
    let [position, _, _, stride] = vertex_offsets(mesh, [Mesh::ATTRIBUTE_POSITION.id; 3])?;
    Some(GpuShadowInput {
        mesh: job.mesh,
        record: GpuShadowRecord {
            light: job.light.to_vec4(),
            stride,
            position_offset: position,
            rings: rings as u32,
            strands: strands as u32,
            ..default()
        },
    })
}

/// The shadow pass's pipeline, made in `RenderStartup`.
#[derive(Resource)]
pub(crate) struct GpuShadowPipeline(pub ComputePass);

/// Queues the shadow pass's pipeline.
pub(crate) fn init_gpu_shadow_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuShadowPipeline(ComputePass::queue_read_write(
        &pipeline_cache,
        "hair_gpu_shadows",
        load_embedded_asset!(asset_server.as_ref(), "shadows.wesl"),
    )));
}

/// The vertices a shadow job writes.
pub(crate) fn shadow_vertices(record: &GpuShadowRecord) -> usize {
    shadow_ribbon_vertex_count(record.strands as usize, record.rings as usize)
}

impl JobRecord for GpuShadowRecord {
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

/// One shadow batch in the render world.
pub(crate) type ShadowBatch = JobBatch<GpuShadowRecord>;
