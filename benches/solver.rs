//! The strand solver's step over a hair's batches: each batch alone (`alone`, the baseline),
//! two batches of one chain length at a time (`pairs`) and three (`threes`, which the
//! simulation uses), both with `Batch::step_together`. The batches end bit for bit in the
//! same state every way; only the time differs.
//!
//! ```text
//! cargo bench --bench solver --no-default-features
//! ```
//!
//! Two shapes: 48 batches of 8 bone chains of 6 joints and a tail (7 particles, a VRM avatar's
//! hair of 384 chains), and 48 batches of 8 groomed strands of 16 and of 32 particles; one frame of four
//! substeps at 240 Hz with gravity, anchors, a moving bone and a head sphere, on one thread.
#![expect(
    missing_docs,
    reason = "criterion's macros define undocumented functions"
)]

use bevy::math::{Affine3A, Quat, Vec3, Vec3A};
use bevy_cartoon_hair::sim::solver::{Batch, LANES, PINNED, StepInput, build_chain};
use criterion::{Criterion, criterion_group, criterion_main};

const BATCHES: usize = 48;

/// `BATCHES` batches of full lanes, each chain of `particles` hanging from a point on a head.
fn hair(particles: usize) -> Vec<Batch> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let mut chain = Vec::new();
    (0..BATCHES)
        .map(|b| {
            let chains: Vec<Vec<Vec3>> = (0..LANES)
                .map(|l| {
                    let i = (b * LANES + l) as f32;
                    let y = 1.0 - (i + 0.5) / (BATCHES * LANES) as f32;
                    let r = (1.0 - y * y).sqrt();
                    let n = Vec3::new(r * (golden * i).cos(), y, r * (golden * i).sin());
                    let step = Vec3::new(n.x, -1.5, n.z).normalize() * 0.03;
                    let points: Vec<Vec3> =
                        (0..particles).map(|k| n * 0.11 + step * k as f32).collect();
                    build_chain(&points, 0.3, None, &mut chain);
                    chain.clone()
                })
                .collect();
            let ids: Vec<u32> = (0..LANES as u32).map(|l| (b * LANES) as u32 + l).collect();
            let refs: Vec<&[Vec3]> = chains.iter().map(Vec::as_slice).collect();
            let mut batch = Batch::new(&ids, &refs, &[], &[0.005; LANES]);
            batch.reset(&Affine3A::IDENTITY);
            batch
        })
        .collect()
}

/// One frame of four substeps with the head turning.
fn frame(nodes: usize, t: f32) -> StepInput {
    let h = 1.0 / 240.0;
    StepInput {
        h,
        bones: (1..=4)
            .map(|s| {
                let turn = 0.8 * (6.0 * (t + s as f32 * h)).sin();
                Affine3A::from_rotation_translation(Quat::from_rotation_y(turn), Vec3::ZERO)
            })
            .collect(),
        spheres: vec![(Vec3A::ZERO, 0.1); 4],
        sphere_count: 1,
        gravity_h2: Vec3::new(0.0, -9.81, 0.0) * h * h,
        damping: 0.995,
        alpha: [0.0, 1e-4, 1e-3],
        anchor_factor: (0..nodes)
            .map(|k| if k < PINNED { 0.0 } else { 0.05 })
            .collect(),
        max_stretch: 1.1,
        ..Default::default()
    }
}

fn bench_groups(c: &mut Criterion) {
    let mut group = c.benchmark_group("solver");
    for (name, particles) in [
        ("chains_48x8x7", 7),
        ("strands_48x8x16", 16),
        ("strands_48x8x32", 32),
    ] {
        for way in ["alone", "pairs", "threes"] {
            let mut batches = hair(particles);
            let nodes = batches[0].nodes.len();
            let mut t = 0.0f32;
            group.bench_function(format!("{way}_{name}"), |b| {
                b.iter(|| {
                    t += 1.0 / 60.0;
                    let input = frame(nodes, t);
                    let anchors = &input.anchor_factor;
                    match way {
                        "alone" => {
                            for batch in &mut batches {
                                batch.step_with(&input, anchors);
                            }
                        }
                        "pairs" => {
                            for pair in batches.chunks_exact_mut(2) {
                                let [a, b] = pair else { unreachable!() };
                                Batch::step_together([a, b], &input, anchors);
                            }
                        }
                        _ => {
                            for three in batches.chunks_exact_mut(3) {
                                let [a, b, c] = three else { unreachable!() };
                                Batch::step_together([a, b, c], &input, anchors);
                            }
                        }
                    }
                });
            });
            assert!(
                batches.iter().all(|b| b.non_finite_lanes() == 0),
                "{way}_{name}: the hair blew up"
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench_groups);
criterion_main!(benches);
