//! Object-space silhouette strokes as ECS data: settings, the per-frame extraction system, and
//! the stroke mesh it fills.
//!
//! # Visibility
//! Strokes are ordinary geometry drawn with the depth test on. Each stroke point is pulled
//! toward the camera by [`SilhouetteSettings::depth_bias`] times the strand radius, along its eye
//! ray (or the view direction of an orthographic camera) before the strip is extruded, so the
//! stroke covers the same pixels at its full width, and the half of
//! the strip that lies over its own strand's surface (which curves away from the silhouette edge
//! by up to one radius) stays in front of it, while anything nearer than that, other strands, the
//! head, or the same strand passing in front of itself, hides the stroke. The thesis used an ID
//! buffer, which cannot tell a strand from itself and so drew outlines through self-overlapping
//! strands (its Figure 4.18); a depth test has no such blind spot.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{NoFrustumCulling, RenderLayers};
use bevy::core_pipeline::prepass::NormalPrepass;
use bevy::prelude::*;
use bevy::tasks::TaskPool;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::adjacency::SilhouetteScratch;
use super::chain::{SilhouetteChains, chain_edges};
use super::gpu_jobs::{GpuStrokeJob, GpuStrokeJobs, gpu_stroke_mesh};
use super::strip::{StrokeCamera, StrokeParams, StrokeVertices, build_chain_strip};
use super::tube_edges::{TubeEdgeScratch, TubeEdges};
use crate::curve::QuadraticCurve;
use crate::math::finite_or;
use crate::mesh::culling::seen_by_any;
use crate::mesh::{
    ComputedHairMesh, HairInView, HairMeshBuiltOnGpu, HairMeshSettings, StripBuffers,
};
use crate::sim::Hair;

/// Object-space outline strokes of a hair (thesis 4.3.7). A component on the [`Hair`] entity,
/// inserted with defaults when missing. Switching `enabled` off and on works any number of times.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct SilhouetteSettings {
    /// Draw strokes. Default: `true`.
    pub enabled: bool,
    /// Stroke width on screen, pixels. Default: `4.0` (the thesis's users preferred thick
    /// strokes, chapter 5.2).
    pub width_px: f32,
    /// Angle scaling: how much corners widen to keep the stroke's width (0 = plain miter off,
    /// 1 = full). Default: `1.0`.
    pub angle_scale: f32,
    /// Depth scaling: far strokes get thinner as `(1/w)^depth_scale` (0 = constant screen width).
    /// Default: `0.0`.
    pub depth_scale: f32,
    /// Overall multiplier of the width. Default: `1.0`.
    pub stroke_scale: f32,
    /// Largest width a stroke may reach after all scaling, pixels. Default: `8.0`.
    pub stroke_limit_px: f32,
    /// The E curve: stroke opacity along the strand, root `x = 0` to tip `x = 1`; fading toward the
    /// root hides outlines where strands leave the scalp. Default: constant `1.0`, unfaded (as
    /// the thesis's users preferred; `QuadraticCurve::new(0.0, 0.8, 0.2)` fades toward roots).
    pub fade: QuadraticCurve,
    /// How far strokes are pulled toward the camera, in strand radii (see the module docs).
    /// Default: `0.6`.
    pub depth_bias: f32,
    /// Stroke colour (multiplied by the stroke texture). Default: near-black.
    pub color: Color,
    /// Which silhouettes become strokes: the outline of the hair as one mass, or every
    /// strand's. Default: [`StrokeScope::Mass`].
    pub scope: StrokeScope,
}

/// Which strand silhouettes a hair's strokes draw ([`SilhouetteSettings::scope`]).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum StrokeScope {
    /// The outline of the hair as one mass (the thesis's users preferred thick outlines around
    /// the hair, chapter 5.2): a stroke shows only where something other than hair (the
    /// background, the face, a prop) lies within its own width, so strands lying on other
    /// strands get no outline. Read from the hair mask in the normal prepass: the plugin adds a
    /// `NormalPrepass` to the cameras that draw these strokes (and removes it when none do
    /// any more, unless it was there before). See [`crate::render::HairStrokeMaterial`].
    #[default]
    Mass,
    /// Every strand's silhouette (the thesis's strokes): each lock outlined on its own.
    Strands,
}

impl Default for SilhouetteSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            width_px: 4.0,
            angle_scale: 1.0,
            depth_scale: 0.0,
            stroke_scale: 1.0,
            stroke_limit_px: 8.0,
            fade: QuadraticCurve::constant(1.0),
            depth_bias: 0.6,
            color: Color::srgb(0.05, 0.03, 0.03),
            scope: StrokeScope::Mass,
        }
    }
}

impl SilhouetteSettings {
    /// The stroke parameters these settings give for tubes of `radius` (world units, for the
    /// depth bias): a non-finite field falls back to its default, and every field is clamped to
    /// its documented range.
    pub fn stroke_params(&self, radius: f32) -> StrokeParams {
        let d = Self::default();
        StrokeParams {
            width_px: finite_or(self.width_px, d.width_px).clamp(0.0, 64.0),
            angle_scale: finite_or(self.angle_scale, d.angle_scale).clamp(0.0, 4.0),
            depth_scale: finite_or(self.depth_scale, d.depth_scale).clamp(0.0, 4.0),
            stroke_scale: finite_or(self.stroke_scale, d.stroke_scale).clamp(0.0, 16.0),
            stroke_limit_px: finite_or(self.stroke_limit_px, d.stroke_limit_px).clamp(0.0, 128.0),
            fade: self.fade,
            depth_bias: finite_or(self.depth_bias, d.depth_bias).max(0.0)
                * finite_or(radius, 0.0).max(0.0),
            color: self.color.to_linear().to_f32_array(),
            ..default()
        }
    }
}

/// A camera strokes are built for. Without any, the first active 3D camera is used.
///
/// Strokes depend on the camera (which edges are silhouettes, and their width in pixels), so
/// each marked camera gets strokes of its own. With more than one, each camera's strokes are put
/// on a render layer of their own ([`FIRST_STROKE_LAYER`] onward, in the cameras' entity
/// order) and that layer is added to the camera's [`RenderLayers`], so that every camera sees
/// only its own outlines. Up to [`MAX_STROKE_CAMERAS`] cameras get strokes.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
pub struct SilhouetteCamera;

/// The stroke layer [`extract_silhouettes`] gave a camera (see [`SilhouetteCamera`]); when the
/// camera stops getting strokes of its own, the layer is taken out of its [`RenderLayers`] again
/// (unless the camera had it before).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
pub struct StrokeLayer {
    /// The layer.
    pub layer: usize,
    /// Whether the layer was added to the camera's [`RenderLayers`] (it was not there before).
    pub added: bool,
}

/// The render layer of the first [`SilhouetteCamera`]'s strokes when several cameras have them.
pub const FIRST_STROKE_LAYER: usize = 24;

/// The most cameras that get strokes of their own.
pub const MAX_STROKE_CAMERAS: usize = 8;

/// The stroke mesh entity of a hair (world space).
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = HairStrokes)]
pub struct HairStrokesOf(pub Entity);

/// A hair's stroke entities; despawning the hair despawns them.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
#[relationship_target(relationship = HairStrokesOf, linked_spawn)]
pub struct HairStrokes(Vec<Entity>);

/// Derived silhouette state of a hair: the edge map of its strand topology (built once per
/// topology, shared by every strand) and the stroke meshes (one per block of strands, see
/// [`STROKE_BLOCKS`], so that each block's output becomes a mesh without being copied).
///
/// Reflected for inspectors: the stroke count and the per-vertex positions along the strand
/// (the edge finder and the per-camera buffers are not).
#[derive(Component, Reflect)]
#[reflect(Component, from_reflect = false)]
pub struct ComputedSilhouettes {
    /// The silhouette-edge finder of the strands' tube topology.
    #[reflect(ignore)]
    pub tube: TubeEdges,
    /// Position along the strand (0 root, 1 tip) of each tube vertex.
    pub along: Vec<f32>,
    /// The strokes of each camera they are built for.
    #[reflect(ignore)]
    pub views: Vec<StrokeView>,
    /// Strokes (chains) drawn last frame.
    pub chains: usize,
}

/// The strokes of one hair for one camera.
#[derive(Clone, Debug)]
pub struct StrokeView {
    /// The camera.
    pub camera: Entity,
    /// The stroke meshes (world space), one per block of strands.
    pub meshes: Vec<Handle<Mesh>>,
    /// The stroke entities, one per mesh.
    pub entities: Vec<Entity>,
    /// The render layer the entities are on (`None`: the default layers, with one camera).
    pub layer: Option<usize>,
    /// The strands, rings and sides of the GPU's stroke mesh the first mesh holds, while the
    /// GPU builds these strokes (see [`gpu_jobs`](super::gpu_jobs)).
    pub gpu_layout: Option<(usize, usize, usize)>,
    /// Whether each mesh holds strokes: an entity whose mesh holds none is hidden, so it costs
    /// no draw call.
    pub drawn: Vec<bool>,
}

/// The per-strand work of [`extract_silhouettes`], with its reused buffers: keep one per thread
/// (or per block of strands).
/// After warming up, nothing allocates.
#[derive(Default)]
pub struct StrokeWorker {
    tube_scratch: TubeEdgeScratch,
    scratch: SilhouetteScratch,
    edges: Vec<[u32; 2]>,
    chains: SilhouetteChains,
    /// The strokes built since the last [`StrokeVertices::clear`].
    pub out: StrokeVertices,
    /// The chains built since the last [`StrokeWorker::clear`].
    pub chain_count: usize,
}

impl StrokeWorker {
    /// Removes every stroke, keeping the buffers.
    pub fn clear(&mut self) {
        self.out.clear();
        self.chain_count = 0;
    }

    /// Appends the strokes of one strand: its tube's silhouette edges seen by the camera's
    /// viewer (nothing without one), chained, then extruded into strips. `strand` is the strand's
    /// tube vertices and `along` each vertex's position along the strand (`0` root, `1` tip).
    pub fn add_strand(
        &mut self,
        tube: &TubeEdges,
        strand: &[[f32; 3]],
        along: &[f32],
        camera: &StrokeCamera,
        params: &StrokeParams,
    ) {
        let Some(viewer) = camera.viewer() else {
            return;
        };
        tube.silhouette_edges(strand, viewer, &mut self.tube_scratch, &mut self.edges);
        chain_edges(&self.edges, &mut self.scratch, &mut self.chains);
        self.chain_count += self.chains.len();
        for chain in self.chains.iter() {
            build_chain_strip(chain, strand, along, camera, params, &mut self.out);
        }
    }
}

/// Finds each strand's silhouette edges for the camera, chains them, and rebuilds the stroke mesh;
/// for a hair whose tubes the GPU builds, hands the GPU its strokes instead ([`GpuStrokeJobs`]).
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub fn extract_silhouettes(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut hairs: Query<
        (
            Entity,
            &SilhouetteSettings,
            &HairMeshSettings,
            &ComputedHairMesh,
            Option<&mut ComputedSilhouettes>,
            &HairInView,
            Has<HairMeshBuiltOnGpu>,
            &mut GpuStrokeJobs,
        ),
        With<Hair>,
    >,
    cameras: Query<
        (
            Entity,
            &Camera,
            &GlobalTransform,
            Has<SilhouetteCamera>,
            Option<&RenderLayers>,
            Option<&StrokeLayer>,
            Option<&Frustum>,
        ),
        With<Camera3d>,
    >,
    bounds: Query<&Aabb>,
    mut visibility: Query<&mut Visibility>,
    mut builder: Local<StrokeBuilder>,
) {
    // The marked cameras (in entity order), or else the first active camera.
    let mut views: Vec<_> = cameras
        .iter()
        .filter(|(_, c, _, marked, ..)| c.is_active && *marked)
        .collect();
    views.sort_by_key(|(e, ..)| *e);
    views.truncate(MAX_STROKE_CAMERAS);
    if views.is_empty() {
        views.extend(cameras.iter().filter(|(_, c, ..)| c.is_active).take(1));
    }
    let layered = views.len() > 1;
    let layer_of = |slot: usize| layered.then_some(FIRST_STROKE_LAYER + slot);
    // Each camera sees its strokes' layer; a camera that no longer gets strokes of its own
    // loses the layer it was given.
    for (camera, _, _, _, layers, given, _) in &cameras {
        let slot = views.iter().position(|(e, ..)| *e == camera);
        let wanted = slot.and_then(layer_of);
        if wanted == given.map(|g| g.layer) {
            continue;
        }
        let mut layers = layers.cloned().unwrap_or_default();
        if let Some(given) = given.filter(|g| g.added) {
            layers = layers.without(given.layer);
        }
        let mut entity = commands.entity(camera);
        match wanted {
            Some(layer) => {
                let added = !layers.intersects(&RenderLayers::layer(layer));
                entity.insert((layers.with(layer), StrokeLayer { layer, added }));
            }
            None => {
                entity.insert(layers).remove::<StrokeLayer>();
            }
        }
    }
    let pool = crate::parallel::compute_pool();
    for (hair, settings, mesh_settings, hair_mesh, computed, in_view, on_gpu, mut jobs) in
        &mut hairs
    {
        if !jobs.0.is_empty() {
            jobs.0.clear();
        }
        let topology = &hair_mesh.topology;
        let tube = TubeEdges::new(topology);
        let mut computed = match computed {
            Some(c) if c.tube == tube => c,
            other => {
                let along = topology.uvs.iter().map(|uv| uv[1]).collect();
                commands.entity(hair).insert(ComputedSilhouettes {
                    tube,
                    along,
                    views: other.map(|c| c.views.clone()).unwrap_or_default(),
                    chains: 0,
                });
                continue;
            }
        };
        // Strokes of cameras that no longer get any go.
        computed.views.retain(|view| {
            let keep = views.iter().any(|(camera, ..)| *camera == view.camera);
            if !keep {
                for &entity in &view.entities {
                    commands.entity(entity).try_despawn();
                }
            }
            keep
        });
        // Strokes only for cameras that see the hair (see `mesh::culling`): the hair's bounds
        // against each camera's frustum. Without bounds or a frustum, the camera sees it.
        let hair_bounds = bounds.get(hair_mesh.entity).ok();
        let sees = |frustum: Option<&Frustum>| {
            in_view.0
                && match (hair_bounds, frustum) {
                    (Some(b), Some(f)) => seen_by_any(b, std::iter::once(f)),
                    _ => true,
                }
        };
        for view in &computed.views {
            let frustum = cameras.get(view.camera).ok().and_then(|c| c.6);
            let want = if settings.enabled && sees(frustum) {
                Visibility::Inherited
            } else {
                Visibility::Hidden
            };
            for (w, &entity) in view.entities.iter().enumerate() {
                if let Ok(mut v) = visibility.get_mut(entity) {
                    v.set_if_neq(if view.drawn.get(w).copied().unwrap_or(true) {
                        want
                    } else {
                        Visibility::Hidden
                    });
                }
            }
        }
        if !settings.enabled {
            continue;
        }
        // Pull strokes toward the viewer (see the module docs on visibility).
        let params = settings.stroke_params(mesh_settings.radius);
        computed.chains = 0;
        for (slot, (camera_entity, camera, camera_transform, .., frustum)) in
            views.iter().enumerate()
        {
            let Some(viewport) = camera.physical_viewport_size() else {
                continue;
            };
            if !sees(*frustum) {
                continue;
            }
            let stroke_camera = StrokeCamera::from_view(
                camera_transform.to_matrix(),
                camera.clip_from_view(),
                Vec2::new(viewport.x as f32, viewport.y as f32),
            );
            // The GPU builds the strokes of GPU-built tubes into one mesh a camera; the CPU
            // builds the others from the tube mesh, in blocks.
            let blocks = if on_gpu {
                1
            } else {
                let Some(positions) = meshes
                    .get(&hair_mesh.mesh)
                    .and_then(|m| m.attribute(Mesh::ATTRIBUTE_POSITION))
                    .and_then(|a| a.as_float3())
                else {
                    continue;
                };
                computed.chains += builder.build(
                    pool,
                    positions,
                    &computed.tube,
                    &computed.along,
                    &stroke_camera,
                    &params,
                );
                builder.blocks()
            };
            let computed = &mut *computed;
            let index = match computed
                .views
                .iter()
                .position(|v| v.camera == *camera_entity)
            {
                Some(i) => i,
                None => {
                    computed.views.push(StrokeView {
                        camera: *camera_entity,
                        meshes: Vec::new(),
                        entities: Vec::new(),
                        layer: None,
                        gpu_layout: None,
                        drawn: Vec::new(),
                    });
                    computed.views.len() - 1
                }
            };
            let view = &mut computed.views[index];
            // One stroke entity per block.
            while view.meshes.len() < blocks {
                let mesh = meshes.add(StripBuffers::empty_mesh(true));
                let mut entity = commands.spawn((
                    Name::new("hair strokes"),
                    Mesh3d(mesh.clone()),
                    Transform::IDENTITY,
                    NoFrustumCulling,
                    // Light strips and ink lines cast no shadow.
                    bevy::light::NotShadowCaster,
                    HairStrokesOf(hair),
                ));
                if let Some(layer) = view.layer {
                    entity.insert(RenderLayers::layer(layer));
                }
                view.meshes.push(mesh);
                view.entities.push(entity.id());
                view.drawn.push(true);
            }
            let layer = layer_of(slot);
            if view.layer != layer {
                view.layer = layer;
                for &entity in &view.entities {
                    let mut entity = commands.entity(entity);
                    match layer {
                        Some(layer) => entity.insert(RenderLayers::layer(layer)),
                        None => entity.remove::<RenderLayers>(),
                    };
                }
            }
            if on_gpu {
                // The contours are found on the closed ring (a half tube's too).
                let layout = (hair_mesh.strands, topology.rings(), topology.closed_sides());
                if view.gpu_layout != Some(layout) {
                    // Once: the first mesh takes the GPU's topology, the others are emptied.
                    view.gpu_layout = Some(layout);
                    for (w, handle) in view.meshes.iter().enumerate() {
                        if let Some(mut mesh) = meshes.get_mut(handle) {
                            *mesh = if w == 0 {
                                gpu_stroke_mesh(layout.0, layout.1, layout.2)
                            } else {
                                StripBuffers::empty_mesh(true)
                            };
                        }
                    }
                }
                jobs.0.push(GpuStrokeJob {
                    mesh: view.meshes[0].id(),
                    camera: stroke_camera,
                    params,
                });
                show_drawn(view, |w| w == 0, &mut visibility);
                continue;
            }
            view.gpu_layout = None;
            let mut drawn = [false; STROKE_BLOCKS];
            for (w, handle) in view.meshes.iter().enumerate() {
                if let (Some(mut mesh), Some(d)) = (meshes.get_mut(handle), drawn.get_mut(w)) {
                    *d = builder.swap_into_mesh(w, &mut mesh);
                }
            }
            show_drawn(
                view,
                |w| drawn.get(w).copied().unwrap_or(false),
                &mut visibility,
            );
        }
    }
}

/// Records which of `view`'s meshes hold strokes now (`drawn(w)` for mesh `w`) and shows or
/// hides the entities whose answer changed: the view is seen (its strokes were just built), so
/// a mesh with strokes is shown and one without is hidden.
fn show_drawn(
    view: &mut StrokeView,
    drawn: impl Fn(usize) -> bool,
    visibility: &mut Query<&mut Visibility>,
) {
    view.drawn.resize(view.entities.len(), true);
    for (w, (&entity, was)) in view.entities.iter().zip(&mut view.drawn).enumerate() {
        let now = drawn(w);
        if *was != now {
            *was = now;
            if let Ok(mut v) = visibility.get_mut(entity) {
                v.set_if_neq(if now {
                    Visibility::Inherited
                } else {
                    Visibility::Hidden
                });
            }
        }
    }
}

/// How many blocks a hair's strands are split into for stroke building (fewer when there are
/// fewer strands). Threads take blocks as they come free, so a thread that starts late does not
/// hold the frame up; each block's strokes are a mesh (a draw call) of their own, the same
/// whichever thread built them.
pub const STROKE_BLOCKS: usize = 8;

/// Builds the strokes of a hair's strands on several threads and writes them into meshes: the
/// work of [`extract_silhouettes`] for one hair and camera, public so that it can be measured and
/// reused. Keep one across frames: its buffers are reused.
#[derive(Default)]
pub struct StrokeBuilder {
    blocks: Vec<Mutex<StrokeWorker>>,
}

impl StrokeBuilder {
    /// Builds the strokes of every strand in `positions` (strand after strand, each
    /// [`TubeEdges::vertex_count`] vertices) with `along` as in [`StrokeWorker::add_strand`], in
    /// [`STROKE_BLOCKS`] blocks of consecutive strands, taken in turn by `pool`'s threads and the
    /// calling thread (which would otherwise only wait). Returns the number of chains.
    pub fn build(
        &mut self,
        pool: &TaskPool,
        positions: &[[f32; 3]],
        tube: &TubeEdges,
        along: &[f32],
        camera: &StrokeCamera,
        params: &StrokeParams,
    ) -> usize {
        let per = tube.vertex_count();
        let strands = positions.len() / per;
        let blocks = strands.clamp(1, STROKE_BLOCKS);
        let chunk = strands.div_ceil(blocks).max(1);
        self.blocks.resize_with(blocks, Default::default);
        let threads = crate::parallel::workers(pool).min(blocks);
        let next = AtomicUsize::new(0);
        let workers = &self.blocks;
        // Each thread takes the next block until none is left.
        crate::parallel::run_parts(pool, 0..threads, &|_| {
            loop {
                let b = next.fetch_add(1, Ordering::Relaxed);
                let Some(block) = workers.get(b) else {
                    break;
                };
                let range = (b * chunk * per).min(strands * per)
                    ..((b + 1) * chunk * per).min(strands * per);
                // Each block is taken once: the lock is never contended.
                let mut worker = block
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                worker.clear();
                for strand in positions[range].chunks_exact(per) {
                    worker.add_strand(tube, strand, along, camera, params);
                }
            }
        });
        self.blocks
            .iter_mut()
            .map(|w| w.get_mut().map_or(0, |w| w.chain_count))
            .sum()
    }

    /// The number of blocks (and stroke meshes) of the last build.
    pub fn blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Moves block `b`'s strokes into `mesh` (positions, UVs, colours, indices; normals face
    /// +Z), taking the mesh's old buffers back for the next build: nothing is copied. A mesh
    /// beyond the blocks is emptied. Returns whether the mesh holds any stroke (an empty one
    /// holds a degenerate triangle, which draws nothing).
    pub fn swap_into_mesh(&mut self, b: usize, mesh: &mut Mesh) -> bool {
        let mut buffers = StripBuffers::take(mesh);
        if let Some(Ok(worker)) = self.blocks.get_mut(b).map(Mutex::get_mut) {
            std::mem::swap(&mut buffers.positions, &mut worker.out.positions);
            std::mem::swap(&mut buffers.uvs, &mut worker.out.uvs);
            std::mem::swap(&mut buffers.colors, &mut worker.out.colors);
            std::mem::swap(&mut buffers.indices, &mut worker.out.indices);
            worker.clear();
        }
        let drawn = !buffers.indices.is_empty();
        buffers.put(mesh);
        drawn
    }
}

/// On a camera: [`sync_stroke_prepasses`] added its `NormalPrepass` (and so may remove it).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Debug)]
pub struct StrokePrepass;

/// Keeps a `NormalPrepass` on every camera that draws strokes of [`StrokeScope::Mass`] (their
/// material reads the hair mask from it), and removes the ones it added when the camera no
/// longer draws any. A prepass that was there before (the user's, or an
/// [`ImageSpaceOutline`](crate::render::ImageSpaceOutline)'s) is left alone.
pub fn sync_stroke_prepasses(
    mut commands: Commands,
    hairs: Query<(&SilhouetteSettings, &ComputedSilhouettes)>,
    cameras: Query<(Entity, Has<NormalPrepass>, Has<StrokePrepass>), With<Camera3d>>,
) {
    for (camera, has_prepass, added) in &cameras {
        let wanted = hairs.iter().any(|(settings, computed)| {
            settings.enabled
                && settings.scope == StrokeScope::Mass
                && computed.views.iter().any(|v| v.camera == camera)
        });
        if wanted && !has_prepass {
            commands
                .entity(camera)
                .insert((NormalPrepass, StrokePrepass));
        } else if !wanted && added {
            commands
                .entity(camera)
                .remove::<(NormalPrepass, StrokePrepass)>();
        }
    }
}
