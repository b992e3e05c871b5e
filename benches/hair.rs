//! Criterion benches for the issue targets. Run: `cargo bench --bench hair`.
//!
//! - `sim_frame/*`: one 60 Hz frame (default substeps) of the whole app update, for the thesis
//!   default (100 x 6), 1,000 x 16 and 10,000 x 16 strands; with a gusty wind; with hair–hair
//!   volume (`*_volume`); with a local force field reaching the hair and one out of reach
//!   (`1000x16_fan*`); with a body of colliders (`1000x16_body*`: head sphere, neck and
//!   shoulder capsules, a back plane, a swinging arm capsule, friction 0.3), with 300 more
//!   capsules out of reach (the broad phase's cost), beside the head sphere alone.
//! - `solver_frame/*`: the solver alone for the same workloads, one thread (no Bevy frame, no
//!   copy into strand entities).
//! - `rapier_chains/*`: the baseline a Bevy user would otherwise write: the same strands as
//!   bevy_rapier ball bodies joined by spherical impulse joints, one 60 Hz step, in the same run.
//! - `load_groom/100k_x_6`: parsing a 100,000-strand, 6-particle groom file.
//! - `mesh/*`, `silhouettes/*`: tube rebuild and silhouette strokes for 1,000 strands at 16 x 8:
//!   single-threaded, plus the strokes as the plugin builds them on this machine's two threads
//!   (`silhouettes/plugin_2_threads_*`) and the general closed-mesh path beside the tube one.
//! - `tam/*`: generating the thesis's default tonal art map (6 tones, 512 px, 3 mips, 78 strokes,
//!   10 candidates).
//! - `frame/*`: the whole `app.update()` with every stage of the hair on (simulation, tube
//!   mesh, object-space strokes for a 1280x720 camera, specular quads), the tubes, strokes and
//!   quads built where the plugin builds them by default (on the GPU: the CPU gathers the
//!   passes' inputs; `frame_build` has the CPU path beside it), each beside the same app
//!   without hair (`*_no_hair`): W1, the thesis default (100 x 6, 8 rings x 8 sides); W6, a
//!   crowd of 16 heads of 160 x 7 at 2 to 24.5 m, half of them behind the camera, with culling
//!   and level of detail and with both off; W2, 10,000 x 16 on one hair. There is no render app here (no GPU on the
//!   bench machine): material assignment and the upload of meshes to the GPU are not measured.
//!   After each, the stage times of `HairStageTimings` (smoothed over about ten frames) are
//!   printed.
//! - `thesis/*`: the thesis's performance tables 5.3-5.5 reproduced on the W1 hair (resolution
//!   x outline method, outline width, anchor stiffness x skeleton and hair animation), printed
//!   as a table beside the thesis's frame rates at the end of the group. Image-space outlines
//!   and dilation are GPU work: on the CPU those rows are the frame without strokes.
#![expect(
    missing_docs,
    reason = "criterion's macros define undocumented functions"
)]

mod common;

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cartoon_hair::HairSchedulePlugin;
use bevy_cartoon_hair::asset::{CollisionCapsule, CollisionPlane, CollisionSphere};
use bevy_cartoon_hair::asset::{HairAssetPlugin, HairGroom, parse_groom};
use bevy_cartoon_hair::sim::{Hair, HairCollider, HairSimSettings, HairSimulationPlugin};
use bevy_rapier3d::prelude::*;
use common::{Head, bench_camera, minimal_plugins, strands};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

fn hair_app(n: usize, particles: usize) -> App {
    let mut app = App::new();
    app.add_plugins((
        minimal_plugins(),
        TransformPlugin,
        AssetPlugin::default(),
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    let bone = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 1.6, 0.0))
        .id();
    if n > 0 {
        let groom = HairGroom::from_strands("head", strands(n, particles)).unwrap();
        let groom = app
            .world_mut()
            .resource_mut::<Assets<HairGroom>>()
            .add(groom);
        app.world_mut().spawn((
            Hair { groom, ..default() },
            HairSimSettings::default(),
            ChildOf(bone),
        ));
    }
    for _ in 0..3 {
        app.update();
    }
    app
}

/// The arm of `with_body`, swinging through the hair.
#[derive(Component)]
struct Arm;

fn swing_arm(time: Res<Time>, mut arms: Query<&mut Transform, With<Arm>>) {
    for mut t in &mut arms {
        // 0.3 m either side at 1 Hz: up to 1.9 m/s.
        t.translation.x = 0.3 * (std::f32::consts::TAU * time.elapsed_secs()).sin();
    }
}

/// Adds a body of colliders around the bone at (0, 1.6, 0): the head sphere; neck, shoulder
/// and arm capsules (the arm swings through the hair); a plane behind the back; friction 0.3;
/// and `far` capsules out of the hair's reach.
fn with_body(app: &mut App, far: usize) {
    let world = app.world_mut();
    let capsule = |a: Vec3, b: Vec3, radius| CollisionCapsule { a, b, radius };
    world.spawn((
        HairCollider {
            spheres: vec![CollisionSphere {
                center: Vec3::ZERO,
                radius: 0.1,
            }],
            capsules: vec![
                capsule(Vec3::new(0.0, -0.05, 0.0), Vec3::new(0.0, -0.2, 0.0), 0.05),
                capsule(
                    Vec3::new(0.05, -0.22, 0.0),
                    Vec3::new(0.2, -0.25, 0.0),
                    0.06,
                ),
                capsule(
                    Vec3::new(-0.05, -0.22, 0.0),
                    Vec3::new(-0.2, -0.25, 0.0),
                    0.06,
                ),
            ],
            planes: vec![CollisionPlane {
                point: Vec3::new(0.0, 0.0, -0.12),
                normal: Vec3::Z,
            }],
            ..default()
        },
        Transform::from_xyz(0.0, 1.6, 0.0),
    ));
    world.spawn((
        HairCollider {
            capsules: vec![capsule(
                Vec3::new(0.0, 0.0, -0.3),
                Vec3::new(0.0, 0.0, 0.3),
                0.04,
            )],
            ..default()
        },
        Transform::from_xyz(0.0, 1.5, 0.0),
        Arm,
    ));
    for i in 0..far {
        world.spawn((
            HairCollider {
                capsules: vec![capsule(Vec3::ZERO, Vec3::X, 0.1)],
                ..default()
            },
            Transform::from_xyz(10.0 + (i % 20) as f32, 0.0, (i / 20) as f32),
        ));
    }
    let mut q = world.query::<&mut HairSimSettings>();
    for mut s in q.iter_mut(world) {
        s.friction = 0.3;
    }
    app.add_systems(Update, swing_arm);
    for _ in 0..3 {
        app.update();
    }
}

fn rapier_app(n: usize, particles: usize) -> App {
    let mut app = App::new();
    app.add_plugins((
        minimal_plugins(),
        TransformPlugin,
        RapierPhysicsPlugin::<NoUserData>::default(),
    ))
    .insert_resource(TimestepMode::Fixed {
        dt: 1.0 / 60.0,
        substeps: 1,
    })
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    app.update();
    let world = app.world_mut();
    for strand in strands(n, particles) {
        let mut parent = world
            .spawn((RigidBody::Fixed, Transform::from_translation(strand[0])))
            .id();
        for w in strand.windows(2) {
            let joint = SphericalJointBuilder::new().local_anchor2(w[0] - w[1]);
            parent = world
                .spawn((
                    RigidBody::Dynamic,
                    AdditionalMassProperties::Mass(0.001),
                    // Hair must react at any time; sleeping chains would cost nothing.
                    Sleeping::disabled(),
                    Transform::from_translation(w[1]),
                    ImpulseJoint::new(parent, joint),
                ))
                .id();
        }
    }
    for _ in 0..3 {
        app.update();
    }
    app
}

fn bench_sim(c: &mut Criterion) {
    let mut group = c.benchmark_group("sim_frame");
    // The same app with no hair: Bevy's own per-frame cost, to subtract.
    let mut app = hair_app(0, 0);
    group.bench_function("no_hair", |b| b.iter(|| app.update()));
    for (n, p) in [(100, 6), (1_000, 16), (10_000, 16)] {
        let mut app = hair_app(n, p);
        group.bench_function(BenchmarkId::from_parameter(format!("{n}x{p}")), |b| {
            b.iter(|| app.update());
        });
    }
    // The same frame with a gusty wind: the cost of the wind's drag pass.
    let mut app = hair_app(1_000, 16);
    app.insert_resource(bevy_cartoon_hair::sim::HairWind {
        velocity: Vec3::new(6.0, 0.0, 0.0),
        ..Default::default()
    });
    group.bench_function("1000x16_wind", |b| b.iter(|| app.update()));
    // A local force field (a fan) reaching the whole hair, and one out of reach.
    for (name, at) in [("1000x16_fan", 0.6), ("1000x16_fan_far", 20.0)] {
        let mut app = hair_app(1_000, 16);
        app.world_mut().spawn((
            bevy_cartoon_hair::sim::HairForceField {
                kind: bevy_cartoon_hair::sim::HairForceFieldKind::Directional,
                speed: 8.0,
                radius: 1.5,
                ..Default::default()
            },
            Transform::from_xyz(at, 1.6, 0.0).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y),
        ));
        group.bench_function(name, |b| b.iter(|| app.update()));
    }
    // Colliders: the head sphere alone; a body of capsules, a plane and a swinging arm with
    // friction; the same with 300 capsules out of reach.
    let mut app = hair_app(1_000, 16);
    app.world_mut().spawn((
        HairCollider::spheres(vec![CollisionSphere {
            center: Vec3::ZERO,
            radius: 0.1,
        }]),
        Transform::from_xyz(0.0, 1.6, 0.0),
    ));
    group.bench_function("1000x16_head_sphere", |b| b.iter(|| app.update()));
    for (name, far) in [("1000x16_body", 0), ("1000x16_body_300_far", 300)] {
        let mut app = hair_app(1_000, 16);
        with_body(&mut app, far);
        group.bench_function(name, |b| b.iter(|| app.update()));
    }
    // The same frames with hair–hair volume: with a radius of half the roots' spacing (the
    // strands touch at the roots, as guide strands a tube apart do), and with the default 16 mm
    // (tubes overlapping many times over: the worst case, bounded by `MAX_PAIRS`).
    for (n, p) in [(100, 6), (1_000, 16), (10_000, 16)] {
        // Roots on a 0.1 m half sphere: spacing sqrt(2 pi 0.1^2 / n).
        let spacing = (std::f32::consts::TAU * 0.01 / n as f32).sqrt();
        for (name, radius) in [("touching", Some(0.5 * spacing)), ("16mm", None)] {
            let mut app = hair_app(n, p);
            let world = app.world_mut();
            let mut q = world.query::<&mut HairSimSettings>();
            for mut s in q.iter_mut(world) {
                s.volume = Some(bevy_cartoon_hair::sim::HairVolume {
                    radius,
                    ..Default::default()
                });
            }
            for _ in 0..3 {
                app.update();
            }
            group.bench_function(format!("{n}x{p}_volume_{name}"), |b| {
                b.iter(|| app.update());
            });
        }
    }
    // The same while the head nods (0.6 rad at 2 rad/s, 0.2 at 3): the hair moves against the
    // head every frame, so the volume's pair list is rebuilt as often as the motion needs.
    for (name, volume) in [
        ("none", None),
        (
            "touching",
            Some(Some(0.5 * (std::f32::consts::TAU * 0.01 / 1_000.0).sqrt())),
        ),
        ("16mm", Some(None)),
    ] {
        let mut app = hair_app(1_000, 16);
        let world = app.world_mut();
        let bone = world
            .query_filtered::<&ChildOf, With<Hair>>()
            .iter(world)
            .next()
            .map(ChildOf::parent)
            .unwrap();
        world.entity_mut(bone).insert(Nod);
        let mut q = world.query::<&mut HairSimSettings>();
        for mut s in q.iter_mut(world) {
            s.volume = volume.map(|radius| bevy_cartoon_hair::sim::HairVolume {
                radius,
                ..Default::default()
            });
        }
        app.add_systems(Update, nod);
        for _ in 0..30 {
            app.update();
        }
        group.bench_function(format!("1000x16_nodding_volume_{name}"), |b| {
            b.iter(|| app.update());
        });
    }
    // The same on a head: the head sphere keeps the hair spread as on a character (without
    // it the hair falls through the head into one bundle), beside the frame with the head and
    // no volume.
    for (n, p) in [(1_000, 16), (10_000, 16)] {
        let spacing = (std::f32::consts::TAU * 0.01 / n as f32).sqrt();
        for (name, volume) in [
            ("none", None),
            ("touching", Some(Some(0.5 * spacing))),
            ("16mm", Some(None)),
        ] {
            let mut app = hair_app(n, p);
            app.world_mut().spawn((
                HairCollider::spheres(vec![CollisionSphere {
                    center: Vec3::ZERO,
                    radius: 0.1,
                }]),
                Transform::from_xyz(0.0, 1.6, 0.0),
            ));
            let world = app.world_mut();
            let mut q = world.query::<&mut HairSimSettings>();
            for mut s in q.iter_mut(world) {
                s.volume = volume.map(|radius| bevy_cartoon_hair::sim::HairVolume {
                    radius,
                    ..Default::default()
                });
            }
            for _ in 0..30 {
                app.update();
            }
            group.bench_function(format!("{n}x{p}_on_head_volume_{name}"), |b| {
                b.iter(|| app.update());
            });
        }
    }
    group.finish();
    let mut group = c.benchmark_group("rapier_chains");
    group.sample_size(10);
    for (n, p) in [(100, 6), (1_000, 16)] {
        let mut app = rapier_app(n, p);
        group.bench_function(BenchmarkId::from_parameter(format!("{n}x{p}")), |b| {
            b.iter(|| app.update());
        });
    }
    group.finish();
}

/// A tree parser's work for the same file: a roxmltree document, then every strand's numbers.
fn roxmltree_baseline(text: &str) -> Vec<Vec3> {
    let doc = roxmltree::Document::parse(text).unwrap();
    let mut points = Vec::new();
    for node in doc
        .root_element()
        .children()
        .filter(|n| n.has_tag_name("strand"))
    {
        let mut numbers = node.text().unwrap_or("").split_ascii_whitespace();
        while let (Some(x), Some(y), Some(z)) = (numbers.next(), numbers.next(), numbers.next()) {
            let p = [x, y, z].map(|t| t.parse::<f32>().unwrap());
            points.push(Vec3::from_array(p));
        }
    }
    points
}

fn bench_load(c: &mut Criterion) {
    let mut text =
        String::from("<?xml version=\"1.0\"?>\n<groom version=\"1\" scale=\"1\" bone=\"head\">\n");
    for s in strands(100_000, 6) {
        text.push_str("<strand>");
        for p in s {
            text.push_str(&format!("{:.6} {:.6} {:.6} ", p.x, p.y, p.z));
        }
        text.push_str("</strand>\n");
    }
    text.push_str("</groom>\n");
    let mut group = c.benchmark_group("load_groom");
    group.sample_size(10);
    group.bench_function("100k_x_6", |b| {
        b.iter(|| parse_groom("bench.hair.xml", &text).unwrap());
    });
    // The baseline: a tree parser (roxmltree builds the document's
    // tree, then the strands' numbers are parsed from it), on the same text in the same run.
    group.bench_function("100k_x_6_roxmltree_baseline", |b| {
        b.iter(|| roxmltree_baseline(&text));
    });
    // As many short strands as a groom may have (many elements, few numbers each), an
    // attribute on each: 3.6 MB.
    let mut short = String::from("<groom version=\"1\">\n");
    for i in 0..bevy_cartoon_hair::asset::MAX_STRANDS {
        short.push_str(&format!(
            "<strand a=\"{i}\">0 0 0 0 1 {}</strand>\n",
            i % 7 + 1
        ));
    }
    short.push_str("</groom>\n");
    group.bench_function("100k_short_strands", |b| {
        b.iter(|| parse_groom("short.hair.xml", &short).unwrap());
    });
    // A hostile header: 100,000 attributes on the root (38.6 s before; refused at the 33rd now).
    let attrs: String = (0..100_000).map(|i| format!(" a{i}=\"{i}\"")).collect();
    let hostile = format!("<groom version=\"1\"{attrs}><strand>0 0 0 0 1 0</strand></groom>");
    group.bench_function("100k_attributes_refused", |b| {
        b.iter(|| parse_groom("hostile.hair.xml", &hostile).unwrap_err());
    });
    group.finish();
}

fn bench_tam(c: &mut Criterion) {
    use bevy_cartoon_hair::hatching::{StrokeImage, TamSettings, generate};
    let stroke = StrokeImage::default();
    let settings = TamSettings::default();
    let mut group = c.benchmark_group("tam");
    group.sample_size(10);
    group.bench_function("thesis_default_6x512x3_78x10", |b| {
        b.iter(|| generate(&stroke, &settings, |_, _| {}).unwrap());
    });
    group.finish();
}

/// 1,000 strands at 16 rings x 8 sides: tube positions and normals, then silhouette extraction,
/// chaining and stroke strips: single-threaded (`tube_*`, `general_*` and the stages), and as the
/// plugin runs it on this machine's two cores, mesh writing included (`plugin_2_threads_*`).
fn bench_mesh_and_silhouettes(c: &mut Criterion) {
    use bevy_cartoon_hair::mesh::tube::{TubeParams, TubeScratch, TubeTopology, build_tube};
    use bevy_cartoon_hair::silhouette::adjacency::{
        EdgeAdjacency, SilhouetteScratch, silhouette_edges,
    };
    use bevy_cartoon_hair::silhouette::chain::{SilhouetteChains, chain_edges};
    use bevy_cartoon_hair::silhouette::strip::{
        StrokeCamera, StrokeParams, StrokeVertices, build_chain_strip,
    };
    use bevy_cartoon_hair::silhouette::strokes::{StrokeBuilder, StrokeWorker};
    use bevy_cartoon_hair::silhouette::tube_edges::{TubeEdgeScratch, TubeEdges};
    let topology = TubeTopology::new(16, 8);
    let per = topology.vertex_count();
    let strands = strands(1_000, 12);
    let mut positions = vec![[0.0f32; 3]; per * strands.len()];
    let mut normals = positions.clone();
    let params = TubeParams {
        radius: 0.015,
        ..default()
    };
    let mut scratch = TubeScratch::default();
    // Filled here too, so that the silhouette benches see real tubes when run alone.
    for ((s, p), n) in strands
        .iter()
        .zip(positions.chunks_mut(per))
        .zip(normals.chunks_mut(per))
    {
        build_tube(&topology, s, &params, &mut scratch, p, n, None);
    }
    let mut group = c.benchmark_group("mesh");
    group.bench_function("rebuild_1000x16x8", |b| {
        b.iter(|| {
            for ((s, p), n) in strands
                .iter()
                .zip(positions.chunks_mut(per))
                .zip(normals.chunks_mut(per))
            {
                build_tube(&topology, s, &params, &mut scratch, p, n, None);
            }
        });
    });
    group.finish();
    let adjacency = EdgeAdjacency::from_triangles(&topology.indices).unwrap();
    let tube = TubeEdges::new(&topology);
    let along: Vec<f32> = topology.uvs.iter().map(|uv| uv[1]).collect();
    let eye = Vec3::new(0.0, 0.2, 1.5);
    let camera_transform = Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y);
    let proj = bevy::math::proj::perspective(0.8, 16.0 / 9.0, 0.05, 100.0);
    let camera =
        StrokeCamera::from_view(camera_transform.to_matrix(), proj, Vec2::new(1280.0, 720.0));
    // What the plugin passes with its default settings: a 0.6-radius pull toward the camera.
    let stroke = StrokeParams {
        depth_bias: 0.6 * params.radius,
        ..default()
    };
    let mut group = c.benchmark_group("silhouettes");
    // What `extract_silhouettes` runs per strand (facing masks on the tube grid).
    let mut worker = StrokeWorker::default();
    group.bench_function("tube_1000x16x8", |b| {
        b.iter(|| {
            worker.clear();
            for s in positions.chunks(per) {
                worker.add_strand(&tube, s, &along, &camera, &stroke);
            }
        });
    });
    // What the plugin does per frame on this machine: the strands split between Bevy's compute
    // thread (one on two cores, by default) and the system's own thread, then the strokes
    // moved into the stroke meshes (one per block of strands).
    let pool = bevy::tasks::TaskPoolBuilder::new().num_threads(1).build();
    let mut builder = StrokeBuilder::default();
    let mut meshes = vec![
        Mesh::new(
            bevy::mesh::PrimitiveTopology::TriangleList,
            bevy::asset::RenderAssetUsages::default(),
        );
        bevy_cartoon_hair::silhouette::strokes::STROKE_BLOCKS
    ];
    // Once first, to check that strokes come out.
    builder.build(&pool, &positions, &tube, &along, &camera, &stroke);
    for (w, mesh) in meshes.iter_mut().enumerate() {
        builder.swap_into_mesh(w, mesh);
    }
    let drawn: usize = meshes.iter().map(Mesh::count_vertices).sum();
    assert!(drawn > 10_000, "{drawn} stroke vertices");
    group.bench_function("plugin_2_threads_1000x16x8", |b| {
        b.iter(|| {
            builder.build(&pool, &positions, &tube, &along, &camera, &stroke);
            for (w, mesh) in meshes.iter_mut().enumerate() {
                builder.swap_into_mesh(w, mesh);
            }
        });
    });
    // The same strokes through the general closed-mesh path (any triangle list).
    let mut sil_scratch = SilhouetteScratch::default();
    let mut edges = Vec::new();
    let mut chains = SilhouetteChains::default();
    let mut out = StrokeVertices::new();
    group.bench_function("general_1000x16x8", |b| {
        b.iter(|| {
            out.clear();
            for s in positions.chunks(per) {
                silhouette_edges(
                    &adjacency,
                    &topology.indices,
                    s,
                    eye,
                    &mut sil_scratch,
                    &mut edges,
                );
                chain_edges(&edges, &mut sil_scratch, &mut chains);
                for chain in chains.iter() {
                    build_chain_strip(chain, s, &along, &camera, &stroke, &mut out);
                }
            }
        });
    });
    // The stages alone, to see where the time goes.
    let mut tube_scratch = TubeEdgeScratch::default();
    group.bench_function("stage_tube_edges_1000x16x8", |b| {
        b.iter(|| {
            for s in positions.chunks(per) {
                tube.silhouette_edges(s, eye, &mut tube_scratch, &mut edges);
            }
        });
    });
    let all_edges: Vec<Vec<[u32; 2]>> = positions
        .chunks(per)
        .map(|s| {
            let mut e = Vec::new();
            tube.silhouette_edges(s, eye, &mut tube_scratch, &mut e);
            e
        })
        .collect();
    let edge_count: usize = all_edges.iter().map(Vec::len).sum();
    group.bench_function(format!("stage_chain_{edge_count}_edges"), |b| {
        b.iter(|| {
            for e in &all_edges {
                chain_edges(e, &mut sil_scratch, &mut chains);
            }
        });
    });
    let all_chains: Vec<SilhouetteChains> = all_edges
        .iter()
        .map(|e| {
            let mut c = SilhouetteChains::default();
            chain_edges(e, &mut sil_scratch, &mut c);
            c
        })
        .collect();
    let points: usize = all_chains.iter().map(|c| c.vertices.len()).sum();
    group.bench_function(format!("stage_strips_{points}_points"), |b| {
        b.iter(|| {
            out.clear();
            for (s, c) in positions.chunks(per).zip(&all_chains) {
                for chain in c.iter() {
                    build_chain_strip(chain, s, &along, &camera, &stroke, &mut out);
                }
            }
        });
    });
    group.finish();
}

/// The solver alone, one 60 Hz frame (4 substeps at the default 240 Hz), one thread: what the
/// simulation itself costs, without Bevy's frame or the copy into strand entities.
fn bench_solver(c: &mut Criterion) {
    use bevy::math::Affine3A;
    use bevy_cartoon_hair::sim::compliance_factor;
    use bevy_cartoon_hair::sim::solver::{Batch, LANES, PINNED, StepInput, along, build_chain};
    let settings = HairSimSettings::default();
    let h = settings.substep();
    let alpha = |s: f32| {
        let f = compliance_factor(s, h, 1.0);
        if f <= 0.0 {
            f32::INFINITY
        } else {
            1.0 / f - 1.0
        }
    };
    let mut group = c.benchmark_group("solver_frame");
    for (n, p) in [(100, 6), (1_000, 16), (10_000, 16)] {
        let chains: Vec<Vec<Vec3>> = strands(n, p)
            .iter()
            .map(|s| {
                let mut c = Vec::new();
                build_chain(s, settings.structure_offset(), None, &mut c);
                c
            })
            .collect();
        let bone = Affine3A::from_translation(Vec3::new(0.0, 1.6, 0.0));
        let mut batches: Vec<Batch> = chains
            .chunks(LANES)
            .enumerate()
            .map(|(b, group)| {
                let ids: Vec<u32> = (0..group.len() as u32)
                    .map(|l| (b * LANES) as u32 + l)
                    .collect();
                let refs: Vec<&[Vec3]> = group.iter().map(|c| &c[..]).collect();
                let mut batch = Batch::new(&ids, &refs, &[], &vec![0.01; group.len()]);
                batch.reset(&bone);
                batch
            })
            .collect();
        let nodes = chains[0].len();
        let input = StepInput {
            h,
            bones: vec![bone; 4],
            max_stretch: settings.max_stretch(),
            gravity_h2: settings.gravity() * h * h,
            damping: settings.damping_factor(),
            alpha: [
                alpha(settings.edge_stiffness),
                alpha(settings.bend_stiffness),
                alpha(settings.torsion_stiffness),
            ],
            anchor_factor: (0..nodes)
                .map(|k| {
                    if k < PINNED {
                        0.0
                    } else {
                        compliance_factor(
                            settings.anchor_stiffness.eval_unit(along(k, nodes)),
                            h,
                            1.0,
                        )
                    }
                })
                .collect(),
            ..default()
        };
        group.bench_function(BenchmarkId::from_parameter(format!("{n}x{p}")), |b| {
            b.iter(|| {
                for batch in &mut batches {
                    batch.step(&input);
                }
            });
        });
    }
    group.finish();
}

/// The app of the `frame` benches: every CPU stage of the hair, a camera at the origin looking
/// down -Z, and `heads` (none: the app's own cost).
/// Every CPU stage of the hair, stage timings, 60 Hz frames, and a camera at the origin looking
/// down -Z: what the `frame` and `thesis` apps share.
fn stages_app() -> App {
    use bevy_cartoon_hair::mesh::HairMeshPlugin;
    use bevy_cartoon_hair::silhouette::HairSilhouettePlugin;
    let mut app = App::new();
    app.add_plugins((
        minimal_plugins(),
        TransformPlugin,
        AssetPlugin::default(),
        bevy::diagnostic::DiagnosticsPlugin,
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
        HairMeshPlugin,
        HairSilhouettePlugin,
        bevy_cartoon_hair::debug::HairStageTimingsPlugin,
    ))
    .init_asset::<Mesh>()
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    bench_camera(app.world_mut(), Vec3::ZERO, Vec3::NEG_Z);
    app
}

fn frame_app(heads: &[Head], culling: bool) -> App {
    use bevy_cartoon_hair::mesh::HairCulling;
    use bevy_cartoon_hair::mesh::highlights::SpecularQuads;
    use bevy_cartoon_hair::silhouette::SilhouetteSettings;
    let mut app = stages_app();
    common::gpu_path(&mut app);
    for head in heads {
        let world = app.world_mut();
        let hair = common::spawn_head(world, head);
        world.entity_mut(hair).insert((
            SilhouetteSettings::default(),
            SpecularQuads {
                enabled: true,
                ..default()
            },
            HairCulling {
                enabled: culling,
                ..default()
            },
            bevy_cartoon_hair::mesh::HairLod {
                enabled: culling,
                ..default()
            },
        ));
    }
    for _ in 0..5 {
        app.update();
    }
    app
}

fn print_stages(name: &str, app: &App) {
    let t = app
        .world()
        .resource::<bevy_cartoon_hair::debug::HairStageTimings>();
    let culled = app
        .world()
        .get_resource::<bevy_cartoon_hair::mesh::HairCullingStats>()
        .copied()
        .unwrap_or_default();
    let stages: Vec<String> = t
        .stages()
        .iter()
        .map(|(n, ms)| format!("{n} {ms:.3} ms"))
        .collect();
    println!(
        "{name} stages: {}; culled {} of {} hairs, {} at level of detail 1, {} at 2, {} at 3",
        stages.join(", "),
        culled.culled,
        culled.hairs,
        culled.reduced[0],
        culled.reduced[1],
        culled.reduced[2]
    );
}

fn bench_frame(c: &mut Criterion) {
    let (w1, w6, w2) = (common::w1(), common::w6(), common::w2());
    let mut group = c.benchmark_group("frame");
    let mut app = frame_app(&[], true);
    group.bench_function("no_hair", |b| b.iter(|| app.update()));
    for (name, heads, culling, samples) in [
        ("W1_thesis_100x6", &w1[..], true, 100),
        ("W6_crowd_16x160x7", &w6[..], true, 30),
        ("W6_crowd_16x160x7_no_culling_no_lod", &w6[..], false, 20),
        ("W2_10000x16", &w2[..], true, 10),
    ] {
        group.sample_size(samples);
        let mut app = frame_app(heads, culling);
        group.bench_function(name, |b| b.iter(|| app.update()));
        print_stages(name, &app);
    }
    group.finish();
}

/// One row of the thesis's tables 5.3-5.5: the W1 hair (100 x 6) with these settings.
#[derive(Clone, Copy)]
struct ThesisRow {
    /// The thesis's table and its row's frame rate (frames per second, its whole app: CPU
    /// and GPU, 2013 hardware).
    table: &'static str,
    thesis_fps: &'static str,
    label: &'static str,
    rings: u32,
    sides: u32,
    /// Object-space strokes (`Some(stroke limit px)`), or the image-space outline (`None`),
    /// which is GPU work only: no CPU stage.
    strokes: Option<f32>,
    anchor: f32,
    skeleton: bool,
    hair_animation: bool,
}

/// Turns every bone marked `Nod` (the skeleton animation of table 5.5).
#[derive(Component)]
struct Nod;

fn nod(time: Res<Time>, mut bones: Query<&mut Transform, With<Nod>>) {
    for mut t in &mut bones {
        let s = time.elapsed_secs();
        t.rotation = Quat::from_rotation_y(0.6 * (2.0 * s).sin())
            * Quat::from_rotation_x(0.2 * (3.0 * s).sin());
    }
}

fn thesis_app(row: &ThesisRow) -> App {
    use bevy_cartoon_hair::asset::{HairAnimation, HairKeyframe};
    use bevy_cartoon_hair::mesh::HairMeshSettings;
    use bevy_cartoon_hair::silhouette::SilhouetteSettings;
    let mut app = stages_app();
    app.add_systems(Update, nod);
    let base = HairGroom::from_strands("head", strands(100, 6)).unwrap();
    let animation = row.hair_animation.then(|| {
        // Two styles: the base and the tips swept back.
        let swept = HairGroom::from_strands(
            "head",
            base.strands().map(|s| {
                s.iter()
                    .enumerate()
                    .map(|(k, p)| *p + Vec3::new(0.0, 0.0, -0.02 * k as f32))
                    .collect::<Vec<_>>()
            }),
        )
        .unwrap();
        HairAnimation::new(
            vec![
                HairKeyframe {
                    time: 0.0,
                    pose: base.clone(),
                },
                HairKeyframe {
                    time: 0.5,
                    pose: swept,
                },
            ],
            true,
            1.0,
        )
        .unwrap()
    });
    let world = app.world_mut();
    let groom = world.resource_mut::<Assets<HairGroom>>().add(base);
    let animation = animation.map(|a| world.resource_mut::<Assets<HairAnimation>>().add(a));
    let mut bone = world.spawn(Transform::from_xyz(0.0, -0.1, -0.8));
    if row.skeleton {
        bone.insert(Nod);
    }
    let bone = bone.id();
    world.spawn((
        Hair {
            groom,
            animation,
            ..default()
        },
        HairSimSettings {
            anchor_stiffness: bevy_cartoon_hair::curve::QuadraticCurve::new(0.0, 0.0, row.anchor),
            ..default()
        },
        HairMeshSettings {
            hair_resolution: row.rings,
            shape_resolution: row.sides,
            ..default()
        },
        SilhouetteSettings {
            enabled: row.strokes.is_some(),
            stroke_limit_px: row.strokes.unwrap_or(8.0),
            width_px: row.strokes.unwrap_or(4.0),
            ..default()
        },
        // The thesis's frame had no culling or level of detail.
        bevy_cartoon_hair::mesh::HairLod {
            enabled: false,
            ..default()
        },
        ChildOf(bone),
    ));
    for _ in 0..5 {
        app.update();
    }
    app
}

/// The thesis's performance tables 5.3 (hair and shape resolution x outline
/// method), 5.4 (outline width) and 5.5 (anchor stiffness and animation), our CPU frame beside
/// its frame rate, printed as a table at the end of the group.
fn bench_thesis_tables(c: &mut Criterion) {
    let row = |table, thesis_fps, label, rings, sides, strokes| ThesisRow {
        table,
        thesis_fps,
        label,
        rings,
        sides,
        strokes,
        anchor: 0.5,
        skeleton: false,
        hair_animation: false,
    };
    let obj = Some(8.0);
    let mut rows = vec![
        row("5.3", "37", "6 samples x 4 sides, object-space", 6, 4, obj),
        row("5.3", "28", "8 x 8, object-space", 8, 8, obj),
        row("5.3", "3", "32 x 32, object-space", 32, 32, obj),
        row("5.3", "44", "6 x 4, image-space", 6, 4, None),
        row("5.3", "32", "8 x 8, image-space", 8, 8, None),
        row("5.3", "4", "32 x 32, image-space", 32, 32, None),
        row("5.4", "32", "dilation 1 (image-space)", 8, 8, None),
        row("5.4", "23", "dilation 12 (image-space)", 8, 8, None),
        // The thesis's stroke limits 0.1 and 1 (1 as thick as dilation 12): 1.2 and 12 px here.
        row("5.4", "28", "stroke limit 0.1 (1.2 px)", 8, 8, Some(1.2)),
        row("5.4", "28", "stroke limit 1 (12 px)", 8, 8, Some(12.0)),
    ];
    for (fps, label, anchor, skeleton, hair_animation) in [
        ("28", "anchors 0.01, static", 0.01, false, false),
        ("28", "anchors 0.01, skeleton", 0.01, true, false),
        ("26", "anchors 0.01, skeleton + hair", 0.01, true, true),
        ("23-26", "anchors 0, skeleton + hair", 0.0, true, true),
        ("23-26", "anchors 1, skeleton + hair", 1.0, true, true),
    ] {
        rows.push(ThesisRow {
            anchor,
            skeleton,
            hair_animation,
            ..row("5.5", fps, label, 8, 8, obj)
        });
    }
    let mut group = c.benchmark_group("thesis");
    group.sample_size(30);
    // Each bench's samples (ms per frame), for the table's medians.
    let timed = |group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
                 name: String,
                 app: &mut App| {
        let mut samples = Vec::new();
        group.bench_function(name, |b| {
            b.iter_custom(|iters| {
                let start = std::time::Instant::now();
                for _ in 0..iters {
                    app.update();
                }
                let took = start.elapsed();
                samples.push(took.as_secs_f64() * 1e3 / iters as f64);
                took
            });
        });
        samples.sort_by(f64::total_cmp);
        samples.get(samples.len() / 2).copied().unwrap_or(0.0)
    };
    let none = timed(&mut group, "no_hair".into(), &mut frame_app(&[], true));
    let mut printed = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let ms = timed(
            &mut group,
            format!("{}_{i:02}", row.table),
            &mut thesis_app(row),
        );
        printed.push((row, ms));
    }
    group.finish();
    println!("\nThesis tables 5.3-5.5, 100 x 6 strands (W1), this machine's CPU frame (no GPU):");
    println!(
        "| table | row | thesis FPS (whole app, 2013) | our frame, ms (median sample) | hair share, ms |"
    );
    println!("|---|---|---|---|---|");
    for (row, ms) in printed {
        println!(
            "| {} | {} | {} | {ms:.2} | {:.2} |",
            row.table,
            row.label,
            row.thesis_fps,
            ms - none
        );
    }
    println!("(no-hair frame: {none:.2} ms)");
}

criterion_group!(
    benches,
    bench_thesis_tables,
    bench_frame,
    bench_sim,
    bench_solver,
    bench_load,
    bench_tam,
    bench_mesh_and_silhouettes
);
criterion_main!(benches);
