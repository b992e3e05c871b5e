//! Batches stepped side by side (`Batch::step_together`) end where each batch
//! stepped alone ends, bit for bit, on both the portable and the AVX2 paths, with every stage
//! of a substep in play.

use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use super::super::solver::{Batch, Contact, ContactShape, LANES, PINNED, StepInput, WindInput};
use super::super::wind::{FieldStep, HairWind};
use super::random_strands;
use crate::test_support::Rng;

/// A batch of `lanes` random wavy chains of `particles` particles near the bone, moving.
fn random_batch(rng: &mut Rng, particles: usize, lanes: usize, first_id: u32) -> Batch {
    let mut batch = random_strands(rng, particles, lanes, first_id);
    batch.reset(&Affine3A::from_translation(rng.vec3(0.02)));
    // Give it some motion to damp and carry.
    for node in batch.nodes.iter_mut().skip(PINNED) {
        for c in 0..3 {
            for l in 0..LANES {
                node.p[c][l] = node.x[c][l] + 0.002 * rng.next();
            }
        }
    }
    batch
}

/// A frame's input with every stage a substep has: a moving bone, inertia frame carry, bone
/// frame damping, wind, a force field, spheres, capsules and a keep-inside sphere, segment
/// collision, friction in some trials, both limits and volumes.
fn random_input(rng: &mut Rng, trial: usize, nodes: usize) -> StepInput {
    let substeps = 1 + trial % 4;
    let h = 1.0 / 240.0;
    let bones: Vec<Affine3A> = (0..substeps)
        .map(|s| {
            Affine3A::from_rotation_translation(
                Quat::from_rotation_y(0.2 * rng.next() * s as f32),
                rng.vec3(0.01),
            )
        })
        .collect();
    let small_move = |rng: &mut Rng| {
        Affine3A::from_rotation_translation(
            Quat::from_rotation_z(0.01 * rng.next()),
            rng.vec3(0.002),
        )
    };
    let sphere_count = 1 + trial % 2;
    let contact_count = 2;
    let mut contacts = Vec::new();
    for _ in 0..substeps {
        let a = Vec3A::from(rng.vec3(0.05)) + Vec3A::new(0.0, -0.08, 0.0);
        contacts.push(Contact::new(
            ContactShape::Capsule {
                a,
                b: a + Vec3A::new(0.1, 0.0, 0.02),
                radius: 0.02,
            },
            false,
            Vec3A::from(rng.vec3(0.002)),
            0.01,
        ));
        contacts.push(Contact::new(
            ContactShape::Sphere {
                centre: Vec3A::new(0.0, -0.1, 0.0),
                radius: 0.4,
            },
            true,
            Vec3A::ZERO,
            0.01,
        ));
    }
    StepInput {
        h,
        spheres: (0..substeps * sphere_count)
            .map(|_| (rng.vec3(0.08).into(), 0.02 + 0.04 * rng.next().abs()))
            .collect(),
        sphere_count,
        sphere_shift: (0..substeps * sphere_count)
            .map(|_| rng.vec3(0.002).into())
            .collect(),
        contacts,
        contact_count,
        friction: if trial.is_multiple_of(2) { 0.0 } else { 0.3 },
        gravity_h2: Vec3::new(0.0, -9.81, 0.0) * h * h,
        damping: 0.99,
        alpha: [0.0, 1e-3 * rng.next().abs(), 1e-2 * rng.next().abs()],
        anchor_factor: (0..nodes)
            .map(|k| {
                if k < PINNED {
                    0.0
                } else {
                    0.2 * rng.next().abs()
                }
            })
            .collect(),
        bone_motion: (0..substeps).map(|_| small_move(rng)).collect(),
        carry: (0..substeps).map(|_| small_move(rng)).collect(),
        wind: Some(WindInput {
            wind: HairWind {
                velocity: rng.vec3(3.0),
                ..default()
            },
            pull: 0.01,
            times: (0..substeps).map(|s| s as f32 * h).collect(),
        }),
        fields: (0..substeps)
            .map(|_| FieldStep {
                centre: rng.vec3(0.1),
                direction: None,
                speed_h: 2.0 * h,
                radius: 0.3,
                pull: 0.02,
            })
            .collect(),
        field_count: 1,
        first_substep: trial as u64,
        style_limit: 0.05,
        segments: true,
        max_stretch: 1.1,
        bones,
        ..default()
    }
}

/// Every position and previous position of `batches`, as bits.
fn state(batches: &[Batch]) -> Vec<u32> {
    batches
        .iter()
        .flat_map(|b| &b.nodes)
        .flat_map(|n| n.x.iter().chain(&n.p).flatten().map(|v| v.to_bits()))
        .collect()
}

#[test]
fn batches_stepped_side_by_side_end_where_each_alone_ends() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut compared = 0usize;
    for trial in 0..12 {
        let particles = 3 + trial % 6;
        let batches: Vec<Batch> = (0..3)
            .map(|i| random_batch(&mut rng, particles, 1 + (trial + i) % LANES, 8 * i as u32))
            .collect();
        let nodes = batches[0].nodes.len();
        let input = random_input(&mut rng, trial, nodes);
        let anchors = input.anchor_factor.clone();
        let run = || {
            let alone = {
                let mut b = batches.clone();
                for _ in 0..3 {
                    for batch in &mut b {
                        batch.step_with(&input, &anchors);
                    }
                }
                b
            };
            let paired = {
                let mut b = batches[..2].to_vec();
                let [first, second] = &mut b[..] else {
                    unreachable!()
                };
                for _ in 0..3 {
                    Batch::step_together([first, second], &input, &anchors);
                }
                b
            };
            let three = {
                let mut b = batches.clone();
                let [first, second, third] = &mut b[..] else {
                    unreachable!()
                };
                for _ in 0..3 {
                    Batch::step_together([first, second, third], &input, &anchors);
                }
                b
            };
            (state(&alone), state(&paired), state(&three))
        };
        let (portable, vector) = crate::simd::on_both_paths(run);
        for (path, (alone, paired, three)) in [("portable", Some(portable)), ("AVX2", vector)]
            .into_iter()
            .filter_map(|(path, r)| r.map(|r| (path, r)))
        {
            // The batches moved, and differ from each other: a mix-up would show.
            assert_ne!(alone, state(&batches), "trial {trial}: nothing moved");
            let third = alone.len() / 3;
            assert_ne!(alone[..third], alone[third..2 * third], "trial {trial}");
            assert_eq!(
                paired,
                alone[..2 * third],
                "trial {trial} ({path}): a pair differs from its batches alone"
            );
            assert_eq!(
                three, alone,
                "trial {trial} ({path}): three together differ from each alone"
            );
            compared += alone.len();
        }
    }
    assert!(compared > 10_000, "only {compared} values compared");
}

#[test]
#[should_panic(expected = "batches stepped together step chains of one length")]
fn batches_of_different_chain_lengths_are_refused() {
    let mut rng = Rng(11);
    let mut a = random_batch(&mut rng, 4, 3, 0);
    let mut b = random_batch(&mut rng, 4, 3, 8);
    let mut c = random_batch(&mut rng, 6, 3, 16);
    let input = random_input(&mut rng, 0, a.nodes.len());
    let anchors = input.anchor_factor.clone();
    Batch::step_together([&mut a, &mut b, &mut c], &input, &anchors);
}
