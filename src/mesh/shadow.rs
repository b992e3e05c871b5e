//! What a hair casts into the shadow maps.
//!
//! A round tube's shadow from a light is the shadow of a flat ribbon through its axis, as wide
//! as the tube, turned to face the light. So by default ([`HairShadowCaster::Ribbons`]) a hair's
//! tubes cast no shadow themselves (`NotShadowCaster` on its mesh entity) and a second mesh of
//! its own ([`HairShadowMeshOf`]) casts in their place: at every [`SHADOW_RING_STEP`]th ring of
//! the tube (and the tip's) its centre plus and minus the ring's radius across the strand and
//! the way to the light, two triangles a ribbon segment against the tube's two a side and ring.
//! A shadow map's texel is coarser than the tube's rings are apart; the render test measures
//! the ribbons' shadow against the tubes'. The cameras never draw it (the render plugin
//! keeps it out of their visible entities); the shadow passes draw it, both faces.
//!
//! The ribbons face one light: the brightest directional light that casts shadows, or, with
//! none, the nearest point or spot light that does. Another shadow-casting light sees them at
//! an angle, their shadow narrower by the cosine of it; [`HairShadowCaster::Tubes`] casts the
//! tubes themselves as before, for scenes lit by several shadowing lights from far apart.
//!
//! For a hair whose tubes the GPU builds ([`HairMeshBuiltOnGpu`]) the ribbons are built on the
//! GPU too, from the tube pass's ring frames: [`build_shadow_ribbons`] gives the hair a mesh of
//! fixed topology ([`shadow_ribbon_mesh`]) and a [`GpuShadowJob`].

use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::NoAutoAabb;
use bevy::light::NotShadowCaster;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;

use super::{ComputedHairMesh, HairInView, HairMeshBuiltOnGpu, HairMeshOf, HairMeshSettings};
use crate::sim::{ComputedHair, Hair};

/// What a hair casts into the shadow maps. A component on the [`Hair`] entity (inserted with
/// the default when missing).
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub enum HairShadowCaster {
    /// Ribbons as wide as the tubes, facing the shadow light (see the module docs): a
    /// sixteenth of the triangles of 8-sided tubes, the same shadow from that light.
    #[default]
    Ribbons,
    /// The tubes themselves, from every light alike.
    Tubes,
    /// No shadow.
    Off,
}

/// The hair whose shadow this mesh entity casts (see the module docs).
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = HairShadowMeshes)]
pub struct HairShadowMeshOf(pub Entity);

/// A hair's shadow mesh entities; despawning the hair despawns them.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
#[relationship_target(relationship = HairShadowMeshOf, linked_spawn)]
pub struct HairShadowMeshes(Vec<Entity>);

/// The light a hair's shadow ribbons face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShadowLight {
    /// A directional light: the direction toward it.
    Toward(Vec3),
    /// A point or spot light: where it is.
    At(Vec3),
}

impl ShadowLight {
    /// The direction from `p` toward the light (`fallback` where undefined).
    pub fn from(self, p: Vec3, fallback: Vec3) -> Vec3 {
        match self {
            ShadowLight::Toward(d) => d.normalize_or(fallback),
            ShadowLight::At(at) => (at - p).normalize_or(fallback),
        }
    }

    /// As the GPU reads it: `xyz` the direction toward the light with `w = 0`, or its position
    /// with `w = 1`.
    pub fn to_vec4(self) -> Vec4 {
        match self {
            ShadowLight::Toward(d) => d.extend(0.0),
            ShadowLight::At(at) => at.extend(1.0),
        }
    }
}

/// The shadow ribbons of a hair to build on the GPU this frame; on the [`Hair`] entity
/// (inserted with it), `None` inside while the CPU builds them or none are cast.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct GpuShadowJob(pub Option<GpuShadowRibbons>);

/// The ring centres of a hair's tubes as the CPU built them this frame, strand after strand in
/// groom order, [`TubeTopology::rings`](super::tube::TubeTopology::rings) a strand: the CPU
/// builds the shadow ribbons from them, so a strand's spline is sampled once a frame. On the
/// [`Hair`] entity (inserted with it); left empty while the hair casts no ribbons.
#[derive(Component, Clone, Debug, Default)]
pub struct TubeRingCentres(pub Vec<Vec3>);

/// What the GPU needs to build a hair's shadow ribbons.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuShadowRibbons {
    /// The mesh the GPU fills ([`shadow_ribbon_mesh`]).
    pub mesh: AssetId<Mesh>,
    /// The light they face.
    pub light: ShadowLight,
}

/// Hairs of fewer strands have their ribbons built on one thread.
const PARALLEL_RIBBON_STRANDS: usize = 1024;

/// The ribbons take every this many rings of the tube, and the tip's.
pub const SHADOW_RING_STEP: usize = 2;

/// The rings of a strand's ribbon for a tube of `rings` rings: every [`SHADOW_RING_STEP`]th and
/// the tip's (at least two).
pub fn shadow_ribbon_rings(rings: usize) -> usize {
    rings.saturating_sub(1).div_ceil(SHADOW_RING_STEP).max(1) + 1
}

/// Vertices of a shadow ribbon mesh for tubes of `rings` rings: two a ribbon ring of every
/// strand.
pub fn shadow_ribbon_vertex_count(strands: usize, rings: usize) -> usize {
    strands * shadow_ribbon_rings(rings) * 2
}

/// A shadow ribbon mesh of `strands` strands for tubes of `rings` rings: positions (zero until
/// built; the shadow passes read nothing else), and two triangles a ribbon segment (vertex
/// `2 (strand * n + j) + side` for ribbon ring `j` of [`shadow_ribbon_rings`] `n`).
pub fn shadow_ribbon_mesh(strands: usize, rings: usize) -> Mesh {
    let vertices = shadow_ribbon_vertex_count(strands, rings);
    let rings = shadow_ribbon_rings(rings) as u32;
    let indices: Vec<u32> = (0..strands as u32)
        .flat_map(|s| {
            (0..rings.saturating_sub(1)).flat_map(move |r| {
                let v = 2 * (s * rings + r);
                [v, v + 1, v + 2, v + 1, v + 3, v + 2]
            })
        })
        .collect();
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; vertices])
    .with_inserted_indices(Indices::U32(indices))
}

/// Writes one strand's ribbon: at every [`SHADOW_RING_STEP`]th of `centres` (the tube's ring
/// centres, root first) and the last, the centre minus and plus `radius_at(x)` (`x` from `0` at
/// the root to `1` at the tip) across the strand and the way to `light`. `positions` holds two
/// entries a ribbon ring ([`shadow_ribbon_rings`] of `centres.len()`).
pub fn ribbon_strand(
    centres: &[Vec3],
    radius_at: impl Fn(f32) -> f32,
    light: ShadowLight,
    positions: &mut [[f32; 3]],
) {
    let n = centres.len();
    if n == 0 {
        return;
    }
    let last = n.saturating_sub(1).max(1) as f32;
    let mut tangent = Vec3::Y;
    // A directional light's way is the same for every ring.
    let sun = match light {
        ShadowLight::Toward(d) => Some(d.normalize_or(Vec3::Y)),
        ShadowLight::At(_) => None,
    };
    for j in 0..shadow_ribbon_rings(n).min(positions.len() / 2) {
        let i = (j * SHADOW_RING_STEP).min(n - 1);
        let c = centres[i];
        let (prev, next) = (centres[i.saturating_sub(1)], centres[(i + 1).min(n - 1)]);
        tangent = (next - prev).normalize_or(tangent);
        let to_light = sun.unwrap_or_else(|| light.from(c, Vec3::Y));
        let across = tangent
            .cross(to_light)
            .normalize_or(tangent.any_orthonormal_vector());
        let r = radius_at(i as f32 / last);
        let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
        let (a, b) = (c - across * r, c + across * r);
        let (a, b) = if a.is_finite() && b.is_finite() {
            (a, b)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        positions[2 * j] = a.to_array();
        positions[2 * j + 1] = b.to_array();
    }
}

/// The light a hair's ribbons face: the brightest shadow-casting directional light, else the
/// nearest shadow-casting point or spot light to `at`.
fn shadow_light(
    at: Vec3,
    directional: &Query<(&DirectionalLight, &GlobalTransform)>,
    points: &Query<(&PointLight, &GlobalTransform)>,
    spots: &Query<(&SpotLight, &GlobalTransform)>,
) -> Option<ShadowLight> {
    let sun = directional
        .iter()
        .filter(|(l, _)| l.shadow_maps_enabled)
        .max_by(|a, b| a.0.illuminance.total_cmp(&b.0.illuminance))
        .map(|(_, t)| ShadowLight::Toward(t.back().as_vec3()));
    sun.or_else(|| {
        let point = points
            .iter()
            .filter(|(l, _)| l.shadow_maps_enabled)
            .map(|(_, t)| t.translation());
        let spot = spots
            .iter()
            .filter(|(l, _)| l.shadow_maps_enabled)
            .map(|(_, t)| t.translation());
        point
            .chain(spot)
            .min_by(|a, b| a.distance_squared(at).total_cmp(&b.distance_squared(at)))
            .map(ShadowLight::At)
    })
}

/// Gives every hair the shadow caster its [`HairShadowCaster`] asks for, and rebuilds the
/// ribbons of the hairs in view (on the CPU, or as a [`GpuShadowJob`]).
#[expect(
    clippy::type_complexity,
    clippy::too_many_arguments,
    reason = "a Bevy system: its parameters are its queries"
)]
pub fn build_shadow_ribbons(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut hairs: Query<
        (
            Entity,
            &HairShadowCaster,
            &HairMeshSettings,
            &TubeRingCentres,
            Option<&HairShadowMeshes>,
            &HairInView,
            &ComputedHairMesh,
            &mut GpuShadowJob,
            (&ComputedHair, &GlobalTransform),
            Has<HairMeshBuiltOnGpu>,
        ),
        With<Hair>,
    >,
    ribbon_meshes: Query<&Mesh3d, With<HairShadowMeshOf>>,
    mut visibility: Query<&mut Visibility, With<HairShadowMeshOf>>,
    mut aabbs: Query<&mut Aabb, Or<(With<HairMeshOf>, With<HairShadowMeshOf>)>>,
    tube_casts: Query<Has<NotShadowCaster>, With<HairMeshOf>>,
    lights: (
        Query<(&DirectionalLight, &GlobalTransform)>,
        Query<(&PointLight, &GlobalTransform)>,
        Query<(&SpotLight, &GlobalTransform)>,
    ),
) {
    for (hair, caster, settings, centres, ribbons, in_view, computed, mut job, (sim, at), gpu) in
        &mut hairs
    {
        if job.0.is_some() {
            job.0 = None;
        }
        let light = shadow_light(at.translation(), &lights.0, &lights.1, &lights.2);
        let ribbon = ribbons.and_then(|r| r.iter().next());
        let cast_ribbons = *caster == HairShadowCaster::Ribbons && light.is_some();
        // The tubes cast only when asked to.
        let tubes_quiet = *caster != HairShadowCaster::Tubes;
        if let Ok(quiet) = tube_casts.get(computed.entity)
            && quiet != tubes_quiet
        {
            if tubes_quiet {
                commands.entity(computed.entity).insert(NotShadowCaster);
            } else {
                commands.entity(computed.entity).remove::<NotShadowCaster>();
            }
        }
        if let Some(e) = ribbon
            && let Ok(mut v) = visibility.get_mut(e)
        {
            v.set_if_neq(if cast_ribbons {
                Visibility::Inherited
            } else {
                Visibility::Hidden
            });
        }
        let (Some(light), true) = (light, cast_ribbons) else {
            continue;
        };
        let Some(ribbon) = ribbon else {
            commands.spawn((
                Name::new("hair shadow ribbons"),
                Mesh3d(meshes.add(shadow_ribbon_mesh(0, 2))),
                Transform::IDENTITY,
                NoAutoAabb,
                Aabb::from_min_max(Vec3::ZERO, Vec3::ZERO),
                HairShadowMeshOf(hair),
            ));
            continue;
        };
        // The ribbons lie within the tubes: their bounds are the tubes'.
        if let Ok(bounds) = aabbs.get(computed.entity).copied()
            && let Ok(mut aabb) = aabbs.get_mut(ribbon)
        {
            aabb.set_if_neq(bounds);
        }
        let Ok(handle) = ribbon_meshes.get(ribbon).map(|m| m.0.clone()) else {
            continue;
        };
        // Hair no camera sees keeps its last shadow, as it keeps its last tubes.
        if !in_view.0 {
            continue;
        }
        let rings = computed.topology.rings();
        let count = shadow_ribbon_vertex_count(computed.strands, rings);
        if meshes.get(&handle).map(Mesh::count_vertices) != Some(count)
            && let Some(mut mesh) = meshes.get_mut(&handle)
        {
            *mesh = shadow_ribbon_mesh(computed.strands, rings);
        }
        if gpu {
            job.0 = Some(GpuShadowRibbons {
                mesh: handle.id(),
                light,
            });
            continue;
        }
        // The tubes' ring centres as the CPU built them this frame.
        if rings == 0 || centres.0.len() != computed.strands * rings {
            continue;
        }
        let Some(mut mesh) = meshes.get_mut(&handle) else {
            continue;
        };
        let Some(bevy::mesh::VertexAttributeValues::Float32x3(mut positions)) =
            mesh.remove_attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            continue;
        };
        let radius = settings.radius * sim.size();
        let taper = settings.taper;
        let per_strand = 2 * shadow_ribbon_rings(rings);
        let build = |(positions, centres): (&mut [[f32; 3]], &[Vec3])| {
            let radius_at = |x: f32| radius * taper.eval(x).max(0.0);
            for (p, centres) in positions.chunks_mut(per_strand).zip(centres.chunks(rings)) {
                ribbon_strand(centres, radius_at, light, p);
            }
        };
        // A few writes a ring: in parallel over the strands only where there are enough of them
        // to pay for waking the workers.
        if computed.strands < PARALLEL_RIBBON_STRANDS {
            build((&mut positions, &centres.0));
        } else {
            let pool = crate::parallel::compute_pool();
            let chunk = computed
                .strands
                .div_ceil(crate::parallel::workers(pool))
                .max(1);
            let parts = positions
                .chunks_mut(per_strand * chunk)
                .zip(centres.0.chunks(rings * chunk));
            crate::parallel::run_parts(pool, parts, &build);
        }
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ribbon across a straight strand lies across the way to the light at the ring's radius,
    /// so its outline seen from the light is the tube's; it takes every other ring and the tip.
    #[test]
    fn ribbons_are_as_wide_as_the_tube_across_the_light() {
        let centres: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(0.0, -0.1 * i as f32, 0.0))
            .collect();
        // Rings 0, 2, 4 and the tip's, 5.
        assert_eq!(shadow_ribbon_rings(6), 4);
        let rings = [0, 2, 4, 5];
        let mut p = vec![[0.0; 3]; 8];
        let light = ShadowLight::Toward(Vec3::new(0.0, 0.0, 2.0));
        ribbon_strand(&centres, |x| 0.01 * (1.2 - x), light, &mut p);
        for (j, &i) in rings.iter().enumerate() {
            let (a, b) = (Vec3::from(p[2 * j]), Vec3::from(p[2 * j + 1]));
            let width = a.distance(b);
            let expected = 0.02 * (1.2 - i as f32 / 5.0);
            assert!(
                (width - expected).abs() < 1e-6,
                "ring {i}: {width} for {expected}"
            );
            // Across: perpendicular to the strand and to the light.
            let d = (b - a).normalize_or_zero();
            assert!(d.dot(Vec3::Y).abs() < 1e-6 && d.dot(Vec3::Z).abs() < 1e-6);
            assert!(((a + b) * 0.5).distance(centres[i]) < 1e-6);
        }
        // A point light: each ring faces the light from where it is.
        let at = Vec3::new(1.0, -0.2, 0.0);
        ribbon_strand(&centres, |_| 0.01, ShadowLight::At(at), &mut p);
        for (j, &i) in rings.iter().enumerate() {
            let d = Vec3::from(p[2 * j + 1]) - Vec3::from(p[2 * j]);
            let to = (at - centres[i]).normalize();
            assert!(
                d.dot(to).abs() < 1e-6,
                "ring {i} is not across the way to the light"
            );
        }
    }

    /// On the CPU path the ribbons run through the centres of the tube rings built the same
    /// frame, strand by strand: each ribbon ring's midpoint is the mean of its tube ring's
    /// vertices (a round section is symmetric about its centre), and its width the ring's
    /// diameter.
    #[test]
    fn cpu_ribbons_run_through_this_frames_tube_rings() {
        use crate::mesh::lod::app_tests::{camera, hair, lod_app};
        let mut app = lod_app();
        camera(app.world_mut());
        app.world_mut().spawn((
            DirectionalLight {
                shadow_maps_enabled: true,
                ..default()
            },
            Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
        ));
        let (bone, hair) = hair(&mut app, -0.8);
        for frame in 0..8 {
            // The head moves every frame, so stale ribbons would lag the tubes.
            app.world_mut()
                .get_mut::<Transform>(bone)
                .unwrap()
                .translation
                .x = 0.02 * frame as f32;
            app.update();
        }
        let world = app.world();
        let computed = world.get::<ComputedHairMesh>(hair).unwrap();
        let (rings, sides) = (computed.topology.rings(), computed.topology.sides());
        assert!(
            !computed.topology.is_facing(),
            "the CPU builds closed tubes"
        );
        let per = computed.vertices_per_strand();
        let meshes = world.resource::<Assets<Mesh>>();
        let positions = |handle: &Handle<Mesh>| -> Vec<Vec3> {
            match meshes
                .get(handle)
                .unwrap()
                .attribute(Mesh::ATTRIBUTE_POSITION)
            {
                Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) => {
                    p.iter().map(|v| Vec3::from(*v)).collect()
                }
                other => panic!("no positions: {other:?}"),
            }
        };
        let tubes = positions(&computed.mesh);
        let ribbon = world.get::<HairShadowMeshes>(hair).unwrap().iter().next();
        let ribbon = world.get::<Mesh3d>(ribbon.unwrap()).unwrap().0.clone();
        let ribbons = positions(&ribbon);
        let n = shadow_ribbon_rings(rings);
        assert_eq!(ribbons.len(), computed.strands * n * 2);
        for s in 0..computed.strands {
            for j in 0..n {
                let i = (j * SHADOW_RING_STEP).min(rings - 1);
                let ring = &tubes[s * per + i * sides..s * per + (i + 1) * sides];
                let centre = ring.iter().sum::<Vec3>() / sides as f32;
                let (a, b) = (ribbons[2 * (s * n + j)], ribbons[2 * (s * n + j) + 1]);
                assert!(
                    ((a + b) * 0.5).distance(centre) < 1e-4,
                    "strand {s} ring {i}: ribbon at {}, tube at {centre}",
                    (a + b) * 0.5
                );
                let diameter = 2.0 * ring[0].distance(centre);
                assert!(
                    (a.distance(b) - diameter).abs() < 1e-3 * diameter.max(1e-3),
                    "strand {s} ring {i}: ribbon {} wide, tube {diameter}",
                    a.distance(b)
                );
            }
        }
    }

    /// Non-finite input collapses a ring instead of writing NaN.
    #[test]
    fn ribbons_never_hold_nan() {
        let centres = [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Y];
        let mut p = vec![[1.0; 3]; 4];
        let light = ShadowLight::Toward(Vec3::ZERO);
        ribbon_strand(&centres, |_| f32::INFINITY, light, &mut p);
        assert!(p.iter().flatten().all(|v| v.is_finite()), "{p:?}");
    }

    /// Two triangles a ribbon segment, every index inside the mesh: for 16-ring tubes, rings
    /// 0, 2, ..., 14 and 15.
    #[test]
    fn the_ribbon_mesh_has_two_triangles_a_segment() {
        assert_eq!(shadow_ribbon_rings(16), 9);
        assert_eq!(shadow_ribbon_rings(2), 2);
        assert_eq!(shadow_ribbon_rings(3), 2);
        let mesh = shadow_ribbon_mesh(3, 16);
        assert_eq!(mesh.count_vertices(), 54);
        let indices = mesh.indices().expect("indices");
        assert_eq!(indices.len(), 3 * 8 * 6);
        assert!(indices.iter().all(|i| i < 54));
    }
}
