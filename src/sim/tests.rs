//! Headless app tests of the simulation: physical invariants, robustness, determinism.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;

use super::solver::{Batch, LANES, PINNED, build_chain};
use super::*;
use crate::asset::{CollisionSphere, HairAnimation, HairGroom, HairKeyframe, HeadCollision};
use crate::curve::QuadraticCurve;
use crate::test_support::Rng;

pub(super) const HEAD_RADIUS: f32 = 0.1;

/// A spiky groom on a head of radius 0.1 at the bone origin: strands leave the scalp along the
/// normal and curve sideways.
pub(super) fn spiky_groom(strands: usize, particles: usize) -> HairGroom {
    HairGroom::from_strands(
        "head",
        crate::test_support::spiky_strands(strands, particles, HEAD_RADIUS, 0.12, 0.03),
    )
    .unwrap()
}

fn head() -> HeadCollision {
    HeadCollision {
        bone: "head".into(),
        spheres: vec![CollisionSphere {
            center: Vec3::ZERO,
            radius: HEAD_RADIUS,
        }],
        capsules: Vec::new(),
        planes: Vec::new(),
    }
}

pub(super) struct Harness {
    pub(super) app: App,
    pub(super) bone: Entity,
    pub(super) hair: Entity,
}

impl Harness {
    pub(super) fn new(groom: HairGroom, settings: HairSimSettings, fps: f64) -> Self {
        Self::with(groom, None, Some(head()), settings, fps)
    }

    pub(super) fn with(
        groom: HairGroom,
        animation: Option<HairAnimation>,
        collision: Option<HeadCollision>,
        settings: HairSimSettings,
        fps: f64,
    ) -> Self {
        let mut app = crate::test_support::sim_app(fps);
        let world = app.world_mut();
        let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
        let animation = animation.map(|a| world.resource_mut::<Assets<HairAnimation>>().add(a));
        let collision = collision.map(|c| world.resource_mut::<Assets<HeadCollision>>().add(c));
        let bone = world.spawn(Transform::from_xyz(0.0, 1.6, 0.0)).id();
        let hair = world
            .spawn((
                Hair {
                    groom,
                    animation,
                    collision,
                },
                settings,
                ChildOf(bone),
            ))
            .id();
        let mut h = Self { app, bone, hair };
        h.app.update();
        h.app.update();
        assert!(h.computed().strand_count() > 0, "strands were not built");
        h
    }

    pub(super) fn update(&mut self) {
        self.app.update();
    }

    pub(super) fn set_bone(&mut self, t: Transform) {
        *self
            .app
            .world_mut()
            .get_mut::<Transform>(self.bone)
            .unwrap() = t;
    }

    pub(super) fn computed(&self) -> &ComputedHair {
        self.app.world().get::<ComputedHair>(self.hair).unwrap()
    }

    fn bone_affine(&self) -> bevy::math::Affine3A {
        self.app
            .world()
            .get::<GlobalTransform>(self.hair)
            .unwrap()
            .affine()
    }

    /// Every strand's particles, in strand order.
    pub(super) fn strands(&mut self) -> Vec<Vec<Vec3>> {
        let mut q = self.app.world_mut().query::<(&Strand, &StrandParticles)>();
        let mut v: Vec<_> = q
            .iter(self.app.world())
            .map(|(s, p)| (s.index, p.positions.clone()))
            .collect();
        v.sort_by_key(|(i, _)| *i);
        v.into_iter().map(|(_, p)| p).collect()
    }

    fn all_finite(&mut self) -> bool {
        self.strands().iter().flatten().all(|p| p.is_finite())
    }

    /// FNV-1a over the bits of every particle, in strand order: stable across Rust versions,
    /// so a golden value can be stored.
    fn hash(&mut self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for p in self.strands().iter().flatten() {
            for v in p.to_array() {
                for byte in v.to_bits().to_le_bytes() {
                    h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
                }
            }
        }
        h
    }
}

fn groom_rest_world(groom: &HairGroom, bone: &bevy::math::Affine3A) -> Vec<Vec<Vec3>> {
    groom
        .strands()
        .map(|s| s.iter().map(|p| bone.transform_point3(*p)).collect())
        .collect()
}

fn max_deviation(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> f32 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f32::max)
}

#[test]
fn chain_interleaves_structural_particles_off_the_strand() {
    let points = [Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0)];
    let mut chain = Vec::new();
    build_chain(&points, 0.5, None, &mut chain);
    assert_eq!(chain.len(), 6);
    assert_eq!(
        (chain[1], chain[3], chain[5]),
        (points[0], points[1], points[2])
    );
    // Every four consecutive nodes span a real tetrahedron (torsion is constrained).
    for w in chain.windows(4) {
        let vol = (w[1] - w[0]).cross(w[2] - w[0]).dot(w[3] - w[0]).abs();
        assert!(vol > 1e-3, "flat tetrahedron {w:?}");
    }
}

#[test]
fn styled_hair_keeps_its_style_without_gravity() {
    let groom = spiky_groom(20, 6);
    let settings = HairSimSettings {
        gravity: Vec3::ZERO,
        anchor_stiffness: QuadraticCurve::constant(0.0),
        ..default()
    };
    let mut h = Harness::new(groom.clone(), settings, 60.0);
    for _ in 0..120 {
        h.update();
    }
    let rest = groom_rest_world(&groom, &h.bone_affine());
    let dev = max_deviation(&h.strands(), &rest);
    assert!(dev < 1e-3, "style drifted by {dev} m");
}

#[test]
fn roots_follow_the_animated_bone_exactly_and_lengths_hold() {
    let groom = spiky_groom(30, 6);
    let mut h = Harness::new(groom.clone(), HairSimSettings::default(), 60.0);
    for frame in 0..180 {
        let t = frame as f32 / 60.0;
        h.set_bone(
            Transform::from_xyz(0.3 * (2.0 * t).sin(), 1.6 + 0.1 * t.sin(), 0.0)
                .with_rotation(Quat::from_rotation_y(1.2 * (3.0 * t).sin())),
        );
        h.update();
        let bone = h.bone_affine();
        let strands = h.strands();
        for (s, particles) in strands.iter().enumerate() {
            let root = bone.transform_point3(groom.strand(s)[0]);
            assert!(
                particles[0].distance(root) < 1e-5,
                "frame {frame}: root {s} left the bone"
            );
        }
    }
    // Edge stiffness 1: segments stay near their rest length despite gravity and a head turning
    // at up to 3.6 rad/s (one Gauss-Seidel pass per substep leaves a little stretch).
    let mut worst: f32 = 0.0;
    for (s, particles) in h.strands().iter().enumerate() {
        for (i, w) in particles.windows(2).enumerate() {
            let rest = groom.strand(s)[i].distance(groom.strand(s)[i + 1]);
            worst = worst.max((w[0].distance(w[1]) / rest - 1.0).abs());
        }
    }
    println!("largest segment length change: {:.1}%", worst * 100.0);
    assert!(worst < 0.1, "segments stretched by {:.1}%", worst * 100.0);
}

#[test]
fn frame_rate_does_not_change_the_result() {
    let run = |fps: f64| {
        let groom = spiky_groom(16, 6);
        let mut h = Harness::new(groom, HairSimSettings::default(), fps);
        // Settle under gravity with a still bone (the frame that builds strands is not
        // simulated, so starting states differ by one frame), then move the bone for 2 s.
        let frames = |secs: f64| (secs * fps).round() as usize;
        for _ in 0..frames(1.0) {
            h.update();
        }
        for f in 0..frames(2.0) {
            let t = (f + 1) as f32 / fps as f32;
            h.set_bone(
                Transform::from_xyz(0.2 * (1.5 * t).sin(), 1.6, 0.0)
                    .with_rotation(Quat::from_rotation_y(0.8 * (2.0 * t).sin())),
            );
            h.update();
        }
        h.strands()
    };
    let (a, b, c) = (run(30.0), run(60.0), run(144.0));
    let (ab, ac) = (max_deviation(&a, &b), max_deviation(&a, &c));
    println!("30 vs 60 fps: {ab} m, 30 vs 144 fps: {ac} m");
    // Stated tolerance: 2 mm on 12 cm strands after 2 s of motion.
    assert!(
        ab < 2e-3 && ac < 2e-3,
        "30 vs 60 fps: {ab} m, 30 vs 144 fps: {ac} m"
    );
}

fn two_key_animation(groom: &HairGroom) -> HairAnimation {
    let swept = HairGroom::from_strands(
        "head",
        groom.strands().map(|s| {
            s.iter()
                .enumerate()
                .map(|(k, p)| *p + Vec3::new(0.0, 0.0, -0.04 * k as f32))
                .collect()
        }),
    )
    .unwrap();
    HairAnimation::new(
        vec![
            HairKeyframe {
                time: 0.0,
                pose: groom.clone(),
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
}

#[test]
fn anchor_stiffness_one_holds_the_keyframe_pose() {
    let groom = spiky_groom(12, 6);
    let anim = two_key_animation(&groom);
    let settings = HairSimSettings {
        anchor_stiffness: QuadraticCurve::constant(1.0),
        ..default()
    };
    let mut h = Harness::with(groom, Some(anim.clone()), None, settings, 60.0);
    let mut worst: f32 = 0.0;
    for f in 0..90 {
        h.update();
        if f < 5 {
            continue;
        }
        // The pose the anchors follow at the simulation's animation time.
        let t = h.computed().animation_time;
        let mut pose = vec![Vec3::ZERO; anim.base().points.len()];
        anim.sample(t, &mut pose);
        let bone = h.bone_affine();
        for (s, particles) in h.strands().iter().enumerate() {
            let o = anim.base().offsets[s] as usize;
            for (i, p) in particles.iter().enumerate() {
                worst = worst.max(p.distance(bone.transform_point3(pose[o + i])));
            }
        }
    }
    assert!(worst < 2e-3, "hair left the keyframe pose by {worst} m");
}

#[test]
fn anchor_stiffness_zero_leaves_the_hair_free() {
    let groom = spiky_groom(12, 6);
    let settings = HairSimSettings {
        anchor_stiffness: QuadraticCurve::constant(0.0),
        bend_stiffness: 0.05,
        torsion_stiffness: 0.05,
        ..default()
    };
    let mut h = Harness::with(groom.clone(), None, None, settings, 60.0);
    for _ in 0..120 {
        h.update();
    }
    let rest = groom_rest_world(&groom, &h.bone_affine());
    let strands = h.strands();
    let dropped = strands
        .iter()
        .zip(&rest)
        .map(|(s, r)| r.last().unwrap().y - s.last().unwrap().y)
        .fold(0.0, f32::max);
    assert!(
        dropped > 0.03,
        "free, soft hair should sag under gravity: {dropped} m"
    );
}

#[test]
fn shaking_head_keeps_particles_out_of_the_head() {
    let groom = spiky_groom(60, 7);
    let settings = HairSimSettings {
        anchor_stiffness: QuadraticCurve::constant(0.0),
        bend_stiffness: 0.2,
        ..default()
    };
    let (margin_min, margin_max) = settings.margins();
    let mut h = Harness::new(groom, settings, 60.0);
    let mut worst_fraction: f32 = 0.0;
    for f in 0..240 {
        // 4 turns per second, +-60 degrees, and a nod.
        let t = f as f32 / 60.0;
        let yaw = 1.05 * (std::f32::consts::TAU * 4.0 * t).sin();
        let pitch = 0.4 * (std::f32::consts::TAU * 1.3 * t).sin();
        h.set_bone(
            Transform::from_xyz(0.0, 1.6, 0.0).with_rotation(Quat::from_euler(
                EulerRot::YXZ,
                yaw,
                pitch,
                0.0,
            )),
        );
        h.update();
        let centre = h.bone_affine().translation;
        let margins: Vec<f32> = {
            let mut q = h.app.world_mut().query::<&Strand>();
            let mut m: Vec<_> = q.iter(h.app.world()).map(|s| (s.index, s.margin)).collect();
            m.sort_by_key(|x| x.0);
            m.into_iter().map(|x| x.1).collect()
        };
        for (s, particles) in h.strands().iter().enumerate() {
            let margin = margins[s];
            assert!((margin_min..=margin_max).contains(&margin));
            for p in &particles[1..] {
                let depth = HEAD_RADIUS + margin - p.distance(centre.into());
                worst_fraction = worst_fraction.max(depth / margin);
            }
        }
    }
    println!(
        "deepest particle inside its margin: {:.2}% of the margin",
        worst_fraction * 100.0
    );
    assert!(worst_fraction <= 0.1, "{worst_fraction}");
}

#[test]
fn margins_are_redrawn_at_runtime() {
    let mut h = Harness::new(spiky_groom(10, 5), HairSimSettings::default(), 60.0);
    let before: Vec<f32> = h.computed().batches[0].margin.to_vec();
    h.app
        .world_mut()
        .get_mut::<HairSimSettings>(h.hair)
        .unwrap()
        .margin_seed = 99;
    h.update();
    let after: Vec<f32> = h.computed().batches[0].margin.to_vec();
    assert_ne!(before, after);
}

#[test]
fn teleports_long_frames_and_bad_bones_never_produce_nan() {
    let mut groom_strands: Vec<Vec<Vec3>> =
        spiky_groom(10, 6).strands().map(<[Vec3]>::to_vec).collect();
    groom_strands.push(vec![Vec3::new(0.0, 0.11, 0.0), Vec3::new(0.0, 0.2, 0.0)]); // 2 particles
    let groom = HairGroom::from_strands("head", groom_strands).unwrap();
    for stiff in [0.0, 1.0] {
        let settings = HairSimSettings {
            edge_stiffness: stiff,
            bend_stiffness: stiff,
            torsion_stiffness: stiff,
            anchor_stiffness: QuadraticCurve::constant(stiff),
            ..default()
        };
        let mut h = Harness::new(groom.clone(), settings, 60.0);
        for _ in 0..30 {
            h.update();
        }
        // Teleport by 100 m: carried, not dragged: relative to the bone, each particle moves
        // over the teleport frame as it moved over the frame before (free-falling hair keeps
        // falling; nothing whips).
        let relative = |h: &mut Harness| -> Vec<Vec3> {
            let bone = Vec3::from(h.bone_affine().translation);
            h.strands().iter().flatten().map(|p| *p - bone).collect()
        };
        let a = relative(&mut h);
        h.update();
        let b = relative(&mut h);
        h.set_bone(Transform::from_xyz(100.0, 1.6, 0.0));
        h.update();
        assert_eq!(h.computed().stats.teleports, 1);
        let c = relative(&mut h);
        let whip = (0..a.len())
            .map(|i| ((c[i] - b[i]) - (b[i] - a[i])).length())
            .fold(0.0, f32::max);
        assert!(
            whip < 0.01,
            "stiffness {stiff}: the teleport jerked hair by {whip} m"
        );
        // A 1 s frame is clamped.
        h.app
            .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs(1)));
        h.update();
        assert!(
            h.computed().stats.substeps <= 25,
            "{}",
            h.computed().stats.substeps
        );
        h.app
            .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
                1.0 / 60.0,
            )));
        // Zero scale, then NaN: skipped.
        h.set_bone(Transform::from_xyz(100.0, 1.6, 0.0).with_scale(Vec3::ZERO));
        h.update();
        h.set_bone(Transform::from_xyz(f32::NAN, 1.6, 0.0));
        h.update();
        assert!(h.computed().stats.invalid_bone_frames >= 2);
        assert!(h.all_finite(), "stiffness {stiff}: NaN after a bad bone");
        // Back to normal: settles again near the head.
        h.set_bone(Transform::from_xyz(100.0, 1.6, 0.0));
        for _ in 0..120 {
            h.update();
        }
        assert!(h.all_finite());
        if stiff > 0.0 {
            // Springs hold it: it settles back around the head. (With every stiffness 0 the
            // particles are unconnected and fall freely, finite but never settling.)
            let root = h.bone_affine().translation;
            let far = h
                .strands()
                .iter()
                .flatten()
                .map(|p| p.distance(root.into()))
                .fold(0.0, f32::max);
            assert!(far < 0.3, "stiffness {stiff}: did not settle, {far} m away");
        }
        assert_eq!(h.computed().stats.strand_resets, 0);
    }
}

#[test]
fn non_finite_strands_are_reset_not_propagated() {
    let groom = spiky_groom(10, 6);
    let (mut batches, _) = super::attach::build_batches(&groom, None, 0.5, &[0.01; 10], Vec3::ONE);
    let bone = bevy::math::Affine3A::IDENTITY;
    let b: &mut Batch = &mut batches[0];
    b.reset(&bone);
    b.nodes[5].x[0][2] = f32::NAN;
    assert_eq!(b.non_finite_lanes(), 1 << 2);
    b.reset_lane(2, &bone);
    assert_eq!(b.non_finite_lanes(), 0);
}

/// The state hash of [`state_after_500_fixed_steps_is_deterministic`] on this crate's
/// reference platform (x86-64, Linux); a change to the solver's arithmetic changes it.
const GOLDEN_500_STEPS: u64 = 0x33ea_a949_24ea_e356;

#[test]
fn state_after_500_fixed_steps_is_deterministic() {
    let run = |amplitude: f32| {
        let mut h = Harness::new(spiky_groom(40, 7), HairSimSettings::default(), 60.0);
        for f in 0..500 {
            let t = f as f32 / 60.0;
            h.set_bone(
                Transform::from_xyz(0.1 * t.sin(), 1.6, 0.0)
                    .with_rotation(Quat::from_rotation_y(amplitude * (4.0 * t).sin())),
            );
            h.update();
        }
        h.hash()
    };
    let (portable, vector) = crate::simd::on_both_paths(|| run(2.0));
    println!("state hash after 500 steps: {portable:#018x} portable, {vector:x?} AVX2");
    assert_eq!(
        vector.unwrap_or(portable),
        portable,
        "AVX2 and portable paths differ"
    );
    assert_eq!(portable, run(2.0), "same input, different state");
    assert_ne!(portable, run(2.001), "the hash does not see the state");
    #[cfg(target_arch = "x86_64")]
    assert_eq!(
        portable, GOLDEN_500_STEPS,
        "the solver's results changed: if that was meant, store the new hash"
    );
}

#[test]
fn solver_avx2_and_portable_paths_agree_bit_for_bit() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let mut compared = 0usize;
    for trial in 0..24 {
        let particles = 3 + trial % 9;
        let lanes = 1 + trial % LANES;
        // Random wavy strands hanging from a random root.
        let chains: Vec<Vec<Vec3>> = (0..lanes)
            .map(|_| {
                let root = rng.vec3(0.1);
                let points: Vec<Vec3> = (0..particles)
                    .map(|i| root + Vec3::new(0.0, -0.03 * i as f32, 0.0) + rng.vec3(0.01))
                    .collect();
                let mut chain = Vec::new();
                build_chain(&points, 0.3 + 0.2 * rng.next(), None, &mut chain);
                chain
            })
            .collect();
        let ids: Vec<u32> = (0..lanes as u32).collect();
        let refs: Vec<&[Vec3]> = chains.iter().map(Vec::as_slice).collect();
        let margins: Vec<f32> = (0..lanes).map(|_| 0.005 + 0.005 * rng.next()).collect();
        let mut batch = Batch::new(&ids, &refs, &[], &margins);
        let start = bevy::math::Affine3A::from_translation(rng.vec3(0.2));
        batch.reset(&start);
        let nodes = batch.nodes.len();
        let substeps = 1 + trial % 4;
        let spheres_per = trial % 3;
        let h = 1.0 / 240.0;
        let input = super::solver::StepInput {
            h,
            bones: (0..substeps)
                .map(|s| {
                    bevy::math::Affine3A::from_rotation_translation(
                        Quat::from_rotation_y(0.3 * rng.next() * s as f32),
                        start.translation.into(),
                    )
                })
                .collect(),
            spheres: (0..substeps * spheres_per)
                .map(|_| (rng.vec3(0.1).into(), 0.02 + 0.05 * rng.next().abs()))
                .collect(),
            sphere_count: spheres_per,
            gravity_h2: Vec3::new(0.0, -9.81, 0.0) * h * h,
            damping: 0.99,
            alpha: [0.0, 1e-3 * rng.next().abs(), f32::INFINITY],
            anchor_factor: (0..nodes)
                .map(|k| if k < PINNED { 0.0 } else { rng.next().abs() })
                .collect(),
            ..default()
        };
        let run = || {
            let mut b = batch.clone();
            for _ in 0..20 {
                b.step(&input);
            }
            b.nodes
                .iter()
                .flat_map(|n| n.x.iter().chain(&n.p).flatten().map(|v| v.to_bits()))
                .collect::<Vec<u32>>()
        };
        let (portable, vector) = crate::simd::on_both_paths(run);
        if let Some(vector) = vector {
            assert_eq!(portable, vector, "trial {trial}: the paths differ");
            compared += portable.len();
        }
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        assert!(compared > 10_000, "only {compared} values compared");
    }
}

#[test]
fn hair_attaches_detaches_and_despawns_without_leaks() {
    let mut h = Harness::new(spiky_groom(25, 5), HairSimSettings::default(), 60.0);
    let count = |h: &mut Harness| {
        h.app
            .world_mut()
            .query::<&StrandOf>()
            .iter(h.app.world())
            .count()
    };
    let colliders = |h: &mut Harness| {
        h.app
            .world_mut()
            .query::<&HeadColliderOf>()
            .iter(h.app.world())
            .count()
    };
    assert_eq!(count(&mut h), 25);
    assert_eq!(colliders(&mut h), 1);
    let base = h.app.world().entities().count_spawned();
    // Detach: strands and collider go, the entity stays.
    h.app.world_mut().entity_mut(h.hair).remove::<Hair>();
    h.update();
    assert_eq!(count(&mut h), 0);
    assert_eq!(colliders(&mut h), 0);
    assert_eq!(h.app.world().entities().count_spawned(), base - 26);
    // Re-attach, then despawn the bone: everything goes.
    let groom = h
        .app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(25, 5));
    h.app.world_mut().entity_mut(h.hair).insert(Hair {
        groom,
        animation: None,
        collision: None,
    });
    h.update();
    assert_eq!(count(&mut h), 25);
    h.app.world_mut().entity_mut(h.bone).despawn();
    h.update();
    assert_eq!(count(&mut h), 0);
}

/// An app with the simulation, the asset server on the repository's `assets/`, and a log of
/// every hair event.
fn event_app() -> App {
    let mut app = crate::test_support::sim_app(60.0);
    app.init_resource::<Seen>()
        .add_observer(|e: On<HairReady>, mut seen: ResMut<Seen>| {
            seen.0.push(format!("ready {}", e.strands));
        })
        .add_observer(|e: On<HairRebuilt>, mut seen: ResMut<Seen>| {
            seen.0.push(format!("rebuilt {:?}", e.reason));
        })
        .add_observer(|e: On<HairAssetFailed>, mut seen: ResMut<Seen>| {
            seen.0
                .push(format!("failed {:?} {} | {}", e.asset, e.path, e.error));
        })
        .add_observer(|e: On<BoneNotFound>, mut seen: ResMut<Seen>| {
            seen.0
                .push(format!("no bone {} among {:?}", e.bone, e.available));
        })
        .add_observer(|e: On<BoneMismatch>, mut seen: ResMut<Seen>| {
            seen.0
                .push(format!("mismatch {} {}", e.attached, e.exported));
        })
        .add_observer(|e: On<BoneScaleMismatch>, mut seen: ResMut<Seen>| {
            seen.0
                .push(format!("scale mismatch {} {}", e.authored, e.bone));
        })
        .add_observer(|e: On<HairAnimationMismatch>, mut seen: ResMut<Seen>| {
            seen.0.push(format!("animation mismatch {}", e.message));
        });
    app
}

/// Hair events seen, in order.
#[derive(Resource, Default)]
struct Seen(Vec<String>);

fn seen(app: &App) -> Vec<String> {
    app.world().resource::<Seen>().0.clone()
}

/// A character root with `neck` and `head` bones; the head at `head_at` (world).
fn character(app: &mut App, root: Transform, head_at: Vec3) -> (Entity, Entity) {
    let world = app.world_mut();
    let root = world.spawn((Name::new("character"), root)).id();
    let neck = world
        .spawn((Name::new("neck"), Transform::default(), ChildOf(root)))
        .id();
    let head = world
        .spawn((
            Name::new("head"),
            Transform::from_translation(head_at),
            ChildOf(neck),
        ))
        .id();
    (root, head)
}

fn strand_count(app: &mut App) -> usize {
    app.world_mut()
        .query::<&StrandOf>()
        .iter(app.world())
        .count()
}

/// Marks the user's own component, to check the plugin keeps it.
#[derive(Component)]
struct MyTag;

#[test]
fn attach_to_bone_keeps_the_users_entity_and_finds_its_bone() {
    let mut app = event_app();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(5, 4));
    let root = app.world_mut().spawn(Transform::default()).id();
    let hair = app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            MyTag,
            AttachToBone::named(root, "head"),
        ))
        .id();
    app.update();
    // A root without a glTF scene decides at once: the bone is not there yet, an error.
    assert_eq!(strand_count(&mut app), 0);
    assert_eq!(
        app.world().get::<BoneSearch>(hair),
        Some(&BoneSearch::NotFound)
    );
    let neck = app
        .world_mut()
        .spawn((Name::new("neck"), Transform::default(), ChildOf(root)))
        .id();
    let head = app
        .world_mut()
        .spawn((
            Name::new("head"),
            Transform::from_xyz(0.0, 1.6, 0.0),
            ChildOf(neck),
        ))
        .id();
    // Inserting `AttachToBone` again searches again.
    app.world_mut()
        .entity_mut(hair)
        .insert(AttachToBone::named(root, "head"));
    app.update();
    let e = app.world().entity(hair);
    assert!(e.contains::<MyTag>(), "the user's component was dropped");
    assert_eq!(e.get::<ChildOf>().map(ChildOf::parent), Some(head));
    assert_eq!(e.get::<BoneSearch>(), Some(&BoneSearch::Found(head)));
    assert_eq!(strand_count(&mut app), 5);
    assert!(
        seen(&app).contains(&"ready 5".to_string()),
        "{:?}",
        seen(&app)
    );
    // By predicate and by entity.
    for attach in [
        AttachToBone::matching(root, |n| n.ends_with("ead")),
        AttachToBone::entity(head),
    ] {
        let groom = app
            .world_mut()
            .resource_mut::<Assets<HairGroom>>()
            .add(spiky_groom(3, 4));
        let other = app
            .world_mut()
            .spawn((Hair { groom, ..default() }, attach))
            .id();
        app.update();
        assert_eq!(
            app.world().get::<ChildOf>(other).map(ChildOf::parent),
            Some(head)
        );
    }
}

#[test]
fn a_missing_bone_is_reported_once_with_the_bones_there_are() {
    let mut app = event_app();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(5, 4));
    // A glTF root whose scene has not spawned: the search waits, no error yet.
    let root = app
        .world_mut()
        .spawn((
            Transform::default(),
            bevy::world_serialization::WorldAssetRoot(Handle::default()),
        ))
        .id();
    app.world_mut()
        .spawn((Name::new("neck"), Transform::default(), ChildOf(root)));
    let hair = app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            AttachToBone::named(root, "mixamorig:Head"),
        ))
        .id();
    for _ in 0..5 {
        app.update();
    }
    assert_eq!(
        app.world().get::<BoneSearch>(hair),
        Some(&BoneSearch::Waiting)
    );
    assert!(seen(&app).is_empty(), "{:?}", seen(&app));
    // The scene spawns (what `WorldInstanceReady` marks): now the bone is missing.
    app.world_mut().entity_mut(root).insert(CharacterSpawned);
    for _ in 0..10 {
        app.update();
    }
    let events = seen(&app);
    assert_eq!(events.len(), 1, "reported once, no spin: {events:?}");
    assert!(
        events[0].contains("no bone bone named \"mixamorig:Head\"")
            && events[0].contains("\"neck\""),
        "{events:?}"
    );
    assert_eq!(
        app.world().get::<BoneSearch>(hair),
        Some(&BoneSearch::NotFound)
    );
    assert_eq!(strand_count(&mut app), 0);
    assert!(app.world().get::<ChildOf>(hair).is_none());
}

#[test]
fn a_bone_other_than_the_exported_one_is_an_error() {
    let mut app = event_app();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(5, 4)); // exported for "head"
    let (root, _) = character(&mut app, Transform::default(), Vec3::Y);
    app.world_mut().spawn((
        Hair { groom, ..default() },
        AttachToBone::named(root, "neck"),
    ));
    for _ in 0..3 {
        app.update();
    }
    assert_eq!(seen(&app), vec!["mismatch neck head".to_string()]);
    assert_eq!(strand_count(&mut app), 0);
}

#[test]
fn a_bone_of_another_scale_than_the_authored_one_is_reported_once() {
    let run = |bone_scale: f32| {
        let mut app = event_app();
        let mut groom = spiky_groom(5, 4);
        groom.bone_scale = Some(0.01); // made on a Mixamo-style rig
        let groom = app
            .world_mut()
            .resource_mut::<Assets<HairGroom>>()
            .add(groom);
        let root = Transform::from_scale(Vec3::splat(bone_scale));
        let (root, _) = character(&mut app, root, Vec3::Y);
        app.world_mut().spawn((
            Hair { groom, ..default() },
            AttachToBone::named(root, "head"),
        ));
        for _ in 0..5 {
            app.update();
        }
        (seen(&app), strand_count(&mut app))
    };
    let (events, strands) = run(0.01);
    assert_eq!(
        events,
        vec!["ready 5".to_string()],
        "the authored scale: no report"
    );
    assert_eq!(strands, 5);
    let (events, strands) = run(1.0);
    assert_eq!(
        events,
        vec!["scale mismatch 0.01 1".to_string(), "ready 5".to_string()],
        "another scale: one report, and the hair is still built"
    );
    assert_eq!(strands, 5);
}

/// Every strand's particles, in strand order.
fn particles(app: &mut App) -> Vec<Vec<Vec3>> {
    let mut q = app.world_mut().query::<(&Strand, &StrandParticles)>();
    let mut v: Vec<_> = q
        .iter(app.world())
        .map(|(s, p)| (s.index, p.positions.clone()))
        .collect();
    v.sort_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, p)| p).collect()
}

/// The same hair on a unit rig and on a Mixamo-style rig (armature scale 0.01, groom in the
/// bone's centimetre units, as the add-on exports it) moves identically in world metres, with
/// hair–hair volume on (its radius is metres too; measured: 4e-6 m apart over 90 frames).
#[test]
fn hair_on_a_scaled_rig_moves_exactly_as_on_a_unit_rig() {
    let run = |rig_scale: f32| {
        let mut app = event_app();
        let groom = spiky_groom(20, 6);
        let in_bone_units = HairGroom::from_strands(
            "head",
            groom
                .strands()
                .map(|s| s.iter().map(|p| *p / rig_scale).collect()),
        )
        .unwrap();
        let head_collision = HeadCollision {
            bone: "head".into(),
            spheres: vec![CollisionSphere {
                center: Vec3::ZERO,
                radius: HEAD_RADIUS / rig_scale,
            }],
            capsules: Vec::new(),
            planes: Vec::new(),
        };
        let world = app.world_mut();
        let groom = world.resource_mut::<Assets<HairGroom>>().add(in_bone_units);
        let collision = world
            .resource_mut::<Assets<HeadCollision>>()
            .add(head_collision);
        let (root, _) = character(
            &mut app,
            Transform::from_scale(Vec3::splat(rig_scale)),
            Vec3::new(0.0, 1.6 / rig_scale, 0.0),
        );
        // With hair–hair volume on: its radius is in metres too, whatever the rig's units.
        let hair = app
            .world_mut()
            .spawn((
                Hair {
                    groom,
                    animation: None,
                    collision: Some(collision),
                },
                HairSimSettings {
                    volume: Some(HairVolume {
                        radius: Some(0.05),
                        ..default()
                    }),
                    ..default()
                },
                AttachToBone::named(root, "head"),
            ))
            .id();
        let mut frames = Vec::new();
        let mut pushed = 0;
        for f in 0..90 {
            let t = f as f32 / 60.0;
            app.world_mut().get_mut::<Transform>(root).unwrap().rotation =
                Quat::from_rotation_y(1.5 * (4.0 * t).sin());
            app.update();
            frames.push(particles(&mut app));
            pushed += app
                .world()
                .get::<ComputedHair>(hair)
                .map_or(0, |c| c.stats.volume_pairs);
        }
        assert!(
            pushed > 0,
            "rig scale {rig_scale}: the volume pushed nothing"
        );
        frames
    };
    let unit = run(1.0);
    let mixamo = run(0.01);
    let mut worst: f32 = 0.0;
    for (a, b) in unit.iter().zip(&mixamo) {
        assert_eq!(a.len(), 20);
        worst = worst.max(max_deviation(a, b));
    }
    println!("unit rig vs 0.01 rig: largest difference {worst:e} m over 90 frames");
    assert!(worst < 1e-3, "the scaled rig's hair differs by {worst} m");
    // And the strands keep their lengths in metres (not 100 times longer).
    let last = mixamo.last().unwrap();
    let len: f32 = last[0].windows(2).map(|w| w[0].distance(w[1])).sum();
    assert!((0.1..0.2).contains(&len), "strand 0 is {len} m long");
}

#[test]
fn a_character_scaled_at_run_time_keeps_its_hair_in_proportion() {
    let mut app = event_app();
    let groom_asset = spiky_groom(10, 5);
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(groom_asset.clone());
    let (root, _) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
    app.world_mut().spawn((
        Hair { groom, ..default() },
        AttachToBone::named(root, "head"),
    ));
    app.update();
    let rest_len: f32 = groom_asset
        .strand(0)
        .windows(2)
        .map(|w| w[0].distance(w[1]))
        .sum();
    for scale in [3.0f32, 0.01] {
        app.world_mut().get_mut::<Transform>(root).unwrap().scale = Vec3::splat(scale);
        for _ in 0..30 {
            app.update();
        }
        let p = particles(&mut app);
        let len: f32 = p[0].windows(2).map(|w| w[0].distance(w[1])).sum();
        println!(
            "scale {scale}: strand 0 is {len} m, styled {} m",
            rest_len * scale
        );
        assert!(
            (len / (rest_len * scale) - 1.0).abs() < 0.15,
            "scale {scale}: strand is {len} m, expected {} m",
            rest_len * scale
        );
    }
    let events = seen(&app);
    assert_eq!(
        events,
        vec!["ready 10", "rebuilt Scale", "rebuilt Scale"],
        "{events:?}"
    );
}

#[test]
fn hair_appears_on_its_bone_in_its_styled_pose_on_the_first_frame() {
    let mut app = event_app();
    let groom_asset = spiky_groom(12, 6);
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(groom_asset.clone());
    let (root, head) = character(
        &mut app,
        Transform::from_xyz(2.0, 0.0, -1.0).with_rotation(Quat::from_rotation_y(0.7)),
        Vec3::new(0.0, 1.6, 0.0),
    );
    let hair = app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            AttachToBone::named(root, "head"),
        ))
        .id();
    app.update();
    // Built this frame, after the bone was found: on the bone, not at the origin.
    let bone = app.world().get::<GlobalTransform>(head).unwrap().affine();
    let rest = groom_rest_world(&groom_asset, &bone);
    let first = particles(&mut app);
    let dev = max_deviation(&first, &rest);
    // One frame of gravity sags the tips a little; built at the origin it would be 1.7 m off.
    assert!(dev < 3e-3, "first frame is {dev} m off the styled pose");
    app.update();
    let second = particles(&mut app);
    let moved = max_deviation(&first, &second);
    assert!(
        moved < 0.01,
        "the hair whipped {moved} m in its second frame"
    );
    assert_eq!(
        app.world()
            .get::<ComputedHair>(hair)
            .unwrap()
            .stats
            .teleports,
        0
    );
}

/// A handle whose asset is not there yet: inserting it later is a late load.
fn reserve<A: Asset>(app: &mut App) -> Handle<A> {
    app.world().resource::<Assets<A>>().reserve_handle()
}

#[test]
fn every_load_order_builds_the_hair_with_its_collider() {
    let orders: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    for order in orders {
        let mut app = event_app();
        let groom_handle = reserve::<HairGroom>(&mut app);
        let anim_handle = reserve::<HairAnimation>(&mut app);
        let collision_handle = reserve::<HeadCollision>(&mut app);
        let (root, _) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
        let hair = app
            .world_mut()
            .spawn((
                Hair {
                    groom: groom_handle.clone(),
                    animation: Some(anim_handle.clone()),
                    collision: Some(collision_handle.clone()),
                },
                AttachToBone::named(root, "head"),
            ))
            .id();
        app.update();
        let groom = spiky_groom(8, 5);
        for (n, which) in order.into_iter().enumerate() {
            assert_eq!(
                strand_count(&mut app),
                0,
                "{order:?}: built before all loaded"
            );
            let world = app.world_mut();
            match which {
                0 => world
                    .resource_mut::<Assets<HairGroom>>()
                    .insert(&groom_handle, groom.clone())
                    .unwrap(),
                1 => world
                    .resource_mut::<Assets<HairAnimation>>()
                    .insert(&anim_handle, two_key_animation(&groom))
                    .unwrap(),
                _ => world
                    .resource_mut::<Assets<HeadCollision>>()
                    .insert(&collision_handle, head())
                    .unwrap(),
            }
            app.update();
            if n < 2 {
                app.update();
            }
        }
        assert_eq!(strand_count(&mut app), 8, "{order:?}");
        let colliders = app
            .world_mut()
            .query::<&HeadColliderOf>()
            .iter(app.world())
            .filter(|c| c.0 == hair)
            .count();
        assert_eq!(colliders, 1, "{order:?}: head collider missing");
        assert!(
            app.world()
                .get::<ComputedHair>(hair)
                .unwrap()
                .animation
                .is_some()
        );
        assert_eq!(seen(&app), vec!["ready 8"], "{order:?}");
    }
}

#[test]
fn failed_files_are_events_and_the_hair_still_appears_without_them() {
    let mut app = event_app();
    let server = app.world().resource::<AssetServer>().clone();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(6, 4));
    let (root, _) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
    app.world_mut().spawn((
        Hair {
            groom,
            animation: Some(server.load("missing/none.hairanim.xml")),
            collision: Some(server.load("missing/none.collision.xml")),
        },
        AttachToBone::named(root, "head"),
    ));
    // A groom that fails: no hair, one event naming the file.
    app.world_mut().spawn((
        Hair {
            groom: server.load("missing/none.hair.xml"),
            ..default()
        },
        AttachToBone::named(root, "head"),
    ));
    for _ in 0..400 {
        app.update();
        if seen(&app).iter().any(|e| e.starts_with("ready")) && seen(&app).len() >= 4 {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let events = seen(&app);
    let has = |start: &str, path: &str| {
        events
            .iter()
            .any(|e| e.starts_with(start) && e.contains(path))
    };
    assert!(
        has("failed Animation", "missing/none.hairanim.xml"),
        "{events:?}"
    );
    assert!(
        has("failed Collision", "missing/none.collision.xml"),
        "{events:?}"
    );
    assert!(has("failed Groom", "missing/none.hair.xml"), "{events:?}");
    assert!(
        has("ready 6", ""),
        "the hair must appear without its animation: {events:?}"
    );
    assert_eq!(events.len(), 4, "each failure once: {events:?}");
    assert_eq!(strand_count(&mut app), 6);
}

#[test]
fn replacing_a_groom_rebuilds_the_hair() {
    let mut app = event_app();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(6, 4));
    let (root, _) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
    app.world_mut().spawn((
        Hair {
            groom: groom.clone(),
            ..default()
        },
        AttachToBone::named(root, "head"),
    ));
    app.update();
    assert_eq!(strand_count(&mut app), 6);
    // What Bevy's file watcher does on a re-export: the same asset, new contents.
    app.world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .insert(&groom, spiky_groom(9, 5))
        .unwrap();
    app.update();
    app.update();
    assert_eq!(strand_count(&mut app), 9);
    assert_eq!(seen(&app), vec!["ready 6", "rebuilt Reloaded"]);
    assert_eq!(particles(&mut app)[0].len(), 5);
}

/// Deepest a particle (not a root) sits inside a sphere at `centre` of `radius`, metres (0 when
/// none is inside).
fn deepest_inside(strands: &[Vec<Vec3>], centre: Vec3, radius: f32) -> f32 {
    strands
        .iter()
        .flat_map(|s| s.iter().skip(1))
        .map(|p| radius - p.distance(centre))
        .fold(0.0, f32::max)
}

/// A ball sitting where the styled hair stands (above the head of the harness's bone).
fn ball_in_the_hair() -> (Vec3, f32) {
    (Vec3::new(0.0, 1.6 + 0.2, 0.0), 0.06)
}

#[test]
fn a_hair_collider_anyone_adds_pushes_the_hair_out() {
    let mut h = Harness::new(spiky_groom(40, 6), HairSimSettings::default(), 60.0);
    let (centre, radius) = ball_in_the_hair();
    for _ in 0..30 {
        h.update();
    }
    let before = deepest_inside(&h.strands(), centre, radius);
    assert!(
        before > 0.01,
        "the test ball must start inside the hair ({before} m)"
    );
    h.app.world_mut().spawn((
        HairCollider::spheres(vec![CollisionSphere {
            center: Vec3::ZERO,
            radius,
        }]),
        Transform::from_translation(centre),
    ));
    for _ in 0..60 {
        h.update();
    }
    let after = deepest_inside(&h.strands(), centre, radius);
    println!(
        "particles inside a user's HairCollider: {before:.4} m deep before, {after:.4} m after"
    );
    assert!(after < 1e-3, "a particle is {after} m inside the collider");
}

/// Deepest a particle (not a root) sits inside a box of half extents `half` at `pose`, metres
/// (0 when none is).
#[cfg(any(feature = "rapier", feature = "avian"))]
fn deepest_inside_box(strands: &[Vec<Vec3>], pose: &Transform, half: Vec3) -> f32 {
    strands
        .iter()
        .flat_map(|s| s.iter().skip(1))
        .map(|p| (half - (pose.rotation.inverse() * (*p - pose.translation)).abs()).min_element())
        .fold(0.0, f32::max)
}

/// A physics engine's colliders as the hair sees them: how deep the hair sits, after 90 frames,
/// in a ball and in a box placed in it, (without opting in, opted in, as a sensor).
#[cfg(any(feature = "rapier", feature = "avian"))]
struct EngineDepths {
    ball: [f32; 3],
    cuboid: [f32; 3],
}

#[cfg(any(feature = "rapier", feature = "avian"))]
impl EngineDepths {
    /// `spawn(world, at, ball radius or box half extents, ball?, sensor?)` makes the engine's
    /// collider; `opt_in` marks the hair.
    fn measure(
        spawn: impl Fn(&mut World, Transform, Vec3, bool, bool),
        opt_in: impl Fn(&mut EntityWorldMut),
    ) -> Self {
        let run = |ball: bool, opted: bool, sensor: bool| {
            let mut h = Harness::new(spiky_groom(40, 6), HairSimSettings::default(), 60.0);
            let (centre, radius) = ball_in_the_hair();
            // The box is turned, so a strand through its middle is pushed out sideways too.
            let pose = Transform::from_translation(centre).with_rotation(Quat::from_euler(
                EulerRot::XYZ,
                0.6,
                0.3,
                0.5,
            ));
            let size = if ball {
                Vec3::splat(radius)
            } else {
                Vec3::new(0.05, 0.04, 0.06)
            };
            spawn(h.app.world_mut(), pose, size, ball, sensor);
            if opted {
                opt_in(&mut h.app.world_mut().entity_mut(h.hair));
            }
            for _ in 0..90 {
                h.update();
            }
            if ball {
                deepest_inside(&h.strands(), centre, radius)
            } else {
                deepest_inside_box(&h.strands(), &pose, size)
            }
        };
        let three = |ball| {
            [
                run(ball, false, false),
                run(ball, true, false),
                run(ball, true, true),
            ]
        };
        Self {
            ball: three(true),
            cuboid: three(false),
        }
    }

    fn check(&self, engine: &str) {
        println!(
            "{engine}: ball {:.4} m deep without opting in, {:.4} m with, {:.4} m as a sensor; \
             box {:.4} / {:.4} / {:.4} m",
            self.ball[0],
            self.ball[1],
            self.ball[2],
            self.cuboid[0],
            self.cuboid[1],
            self.cuboid[2]
        );
        for (shape, [off, on, sensor]) in [("ball", self.ball), ("box", self.cuboid)] {
            assert!(
                off > 0.01,
                "{engine} {shape}: without opting in the world's colliders are ignored ({off} m)"
            );
            assert!(
                on < 1e-3,
                "{engine} {shape}: opted in, it pushes the hair out ({on} m)"
            );
            assert!(
                sensor > 0.01,
                "{engine} {shape}: sensors are never collided with ({sensor} m)"
            );
        }
    }
}

#[cfg(feature = "rapier")]
#[test]
fn the_worlds_rapier_colliders_are_opt_in() {
    use bevy_rapier3d::prelude::{Collider, CollisionGroups, Sensor};
    EngineDepths::measure(
        |world, at, size, ball, sensor| {
            let collider = if ball {
                Collider::ball(size.x)
            } else {
                Collider::cuboid(size.x, size.y, size.z)
            };
            let mut e = world.spawn((collider, at));
            if sensor {
                e.insert(Sensor);
            }
        },
        |hair| {
            hair.insert(HairCollisionGroups(CollisionGroups::default()));
        },
    )
    .check("rapier");
}

#[cfg(feature = "avian")]
#[test]
fn the_worlds_avian_colliders_are_opt_in() {
    use avian3d::prelude::{Collider, CollisionLayers, Sensor};
    EngineDepths::measure(
        |world, at, size, ball, sensor| {
            let collider = if ball {
                Collider::sphere(size.x)
            } else {
                Collider::cuboid(2.0 * size.x, 2.0 * size.y, 2.0 * size.z)
            };
            let mut e = world.spawn((collider, at));
            if sensor {
                e.insert(Sensor);
            }
        },
        |hair| {
            hair.insert(crate::sim::HairCollisionLayers(CollisionLayers::default()));
        },
    )
    .check("avian");
}

/// With an engine feature, the head collider is also that engine's collider, of the head's
/// spheres (so the engine's other users see the head).
#[cfg(any(feature = "rapier", feature = "avian"))]
#[test]
fn the_head_collider_is_an_engine_collider_too() {
    let mut h = Harness::new(spiky_groom(4, 4), HairSimSettings::default(), 60.0);
    let world = h.app.world_mut();
    let head_collider = world
        .query_filtered::<Entity, With<HeadColliderOf>>()
        .single(world)
        .unwrap();
    let spheres = head().spheres;
    #[cfg(feature = "rapier")]
    {
        let c = world
            .get::<bevy_rapier3d::prelude::Collider>(head_collider)
            .unwrap();
        let compound = c.raw.as_compound().expect("a compound of balls");
        assert_eq!(compound.shapes().len(), spheres.len());
        for ((pose, shape), s) in compound.shapes().iter().zip(&spheres) {
            assert_eq!(pose.translation, s.center);
            assert_eq!(shape.as_ball().unwrap().radius, s.radius);
        }
    }
    #[cfg(feature = "avian")]
    {
        let c = world
            .get::<avian3d::prelude::Collider>(head_collider)
            .unwrap();
        let compound = c.shape().as_compound().expect("a compound of spheres");
        assert_eq!(compound.shapes().len(), spheres.len());
        for ((pose, shape), s) in compound.shapes().iter().zip(&spheres) {
            assert!((pose.translation - s.center).length() < 1e-6);
            assert_eq!(shape.as_ball().unwrap().radius, s.radius);
        }
        let density = world
            .get::<avian3d::prelude::ColliderDensity>(head_collider)
            .unwrap();
        assert_eq!(
            density.0, 0.0,
            "the head must not add mass to a character body"
        );
    }
}

#[test]
fn reloading_the_same_strands_keeps_the_hair_moving() {
    // Two identical runs; in one the groom is re-exported (same strands) mid-swing. With its
    // motion kept, the reloaded hair goes on exactly as the other; snapped back to its style it
    // would differ by the hair's lag.
    let run = |reload: bool| {
        let mut app = event_app();
        let style = spiky_groom(12, 6);
        let groom = app
            .world_mut()
            .resource_mut::<Assets<HairGroom>>()
            .add(style.clone());
        let (root, _) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
        app.world_mut().spawn((
            Hair {
                groom: groom.clone(),
                ..default()
            },
            AttachToBone::named(root, "head"),
        ));
        let mut lag = 0.0;
        for f in 0..30 {
            if reload && f == 20 {
                app.world_mut()
                    .resource_mut::<Assets<HairGroom>>()
                    .insert(&groom, style.clone())
                    .unwrap();
            }
            app.world_mut().get_mut::<Transform>(root).unwrap().rotation =
                Quat::from_rotation_y(0.1 * f as f32);
            app.update();
            if f == 19 {
                let bone = app.world().get::<GlobalTransform>(root).unwrap().affine();
                let styled: Vec<Vec<Vec3>> = style
                    .strands()
                    .map(|s| {
                        s.iter()
                            .map(|p| bone.transform_point3(*p + Vec3::new(0.0, 1.6, 0.0)))
                            .collect()
                    })
                    .collect();
                lag = max_deviation(&particles(&mut app), &styled);
            }
        }
        (particles(&mut app), seen(&app), lag)
    };
    let (kept, events, lag) = run(true);
    let (control, _, _) = run(false);
    assert_eq!(events.last().map(String::as_str), Some("rebuilt Reloaded"));
    let differ = max_deviation(&kept, &control);
    println!(
        "after a reload mid-swing: {differ:e} m from the run without one (the hair lagged {lag:.4} m behind its style)"
    );
    assert!(
        lag > 0.01,
        "the swing must move the hair off its style ({lag} m)"
    );
    assert!(differ < 1e-4, "the reload changed the motion by {differ} m");
}

#[test]
fn the_hair_clock_pauses_and_steps_only_the_hair() {
    let mut h = Harness::new(spiky_groom(10, 6), HairSimSettings::default(), 60.0);
    for _ in 0..5 {
        h.update();
    }
    h.app.world_mut().resource_mut::<Time<HairTime>>().pause();
    h.update();
    let paused = h.strands();
    let hair_seconds = h.app.world().resource::<Time<HairTime>>().elapsed_secs();
    for _ in 0..10 {
        h.update();
    }
    assert_eq!(h.strands(), paused, "paused hair moved");
    let time = h.app.world().resource::<Time<HairTime>>();
    assert_eq!(
        time.elapsed_secs(),
        hair_seconds,
        "the paused clock advanced"
    );
    // A NaN step is refused; one step advances exactly one step, once.
    let mut time = h.app.world_mut().resource_mut::<Time<HairTime>>();
    time.set_step_seconds(f32::NAN);
    assert_eq!(time.context().step_seconds(), 1.0 / 60.0);
    time.step_once();
    h.update();
    assert_ne!(h.strands(), paused, "a step did not move the hair");
    let stepped = h.strands();
    let time = h.app.world().resource::<Time<HairTime>>();
    assert!((time.elapsed_secs() - hair_seconds - 1.0 / 60.0).abs() < 1e-6);
    h.update();
    assert_eq!(h.strands(), stepped, "one step, not two");
    // The game's virtual clock went on all along.
    let virt = h.app.world().resource::<Time<Virtual>>().elapsed_secs();
    assert!(virt > hair_seconds + 0.15, "{virt} vs {hair_seconds}");
}

#[test]
fn hair_components_are_reflected_for_inspectors() {
    use bevy::reflect::ReflectRef;
    let h = Harness::new(spiky_groom(5, 4), HairSimSettings::default(), 60.0);
    let world = h.app.world();
    let registry = world.resource::<AppTypeRegistry>().read();
    for name in [
        "Hair",
        "HairSimSettings",
        "AttachToBone",
        "StrandParticles",
        "HairCollider",
        "ComputedHair",
        "HairStatus",
    ] {
        assert!(
            registry
                .get_with_short_type_path(name)
                .is_some_and(|r| r.data::<bevy::ecs::reflect::ReflectComponent>().is_some()),
            "{name} is not a reflected component"
        );
    }
    let computed = world.get::<ComputedHair>(h.hair).unwrap();
    let ReflectRef::Struct(fields) = computed.reflect_ref() else {
        panic!("ComputedHair is not a reflected struct");
    };
    let size = fields
        .field("size")
        .and_then(|f| f.try_downcast_ref::<f32>());
    assert_eq!(size, Some(&1.0));
}

/// The ninja's own hair and head, as shipped.
fn ninja_groom_and_head() -> (HairGroom, HeadCollision) {
    let groom = crate::asset::parse_groom(
        "ninja.hair.xml",
        include_str!("../../assets/ninja/ninja.hair.xml"),
    )
    .unwrap();
    let head = crate::asset::parse_collision(
        "ninja.collision.xml",
        include_str!("../../assets/ninja/ninja.collision.xml"),
    )
    .unwrap();
    (groom, head)
}

/// The bone's pose `t` seconds into each fast motion of the issue: a 4 Hz shake, a 60 degree
/// snap, a 0.99 m jump (just under the teleport distance), walking, and spinning at 4 turns/s.
fn fast_motion(motion: usize, t: f32) -> Transform {
    use std::f32::consts::TAU;
    let base = Vec3::new(0.0, 1.6, 0.0);
    match motion {
        0 => Transform::from_translation(base)
            .with_rotation(Quat::from_rotation_y(0.6 * (TAU * 4.0 * t).sin())),
        1 => Transform::from_translation(base).with_rotation(Quat::from_rotation_y(if t < 1.0 {
            std::f32::consts::FRAC_PI_3
        } else {
            0.0
        })),
        2 => Transform::from_translation(base + Vec3::Y * if t < 1.0 { 0.99 } else { 0.0 }),
        3 => {
            // Walking back and forth at 1.4 m/s with a 2 Hz bob and sway.
            let x = 0.7 * (TAU * t / 2.0).sin();
            let bob = 0.04 * (TAU * 2.0 * t).sin().abs();
            Transform::from_translation(base + Vec3::new(x, bob, 0.0))
                .with_rotation(Quat::from_rotation_z(0.08 * (TAU * t).sin()))
        }
        _ => Transform::from_translation(base).with_rotation(Quat::from_rotation_y(TAU * 4.0 * t)),
    }
}

/// After each fast motion and 15 s at rest, every strand of the ninja is back
/// within 2 mm of the pose it had settled in, and no chain tetrahedron is inside out. (Before the
/// signed-volume constraint, 53 to 89 of the 159 strands stayed up to 3.4 cm away.)
#[test]
fn every_strand_returns_to_its_rest_pose_after_fast_motion() {
    let (groom, head) = ninja_groom_and_head();
    let mut h = Harness::with(groom, None, Some(head), HairSimSettings::default(), 60.0);
    let settle = |h: &mut Harness, seconds: u32| {
        h.set_bone(Transform::from_xyz(0.0, 1.6, 0.0));
        for _ in 0..seconds * 60 {
            h.update();
        }
    };
    settle(&mut h, 5);
    let rest = h.strands();
    let mut report = Vec::new();
    for motion in 0..5 {
        for frame in 0..120 {
            h.set_bone(fast_motion(motion, frame as f32 / 60.0));
            h.update();
        }
        settle(&mut h, 15);
        let now = h.strands();
        let per_strand: Vec<f32> = now
            .iter()
            .zip(&rest)
            .map(|(a, b)| max_deviation(std::slice::from_ref(a), std::slice::from_ref(b)))
            .collect();
        let worst = per_strand.iter().copied().fold(0.0, f32::max);
        let away = per_strand.iter().filter(|d| **d > 0.002).count();
        // No tetrahedron of four consecutive chain nodes is left inside out.
        let c = h.computed();
        let mut inverted = 0;
        for &(b, l) in &c.lane_of {
            let (batch, l) = (&c.batches[b as usize], l as usize);
            for k in 3..batch.nodes.len() {
                let node = |i: usize| batch.node(l, i);
                let v =
                    super::solver::signed_volume(node(k - 3), node(k - 2), node(k - 1), node(k));
                inverted += usize::from(v * batch.nodes[k].volume[l] < 0.0);
            }
        }
        report.push((motion, worst, away, inverted));
    }
    eprintln!("(motion, worst metres, strands > 2 mm away, inverted tetrahedra): {report:?}");
    assert!(
        report
            .iter()
            .all(|&(_, worst, _, inverted)| worst < 0.002 && inverted == 0),
        "strands did not come back within 2 mm: {report:?}"
    );
}

/// The largest ratio of a strand segment's length to its rest length.
fn worst_stretch(strands: &[Vec<Vec3>], rest: &[Vec<Vec3>]) -> f32 {
    strands
        .iter()
        .zip(rest)
        .flat_map(|(s, r)| {
            s.windows(2)
                .zip(r.windows(2))
                .map(|(a, b)| a[0].distance(a[1]) / b[0].distance(b[1]).max(1e-9))
        })
        .fold(0.0, f32::max)
}

/// A 0.99 m jump in one frame (59 m/s, just under the teleport distance) stretched
/// segments 12.9x. The strain limit (`max_stretch`, 1.1) holds them to 1.57x: the head's
/// collisions run after it and push the hair dragged through the head back out, which is worth
/// more than exact lengths.
#[test]
fn a_jump_just_under_the_teleport_distance_does_not_stretch_the_hair() {
    let groom = spiky_groom(40, 8);
    let mut h = Harness::new(groom.clone(), HairSimSettings::default(), 60.0);
    let rest = groom_rest_world(&groom, &h.bone_affine());
    for _ in 0..30 {
        h.update();
    }
    let mut worst = 0.0f32;
    // 0.99 m in one frame: 59 m/s, just under the 1 m teleport distance.
    h.set_bone(Transform::from_xyz(0.0, 2.59, 0.0));
    for _ in 0..60 {
        h.update();
        worst = worst.max(worst_stretch(&h.strands(), &rest));
    }
    eprintln!("worst segment stretch after a 0.99 m jump: {worst:.2}x");
    assert!(worst < 2.0, "segments stretched {worst:.2}x");
}

/// A character riding a vehicle at a steady 30 m/s. With damping in the world frame
/// (the default, still air) the ninja's hair is blown back; in the bone's frame it stays as at
/// rest.
#[test]
fn damping_in_the_bones_frame_leaves_hair_in_a_moving_vehicle_at_rest() {
    let mut blown = Vec::new();
    for frame in [HairDampingFrame::World, HairDampingFrame::Bone] {
        let (groom, head) = ninja_groom_and_head();
        let settings = HairSimSettings {
            damping_frame: frame,
            ..default()
        };
        let mut h = Harness::with(groom, None, Some(head), settings, 60.0);
        let relative = |h: &mut Harness| -> Vec<Vec3> {
            let bone = Vec3::from(h.bone_affine().translation);
            h.strands().iter().flatten().map(|p| *p - bone).collect()
        };
        for _ in 0..180 {
            h.update();
        }
        let rest = relative(&mut h);
        // 30 m/s along +x for 4 s: 0.5 m a frame, under the 1 m teleport distance.
        for f in 1..=240 {
            h.set_bone(Transform::from_xyz(0.5 * f as f32, 1.6, 0.0));
            h.update();
        }
        assert_eq!(h.computed().stats.teleports, 0);
        let now = relative(&mut h);
        let worst = rest
            .iter()
            .zip(&now)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        blown.push(worst);
    }
    eprintln!(
        "hair displaced at 30 m/s: world frame {:.4} m, bone frame {:.4} m",
        blown[0], blown[1]
    );
    assert!(
        blown[0] > 0.03,
        "still air should blow the hair back: {blown:?}"
    );
    assert!(
        blown[1] < 0.002,
        "the bone's frame should leave it at rest: {blown:?}"
    );
}

/// A style limit holds every particle within its distance of the keyframed style
/// through the 4 turns/s shake (only the head's collisions, which run after it, may push a
/// particle a little farther).
#[test]
fn a_style_limit_keeps_hair_near_its_style_through_a_hard_shake() {
    let mut farthest = Vec::new();
    for limit in [None, Some(0.02)] {
        let (groom, head) = ninja_groom_and_head();
        let settings = HairSimSettings {
            style_limit: limit,
            ..default()
        };
        let mut h = Harness::with(groom, None, Some(head), settings, 60.0);
        let mut worst = 0.0f32;
        for f in 0..180 {
            h.set_bone(fast_motion(0, f as f32 / 60.0));
            h.update();
            let strands = h.strands();
            let c = h.computed();
            for (s, particles) in strands.iter().enumerate() {
                for (i, p) in particles.iter().enumerate().skip(1) {
                    if let Some(a) = c.anchor(s, i) {
                        worst = worst.max(p.distance(a));
                    }
                }
            }
        }
        farthest.push(worst);
    }
    eprintln!(
        "farthest from the style in a 4 Hz shake: {:.3} m without a limit, {:.4} m with 0.02 m",
        farthest[0], farthest[1]
    );
    assert!(
        farthest[0] > 0.04,
        "the shake should move hair: {farthest:?}"
    );
    assert!(farthest[1] < 0.0205, "the limit did not hold: {farthest:?}");
}

/// Wind. A 6 m/s gusty wind along +x blows the hair downwind, tips more than the middle
/// of the strands (roots are pinned); the same at 30, 60 and 144 fps (2 mm, as without wind); a
/// calm override on the hair shields it.
#[test]
fn wind_blows_tips_most_at_any_frame_rate_and_an_override_shields() {
    let wind = HairWind {
        velocity: Vec3::new(6.0, 0.0, 0.0),
        ..default()
    };
    let run = |fps: f64, shielded: bool| {
        let groom = spiky_groom(16, 6);
        let mut h = Harness::new(groom, HairSimSettings::default(), fps);
        let frames = |secs: f64| (secs * fps).round() as usize;
        for _ in 0..frames(1.0) {
            h.update();
        }
        let calm = h.strands();
        h.app.insert_resource(wind.clone());
        if shielded {
            let hair = h.hair;
            h.app
                .world_mut()
                .entity_mut(hair)
                .insert(HairWindOverride(HairWind::default()));
        }
        for _ in 0..frames(2.0) {
            h.update();
        }
        (calm, h.strands())
    };
    let (calm, blown) = run(60.0, false);
    // Mean downwind (+x) shift of the middle particle and of the tip.
    let shift = |i: usize| {
        calm.iter()
            .zip(&blown)
            .map(|(a, b)| b[i].x - a[i].x)
            .sum::<f32>()
            / calm.len() as f32
    };
    let (middle, tip) = (shift(2), shift(5));
    let (_, b30) = run(30.0, false);
    let (_, b144) = run(144.0, false);
    let (d30, d144) = (max_deviation(&blown, &b30), max_deviation(&blown, &b144));
    let (calm_too, shielded) = run(60.0, true);
    let still = max_deviation(&calm_too, &shielded);
    println!(
        "wind 6 m/s: tips {tip:.4} m and middles {middle:.4} m downwind; 60 vs 30 fps {d30} m, \
         60 vs 144 fps {d144} m; shielded hair moved {still} m"
    );
    assert!(
        tip > 0.01 && tip > 1.5 * middle && middle > 0.0,
        "{tip} {middle}"
    );
    assert!(d30 < 2e-3 && d144 < 2e-3, "{d30} {d144}");
    assert!(still < 1e-3, "the calm override let wind through: {still}");
}

/// Strands from `roots` to `tips` (straight, 8 particles), roots on the bone.
fn straight_groom(pairs: &[(Vec3, Vec3)]) -> HairGroom {
    HairGroom::from_strands(
        "head",
        pairs.iter().map(|&(a, b)| {
            (0..8)
                .map(|k| a.lerp(b, k as f32 / 7.0))
                .collect::<Vec<_>>()
        }),
    )
    .unwrap()
}

/// Two strands styled into each other (their tips meet) end their radius sum
/// apart with the volume at stiffness 1 (0.0320 m for 0.032 m), 0.0275 m at 0.5, and 0.001 m
/// (where the style puts them) without it.
#[test]
fn hair_volume_keeps_two_crossing_strands_apart() {
    let groom = straight_groom(&[
        (Vec3::new(-0.05, 0.0, 0.0), Vec3::new(0.0, -0.2, 0.0)),
        (Vec3::new(0.05, 0.0, 0.0), Vec3::new(0.0, -0.2, 0.001)),
    ]);
    let radius = 0.016;
    let tips = |volume: Option<HairVolume>| {
        let settings = HairSimSettings {
            gravity: Vec3::ZERO,
            volume,
            ..default()
        };
        let mut h = Harness::with(groom.clone(), None, None, settings, 60.0);
        for _ in 0..120 {
            h.update();
        }
        let s = h.strands();
        assert!(s.iter().flatten().all(|p| p.is_finite()));
        (
            s[0].last().unwrap().distance(*s[1].last().unwrap()),
            h.computed().stats.volume_pairs,
        )
    };
    let (off, _) = tips(None);
    let (on, pairs) = tips(Some(HairVolume {
        stiffness: 1.0,
        radius: Some(radius),
    }));
    let (half, _) = tips(Some(HairVolume {
        stiffness: 0.5,
        radius: Some(radius),
    }));
    println!(
        "tips apart: {off:.4} m without volume, {half:.4} m at stiffness 0.5, {on:.4} m at 1 \
         ({pairs} pairs pushed in the last frame); radius sum {:.3} m",
        2.0 * radius
    );
    assert!(off < 0.005, "without volume the tips meet: {off}");
    // Stiffness 1 removes the whole overlap at the end of each frame: they touch.
    assert!(
        on >= 2.0 * radius * 0.999,
        "tips {on} m apart, radius sum {}",
        2.0 * radius
    );
    assert!(half > off + radius, "stiffness 0.5: {half} m");
}

/// A hair of straight strands from `roots` styled to meet 0.25 m under the bone (each tip at
/// 5% of its root's offset from the axis), hanging under gravity for 3 s with `volume`; the
/// harness and the tips' mean distance from the bone's vertical axis.
fn hanging_tips(roots: &[Vec3], volume: Option<HairVolume>) -> (Harness, f32) {
    let pairs: Vec<(Vec3, Vec3)> = roots
        .iter()
        .map(|&root| (root, Vec3::new(0.0, -0.25, 0.0) + root * 0.05))
        .collect();
    let settings = HairSimSettings {
        volume,
        ..default()
    };
    let mut h = Harness::with(straight_groom(&pairs), None, None, settings, 60.0);
    for _ in 0..180 {
        h.update();
    }
    let axis = Vec3::from(h.bone_affine().translation);
    let s = h.strands();
    assert!(s.iter().flatten().all(|p| p.is_finite()));
    let spread = s
        .iter()
        .map(|p| {
            let d = *p.last().unwrap() - axis;
            Vec2::new(d.x, d.z).length()
        })
        .sum::<f32>()
        / s.len() as f32;
    (h, spread)
}

/// A cone of strands styled to meet under the bone, hanging under gravity,
/// keeps more volume with the volume on: its tips' mean distance from the axis is larger
/// (measured: 0.0042 m without, 0.0187 m with the defaults; 0.0399 m when crowded particles'
/// pushes were summed instead of averaged).
#[test]
fn hair_volume_keeps_a_hanging_hair_fuller() {
    let n = 24;
    let roots: Vec<Vec3> = (0..n)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec3::new(a.cos(), 0.0, a.sin()) * 0.05
        })
        .collect();
    let (_, off) = hanging_tips(&roots, None);
    let (_, on) = hanging_tips(&roots, Some(HairVolume::default()));
    println!("hanging cone: tips {off:.4} m from the axis without volume, {on:.4} m with it");
    assert!(on > off + 0.01, "volume {on} vs none {off}");
}

/// Hair far denser than its volume radius (1,000 strands 8 mm apart at the
/// roots with 16 mm tubes: it cannot be kept apart) is spread by its density and stays calm.
/// Measured over 30 frames after 2 s at rest: 0.0001 m mean and 0.0073 m largest motion per
/// frame, with about 14,760 of its 15,000 particles crowded. (With pairs alone and averaged
/// pushes it moved 0.00078 m a frame on average and up to 0.0119 m, and the list was rebuilt
/// in 20 of 30 frames; with summed pushes 0.039 m and up to 0.21 m.) Hair a tube apart (4 mm)
/// keeps its pair list in all 30 frames.
#[test]
fn hair_volume_keeps_dense_hair_calm() {
    for (radius, dense) in [(0.004f32, false), (0.016, true)] {
        let settings = HairSimSettings {
            volume: Some(HairVolume {
                radius: Some(radius),
                ..default()
            }),
            ..default()
        };
        let mut h = Harness::with(spiky_groom(1000, 16), None, None, settings, 60.0);
        for _ in 0..120 {
            h.update();
        }
        let mut prev = h.strands();
        let (mut worst, mut mean, mut rebuilds) = (0f32, 0f32, 0);
        for _ in 0..30 {
            h.update();
            let now = h.strands();
            let moved: Vec<f32> = now
                .iter()
                .flatten()
                .zip(prev.iter().flatten())
                .map(|(a, b)| a.distance(*b))
                .collect();
            worst = moved.iter().copied().fold(worst, f32::max);
            mean += moved.iter().sum::<f32>() / moved.len() as f32 / 30.0;
            rebuilds += usize::from(h.computed().volume.reused == 0);
            prev = now;
        }
        let c = h.computed();
        let (pairs, spread) = (c.stats.volume_pairs, c.stats.volume_spread);
        println!(
            "volume radius {radius}: per-frame motion {mean:.6} m mean, {worst:.5} m largest; \
             {pairs} pairs pushed, {spread} particles spread by density ({} crowded); \
             pair list rebuilt in {rebuilds} of 30 frames",
            c.volume.crowded_count
        );
        assert_eq!(c.volume.dense, dense, "radius {radius}: spread by density");
        if dense {
            assert!(
                spread > 10_000 && pairs == 0,
                "radius {radius}: {spread} spread"
            );
        } else {
            assert!(pairs > 0 && spread == 0, "radius {radius}: {pairs} pairs");
            assert_eq!(rebuilds, 0, "radius {radius}: the list was rebuilt");
        }
        assert!(
            mean < 0.0005,
            "radius {radius}: {mean} m a frame on average"
        );
        assert!(
            worst < radius,
            "radius {radius}: a particle moved {worst} m in a frame"
        );
    }
}

/// The density spreads crowded hair out, and a hair that stops being crowded
/// goes back to pairs. A ponytail of 1,000 strands (roots on a 5 cm disc, styled to meet under
/// it) hanging under gravity with the default 16 mm volume is spread by its density: its tips'
/// mean distance from the axis is over 3 times what it is without volume (measured: 0.0117 m
/// against 0.0031 m; 0.0194 m with pairs alone, at 4 times the cost). Then the radius drops to 0.2 mm: the hair leaves the density and pushes pairs.
#[test]
fn hair_volume_density_spreads_crowded_hair_and_lets_go() {
    let n = 1000;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let roots: Vec<Vec3> = (0..n)
        .map(|i| {
            let (r, a) = (
                0.05 * ((i as f32 + 0.5) / n as f32).sqrt(),
                golden * i as f32,
            );
            Vec3::new(r * a.cos(), 0.0, r * a.sin())
        })
        .collect();
    let (_, off) = hanging_tips(&roots, None);
    let (mut h, on) = hanging_tips(&roots, Some(HairVolume::default()));
    let c = h.computed();
    println!(
        "ponytail of {n}: tips {on:.4} m from the axis with the volume ({} crowded, {} \
         spread), {off:.4} m without",
        c.volume.crowded_count, c.stats.volume_spread
    );
    assert!(c.volume.dense, "not spread by density");
    assert!(on > 3.0 * off, "density {on} vs none {off}");
    h.app
        .world_mut()
        .get_mut::<HairSimSettings>(h.hair)
        .unwrap()
        .volume = Some(HairVolume {
        radius: Some(0.0002),
        ..default()
    });
    for _ in 0..3 {
        h.update();
    }
    let c = h.computed();
    println!(
        "at 0.2 mm: {} crowded, {} pairs pushed",
        c.volume.crowded_count, c.stats.volume_pairs
    );
    assert!(!c.volume.dense, "still spread by density at 0.2 mm");
    assert!(c.stats.volume_pairs > 0, "no pairs pushed at 0.2 mm");
}

/// The density pass gives the same bits on the AVX2 and the portable path.
#[test]
fn hair_volume_density_is_the_same_on_both_paths() {
    let run = || {
        let settings = HairSimSettings {
            volume: Some(HairVolume {
                radius: Some(0.016),
                ..default()
            }),
            ..default()
        };
        let mut h = Harness::with(spiky_groom(1000, 16), None, None, settings, 60.0);
        for f in 0..40 {
            h.set_bone(
                Transform::from_xyz(0.0, 1.6, 0.0)
                    .with_rotation(Quat::from_rotation_y(0.5 * (f as f32 / 10.0).sin())),
            );
            h.update();
        }
        assert!(h.computed().volume.dense);
        h.hash()
    };
    let (portable, vector) = crate::simd::on_both_paths(run);
    println!("state hash: {portable:#018x} portable, {vector:x?} AVX2");
    assert_eq!(
        vector.unwrap_or(portable),
        portable,
        "AVX2 and portable differ"
    );
}

/// The volume's pair list, kept while the hair moves with its bone, pushes
/// exactly what a list built from scratch pushes: the head turns 90 degrees and moves 0.3 m in
/// 4 s; each frame the pass is run again on a copy of the hair with the kept list and with a
/// new one.
#[test]
fn hair_volume_pair_list_matches_a_fresh_one() {
    let settings = HairSimSettings {
        volume: Some(HairVolume {
            radius: Some(0.008),
            ..default()
        }),
        ..default()
    };
    let mut h = Harness::with(spiky_groom(300, 12), None, None, settings, 60.0);
    for _ in 0..60 {
        h.update();
    }
    let (mut kept, mut compared) = (0, 0);
    let frames = 240;
    for f in 1..=frames {
        let t = f as f32 / frames as f32;
        h.set_bone(Transform {
            translation: Vec3::new(0.3 * t, 1.6, 0.0),
            rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2 * t),
            ..default()
        });
        h.update();
        let c = h.computed();
        kept += usize::from(c.volume.reused > 0);
        let bone = h.bone_affine();
        let (mut a, mut b) = (c.batches.clone(), c.batches.clone());
        let (mut list, mut fresh) = (c.volume.clone(), VolumeScratch::default());
        let pa = keep_apart(&mut a, 0.008, 0.5, &bone, &mut list);
        let pb = keep_apart(&mut b, 0.008, 0.5, &bone, &mut fresh);
        assert_eq!(pa, pb, "frame {f}: pairs pushed");
        compared += pa;
        for (x, y) in a.iter().zip(&b) {
            for (nx, ny) in x.nodes.iter().zip(&y.nodes) {
                for c in 0..3 {
                    for l in 0..LANES {
                        assert!(
                            (nx.x[c][l] - ny.x[c][l]).abs() <= 1e-6,
                            "frame {f}: kept and fresh lists differ"
                        );
                    }
                }
            }
        }
    }
    println!(
        "pair list kept in {kept} of {frames} frames of head motion; {compared} pushes compared"
    );
    assert!(
        kept >= frames / 2,
        "the list was kept in only {kept} frames"
    );
    assert!(compared > 0, "nothing was pushed");
}

/// Hostile values: the volume pass (pairs, and density) on particles at
/// +-3e38 m, piled on one point or NaN, with radii from the smallest float to `f32::MAX`,
/// returns and leaves every finite particle finite; the bounds measured part by part (as the
/// solver's pass does for the density) are the whole hair's.
#[test]
fn hair_volume_survives_hostile_positions_and_radii() {
    let settings = HairSimSettings {
        volume: Some(HairVolume::default()),
        ..default()
    };
    let h = Harness::with(spiky_groom(40, 8), None, None, settings, 60.0);
    let bone = h.bone_affine();
    let mut rng = Rng(7);
    let picks = [3e38, -3e38, 0.0, 1e-30, 1e30, f32::NAN, f32::INFINITY];
    for radius in [1e-45, 1e-30, 0.016, 1e30, 3e38, f32::MAX, -1.0, f32::NAN] {
        let mut batches = h.computed().batches.clone();
        for b in &mut batches {
            for node in &mut b.nodes {
                for c in 0..3 {
                    for l in 0..LANES {
                        let r = rng.unit();
                        if r < 0.5 {
                            node.x[c][l] = picks[(r * 14.0) as usize % picks.len()];
                        }
                    }
                }
            }
        }
        let before: Vec<bool> = batches
            .iter()
            .flat_map(|b| b.nodes.iter().flat_map(|n| n.x.iter().flatten()))
            .map(|v| v.is_finite())
            .collect();
        // The bounds the solver's pass measures part by part are the hair's.
        let whole = super::volume::bounds_of(&batches);
        for size in 1..=3 {
            let parts = batches
                .chunks(size)
                .map(super::volume::bounds_of)
                .fold(super::volume::NO_BOUNDS, super::volume::merge_bounds);
            assert_eq!(parts, whole, "bounds measured {size} batches at a time");
        }
        let mut scratch = VolumeScratch::default();
        for _ in 0..2 {
            keep_apart(&mut batches, radius, 1.0, &bone, &mut scratch);
        }
        // And spread by density, as crowded hair is, with the bounds measured as the pass does
        // (checked against the batches under debug assertions).
        scratch.dense = true;
        for _ in 0..2 {
            scratch.measure(super::volume::bounds_of(&batches));
            keep_apart(&mut batches, radius, 1.0, &bone, &mut scratch);
        }
        let after = batches
            .iter()
            .flat_map(|b| b.nodes.iter().flat_map(|n| n.x.iter().flatten()));
        for (was, v) in before.iter().zip(after) {
            assert!(
                !was || v.is_finite(),
                "radius {radius}: a finite particle became {v}"
            );
        }
    }
}
