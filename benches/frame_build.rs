//! Criterion benches of what a frame of hair costs the CPU when its tubes are built on the CPU
//! and when they are built on the GPU (`render::HairMeshBuilder`), including what Bevy does with
//! the result on the CPU before it reaches the GPU. Run: `cargo bench --bench frame_build`.
//!
//! For each workload (W1, the thesis default; W6, a crowd of 16 heads with culling and level of
//! detail; W2, 10,000 x 16 strands; `benches/common`), in one run:
//!
//! - `*/cpu_strokes`: tubes, object-space strokes and specular quads built on the CPU (the
//!   reference, and the fallback where the GPU cannot);
//! - `*/gpu_strokes`: the same look built on the GPU (the default);
//! - `*/cpu`: the tubes on the CPU, no strokes or quads (the clean and locks looks);
//! - `*/gpu`: the same look with the tubes built on the GPU.
//!
//! `no_hair` is the same app without hair: the hair's share of a frame is the rest. Each
//! iteration is `app.update()` and then what Bevy's extraction and preparation do on the
//! CPU with it: for a CPU-built hair mesh, changed every frame, a copy of the mesh into the
//! render world and its vertices interleaved and its indices copied into the bytes written to
//! the GPU, and the same for its stroke, highlight and shadow ribbon meshes; for a GPU-built
//! hair, a copy of its GPU input and its particles, strands, sections and the records of its
//! tube, stroke, highlight and shadow passes written into the bytes sent (its stroke,
//! highlight and ribbon meshes do not change on the CPU, so Bevy sends nothing for them). A
//! sun casts shadows, so each hair builds its shadow ribbons. The bytes sent a frame are printed.
//! There is no GPU here: the compute passes themselves are not timed.
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
use bevy_cartoon_hair::asset::HairAssetPlugin;
use bevy_cartoon_hair::mesh::highlights::{HairHighlightsOf, SpecularQuads};
use bevy_cartoon_hair::mesh::shadow::HairShadowMeshOf;
use bevy_cartoon_hair::mesh::{HairCulling, HairInView, HairLod, HairMeshOf, HairMeshPlugin};
use bevy_cartoon_hair::render::{HairMeshBuilder, encode_gpu_inputs};
use bevy_cartoon_hair::silhouette::{HairSilhouettePlugin, HairStrokesOf, SilhouetteSettings};
use bevy_cartoon_hair::sim::HairSimulationPlugin;
use common::{Head, bench_camera, minimal_plugins};
use criterion::{Criterion, criterion_group, criterion_main};

/// How a workload's hair is drawn.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Build {
    CpuStrokes,
    GpuStrokes,
    Cpu,
    Gpu,
}

fn app(heads: &[Head], build: Build) -> App {
    let mut app = App::new();
    app.add_plugins((
        minimal_plugins(),
        TransformPlugin,
        AssetPlugin::default(),
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
        HairMeshPlugin,
        HairSilhouettePlugin,
    ))
    .init_asset::<Mesh>()
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )))
    .insert_resource(if matches!(build, Build::Gpu | Build::GpuStrokes) {
        HairMeshBuilder::Gpu
    } else {
        HairMeshBuilder::Cpu
    });
    common::gpu_path(&mut app);
    bench_camera(app.world_mut(), Vec3::ZERO, Vec3::NEG_Z);
    // A sun that casts shadows: the hairs build their shadow ribbons.
    app.world_mut().spawn((
        DirectionalLight {
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(1.0, 2.0, 1.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let strokes = matches!(build, Build::CpuStrokes | Build::GpuStrokes);
    for head in heads {
        let world = app.world_mut();
        let hair = common::spawn_head(world, head);
        world.entity_mut(hair).insert((
            SilhouetteSettings {
                enabled: strokes,
                ..default()
            },
            SpecularQuads {
                enabled: strokes,
                ..default()
            },
            HairCulling::default(),
            HairLod::default(),
        ));
    }
    for _ in 0..5 {
        app.update();
    }
    app
}

/// What extraction and preparation do on the CPU with this frame's hair meshes: the bytes that
/// go to the GPU, written into `staging`; returns their count.
fn extract_and_prepare(world: &mut World, staging: &mut Vec<u8>) -> usize {
    staging.clear();
    // GPU-built hairs: their inputs and records, as the render world encodes them.
    encode_gpu_inputs(world, staging);
    // CPU-built hairs in view: their meshes changed this frame and are sent whole.
    let mut hairs = world.query::<(
        &HairInView,
        &bevy_cartoon_hair::mesh::ComputedHairMesh,
        Has<bevy_cartoon_hair::mesh::HairMeshBuiltOnGpu>,
    )>();
    let meshes: Vec<_> = hairs
        .iter(world)
        .filter(|(seen, _, gpu)| seen.0 && !gpu)
        .map(|(_, c, _)| c.mesh.clone())
        .collect();
    let assets = world.resource::<Assets<Mesh>>();
    for handle in meshes {
        if let Some(mesh) = assets.get(&handle) {
            let copy = mesh.clone();
            staging.extend(copy.create_packed_vertex_buffer_data());
            staging.extend(copy.get_index_buffer_bytes().unwrap_or_default());
        }
    }
    // Strokes, highlights and shadow ribbons are meshes of their own, rebuilt every frame on
    // the CPU.
    let mut strips = world.query_filtered::<(
        &Mesh3d,
        Option<&HairStrokesOf>,
        Option<&HairHighlightsOf>,
        Option<&HairShadowMeshOf>,
    ), Without<HairMeshOf>>();
    let owners: Vec<_> = strips
        .iter(world)
        .map(|(m, s, h, r)| {
            let owner = s.map(|s| s.0).or(h.map(|h| h.0)).or(r.map(|r| r.0));
            (m.0.clone(), owner)
        })
        .collect();
    let strip_meshes: Vec<_> = owners
        .into_iter()
        .filter(|(_, owner)| {
            !owner.is_some_and(|o| {
                world
                    .get::<bevy_cartoon_hair::mesh::HairMeshBuiltOnGpu>(o)
                    .is_some()
            })
        })
        .map(|(m, _)| m)
        .collect();
    let assets = world.resource::<Assets<Mesh>>();
    for handle in strip_meshes {
        if let Some(mesh) = assets.get(&handle) {
            let copy = mesh.clone();
            staging.extend(copy.create_packed_vertex_buffer_data());
            staging.extend(copy.get_index_buffer_bytes().unwrap_or_default());
        }
    }
    staging.len()
}

fn bench_frame_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame_build");
    // The same app without hair: what every frame costs anyway (the hair's share is the rest).
    let mut empty = app(&[], Build::Gpu);
    group.bench_function("no_hair", |b| b.iter(|| empty.update()));
    for (name, heads, samples) in [
        ("W1_thesis_100x6", common::w1(), 50),
        ("W6_crowd_16x160x7", common::w6(), 30),
        ("W2_10000x16", common::w2(), 10),
    ] {
        group.sample_size(samples);
        for (build, label) in [
            (Build::CpuStrokes, "cpu_strokes"),
            (Build::GpuStrokes, "gpu_strokes"),
            (Build::Cpu, "cpu"),
            (Build::Gpu, "gpu"),
        ] {
            let mut app = app(&heads, build);
            let mut staging = Vec::new();
            let bytes = extract_and_prepare(app.world_mut(), &mut staging);
            let gpu_hairs = encode_gpu_inputs(app.world_mut(), &mut Vec::new());
            println!(
                "{name}/{label}: {:.2} MB sent to the GPU a frame, {gpu_hairs} hairs built on the GPU",
                bytes as f64 / 1e6
            );
            group.bench_function(format!("{name}/{label}"), |b| {
                b.iter(|| {
                    app.update();
                    extract_and_prepare(app.world_mut(), &mut staging)
                });
            });
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    targets = bench_frame_build
}
criterion_main!(benches);
