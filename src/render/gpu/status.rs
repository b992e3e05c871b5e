//! Whether the GPU passes can build a hair this frame, told by the render world to the main
//! world, and the choice of builder made from it.
//!
//! A hair is never left invisible or frozen by the GPU path:
//! - until the tube, stroke and highlight pipelines have compiled, it is built on the CPU;
//! - when one of them fails (a driver or shader back end that rejects it, a broken shader
//!   reload), every hair goes back to the CPU with a [`HairGpuBuildFailed`] event;
//! - when the device refuses a hair's mesh binding (too large for
//!   `max_storage_buffer_binding_size`, alignment included), that hair goes back to the CPU with
//!   the event, until its mesh changes.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use bevy::prelude::*;
use bevy::render::render_resource::{CachedComputePipelineId, CachedPipelineState, PipelineCache};

use crate::mesh::{ComputedHairMesh, HairMeshBuiltOnGpu};
use crate::sim::{BoneChainHair, Hair};

use crate::silhouette::gpu_jobs::gpu_stroke_vertex_count;

/// Where strand tube meshes are built. A resource; it may change at any time.
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Resource, Default, Debug, PartialEq)]
pub enum HairMeshBuilder {
    /// On the GPU where the render device can ([`HairGpuMeshSupport`]), object-space strokes
    /// included; on the CPU otherwise.
    #[default]
    Gpu,
    /// Always on the CPU (the reference; every frame's vertices are uploaded).
    Cpu,
}

/// Whether this render device can build tubes and strokes on the GPU: compute shaders of 64
/// invocations, seven storage buffers in a compute stage (`max_storage_buffers_per_shader_stage`)
/// and vertex buffers usable as storage. Set when the render plugin finishes.
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq)]
pub struct HairGpuMeshSupport {
    /// Tubes may be built on the GPU.
    pub supported: bool,
    /// Why not, when they may not.
    pub reason: Option<String>,
    /// The largest storage binding the device allows (`max_storage_buffer_binding_size`),
    /// bytes: a hair whose tube or stroke mesh would be larger is built on the CPU. A game may
    /// lower it (never raise it).
    pub max_binding_bytes: u64,
    /// The device's `min_storage_buffer_offset_alignment`: a mesh's binding starts at the
    /// aligned offset at or before its first vertex, so it may be this much larger.
    pub binding_alignment: u64,
}

impl HairGpuMeshSupport {
    /// Whether a hair of `strands` strands of `rings` rings and `sides` sides fits in the
    /// device's storage bindings, its tube mesh (at most 64 bytes a vertex) and its stroke mesh
    /// (48 bytes a vertex), each with the padding its binding's alignment may add in front.
    pub fn fits(&self, strands: usize, rings: usize, sides: usize) -> bool {
        let tubes = (strands * (rings * sides + 2)) as u64 * 64;
        let strokes = gpu_stroke_vertex_count(strands, rings, sides) as u64 * 48;
        let padding = self.binding_alignment.saturating_sub(4);
        tubes.max(strokes) + padding <= self.max_binding_bytes
    }
}

/// The state of the crate's compute pipelines, all three together.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum GpuPassState {
    /// Queued or compiling (hair is built on the CPU meanwhile).
    #[default]
    Compiling,
    /// All compiled: hair may be built on the GPU.
    Ready,
    /// One failed, with the pipeline cache's error.
    Failed(String),
}

/// One pass's work in a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassDispatches {
    /// Dispatches (one a batch: hairs whose meshes share a vertex slab).
    pub dispatches: u32,
    /// Invocations that did work: strands, summed over the pass's hairs or jobs.
    pub invocations: u32,
}

/// The GPU passes' work in the last frame rendered ([`HairGpuPasses::dispatches`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HairGpuDispatches {
    /// The tube pass.
    pub tubes: PassDispatches,
    /// The stroke pass (a strand a camera).
    pub strokes: PassDispatches,
    /// The highlight pass.
    pub highlights: PassDispatches,
    /// The draw-order pass (invocations: indices rewritten; a batch: hairs whose meshes share
    /// an index slab).
    pub draw_order: PassDispatches,
    /// The shadow ribbon pass.
    pub shadows: PassDispatches,
    /// The stroke and highlight passes' second dispatches, which write the triangles of the
    /// quads that draw something (one a batch drawn by count, [`HairCompactQuads`]).
    ///
    /// [`HairCompactQuads`]: super::HairCompactQuads
    pub compact: PassDispatches,
}

#[derive(Debug, Default)]
struct Report {
    state: GpuPassState,
    dispatches: HairGpuDispatches,
    /// Meshes whose binding the device refused this frame, with why.
    refused: HashMap<AssetId<Mesh>, String>,
}

/// What the render world reports of the GPU passes, read by the main world. A resource in both
/// worlds, sharing one report.
#[derive(Resource, Clone, Debug, Default)]
pub struct HairGpuPasses(Arc<Mutex<Report>>);

impl HairGpuPasses {
    fn lock(&self) -> std::sync::MutexGuard<'_, Report> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The pipelines' state as last seen by the render world.
    pub fn state(&self) -> GpuPassState {
        self.lock().state.clone()
    }

    /// Sets the state. The render world does, every frame; an app without a renderer (a
    /// bench of the CPU side of the GPU path) may declare the passes ready.
    pub fn set_state(&self, state: GpuPassState) {
        self.lock().state = state;
    }

    /// The passes' work in the last frame the render world ran them.
    pub fn dispatches(&self) -> HairGpuDispatches {
        self.lock().dispatches
    }

    pub(super) fn set_dispatches(&self, dispatches: HairGpuDispatches) {
        self.lock().dispatches = dispatches;
    }

    /// The device refused `mesh`'s binding: its hair goes back to the CPU.
    pub(super) fn refuse(&self, mesh: AssetId<Mesh>, reason: String) {
        self.lock().refused.insert(mesh, reason);
    }

    /// Takes the refusal of `mesh`, if any.
    fn take_refusal(&self, mesh: AssetId<Mesh>) -> Option<String> {
        self.lock().refused.remove(&mesh)
    }
}

/// A hair that the GPU path could not build went back to the CPU (it stays visible and moving).
/// Triggered on the hair entity and logged once as an error.
#[derive(EntityEvent, Clone, Debug, PartialEq)]
pub struct HairGpuBuildFailed {
    /// The hair entity.
    pub entity: Entity,
    /// Why, and what to do.
    pub reason: String,
}

/// On a hair built on the CPU because the GPU path failed for it: the reason, and the mesh it
/// was refused for (a new mesh, after a level-of-detail or strand-count change, is tried again).
#[derive(Component, Clone, Debug, PartialEq)]
pub struct HairGpuFallback {
    /// Why, as in [`HairGpuBuildFailed`].
    pub reason: String,
    /// The mesh refused; `None` when every hair fell back (a pipeline failed).
    pub mesh: Option<AssetId<Mesh>>,
}

/// Render world: the compute pipelines' state, every frame.
pub(super) fn report_pass_state(
    passes: Res<HairGpuPasses>,
    cache: Res<PipelineCache>,
    ids: Option<Res<GpuPassIds>>,
) {
    let Some(ids) = ids else {
        return;
    };
    let mut state = GpuPassState::Ready;
    for (name, id) in ids.0 {
        match cache.get_compute_pipeline_state(id) {
            CachedPipelineState::Ok(_) => {}
            CachedPipelineState::Err(
                bevy::shader::ShaderCacheError::ShaderNotLoaded(_)
                | bevy::shader::ShaderCacheError::ShaderImportNotYetAvailable,
            )
            | CachedPipelineState::Queued
            | CachedPipelineState::Creating(_) => {
                if state == GpuPassState::Ready {
                    state = GpuPassState::Compiling;
                }
            }
            CachedPipelineState::Err(err) => {
                state = GpuPassState::Failed(format!("the GPU pass `{name}` failed: {err}"));
                break;
            }
        }
    }
    passes.set_state(state);
}

/// The crate's compute pipelines, by name (render world).
#[derive(Resource, Clone, Copy)]
pub(super) struct GpuPassIds(pub [(&'static str, CachedComputePipelineId); 7]);

/// Main world: marks the hairs built on the GPU this frame (the CPU mesh stage skips their
/// vertices), and puts a hair back on the CPU, with [`HairGpuBuildFailed`], when the GPU cannot
/// build it.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(super) fn choose_mesh_builder(
    mut commands: Commands,
    builder: Res<HairMeshBuilder>,
    support: Res<HairGpuMeshSupport>,
    passes: Res<HairGpuPasses>,
    hairs: Query<
        (
            Entity,
            Option<&ComputedHairMesh>,
            Has<HairMeshBuiltOnGpu>,
            Option<&HairGpuFallback>,
        ),
        (With<Hair>, Without<BoneChainHair>),
    >,
) {
    let state = passes.state();
    for (hair, computed, on_gpu, fallback) in &hairs {
        let wanted = *builder == HairMeshBuilder::Gpu && support.supported;
        let mesh = computed.map(|c| c.mesh.id());
        // Why this hair cannot be on the GPU now, if it cannot; `None` for waiting. Judged by
        // its closed tubes, the mesh it has on the CPU (its half tubes are smaller), so the
        // verdict does not change as it goes back there.
        let mut failure = None;
        if let Some(c) = computed
            && !support.fits(c.strands, c.topology.rings(), c.topology.closed_sides())
        {
            failure = Some((
                format!(
                    "its mesh ({} strands of {} rings and {} sides) is larger than this device \
                     binds as storage ({} bytes); it is built on the CPU (fewer strands or a \
                     coarser HairMeshSettings fit)",
                    c.strands,
                    c.topology.rings(),
                    c.topology.closed_sides(),
                    support.max_binding_bytes
                ),
                mesh,
            ));
        }
        if let Some(reason) = mesh.and_then(|m| passes.take_refusal(m)) {
            failure = Some((reason, mesh));
        }
        if let GpuPassState::Failed(reason) = &state {
            failure = Some((
                format!("{reason}; hair is built on the CPU (HairMeshBuilder::Cpu silences this)"),
                None,
            ));
        }
        // A refusal holds while the hair keeps the mesh it was refused for.
        let still_refused = fallback.is_some_and(|f| f.mesh.is_some() && f.mesh == mesh);
        let gpu = wanted
            && failure.is_none()
            && !still_refused
            && state == GpuPassState::Ready
            && computed.is_some();
        if gpu != on_gpu {
            if gpu {
                commands.entity(hair).insert(HairMeshBuiltOnGpu);
            } else {
                commands.entity(hair).remove::<HairMeshBuiltOnGpu>();
            }
        }
        match failure {
            Some((reason, mesh)) if wanted => {
                if fallback.is_none_or(|f| f.reason != reason) {
                    error!("hair {hair}: {reason}");
                    commands.entity(hair).insert(HairGpuFallback {
                        reason: reason.clone(),
                        mesh,
                    });
                    commands.trigger(HairGpuBuildFailed {
                        entity: hair,
                        reason,
                    });
                }
            }
            _ if gpu && fallback.is_some() => {
                commands.entity(hair).remove::<HairGpuFallback>();
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hair_too_large_for_the_devices_storage_bindings_stays_on_the_cpu() {
        // 10,000 strands of 16 rings of 8 sides (about W2's hair). Its stroke mesh (10,000 x 2 x 23
        // quads of 4 vertices of 48 bytes, 88.3 MB) is larger than its tube mesh (83.2 MB at
        // 64 bytes a vertex).
        let support = |max_binding_bytes| HairGpuMeshSupport {
            supported: true,
            reason: None,
            max_binding_bytes,
            binding_alignment: 4,
        };
        assert!(support(128 << 20).fits(10_000, 16, 8));
        assert!(!support(64 << 20).fits(10_000, 16, 8));
        assert!(support(88_320_000).fits(10_000, 16, 8));
        assert!(!support(88_319_999).fits(10_000, 16, 8));
        assert!(!HairGpuMeshSupport::default().fits(1, 2, 3));
        // A binding starts at the aligned offset at or before the mesh's first vertex: with a
        // 256-byte alignment it may hold 252 bytes more than the mesh.
        let aligned = HairGpuMeshSupport {
            binding_alignment: 256,
            ..support(88_320_000 + 252)
        };
        assert!(aligned.fits(10_000, 16, 8));
        let short = HairGpuMeshSupport {
            max_binding_bytes: 88_320_000 + 251,
            ..aligned
        };
        assert!(!short.fits(10_000, 16, 8));
    }
}
