//! Specular sampling quads built on the GPU, for hairs whose tubes the GPU builds
//! ([`gpu_tubes`](super::gpu_tubes)): after a hair's tube pass, a compute pass
//! (`gpu_highlights.wesl`) reads the ring frames the tube pass left and writes the highlight
//! strips straight into the hair's highlight mesh. The mesh stage decides what is built
//! ([`GpuHighlightJob`](crate::mesh::highlights::GpuHighlightJob)).

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::mesh::allocator::MeshAllocator;
use bevy::render::render_resource::binding_types::{
    storage_buffer_read_only_sized, storage_buffer_sized, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutEntries, Buffer, PipelineCache, ShaderStages,
    ShaderType, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::gpu_tubes::{ComputePass, slab_binding};

use crate::math::finite_or;
use crate::mesh::highlights::{GpuHighlights, gpu_highlight_vertex_count};

/// The uniform of one hair's highlight pass (`gpu_highlights.wesl`'s `Params`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct GpuHighlightParams {
    /// The eye.
    pub eye: Vec4,
    /// The direction toward the light.
    pub to_light: Vec4,
    /// Threshold, shininess, strip width as a fraction of the radius.
    pub settings: Vec4,
    /// The mesh's first vertex in its slab, in 4-byte words (set in the render world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position and the UV.
    pub position_offset: u32,
    /// See [`GpuHighlightParams::position_offset`].
    pub uv_offset: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Strands in the hair.
    pub strands: u32,
    /// Padding.
    pub pad: UVec2,
}

/// A hair's highlights in [`GpuTubeInput`](super::gpu_tubes::GpuTubeInput).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GpuHighlightInput {
    /// The highlight mesh.
    pub mesh: AssetId<Mesh>,
    /// Its pass's uniform (`vertex_base` is filled in the render world).
    pub params: GpuHighlightParams,
}

/// The highlight pass input of `job` for a hair of `strands` strands of `rings` rings; `None`
/// when the job's mesh is not a GPU highlight mesh of that size.
pub fn highlight_input(
    job: &GpuHighlights,
    meshes: &Assets<Mesh>,
    rings: usize,
    strands: usize,
) -> Option<GpuHighlightInput> {
    let mesh = meshes.get(job.mesh)?;
    if mesh.count_vertices() != gpu_highlight_vertex_count(strands, rings) || rings < 2 {
        return None;
    }
    let [position, uv, _, stride] = super::gpu_tubes::vertex_offsets(
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
        params: GpuHighlightParams {
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
            pad: UVec2::ZERO,
        },
    })
}

/// The highlight pass's pipeline, made in `RenderStartup`.
#[derive(Resource)]
pub struct GpuHighlightPipeline(pub(super) ComputePass);

/// Queues the highlight pass's pipeline.
pub fn init_gpu_highlight_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuHighlightPipeline(ComputePass::queue(
        &pipeline_cache,
        "hair_gpu_highlights",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<GpuHighlightParams>(false),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
        load_embedded_asset!(asset_server.as_ref(), "gpu_highlights.wesl"),
    )));
}

/// A hair's highlight pass in the render world.
#[derive(Default)]
pub struct GpuHighlightBuffers {
    params: UniformBuffer<GpuHighlightParams>,
    /// This frame's bind group and strand count.
    pub ready: Option<(BindGroup, u32)>,
}

impl GpuHighlightBuffers {
    /// Uploads the uniform and makes the bind group over the highlight mesh's slab.
    pub fn prepare(
        &mut self,
        input: Option<&GpuHighlightInput>,
        frames: &Buffer,
        render: (&RenderDevice, &RenderQueue, &MeshAllocator),
        pipeline: &GpuHighlightPipeline,
        pipeline_cache: &PipelineCache,
    ) {
        let (device, queue, mesh_allocator) = render;
        self.ready = None;
        let Some(input) = input else {
            return;
        };
        let params = input.params;
        let vertices = gpu_highlight_vertex_count(params.strands as usize, params.rings as usize);
        let Some(slice) = mesh_allocator.mesh_vertex_slice(&input.mesh) else {
            return;
        };
        let Some((slab, vertex_base)) = slab_binding(&slice, params.stride, vertices, device)
        else {
            return;
        };
        self.params.set(GpuHighlightParams {
            vertex_base,
            ..params
        });
        self.params.write_buffer(device, queue);
        let Some(binding) = self.params.binding() else {
            return;
        };
        let bind_group = device.create_bind_group(
            "hair_gpu_highlights",
            &pipeline_cache.get_bind_group_layout(&pipeline.0.layout),
            &BindGroupEntries::sequential((binding, frames.as_entire_binding(), slab)),
        );
        self.ready = Some((bind_group, params.strands));
    }
}
