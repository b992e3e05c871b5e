//! The draw-order pass (`order.wesl`): each GPU-built hair's strands drawn nearest its camera
//! first. The main world sorts the strands ([`front_to_back`]); the pass rewrites the strand
//! blocks of the hair mesh's index buffer in that order, every hair of an index slab in one
//! dispatch. The triangles drawn are the same; only their order changes, so the depth test
//! rejects the hair behind instead of shading it and drawing over it.

use bevy::asset::load_embedded_asset;
use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroupEntries, Buffer, PipelineCache, ShaderType, StorageBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};

use super::toolbox::{ComputePass, PreparedBatch, RecordBuffers, SlabGroup};

/// Writes into `out` the strands of a hair in the order to draw them: by the squared distance
/// from `eye` to each strand's nearest particle, nearest first (ties and broken positions keep
/// the groom's order). `strands` gives each strand's particles in the mesh's order; `keys` is
/// scratch.
pub(crate) fn front_to_back<'a>(
    eye: Vec3,
    strands: impl Iterator<Item = &'a [Vec3]>,
    keys: &mut Vec<(u32, u32)>,
    out: &mut Vec<u32>,
) {
    keys.clear();
    for (slot, particles) in strands.enumerate() {
        let nearest = particles
            .iter()
            .map(|p| p.distance_squared(eye))
            .filter(|d| d.is_finite())
            .fold(f32::INFINITY, f32::min);
        // Non-negative floats order as their bits; a strand with no finite particle goes last.
        let key = if nearest.is_finite() {
            nearest.to_bits()
        } else {
            u32::MAX
        };
        keys.push((key, slot as u32));
    }
    keys.sort_unstable();
    out.clear();
    out.extend(keys.iter().map(|&(_, slot)| slot));
}

/// One hair of a draw-order batch (`order.wesl`'s `Hair`).
#[derive(Clone, Copy, Debug, Default, PartialEq, ShaderType)]
pub(crate) struct GpuOrderHair {
    /// Its first index in the batch's binding, in 4-byte words.
    pub index_base: u32,
    /// Its first invocation in the dispatch.
    pub first_invocation: u32,
    /// Indices a strand.
    pub indices_per_strand: u32,
    /// Vertices a strand.
    pub vertices_per_strand: u32,
    /// Strands in the mesh.
    pub strands: u32,
    /// Its first entry in the batch's order.
    pub order_base: u32,
    /// Padding.
    pub pad: UVec2,
}

/// One hair's draw order as the render world batches it.
pub(crate) struct OrderHairInput<'a> {
    /// Indices a strand.
    pub indices_per_strand: u32,
    /// Vertices a strand.
    pub vertices_per_strand: u32,
    /// Its strands, nearest first.
    pub order: &'a [u32],
}

/// The draw-order pass.
#[derive(Resource)]
pub(crate) struct GpuOrderPipeline(pub ComputePass);

pub(crate) fn init_gpu_order_pipeline(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    pipeline_cache: Res<PipelineCache>,
) {
    commands.insert_resource(GpuOrderPipeline(ComputePass::queue_read_write(
        &pipeline_cache,
        "hair_gpu_draw_order",
        load_embedded_asset!(asset_server.as_ref(), "order.wesl"),
    )));
}

/// One draw-order batch's buffers in the render world, reused frame to frame.
#[derive(Default)]
pub(crate) struct OrderBatch {
    records: RecordBuffers<GpuOrderHair>,
    order: StorageBuffer<Vec<u32>>,
    /// This frame's bind group.
    pub prepared: Option<PreparedBatch>,
}

impl OrderBatch {
    /// Fills the batch from `group` (hairs of one index slab: each an index into `hairs` and its
    /// first index in the group's binding), uploads it and makes its bind group.
    pub fn prepare(
        &mut self,
        group: &SlabGroup<&Buffer, usize>,
        hairs: &[OrderHairInput<'_>],
        (device, queue): (&RenderDevice, &RenderQueue),
        (pipeline, pipeline_cache): (&GpuOrderPipeline, &PipelineCache),
    ) {
        self.prepared = None;
        let (records, order) = (self.records.records(), self.order.get_mut());
        order.clear();
        let mut invocations = 0u32;
        for &(i, index_base) in &group.members {
            let input = &hairs[i];
            let strands = input.order.len() as u32;
            records.push(GpuOrderHair {
                index_base,
                first_invocation: invocations,
                indices_per_strand: input.indices_per_strand,
                vertices_per_strand: input.vertices_per_strand,
                strands,
                order_base: order.len() as u32,
                pad: UVec2::ZERO,
            });
            order.extend_from_slice(input.order);
            invocations = invocations.saturating_add(strands * input.indices_per_strand);
        }
        if invocations == 0 {
            return;
        }
        self.order.write_buffer(device, queue);
        let Some((header, records)) = self.records.upload(invocations, device, queue) else {
            return;
        };
        let Some(order) = self.order.binding() else {
            return;
        };
        let bind_group = device.create_bind_group(
            "hair_gpu_draw_order",
            &pipeline_cache.get_bind_group_layout(&pipeline.0.layout),
            &BindGroupEntries::sequential((header, records, order, group.binding())),
        );
        self.prepared = Some(PreparedBatch {
            bind_group,
            invocations,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strands_are_ordered_by_their_nearest_particle() {
        let strands = [
            vec![Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, -4.0)],
            vec![Vec3::new(0.0, 0.0, -9.0), Vec3::new(0.0, 0.0, -1.0)],
            vec![Vec3::new(0.0, 0.0, -3.0), Vec3::new(0.0, 0.0, -3.5)],
            vec![Vec3::new(f32::NAN, 0.0, 0.0)],
        ];
        let (mut keys, mut out) = (Vec::new(), Vec::new());
        front_to_back(
            Vec3::ZERO,
            strands.iter().map(Vec::as_slice),
            &mut keys,
            &mut out,
        );
        // Strand 1 reaches 1 m from the eye, 2 is 3 m, 0 is 4 m; the broken one goes last.
        assert_eq!(out, [1, 2, 0, 3]);
        // Seen from behind, the order turns round.
        front_to_back(
            Vec3::new(0.0, 0.0, -20.0),
            strands.iter().map(Vec::as_slice),
            &mut keys,
            &mut out,
        );
        assert_eq!(out, [1, 0, 2, 3]);
    }
}
