//! Writing the frame out: each hair's strands written by the thread that stepped it, and by the
//! pass after the step when its strand list is not the strands as they were built.

use bevy::prelude::*;

use super::*;

/// Checks every strand of `hair` holds the particles its solver state holds now; returns how
/// many particles it compared.
fn particles_checked(app: &App, hair: Entity) -> usize {
    let world = app.world();
    let computed = world.get::<ComputedHair>(hair).unwrap();
    let mut checked = 0;
    for e in world.get::<HairStrands>(hair).unwrap().iter() {
        let s = world.get::<Strand>(e).unwrap().index as usize;
        let particles = &world.get::<StrandParticles>(e).unwrap().positions;
        assert_eq!(
            particles.len(),
            6,
            "strand {s} of {hair} has all its particles"
        );
        for (i, p) in particles.iter().enumerate() {
            assert_eq!(
                *p,
                computed.particle(s, i),
                "strand {s} particle {i} of {hair} is this frame's"
            );
            checked += 1;
        }
    }
    checked
}

fn written_early(app: &App, hair: Entity) -> bool {
    app.world()
        .get::<ComputedHair>(hair)
        .unwrap()
        .strands_written
}

#[test]
fn strands_are_written_by_their_hairs_thread_or_after_the_step() {
    let mut h = Harness::new(spiky_groom(12, 6), HairSimSettings::default(), 60.0);
    // A second hair on the same bone: beside another, each hair is stepped and written whole on
    // one thread (a hair alone shares its batches out over the threads).
    let groom = h.app.world().get::<Hair>(h.hair).unwrap().groom.clone();
    let other = h
        .app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings::default(),
            ChildOf(h.bone),
        ))
        .id();
    let shake = |h: &mut Harness, frames: std::ops::Range<i32>| {
        for f in frames {
            let mut bone = h.app.world_mut().get_mut::<Transform>(h.bone).unwrap();
            bone.translation.x = 0.2 * (f as f32 * 0.3).sin();
            bone.rotation = Quat::from_rotation_y(0.5 * (f as f32 * 0.2).sin());
            h.update();
        }
    };
    shake(&mut h, 0..20);
    for hair in [h.hair, other] {
        assert!(written_early(&h.app, hair), "{hair} written by the step");
        assert_eq!(particles_checked(&h.app, hair), 12 * 6);
    }
    // One strand of the first hair despawned: its list is no longer its strands as built, so
    // the step leaves them to the pass after it, which writes every one left, every frame.
    let gone = h
        .app
        .world()
        .get::<HairStrands>(h.hair)
        .unwrap()
        .iter()
        .next();
    h.app.world_mut().entity_mut(gone.unwrap()).despawn();
    shake(&mut h, 20..40);
    assert!(!written_early(&h.app, h.hair));
    assert!(written_early(&h.app, other));
    assert_eq!(particles_checked(&h.app, h.hair), 11 * 6);
    assert_eq!(particles_checked(&h.app, other), 12 * 6);
}

/// A character at `x` with two hair chains of four joints under its head (`lock_{c}_{k}`),
/// its lengths in units of `unit` metres (its root scaled by `unit`); returns its root and its
/// joints, chain by chain.
fn locked_character(app: &mut App, x: f32, unit: f32) -> (Entity, Vec<Entity>) {
    let root = Transform::from_xyz(x, 0.0, 0.0).with_scale(Vec3::splat(unit));
    let (root, head) = character(app, root, Vec3::Y * 1.6 / unit);
    let mut joints = Vec::new();
    for c in 0..2 {
        let mut parent = head;
        for k in 0..4 {
            let offset = if k == 0 {
                Vec3::new(0.06 - 0.12 * c as f32, 0.08, 0.02)
            } else {
                Vec3::new(0.005, -0.04, -0.01)
            };
            parent = app
                .world_mut()
                .spawn((
                    Name::new(format!("lock_{c}_{k}")),
                    Transform::from_translation(offset / unit),
                    ChildOf(parent),
                ))
                .id();
            joints.push(parent);
        }
    }
    (root, joints)
}

/// The hairs built on the bone chains of `set`.
fn hairs_of(app: &App, set: Entity) -> Vec<Entity> {
    app.world().get::<BoneChainHairs>(set).unwrap().0.clone()
}

/// Checks every joint of `hair` whose `ChainJoint` names it holds this frame's pose (world
/// transform and local rotation, to the bit); returns how many it compared.
fn joints_checked(app: &mut App, hair: Entity) -> usize {
    let posed = app
        .world()
        .get::<chain_pose::ChainPose>(hair)
        .unwrap()
        .posed()
        .to_vec();
    let mut checked = 0;
    for (slot, (joint, rotation, world)) in posed.into_iter().enumerate() {
        let Some(of) = app.world().get::<chain_pose::ChainJoint>(joint) else {
            continue;
        };
        if of.hair != hair || of.slot as usize != slot {
            continue;
        }
        let global = app.world().get::<GlobalTransform>(joint).unwrap().affine();
        assert_eq!(global, world, "joint {joint} of {hair}: this frame's pose");
        let local = app.world().get::<Transform>(joint).unwrap().rotation;
        assert_eq!(
            local, rotation,
            "joint {joint} of {hair}: this frame's rotation"
        );
        checked += 1;
    }
    checked
}

fn joints_written_early(app: &App, hair: Entity) -> bool {
    app.world()
        .get::<chain_pose::ChainPose>(hair)
        .unwrap()
        .joints_written
}

/// Turns every root in `roots` about its own vertical, frame by frame.
fn shake_roots(app: &mut App, roots: &[Entity], frames: std::ops::Range<i32>) {
    for f in frames {
        for &root in roots {
            let mut t = app.world_mut().get_mut::<Transform>(root).unwrap();
            t.rotation = Quat::from_rotation_y(0.8 * (f as f32 * 0.25).sin());
        }
        app.update();
    }
}

#[test]
fn joints_are_written_by_their_hairs_thread_or_after_the_step() {
    let mut app = event_app();
    // One rig in metres, one in centimetres.
    let (a_root, a_joints) = locked_character(&mut app, 0.0, 1.0);
    let (b_root, b_joints) = locked_character(&mut app, 1.0, 0.01);
    let sets: Vec<Entity> = [a_root, b_root]
        .into_iter()
        .map(|root| {
            app.world_mut()
                .spawn((
                    HairBoneChains::matching(root, |n| n.starts_with("lock_")),
                    HairSimSettings::default(),
                ))
                .id()
        })
        .collect();
    let roots = [a_root, b_root];
    shake_roots(&mut app, &roots, 0..20);
    let [a, b] = [hairs_of(&app, sets[0])[0], hairs_of(&app, sets[1])[0]];
    // Beside each other, each hair is stepped, posed and written on one thread.
    for hair in [a, b] {
        assert!(
            joints_written_early(&app, hair),
            "{hair} written by the step"
        );
        assert_eq!(joints_checked(&mut app, hair), 8);
    }
    // The joints really moved with the shaking, away from their bind pose.
    let tip = app.world().get::<GlobalTransform>(a_joints[3]).unwrap();
    let placed = app
        .world()
        .get::<GlobalTransform>(a_joints[2])
        .unwrap()
        .affine()
        * app
            .world()
            .get::<Transform>(a_joints[3])
            .unwrap()
            .compute_affine();
    assert!(
        tip.translation().distance(placed.translation.into()) < 1e-4,
        "a written joint sits where its parent and its rotation put it"
    );
    // Hair b's inertia frame on a joint of hair a: b's step reads that joint while the step
    // runs, so hair a's joints are left to the write after the step.
    app.world_mut()
        .entity_mut(b)
        .insert(HairInertiaFrame(a_joints[1]));
    shake_roots(&mut app, &roots, 20..30);
    assert!(!joints_written_early(&app, a));
    assert!(joints_written_early(&app, b));
    assert_eq!(joints_checked(&mut app, a), 8);
    assert_eq!(joints_checked(&mut app, b), 8);
    app.world_mut().entity_mut(b).remove::<HairInertiaFrame>();
    shake_roots(&mut app, &roots, 30..35);
    assert!(joints_written_early(&app, a));
    // An accessory hung below a joint of hair b: the write after the step propagates it.
    let bow = app
        .world_mut()
        .spawn((Transform::from_xyz(0.0, 0.01, 0.02), ChildOf(b_joints[2])))
        .id();
    shake_roots(&mut app, &roots, 35..45);
    assert!(joints_written_early(&app, a));
    assert!(
        !joints_written_early(&app, b),
        "{b} has something below a joint"
    );
    assert_eq!(joints_checked(&mut app, a), 8);
    assert_eq!(joints_checked(&mut app, b), 8);
    let joint = app
        .world()
        .get::<GlobalTransform>(b_joints[2])
        .unwrap()
        .affine();
    let hung = app
        .world()
        .get::<GlobalTransform>(bow)
        .unwrap()
        .translation();
    let expected = joint.transform_point3(Vec3::new(0.0, 0.01, 0.02));
    assert!(
        hung.distance(expected) < 1e-5,
        "the accessory hangs from this frame's joint: {hung} against {expected}"
    );
}

/// Joints two hairs take (two sets of chains matching the same bones, built in one frame or
/// one after the other) are the last-built hair's, and are written from its poses after the
/// step: the other hair reads their transforms while the step runs.
#[test]
fn a_joint_two_hairs_take_is_written_after_the_step_from_its_owners_pose() {
    let mut app = event_app();
    let (root, joints) = locked_character(&mut app, 0.0, 1.0);
    let chains = || {
        (
            HairBoneChains::matching(root, |n| n.starts_with("lock_")),
            HairSimSettings::default(),
        )
    };
    let first = app.world_mut().spawn(chains()).id();
    let second = app.world_mut().spawn(chains()).id();
    shake_roots(&mut app, &[root], 0..10);
    // A third set built later takes them again.
    let third = app.world_mut().spawn(chains()).id();
    shake_roots(&mut app, &[root], 10..30);
    let hairs: Vec<Entity> = [first, second, third]
        .into_iter()
        .map(|set| hairs_of(&app, set)[0])
        .collect();
    for &joint in &joints {
        let of = *app.world().get::<chain_pose::ChainJoint>(joint).unwrap();
        assert_eq!(of.hair, hairs[2], "the last hair built owns {joint}");
        assert!(of.shared, "{joint} is shared");
    }
    assert!(!joints_written_early(&app, hairs[2]));
    assert_eq!(joints_checked(&mut app, hairs[2]), 8);
    // The owner's poses moved the joints.
    let bind = app.world().get::<Transform>(joints[3]).unwrap().rotation;
    assert!(bind.angle_between(Quat::IDENTITY) > 1e-3, "{bind:?}");
}
