//! Bone chains: the crate's solver driving a crowd's hair bones, beside the VRM reference
//! spring-bone step written out here as the baseline.
//!
//! ```text
//! cargo bench --bench chains --no-default-features
//! ```
//!
//! 16 and 100 characters x 40 chains x 6 joints (and a tail), each character with a head sphere, a neck
//! capsule and two shoulder capsules. `chains/ours` is a whole `app.update()` of a headless app
//! (bone lookup, solver, writing the joints); `chains/vrm_reference` is the VRM 1.0 spring-bone
//! step (verlet with drag, stiffness toward the bind direction, gravity, length kept, sphere and
//! capsule pushes, joint rotations) over plain arrays, the same colliders and joints;
//! `chains/bevy_vrm1` is the same app with bevy_vrm1 0.11's own spring-bone system moving the
//! same chains with the reference's joint parameters (what a game that loads its avatars with
//! bevy_vrm1 pays today; see `chains_baselines/bevy_vrm1.rs`);
//! `chains/bones_only` is the app with the same moving bones and no chains (Bevy's own frame);
//! `chains/hair_stages` is the part of `ours`'s frame spent in the hair's stages (attach and
//! simulate: solver, posing, writing the joints), timed from inside the frame, which is the work
//! the reference step stands for.
//! Before the timings it prints how far apart each method's last joints are, shaken at 30 and at
//! 144 frames a second: at the end of a second, and every sixth of a second over it; ours twice,
//! with default settings and with the reference's joint parameters mapped as the VRM import maps
//! them. Then the hair's stages and the reference step taken in turns, 200 frames of each at
//! a time, and their ratio: on a machine whose speed drifts from one run to the next (a shared
//! cloud machine), the ratio holds where criterion's figures, taken seconds apart, do not.
//! With it, the share of the machine's time its hypervisor stole meanwhile (Linux): a run with
//! steal is slowed in the hair's two-thread stages more than in the one-thread reference.
#![expect(
    missing_docs,
    reason = "criterion's macros define undocumented functions"
)]

use std::time::{Duration, Instant};

use bevy::asset::AssetPlugin;
use bevy::math::Affine3A;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformSystems;
use bevy_cartoon_hair::asset::{
    CollisionCapsule, CollisionSphere, HairAssetPlugin, VrmJoint, VrmSpring, VrmVersion,
};
use bevy_cartoon_hair::sim::{
    HairBoneChains, HairCollider, HairSimSettings, HairSimulationPlugin, vrm_sim_settings,
};
use bevy_cartoon_hair::{HairSchedulePlugin, HairSystems};
use criterion::{Criterion, criterion_group, criterion_main};

#[path = "chains_baselines/bevy_vrm1.rs"]
mod vrm1_baseline;

const CHARACTERS: usize = 16;
/// A hundred avatars, the crowd a game with many VRM characters has.
const CROWD: usize = 100;
const CHAINS: usize = 40;
const JOINTS: usize = 6;
const SEGMENT: f32 = 0.03;
const HEAD: Vec3 = Vec3::new(0.0, 1.6, 0.0);

/// Joint `k` of chain `c`, in its parent's frame (joint 0 in the head's): root on the upper
/// half of a head of radius 0.11, then straight out and down.
fn joint_local(c: usize, k: usize) -> Vec3 {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let y = 1.0 - (c as f32 + 0.5) / CHAINS as f32 * 0.6;
    let r = (1.0 - y * y).sqrt();
    let a = golden * c as f32;
    let n = Vec3::new(r * a.cos(), y, r * a.sin());
    if k == 0 {
        n * 0.11
    } else {
        (Vec3::new(n.x, -1.5, n.z)).normalize() * SEGMENT
    }
}

/// The body's colliders, in the head's frame.
fn body() -> (Vec<CollisionSphere>, Vec<CollisionCapsule>) {
    let spheres = vec![CollisionSphere {
        center: Vec3::ZERO,
        radius: 0.1,
    }];
    let capsule = |a: Vec3, b: Vec3| CollisionCapsule { a, b, radius: 0.05 };
    let capsules = vec![
        capsule(Vec3::new(0.0, -0.05, 0.0), Vec3::new(0.0, -0.2, 0.0)),
        capsule(Vec3::new(0.05, -0.22, 0.0), Vec3::new(0.2, -0.25, 0.0)),
        capsule(Vec3::new(-0.05, -0.22, 0.0), Vec3::new(-0.2, -0.25, 0.0)),
    ];
    (spheres, capsules)
}

fn shake(t: f32) -> Quat {
    Quat::from_rotation_y(1.2 * (6.0 * t).sin()) * Quat::from_rotation_x(0.3 * (4.0 * t).sin())
}

// ---------------------------------------------------------------------------------------------
// Ours: the plugin in a headless app.

fn our_app(
    characters: usize,
    fps: f64,
    chains: Option<&HairSimSettings>,
) -> (App, Vec<Entity>, Vec<Vec<Entity>>) {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(bevy_cartoon_hair::compute_on_every_core()),
        TransformPlugin,
        AssetPlugin::default(),
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / fps,
    )));
    let (spheres, capsules) = body();
    let mut roots = Vec::new();
    let mut tips = Vec::new();
    for i in 0..characters {
        let world = app.world_mut();
        let root = world
            .spawn(Transform::from_xyz(i as f32 * 1.0, 0.0, 0.0))
            .id();
        let head = world
            .spawn((
                Name::new("head"),
                Transform::from_translation(HEAD),
                ChildOf(root),
            ))
            .id();
        world.spawn((
            HairCollider {
                spheres: spheres.clone(),
                capsules: capsules.clone(),
                ..default()
            },
            ChildOf(head),
        ));
        for c in 0..CHAINS {
            let mut parent = head;
            for k in 0..JOINTS {
                parent = world
                    .spawn((
                        Name::new(format!("hair_{c}_{k}")),
                        Transform::from_translation(joint_local(c, k)),
                        ChildOf(parent),
                    ))
                    .id();
            }
            if i == 0 {
                tips.push(parent);
            }
        }
        if let Some(settings) = chains {
            world.spawn((
                HairBoneChains::matching(root, |n| n.starts_with("hair_")),
                settings.clone(),
            ));
        }
        roots.push(root);
    }
    app.update();
    app.update();
    (app, roots, vec![tips])
}

// ---------------------------------------------------------------------------------------------
// The baseline: VRM 1.0's spring-bone step, as the specification and its reference
// implementations write it (inertia not scaled by the time step).

/// VRM joint parameters: the defaults of the specification's examples.
const STIFFNESS: f32 = 1.0;
const DRAG: f32 = 0.4;
const GRAVITY_POWER: f32 = 1.0;
const HIT_RADIUS: f32 = 0.01;

/// Our settings for a VRM 1.0 spring whose joints all have the reference step's parameters, as
/// the crate's VRM import maps them (bones of `SEGMENT` metres).
fn vrm_mapped_settings() -> HairSimSettings {
    let joint = VrmJoint {
        hit_radius: HIT_RADIUS,
        stiffness: STIFFNESS,
        gravity_power: GRAVITY_POWER,
        gravity_dir: Vec3::NEG_Y,
        drag_force: DRAG,
        limit: None,
    };
    let spring = VrmSpring {
        name: String::new(),
        nodes: (0..=JOINTS as u32).collect(),
        joints: vec![joint; JOINTS + 1],
        groups: Vec::new(),
        center: None,
    };
    vrm_sim_settings(&spring, VrmVersion::V1, SEGMENT)
}

struct VrmChain {
    /// Each joint's local translation and bind rotation (joint 0 in the head's frame).
    local: Vec<(Vec3, Quat)>,
    /// Each joint's tail now and a step ago, in world space.
    current: Vec<Vec3>,
    previous: Vec<Vec3>,
}

struct VrmCrowd {
    chains: Vec<Vec<VrmChain>>,
    spheres: Vec<CollisionSphere>,
    capsules: Vec<CollisionCapsule>,
}

impl VrmCrowd {
    fn new(characters: usize) -> Self {
        let (spheres, capsules) = body();
        let mut crowd = Self {
            chains: Vec::new(),
            spheres,
            capsules,
        };
        for i in 0..characters {
            let head = head_world(i, Quat::IDENTITY);
            let chains = (0..CHAINS)
                .map(|c| {
                    // The joints and one more (the tail) continuing the last bone.
                    let mut local: Vec<(Vec3, Quat)> = (0..JOINTS)
                        .map(|k| (joint_local(c, k), Quat::IDENTITY))
                        .collect();
                    local.push((joint_local(c, JOINTS - 1), Quat::IDENTITY));
                    let mut world = head;
                    let mut tails = Vec::new();
                    for (t, r) in &local {
                        world *= Affine3A::from_rotation_translation(*r, *t);
                        tails.push(Vec3::from(world.translation));
                    }
                    let tails = tails[1..].to_vec();
                    VrmChain {
                        local,
                        current: tails.clone(),
                        previous: tails,
                    }
                })
                .collect();
            crowd.chains.push(chains);
        }
        crowd
    }

    /// One frame of `dt` seconds with the heads at `rotation`.
    fn step(&mut self, rotation: Quat, dt: f32) {
        for (i, chains) in self.chains.iter_mut().enumerate() {
            let head = head_world(i, rotation);
            let spheres: Vec<(Vec3, f32)> = self
                .spheres
                .iter()
                .map(|s| (head.transform_point3(s.center), s.radius))
                .collect();
            let capsules: Vec<(Vec3, Vec3, f32)> = self
                .capsules
                .iter()
                .map(|c| {
                    (
                        head.transform_point3(c.a),
                        head.transform_point3(c.b),
                        c.radius,
                    )
                })
                .collect();
            for chain in chains.iter_mut() {
                let mut parent = head;
                for k in 0..JOINTS {
                    let (t, r) = chain.local[k];
                    let (_, parent_rotation, _) = parent.to_scale_rotation_translation();
                    let origin = parent.transform_point3(t);
                    let child = chain.local[k + 1].0;
                    let length = child.length();
                    let axis = child / length;
                    let rest_direction = parent_rotation * r * axis;
                    let inertia = (chain.current[k] - chain.previous[k]) * (1.0 - DRAG);
                    let mut next = chain.current[k]
                        + inertia
                        + rest_direction * (STIFFNESS * dt)
                        + Vec3::NEG_Y * (GRAVITY_POWER * dt);
                    next = origin + (next - origin).normalize_or(rest_direction) * length;
                    for &(c, radius) in &spheres {
                        let d = next - c;
                        let reach = radius + HIT_RADIUS;
                        if d.length_squared() < reach * reach {
                            next = c + d.normalize_or(Vec3::Y) * reach;
                            next = origin + (next - origin).normalize_or(rest_direction) * length;
                        }
                    }
                    for &(a, b, radius) in &capsules {
                        let ab = b - a;
                        let s = ((next - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                        let closest = a + ab * s;
                        let d = next - closest;
                        let reach = radius + HIT_RADIUS;
                        if d.length_squared() < reach * reach {
                            next = closest + d.normalize_or(Vec3::Y) * reach;
                            next = origin + (next - origin).normalize_or(rest_direction) * length;
                        }
                    }
                    chain.previous[k] = chain.current[k];
                    chain.current[k] = next;
                    let turn = Quat::from_rotation_arc(rest_direction, (next - origin) / length);
                    let rotation = (turn * parent_rotation * r).normalize();
                    parent = Affine3A::from_rotation_translation(rotation, origin);
                }
            }
        }
    }
}

/// When the hair's stages began in this frame, and the time spent in them since the last read.
#[derive(Resource, Default)]
struct StageClock {
    began: Option<Instant>,
    spent: Duration,
}

/// Times the hair's stages inside each frame of `app`: from the end of Bevy's transform
/// propagation (which they wait for) to the end of the simulation stage.
fn time_hair_stages(app: &mut App) {
    let begin = |mut clock: ResMut<StageClock>| clock.began = Some(Instant::now());
    let end = |mut clock: ResMut<StageClock>| {
        if let Some(began) = clock.began.take() {
            clock.spent += began.elapsed();
        }
    };
    app.init_resource::<StageClock>().add_systems(
        PostUpdate,
        (
            begin
                .after(TransformSystems::Propagate)
                .before(HairSystems::Attach),
            end.after(HairSystems::Simulate),
        ),
    );
}

fn head_world(i: usize, rotation: Quat) -> Affine3A {
    Affine3A::from_rotation_translation(rotation, Vec3::new(i as f32 * 1.0, 0.0, 0.0))
        * Affine3A::from_translation(HEAD)
}

// ---------------------------------------------------------------------------------------------
// Frame-rate dependence: the same second of shaking at 30 and 144 fps.

/// Samples a second of shaking is compared at: every sixth of a second (a whole number of
/// frames at both 30 and 144 fps).
const SAMPLES: u32 = 6;

/// A second of shaking character 0 of `app` (its root `root`) at `fps`: `sample(app, head
/// rotation)` every sixth of a second.
fn shaken_second(
    app: &mut App,
    root: Entity,
    fps: f64,
    mut sample: impl FnMut(&mut App, Quat) -> Vec<Vec3>,
) -> Vec<Vec<Vec3>> {
    let frames = fps.round() as u32;
    let mut samples = Vec::new();
    for f in 0..frames {
        let t = (f + 1) as f32 / fps as f32;
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(t);
        app.update();
        if (f + 1) % (frames / SAMPLES) == 0 {
            samples.push(sample(app, shake(t)));
        }
    }
    samples
}

/// The last joints of character 0's chains, in the head's frame, every sixth of a second of
/// shaking at `fps`.
fn our_tips_after_shaking(fps: f64, settings: &HairSimSettings) -> Vec<Vec<Vec3>> {
    let (mut app, roots, tips) = our_app(1, fps, Some(settings));
    shaken_second(&mut app, roots[0], fps, |app, rotation| {
        let to_head = head_world(0, rotation).inverse();
        // The tail particle is not a joint: compare the last joints.
        tips[0]
            .iter()
            .map(|e| {
                let world = app.world().get::<GlobalTransform>(*e).unwrap();
                to_head.transform_point3(world.translation())
            })
            .collect()
    })
}

/// As [`our_tips_after_shaking`], for the VRM reference step.
fn vrm_tips_after_shaking(fps: f64) -> Vec<Vec<Vec3>> {
    let mut crowd = VrmCrowd::new(1);
    let frames = fps.round() as u32;
    let mut samples = Vec::new();
    for f in 0..frames {
        let t = (f + 1) as f32 / fps as f32;
        crowd.step(shake(t), 1.0 / fps as f32);
        if (f + 1) % (frames / SAMPLES) != 0 {
            continue;
        }
        let to_head = head_world(0, shake(t)).inverse();
        // Tail k is joint k + 1: the last joint is tail JOINTS - 2.
        samples.push(
            crowd.chains[0]
                .iter()
                .map(|c| to_head.transform_point3(c.current[JOINTS - 2]))
                .collect(),
        );
    }
    samples
}

/// How far apart the same joints are in two runs: at the last sample, the farthest; over every
/// sample, the mean and the farthest (metres). The motion is chaotic (a shaken chain hitting
/// colliders), so one joint at one instant moves with rounding; the mean over the second does
/// not.
fn apart(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> (f32, f32, f32) {
    let distances = |i: usize| a[i].iter().zip(&b[i]).map(|(p, q)| p.distance(*q));
    let last = distances(a.len() - 1).fold(0.0, f32::max);
    let all: Vec<f32> = (0..a.len()).flat_map(distances).collect();
    let mean = all.iter().sum::<f32>() / all.len() as f32;
    (last, mean, all.iter().copied().fold(0.0, f32::max))
}

/// bevy_vrm1's last joints of character 0 (those whose child is the tail), in the frame of the
/// head turned by `rotation`, in the order the chains were spawned.
fn vrm1_last_joints(app: &mut App, rotation: Quat) -> Vec<Vec3> {
    let to_head = head_world(0, rotation).inverse();
    let mut query = app.world_mut().query_filtered::<(
        Entity,
        &GlobalTransform,
        &Children,
    ), With<bevy_vrm1::vrm::spring_bone::SpringJointProps>>();
    let world = app.world();
    let mut last: Vec<(Entity, Vec3)> = query
        .iter(world)
        .filter(|(_, _, children)| children.iter().all(|c| world.get::<Children>(c).is_none()))
        .map(|(e, g, _)| (e, to_head.transform_point3(g.translation())))
        .collect();
    last.sort_by_key(|(e, _)| *e);
    assert_eq!(last.len(), CHAINS, "one last joint a chain");
    last.into_iter().map(|(_, p)| p).collect()
}

/// As [`our_tips_after_shaking`], for bevy_vrm1's spring system; and where the same joints hung
/// before the shaking.
fn vrm1_tips_after_shaking(fps: f64) -> (Vec<Vec3>, Vec<Vec<Vec3>>) {
    let (mut app, roots) = vrm1_baseline::app(1, fps);
    let hung = vrm1_last_joints(&mut app, Quat::IDENTITY);
    (
        hung,
        shaken_second(&mut app, roots[0], fps, vrm1_last_joints),
    )
}

/// The next 60 Hz frame of `app`: every character's root turned by the shake, then an update.
fn shaken_frame(app: &mut App, roots: &[Entity], frame: &mut u32) {
    *frame += 1;
    let r = shake(*frame as f32 / 60.0);
    for root in roots {
        app.world_mut()
            .get_mut::<Transform>(*root)
            .unwrap()
            .rotation = r;
    }
    app.update();
}

/// The machine's CPU time so far, in clock ticks: all of it, and the share the hypervisor gave
/// to other guests while this one had work ("steal", the eighth number of `/proc/stat`'s `cpu`
/// line). `None` where there is no such file.
fn cpu_ticks() -> Option<(u64, u64)> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let line = stat.lines().find(|l| l.starts_with("cpu "))?;
    let ticks: Vec<u64> = line
        .split_whitespace()
        .skip(1)
        .map(|n| n.parse().ok())
        .collect::<Option<_>>()?;
    Some((ticks.iter().take(8).sum(), *ticks.get(7)?))
}

/// The share of the machine's CPU time stolen by the hypervisor between two [`cpu_ticks`], or
/// NaN where unknown.
fn stolen(from: Option<(u64, u64)>, to: Option<(u64, u64)>) -> f64 {
    match (from, to) {
        (Some((all0, steal0)), Some((all1, steal1))) if all1 > all0 => {
            steal1.saturating_sub(steal0) as f64 / (all1 - all0) as f64
        }
        _ => f64::NAN,
    }
}

/// The median of `values`.
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Ours (the hair's stages of a frame) and the reference step, `ROUNDS` rounds of `FRAMES`
/// frames of each, one after the other: both meet the machine in the same state, so their
/// ratio holds where the machine's speed drifts between runs (criterion's figures for the two
/// are taken seconds apart). Each round begins with caches the other filled and threads asleep,
/// as a game's frame may after its other work (not measured in a game). Per frame: our median,
/// the reference's median, the median of the rounds' ratios, and the share of the machine's
/// time its hypervisor stole meanwhile (a cloud machine's neighbours: the hair's stages wait on
/// both cores, the reference on one, so steal slows ours more).
fn interleaved(characters: usize, settings: &HairSimSettings) -> (f64, f64, f64, f64) {
    const ROUNDS: usize = 8;
    const FRAMES: u32 = 200;
    let (mut app, roots, _) = our_app(characters, 60.0, Some(settings));
    time_hair_stages(&mut app);
    let mut crowd = VrmCrowd::new(characters);
    let (mut frame, mut reference_frame) = (0u32, 0u32);
    let mut reference = |frames: u32| {
        for _ in 0..frames {
            reference_frame += 1;
            crowd.step(shake(reference_frame as f32 / 60.0), 1.0 / 60.0);
        }
    };
    // Both warmed up first.
    for _ in 0..FRAMES {
        shaken_frame(&mut app, &roots, &mut frame);
    }
    reference(FRAMES);
    let (mut ours, mut theirs, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let ticks = cpu_ticks();
    for _ in 0..ROUNDS {
        app.world_mut().resource_mut::<StageClock>().spent = Duration::ZERO;
        for _ in 0..FRAMES {
            shaken_frame(&mut app, &roots, &mut frame);
        }
        let our = app.world().resource::<StageClock>().spent.as_secs_f64() / f64::from(FRAMES);
        let start = Instant::now();
        reference(FRAMES);
        let their = start.elapsed().as_secs_f64() / f64::from(FRAMES);
        ours.push(our);
        theirs.push(their);
        ratios.push(our / their);
    }
    let steal = stolen(ticks, cpu_ticks());
    (median(ours), median(theirs), median(ratios), steal)
}

fn bench_chains(c: &mut Criterion) {
    let defaults = HairSimSettings::default();
    let mapped = vrm_mapped_settings();
    let ours = |settings| {
        apart(
            &our_tips_after_shaking(30.0, settings),
            &our_tips_after_shaking(144.0, settings),
        )
    };
    let vrm = apart(
        &vrm_tips_after_shaking(30.0),
        &vrm_tips_after_shaking(144.0),
    );
    for (name, (last, mean, most)) in [
        ("ours (default settings)", ours(&defaults)),
        (
            "ours (the reference's joint parameters, mapped)",
            ours(&mapped),
        ),
        ("the VRM reference step", vrm),
    ] {
        println!(
            "head shaking at 30 fps vs 144 fps, last joints apart, {name}: after 1 s {:.1} mm \
             at most; over the second (every 1/6 s, 40 chains) {:.1} mm on average, {:.1} mm at \
             most",
            last * 1000.0,
            mean * 1000.0,
            most * 1000.0
        );
    }
    // bevy_vrm1's system must really move its chains, or its timing means nothing.
    let (hung, at_30) = vrm1_tips_after_shaking(30.0);
    let (_, at_144) = vrm1_tips_after_shaking(144.0);
    let end = &at_144[at_144.len() - 1];
    let moved = hung
        .iter()
        .zip(end)
        .map(|(a, b)| a.distance(*b))
        .sum::<f32>()
        / CHAINS as f32;
    let (last, mean, most) = apart(&at_30, &at_144);
    println!(
        "head shaking at 30 fps vs 144 fps, last joints apart, bevy_vrm1 0.11's spring system: \
         after 1 s {:.1} mm at most; over the second {:.1} mm on average, {:.1} mm at most (its \
         last joints moved {:.1} mm on average from where they hung)",
        last * 1000.0,
        mean * 1000.0,
        most * 1000.0,
        moved * 1000.0
    );
    assert!(
        moved.is_finite() && moved > 0.005,
        "bevy_vrm1's spring system did not move its chains ({moved} m): its timing would be \
         of an idle app"
    );
    for characters in [CHARACTERS, CROWD] {
        let (ours, reference, ratio, steal) = interleaved(characters, &defaults);
        println!(
            "{characters} x {CHAINS} x {JOINTS}, 8 rounds of 200 frames of each, taken in \
             turns: the hair's stages {:.3} ms a frame, the VRM reference step {:.3} ms (medians); \
             ours / reference {ratio:.3} (median of the rounds); CPU time stolen by the \
             hypervisor meanwhile {:.1}%",
            ours * 1000.0,
            reference * 1000.0,
            steal * 100.0
        );
    }
    let mut group = c.benchmark_group("chains");
    group.sample_size(30);
    // The crowd the benches are named for, and a hundred avatars.
    for characters in [CHARACTERS, CROWD] {
        // Ours, and the same app and bones without the chains: Bevy's own frame (transform
        // propagation of the moving characters), which any game with these bones pays.
        for (name, chains) in [("ours", Some(&defaults)), ("bones_only", None)] {
            let (mut app, roots, _) = our_app(characters, 60.0, chains);
            let mut frame = 0u32;
            group.bench_function(format!("{name}_{characters}x40x6"), |b| {
                b.iter(|| shaken_frame(&mut app, &roots, &mut frame));
            });
        }
        // The same crowd on bevy_vrm1's spring system.
        let (mut app, roots) = vrm1_baseline::app(characters, 60.0);
        let mut frame = 0u32;
        group.bench_function(format!("bevy_vrm1_{characters}x40x6"), |b| {
            b.iter(|| shaken_frame(&mut app, &roots, &mut frame));
        });
        // Ours again, timing only the hair's stages of each frame.
        let (mut app, roots, _) = our_app(characters, 60.0, Some(&defaults));
        time_hair_stages(&mut app);
        let mut frame = 0u32;
        group.bench_function(format!("hair_stages_{characters}x40x6"), |b| {
            b.iter_custom(|iterations| {
                app.world_mut().resource_mut::<StageClock>().spent = Duration::ZERO;
                for _ in 0..iterations {
                    shaken_frame(&mut app, &roots, &mut frame);
                }
                app.world().resource::<StageClock>().spent
            });
        });
        let mut crowd = VrmCrowd::new(characters);
        let mut frame = 0u32;
        group.bench_function(format!("vrm_reference_{characters}x40x6"), |b| {
            b.iter(|| {
                frame += 1;
                crowd.step(shake(frame as f32 / 60.0), 1.0 / 60.0);
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_chains);
criterion_main!(benches);
