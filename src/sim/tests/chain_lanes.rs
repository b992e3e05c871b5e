//! Chains posed side by side in the solver's lanes come out as each chain posed alone.

use bevy::prelude::*;

use std::cell::RefCell;

use super::super::chain_lanes::ParticleBox;
use super::super::chain_pose::{PosedBothWays, poses_both_ways};
use super::super::solver::{Batch, LANES};
use super::*;
use crate::asset::{JointLimit, JointLimitShape};

/// Joint `k` of chain `c` in its parent's frame: roots spread over the top of the head, then
/// bones out and down, a little turned.
fn offset(c: usize, k: usize) -> Vec3 {
    let a = c as f32 * 2.4;
    if k == 0 {
        Vec3::new(0.09 * a.cos(), 0.06, 0.09 * a.sin())
    } else {
        Vec3::new(0.012 * a.cos(), -0.03, 0.012 * a.sin())
    }
}

/// A character whose head carries, under one [`HairBoneChains`] each:
/// - 11 chains of 5 bones and 3 of 3 found by name (a full batch, a part-filled one, another
///   length), one with a stretched joint;
/// - 9 chains of 4 listed joint by joint, the last joint a tail (as VRM's), with cone, hinge and
///   spherical limits on some joints;
///
/// and a sphere in the head close enough that shaking throws the chains onto it. Lengths are in
/// the rig's units, `unit` metres each (the root scaled by `unit`). Returns the app, the root,
/// the joints of the named chains.
fn lanes_app(unit: f32) -> (App, Entity, Vec<Vec<Entity>>) {
    let mut app = event_app();
    let (root, head) = character(
        &mut app,
        Transform::from_scale(Vec3::splat(unit)),
        Vec3::new(0.0, 1.6 / unit, 0.0),
    );
    let world = app.world_mut();
    let spawn_chain = |world: &mut World, name: &str, c: usize, bones: usize| {
        let mut parent = head;
        let mut joints = Vec::new();
        for k in 0..bones {
            let mut t = Transform::from_translation(offset(c, k) / unit)
                .with_rotation(Quat::from_rotation_z(0.2 * k as f32 - 0.3));
            if name == "hair" && c == 4 && k == 2 {
                t.scale = Vec3::new(1.0, 1.3, 1.0);
            }
            parent = world
                .spawn((Name::new(format!("{name}_{c}_{k}")), t, ChildOf(parent)))
                .id();
            joints.push(parent);
        }
        joints
    };
    let named: Vec<Vec<Entity>> = (0..14)
        .map(|c| spawn_chain(world, "hair", c, if c < 11 { 5 } else { 3 }))
        .collect();
    let listed: Vec<Vec<Entity>> = (14..23)
        .map(|c| spawn_chain(world, "spring", c, 4))
        .collect();
    let shapes = [
        JointLimitShape::Cone { angle: 0.4 },
        JointLimitShape::Hinge { angle: 0.5 },
        JointLimitShape::Spherical {
            pitch: 0.6,
            yaw: 0.3,
        },
    ];
    let limits = listed
        .iter()
        .enumerate()
        .filter(|(c, _)| c % 2 == 0)
        .flat_map(|(c, joints)| {
            joints[..2].iter().map(move |&j| {
                (
                    j,
                    JointLimit {
                        shape: shapes[c % 3],
                        rotation: Quat::from_rotation_x(0.2),
                    },
                )
            })
        })
        .collect();
    world.spawn((
        HairBoneChains::matching(root, |n| n.starts_with("hair_")),
        HairSimSettings::default(),
    ));
    world.spawn((
        HairBoneChains {
            root,
            select: ChainSelect::Joints(listed),
            tail: 1.0,
        },
        ChainJointLimits(limits),
        HairSimSettings::default(),
    ));
    world.spawn((
        HairCollider {
            spheres: vec![crate::asset::CollisionSphere {
                center: Vec3::new(0.0, -0.02 / unit, 0.0),
                radius: 0.1 / unit,
            }],
            ..default()
        },
        ChildOf(head),
    ));
    (app, root, named)
}

/// Two ways of posing gave the same poses and particles, bit for bit (NaN included).
fn assert_same_bits(a: &PosedBothWays, b: &PosedBothWays) {
    let pose_bits = |p: &PosedBothWays| -> Vec<(Entity, Vec<u32>)> {
        p.0.iter()
            .map(|(e, q, w)| {
                let (q, w) = (q.to_array(), w.to_cols_array());
                (*e, q.iter().chain(&w).map(|v| v.to_bits()).collect())
            })
            .collect()
    };
    let particle_bits = |p: &PosedBothWays| -> Vec<[u32; 3]> {
        p.1.iter().map(|v| v.to_array().map(f32::to_bits)).collect()
    };
    assert_eq!(a.2, b.2, "as many joints in lanes");
    assert!(pose_bits(a) == pose_bits(b), "the same poses, bit for bit");
    assert!(
        particle_bits(a) == particle_bits(b),
        "the same particles, bit for bit"
    );
}

/// The farthest apart two hairs' poses and particles are: (rotation, world transform, particle).
fn apart(a: &PosedBothWays, b: &PosedBothWays) -> (f32, f32, f32) {
    assert_eq!(a.0.len(), b.0.len());
    assert_eq!(a.1.len(), b.1.len());
    let (mut rotation, mut world) = (0.0f32, 0.0f32);
    for ((ea, qa, wa), (eb, qb, wb)) in a.0.iter().zip(&b.0) {
        assert_eq!(ea, eb, "the same joint in the same slot");
        // q and -q are the same turn.
        let q = if qa.dot(*qb) < 0.0 { -*qb } else { *qb };
        rotation = rotation.max((*qa - q).length());
        let (ma, mb) = (wa.to_cols_array(), wb.to_cols_array());
        world = ma
            .iter()
            .zip(&mb)
            .map(|(x, y)| (x - y).abs())
            .fold(world, f32::max);
    }
    let particle =
        a.1.iter()
            .zip(&b.1)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0, f32::max);
    (rotation, world, particle)
}

#[test]
fn chains_posed_in_lanes_match_each_chain_posed_alone() {
    // A rig in metres, and one in centimetres (Mixamo's 0.01).
    for unit in [1.0, 0.01] {
        lanes_posed_as_alone(unit);
    }
}

fn lanes_posed_as_alone(unit: f32) {
    let (mut app, root, named) = lanes_app(unit);
    let mut hairs = Vec::new();
    let (mut in_lanes, mut joints, mut moved) = (0, 0, 0usize);
    let mut vector_checked = 0;
    let mut worst = (0.0f32, 0.0f32, 0.0f32);
    let mut compare = |app: &mut App, tamper: &dyn Fn(&mut ComputedHair)| {
        let mut q = app.world_mut().query::<(Entity, &BoneChainHair)>();
        let found: Vec<Entity> = q.iter(app.world()).map(|(e, _)| e).collect();
        for hair in found {
            // The lanes on the portable kernels and (where the CPU has it) on AVX2: the same
            // bits.
            let world = RefCell::new(app.world_mut());
            let (portable, vector) = crate::simd::on_both_paths(|| {
                let [lanes, _] = poses_both_ways(&mut world.borrow_mut(), hair, tamper);
                lanes
            });
            if let Some(vector) = vector {
                assert_same_bits(&portable, &vector);
                vector_checked += 1;
            }
            let [lanes, alone] = poses_both_ways(app.world_mut(), hair, tamper);
            assert_same_bits(&portable, &lanes);
            assert_eq!(alone.2, 0, "posed alone, no joint is in lanes");
            let (r, w, p) = apart(&lanes, &alone);
            worst = (worst.0.max(r), worst.1.max(w), worst.2.max(p));
            in_lanes += lanes.2;
            joints += lanes.0.len();
            // Posing moved particles (off the sphere, into a limit): both ways alike.
            let before = app.world().get::<ComputedHair>(hair).unwrap();
            moved += (0..before.lane_of.len())
                .flat_map(|s| (0..before.particle_count(s)).map(move |i| (s, i)))
                .zip(&lanes.1)
                .filter(|((s, i), p)| before.particle(*s, *i).distance(**p) > 1e-6)
                .count();
            if !hairs.contains(&hair) {
                hairs.push(hair);
            }
        }
    };
    for f in 0..90 {
        let t = (f + 1) as f32 / 60.0;
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation =
            Quat::from_rotation_y(1.4 * (6.0 * t).sin())
                * Quat::from_rotation_x(0.6 * (4.0 * t).sin());
        app.update();
        if f >= 5 {
            compare(&mut app, &|_| {});
        }
    }
    // A chain whose particles stopped being finite follows its bind pose, both ways.
    compare(&mut app, &|c: &mut ComputedHair| {
        c.set_particle(1, 2, Vec3::NAN);
        c.set_particle(9, 0, Vec3::new(f32::INFINITY, 0.0, 0.0));
    });
    // A joint that lost its transform ends its chain's posing there, both ways.
    app.world_mut()
        .entity_mut(named[6][3])
        .remove::<Transform>();
    compare(&mut app, &|_| {});
    assert_eq!(
        hairs.len(),
        2,
        "one hair per chains entity, both on the head"
    );
    // The joints the app wrote this frame are the poses worked out alone from the same state.
    let written = |app: &mut App| {
        let mut q = app.world_mut().query::<(Entity, &BoneChainHair)>();
        let found: Vec<Entity> = q.iter(app.world()).map(|(e, _)| e).collect();
        let mut farthest = 0.0f32;
        for hair in found {
            let [_, alone] = poses_both_ways(app.world_mut(), hair, |_| {});
            for (joint, _, world) in alone.0 {
                let Some(g) = app.world().get::<GlobalTransform>(joint) else {
                    continue;
                };
                let (a, b) = (g.affine().to_cols_array(), world.to_cols_array());
                farthest = a
                    .iter()
                    .zip(&b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(farthest, f32::max);
            }
        }
        farthest
    };
    let before = written(&mut app);
    // The game moves a joint and scales another: posing reads them again.
    let mut moved_joint = app.world_mut().get_mut::<Transform>(named[3][2]).unwrap();
    moved_joint.translation.x += 0.02 / unit;
    app.world_mut()
        .get_mut::<Transform>(named[12][0])
        .unwrap()
        .scale = Vec3::splat(1.5);
    app.update();
    let after = written(&mut app);
    println!(
        "unit {unit} m: written against posed alone: {before:e} before, {after:e} after the game's \
         change"
    );
    assert!(
        before < 1e-4 && after < 1e-4,
        "the app's poses are those worked out alone: {before}, {after}"
    );
    // The same on the other hair, whose joints all have transforms (the first one's joint
    // without a transform makes it read its joints every frame): both hairs are posed and
    // written by the step's threads, which must find the joints the game changed.
    let joint = |app: &mut App, name: &str| {
        let mut q = app.world_mut().query::<(Entity, &Name)>();
        q.iter(app.world())
            .find(|(_, n)| n.as_str() == name)
            .map(|(e, _)| e)
            .unwrap()
    };
    let (shifted, scaled) = (
        joint(&mut app, "spring_15_1"),
        joint(&mut app, "spring_18_0"),
    );
    app.world_mut()
        .get_mut::<Transform>(shifted)
        .unwrap()
        .translation
        .z -= 0.015 / unit;
    app.world_mut().get_mut::<Transform>(scaled).unwrap().scale = Vec3::splat(0.7);
    app.update();
    let later = written(&mut app);
    println!("unit {unit} m: after the game's change to the other hair: {later:e}");
    assert!(
        later < 1e-4,
        "the app's poses follow the game's change to a joint of a hair posed by the step: {later}"
    );
    println!(
        "unit {unit} m: {in_lanes} of {joints} joints posed in lanes; {moved} particles moved by \
         posing; apart at most: rotation {:e}, world transform {:e}, particle {:e} m",
        worst.0, worst.1, worst.2
    );
    if crate::simd::avx2() {
        assert!(vector_checked > 0, "the AVX2 lanes were compared");
    }
    assert!(
        in_lanes * 10 > joints * 6,
        "most joints are posed in lanes ({in_lanes} of {joints})"
    );
    assert!(
        moved > 0,
        "the shake must throw chains onto the sphere or a limit"
    );
    assert!(
        worst.0 < 2e-5 && worst.1 < 2e-5 && worst.2 < 2e-5,
        "the lanes pose as posing alone: {worst:?}"
    );
}

/// The box of a batch's finite particles and its longest segment, particle by particle: what
/// [`ParticleBox::of`] works out over the lanes.
fn box_one_by_one(batches: &[Batch]) -> ParticleBox {
    let mut found = ParticleBox::EMPTY;
    for b in batches {
        for l in 0..b.count.min(LANES) {
            let mut before: Option<Vec3> = None;
            for i in 0..b.nodes.len() / 2 {
                let p = b.particle(l, i);
                if !p.is_finite() {
                    before = None;
                    continue;
                }
                found.min = found.min.min(p.into());
                found.max = found.max.max(p.into());
                if let Some(q) = before {
                    found.longest_sq = found.longest_sq.max(p.distance_squared(q));
                }
                before = Some(p);
            }
        }
    }
    found
}

#[test]
fn the_particle_box_skips_what_is_not_finite_on_both_paths() {
    let (mut app, _, _) = lanes_app(1.0);
    app.update();
    let mut q = app.world_mut().query::<&ComputedHair>();
    let mut batches: Vec<Batch> = q
        .iter(app.world())
        .flat_map(|c| c.batches.clone())
        .collect();
    assert!(batches.len() >= 3, "several batches, one part-filled");
    // A NaN, an infinity, and a far point in a lane past the batch's count (not a strand).
    batches[0].set_particle(1, 2, Vec3::NAN);
    batches[1].set_particle(0, 0, Vec3::new(f32::INFINITY, 0.0, 0.0));
    let part = batches.iter_mut().find(|b| b.count < LANES).unwrap();
    part.set_particle(LANES - 1, 1, Vec3::splat(1e6));
    let want = box_one_by_one(&batches);
    assert!(
        want.max.max_element() < 100.0,
        "the unused lane is not in the box"
    );
    let (portable, vector) = crate::simd::on_both_paths(|| ParticleBox::of(&batches));
    assert_eq!(portable, want);
    if let Some(vector) = vector {
        assert_eq!(vector, want);
    }
    // Nothing finite: an empty box.
    for b in &mut batches {
        for l in 0..LANES {
            for i in 0..b.nodes.len() / 2 {
                b.set_particle(l, i, Vec3::NAN);
            }
        }
    }
    assert_eq!(ParticleBox::of(&batches), ParticleBox::EMPTY);
}

#[test]
fn the_step_measures_the_box_posing_gathers_colliders_by() {
    /// Hairs seen after the step: with the box measured, without, and measured and compared.
    #[derive(Resource, Default)]
    struct Seen(usize, usize, usize);
    let (mut app, root, _) = lanes_app(1.0);
    app.init_resource::<Seen>().add_systems(
        PostUpdate,
        (|hairs: Query<(&ComputedHair, &HairSimSettings, &BoneChainHair)>,
          mut seen: ResMut<Seen>| {
            for (c, settings, driven) in &hairs {
                match c.particle_box {
                    Some(measured) => {
                        // Measured batch by batch after each step: as the step left them all.
                        // The step then poses the hair, which moves only the particles it keeps
                        // inside an angle limit (this app has no colliders): a hair without
                        // limits is still as the step left it.
                        if driven.limits.iter().flatten().all(Option::is_none) {
                            assert_eq!(measured, box_one_by_one(&c.batches));
                            seen.2 += 1;
                        }
                        assert!(settings.volume.is_none());
                        seen.0 += 1;
                    }
                    None => seen.1 += 1,
                }
            }
        })
        .after(super::super::step::step_hair_strands)
        .before(super::super::chain_pose::pose_bone_chains),
    );
    for f in 0..30 {
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation =
            Quat::from_rotation_y(1.4 * (f as f32 / 10.0).sin());
        app.update();
    }
    let seen = app.world().resource::<Seen>();
    assert!(
        seen.0 >= 2 * 28 && seen.2 >= 28,
        "both hairs measured every frame, the one without limits compared: {} {}",
        seen.0,
        seen.2
    );
    // A volume pass moves particles after the step: posing measures them itself then.
    let mut q = app
        .world_mut()
        .query_filtered::<&mut HairSimSettings, With<BoneChainHair>>();
    for mut s in q.iter_mut(app.world_mut()) {
        s.volume = Some(HairVolume::default());
    }
    *app.world_mut().resource_mut::<Seen>() = Seen::default();
    for _ in 0..3 {
        app.update();
    }
    let seen = app.world().resource::<Seen>();
    assert_eq!(
        (seen.0, seen.1),
        (0, 6),
        "no box measured with a volume pass"
    );
}
