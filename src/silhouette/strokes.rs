//! Object-space silhouette strokes as ECS data: settings, the per-frame extraction system, and
//! the stroke mesh it fills.
//!
//! # Visibility
//! Strokes are ordinary geometry drawn with the depth test on. Each stroke vertex is pulled
//! toward the camera by [`SilhouetteSettings::depth_bias`] times the strand radius, so the half of
//! the strip that lies over its own strand's surface (which curves away from the silhouette edge
//! by up to one radius) stays in front of it, while anything nearer than that, other strands, the
//! head, or the same strand passing in front of itself, hides the stroke. The thesis used an ID
//! buffer, which cannot tell a strand from itself and so drew outlines through self-overlapping
//! strands (its Figure 4.18); a depth test has no such blind spot.

use bevy::asset::RenderAssetUsages;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPool};

use super::edges::{
    EdgeAdjacency, SilhouetteChains, SilhouetteScratch, StrokeCamera, StrokeParams, StrokeVertices,
    build_chain_strip, chain_edges, silhouette_edges,
};
use crate::curve::QuadraticCurve;
use crate::mesh::{ComputedHairMesh, HairMeshSettings, StripBuffers};
use crate::sim::Hair;

/// Object-space outline strokes of a hair (thesis 4.3.7). A component on the [`Hair`] entity,
/// inserted with defaults when missing. Switching `enabled` off and on works any number of times.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct SilhouetteSettings {
    /// Draw strokes. Default: `true`.
    pub enabled: bool,
    /// Stroke width on screen, pixels. Default: `3.0`.
    pub width_px: f32,
    /// Angle scaling: how much corners widen to keep the stroke's width (0 = plain miter off,
    /// 1 = full). Default: `1.0`.
    pub angle_scale: f32,
    /// Depth scaling: far strokes get thinner as `(1/w)^depth_scale` (0 = constant screen width).
    /// Default: `0.0`.
    pub depth_scale: f32,
    /// Overall multiplier of the width. Default: `1.0`.
    pub stroke_scale: f32,
    /// Largest width a stroke may reach after all scaling, pixels. Default: `6.0`.
    pub stroke_limit_px: f32,
    /// The E curve: stroke opacity along the strand, root `x = 0` to tip `x = 1`; fading toward the
    /// root hides outlines where strands leave the scalp. Default: `QuadraticCurve { a: 0.0,
    /// b: 0.8, c: 0.2 }`.
    pub fade: QuadraticCurve,
    /// How far strokes are pulled toward the camera, in strand radii (see the module docs).
    /// Default: `0.6`.
    pub depth_bias: f32,
    /// Stroke colour (multiplied by the stroke texture). Default: near-black.
    pub color: Color,
}

impl Default for SilhouetteSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            width_px: 3.0,
            angle_scale: 1.0,
            depth_scale: 0.0,
            stroke_scale: 1.0,
            stroke_limit_px: 6.0,
            fade: QuadraticCurve::new(0.0, 0.8, 0.2),
            depth_bias: 0.6,
            color: Color::srgb(0.05, 0.03, 0.03),
        }
    }
}

impl SilhouetteSettings {
    fn stroke_params(&self) -> StrokeParams {
        let f = |v: f32, d: f32| if v.is_finite() { v } else { d };
        StrokeParams {
            width_px: f(self.width_px, 3.0).clamp(0.0, 64.0),
            angle_scale: f(self.angle_scale, 1.0).clamp(0.0, 4.0),
            depth_scale: f(self.depth_scale, 0.0).clamp(0.0, 4.0),
            stroke_scale: f(self.stroke_scale, 1.0).clamp(0.0, 16.0),
            stroke_limit_px: f(self.stroke_limit_px, 6.0).clamp(0.0, 128.0),
            fade: [self.fade.a, self.fade.b, self.fade.c],
            ..default()
        }
    }
}

/// The camera strokes are built for. Without it, the first active 3D camera is used.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug)]
pub struct SilhouetteCamera;

/// The stroke mesh entity of a hair (world space).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq)]
#[relationship(relationship_target = HairStrokes)]
pub struct HairStrokesOf(pub Entity);

/// A hair's stroke entities; despawning the hair despawns them.
#[derive(Component, Debug, Default)]
#[relationship_target(relationship = HairStrokesOf, linked_spawn)]
pub struct HairStrokes(Vec<Entity>);

/// Derived silhouette state of a hair: the edge map of its strand topology (built once per
/// topology, shared by every strand) and the stroke mesh.
#[derive(Component)]
pub struct ComputedSilhouettes {
    /// Edge adjacency of one strand's tube.
    pub adjacency: EdgeAdjacency,
    /// Position along the strand (0 root, 1 tip) of each tube vertex.
    pub along: Vec<f32>,
    /// Topology this was built for: (rings, sides).
    pub built_for: (usize, usize),
    /// The stroke mesh.
    pub mesh: Handle<Mesh>,
    /// The stroke entity.
    pub entity: Entity,
    /// Strokes (chains) drawn last frame.
    pub chains: usize,
}

/// Per-thread scratch of [`extract_silhouettes`] (reused every frame, no allocation).
#[derive(Default)]
pub struct Worker {
    scratch: SilhouetteScratch,
    edges: Vec<[u32; 2]>,
    chains: SilhouetteChains,
    out: StrokeVertices,
}

/// Finds each strand's silhouette edges for the camera, chains them, and rebuilds the stroke mesh.
#[allow(clippy::type_complexity)]
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
        ),
        With<Hair>,
    >,
    cameras: Query<(&Camera, &GlobalTransform, Has<SilhouetteCamera>), With<Camera3d>>,
    mut visibility: Query<&mut Visibility>,
    mut workers: Local<Vec<Worker>>,
) {
    let camera = cameras
        .iter()
        .filter(|(c, _, _)| c.is_active)
        .max_by_key(|(_, _, marked)| *marked);
    let pool = ComputeTaskPool::get_or_init(TaskPool::default);
    for (hair, settings, mesh_settings, hair_mesh, computed) in &mut hairs {
        let topology = &hair_mesh.topology;
        let key = (topology.rings(), topology.sides());
        let mut computed = match computed {
            Some(c) if c.built_for == key => c,
            other => {
                let Ok(adjacency) = EdgeAdjacency::from_triangles(&topology.indices) else {
                    warn_once!("strand topology is not closed; no silhouettes");
                    continue;
                };
                let along = topology.uvs.iter().map(|uv| uv[1]).collect();
                let (mesh, entity) = match &other {
                    Some(c) => (c.mesh.clone(), c.entity),
                    None => {
                        let mesh = meshes.add(empty_stroke_mesh());
                        let entity = commands
                            .spawn((
                                Name::new("hair strokes"),
                                Mesh3d(mesh.clone()),
                                Transform::IDENTITY,
                                NoFrustumCulling,
                                HairStrokesOf(hair),
                            ))
                            .id();
                        (mesh, entity)
                    }
                };
                commands.entity(hair).insert(ComputedSilhouettes {
                    adjacency,
                    along,
                    built_for: key,
                    mesh,
                    entity,
                    chains: 0,
                });
                continue;
            }
        };
        if let Ok(mut v) = visibility.get_mut(computed.entity) {
            let want = if settings.enabled {
                Visibility::Inherited
            } else {
                Visibility::Hidden
            };
            v.set_if_neq(want);
        }
        let Some((camera, camera_transform, _)) = camera else {
            continue;
        };
        if !settings.enabled {
            continue;
        }
        let Some(viewport) = camera.physical_viewport_size() else {
            continue;
        };
        let view_proj = camera.clip_from_view() * camera_transform.affine().inverse();
        let stroke_camera =
            StrokeCamera::new(view_proj, Vec2::new(viewport.x as f32, viewport.y as f32));
        let eye = camera_transform.translation();
        let Some(hair_mesh_asset) = meshes.get(&hair_mesh.mesh) else {
            continue;
        };
        let Some(positions) = hair_mesh_asset
            .attribute(Mesh::ATTRIBUTE_POSITION)
            .and_then(|a| a.as_float3())
        else {
            continue;
        };
        let per = topology.vertex_count();
        let strands = positions.len() / per.max(1);
        let params = settings.stroke_params();
        let bias = settings.depth_bias.max(0.0) * mesh_settings.radius.max(0.0);
        // The pool's threads plus this one (which would otherwise only wait in `scope`).
        let threads = pool.thread_num().max(1) + 1;
        let chunk = strands.div_ceil(threads).max(1);
        workers.resize_with(strands.div_ceil(chunk), Worker::default);
        let adjacency = &computed.adjacency;
        let along = &computed.along;
        let indices = &topology.indices;
        pool.scope(|scope| {
            for (w, worker) in workers.iter_mut().enumerate() {
                let stroke_camera = &stroke_camera;
                let params = &params;
                let work = async move {
                    worker.out.clear();
                    for s in w * chunk..((w + 1) * chunk).min(strands) {
                        let strand = &positions[s * per..(s + 1) * per];
                        silhouette_edges(
                            adjacency,
                            indices,
                            strand,
                            eye,
                            &mut worker.scratch,
                            &mut worker.edges,
                        );
                        chain_edges(&worker.edges, &mut worker.scratch, &mut worker.chains);
                        for chain in worker.chains.iter() {
                            build_chain_strip(
                                chain,
                                strand,
                                along,
                                stroke_camera,
                                params,
                                &mut worker.out,
                            );
                        }
                    }
                    // Pull strokes toward the eye (see the module docs on visibility).
                    for p in &mut worker.out.positions {
                        let v = Vec3::from(*p);
                        *p = (v + (eye - v).normalize_or_zero() * bias).to_array();
                    }
                };
                if w == 0 {
                    scope.spawn_on_scope(work);
                } else {
                    scope.spawn(work);
                }
            }
        });
        computed.chains = workers.iter().map(|w| w.chains.len()).sum();
        if let Some(mut mesh) = meshes.get_mut(&computed.mesh) {
            fill_stroke_mesh(&mut mesh, &workers, settings.color);
        }
    }
}

fn empty_stroke_mesh() -> Mesh {
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, Vec::<[f32; 3]>::new())
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, Vec::<[f32; 3]>::new())
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, Vec::<[f32; 2]>::new())
    .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, Vec::<[f32; 4]>::new())
    .with_inserted_indices(Indices::U32(Vec::new()))
}

fn fill_stroke_mesh(mesh: &mut Mesh, workers: &[Worker], color: Color) {
    let c = color.to_linear();
    let mut b = StripBuffers::take(mesh);
    for w in workers {
        let base = b.positions.len() as u32;
        b.positions.extend_from_slice(&w.out.positions);
        b.uvs.extend_from_slice(&w.out.uvs);
        let rgba = |a: &f32| [c.red, c.green, c.blue, c.alpha * a];
        b.colors.extend(w.out.alphas.iter().map(rgba));
        b.indices.extend(w.out.indices.iter().map(|i| i + base));
    }
    b.put(mesh);
}
