//! Silhouette strokes built on the GPU, for hairs whose tubes the GPU builds
//! ([`gpu_tubes`](super::gpu_tubes)): after a hair's tube pass, one compute pass a camera
//! (`gpu_strokes.wesl`) reads the ring frames the tube pass left, finds each strand's two
//! contours and writes the stroke strips straight into the camera's stroke mesh (the mesh
//! allocator's slab, as for the tubes). The silhouette stage decides which strokes are built
//! this way and with what camera and parameters ([`GpuStrokeJobs`]); the stroke meshes keep
//! their material, so the mass scope's test against the hair mask works as for the CPU's.

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

use crate::silhouette::GpuStrokeJob;
use crate::silhouette::adjacency::Viewer;
use crate::silhouette::gpu_jobs::gpu_stroke_vertex_count;

/// The uniform of one camera's stroke pass over one hair (`gpu_strokes.wesl`'s `Params`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub struct GpuStrokeParams {
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
    /// The stroke mesh's first vertex in its slab, in 4-byte words (set in the render world).
    pub vertex_base: u32,
    /// Words per vertex.
    pub stride: u32,
    /// Word offsets in a vertex of the position, the UV and the colour.
    pub position_offset: u32,
    /// See [`GpuStrokeParams::position_offset`].
    pub uv_offset: u32,
    /// See [`GpuStrokeParams::position_offset`].
    pub color_offset: u32,
    /// Rings per strand.
    pub rings: u32,
    /// Sides per ring.
    pub sides: u32,
    /// Strands in the hair.
    pub strands: u32,
}

/// One camera's strokes of a hair in [`GpuTubeInput`](super::gpu_tubes::GpuTubeInput).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GpuStrokeInput {
    /// The stroke mesh.
    pub mesh: AssetId<Mesh>,
    /// Its pass's uniform (`vertex_base` is filled in the render world).
    pub params: GpuStrokeParams,
}

/// The stroke pass input of `job` for a hair of `strands` strands of `rings` rings and `sides`
/// sides; `None` when the job's mesh is not a GPU stroke mesh of that size.
pub fn stroke_input(
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
    let [position, uv, color, stride] = super::gpu_tubes::vertex_offsets(
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
        params: GpuStrokeParams {
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
        },
    })
}

/// The stroke pass's pipeline, made in `RenderStartup`.
#[derive(Resource)]
pub struct GpuStrokePipeline(pub(super) ComputePass);

/// Queues the stroke pass's pipeline.
pub fn init_gpu_stroke_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuStrokePipeline(ComputePass::queue(
        &pipeline_cache,
        "hair_gpu_strokes",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<GpuStrokeParams>(false),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_read_only_sized(false, None),
                storage_buffer_sized(false, None),
            ),
        ),
        load_embedded_asset!(asset_server.as_ref(), "gpu_strokes.wesl"),
    )));
}

/// A hair's stroke passes in the render world: a uniform a camera and this frame's bind groups.
#[derive(Default)]
pub struct GpuStrokeBuffers {
    params: Vec<UniformBuffer<GpuStrokeParams>>,
    /// This frame's bind groups and strand counts.
    pub ready: Vec<(BindGroup, u32)>,
}

/// What the hair's tube pass shares with its stroke passes.
pub struct HairGpuBuffers<'a> {
    /// The strands.
    pub strands: &'a Buffer,
    /// The cross-section table.
    pub sections: &'a Buffer,
    /// The ring frames the tube pass writes.
    pub frames: &'a Buffer,
}

impl GpuStrokeBuffers {
    /// Uploads each camera's uniform and makes its bind group over its stroke mesh's slab.
    pub fn prepare(
        &mut self,
        inputs: &[GpuStrokeInput],
        hair: HairGpuBuffers<'_>,
        render: (&RenderDevice, &RenderQueue, &MeshAllocator),
        pipeline: &GpuStrokePipeline,
        pipeline_cache: &PipelineCache,
    ) {
        let (device, queue, mesh_allocator) = render;
        self.ready.clear();
        self.params.resize_with(inputs.len(), Default::default);
        for (input, uniform) in inputs.iter().zip(&mut self.params) {
            let params = input.params;
            let vertices = gpu_stroke_vertex_count(
                params.strands as usize,
                params.rings as usize,
                params.sides as usize,
            );
            let Some(slice) = mesh_allocator.mesh_vertex_slice(&input.mesh) else {
                continue;
            };
            let Some((slab, vertex_base)) = slab_binding(&slice, params.stride, vertices, device)
            else {
                continue;
            };
            uniform.set(GpuStrokeParams {
                vertex_base,
                ..params
            });
            uniform.write_buffer(device, queue);
            let Some(binding) = uniform.binding() else {
                continue;
            };
            let bind_group = device.create_bind_group(
                "hair_gpu_strokes",
                &pipeline_cache.get_bind_group_layout(&pipeline.0.layout),
                &BindGroupEntries::sequential((
                    binding,
                    hair.strands.as_entire_binding(),
                    hair.sections.as_entire_binding(),
                    hair.frames.as_entire_binding(),
                    slab,
                )),
            );
            self.ready.push((bind_group, params.strands));
        }
    }
}
