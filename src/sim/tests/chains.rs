//! Bone chains as strands: a character's own hair bones simulated and turned.

use bevy::prelude::*;

use super::*;

/// A character (root, neck, head at `head_at`) with two hair-bone chains under the head:
/// `hair_a_*` (3 joints) and `hair_b_*` (4 joints), lengths in the rig's units (`unit` metres
/// each), and a bone `hat` that is not hair. Returns the root, the head and the joints.
fn chain_character(app: &mut App, root: Transform, unit: f32) -> (Entity, Entity, Vec<Entity>) {
    let (root, head) = character(app, root, Vec3::new(0.0, 1.6 / unit, 0.0));
    let world = app.world_mut();
    world.spawn((
        Name::new("hat"),
        Transform::from_xyz(0.0, 0.12 / unit, 0.0),
        ChildOf(head),
    ));
    let mut joints = Vec::new();
    for (chain, start, steps) in [
        ("a", Vec3::new(0.06, 0.08, 0.02), 3),
        ("b", Vec3::new(-0.05, 0.09, -0.03), 4),
    ] {
        let mut parent = head;
        for k in 0..steps {
            let offset = if k == 0 {
                start
            } else {
                Vec3::new(0.01 * k as f32, -0.035, -0.01)
            };
            let joint = world
                .spawn((
                    Name::new(format!("hair_{chain}_{k}")),
                    Transform::from_translation(offset / unit)
                        .with_rotation(Quat::from_rotation_z(0.1 * k as f32)),
                    ChildOf(parent),
                ))
                .id();
            joints.push(joint);
            parent = joint;
        }
    }
    (root, head, joints)
}

fn chains_app(settings: HairSimSettings, root: Transform, unit: f32) -> (App, Entity, Vec<Entity>) {
    let mut app = event_app();
    let (root, _, joints) = chain_character(&mut app, root, unit);
    app.world_mut().spawn((
        HairBoneChains::matching(root, |n| n.starts_with("hair_")),
        settings,
    ));
    (app, root, joints)
}

pub(super) fn joint_positions(app: &App, joints: &[Entity]) -> Vec<Vec3> {
    joints
        .iter()
        .map(|j| {
            app.world()
                .get::<GlobalTransform>(*j)
                .unwrap()
                .translation()
        })
        .collect()
}

/// A head turning from side to side (at 30 fps up to 0.12 rad a frame; the fast [`shake`]
/// turns up to 0.28, and how the bone's path is sampled between frames then matters more than
/// the solver).
pub(super) fn turn(t: f32) -> Quat {
    Quat::from_rotation_y(1.2 * (3.0 * t).sin())
}

/// Loose chains: they swing farther, so frame-rate effects would show.
fn soft() -> HairSimSettings {
    HairSimSettings {
        bend_stiffness: 0.2,
        torsion_stiffness: 0.2,
        anchor_stiffness: QuadraticCurve::constant(0.0),
        ..default()
    }
}

fn shake(t: f32) -> Quat {
    Quat::from_rotation_y(1.4 * (6.0 * t).sin()) * Quat::from_rotation_x(0.5 * (4.0 * t).sin())
}

#[test]
fn bone_chains_become_strands_through_their_joints_and_a_tail() {
    let settings = HairSimSettings {
        gravity: Vec3::ZERO,
        ..default()
    };
    let (mut app, _, joints) = chains_app(settings, Transform::default(), 1.0);
    app.update();
    let bind = joint_positions(&app, &joints);
    app.update();
    let world = app.world_mut();
    let sets: Vec<_> = world
        .query::<&BoneChainHairs>()
        .iter(world)
        .map(|h| h.0.clone())
        .collect();
    assert_eq!(sets.len(), 1);
    assert_eq!(sets[0].len(), 1, "both chains hang from the head: one hair");
    let hair = sets[0][0];
    let driven = app.world().get::<BoneChainHair>(hair).unwrap();
    assert_eq!(
        driven.joints,
        vec![joints[..3].to_vec(), joints[3..].to_vec()]
    );
    let strands = particles(&mut app);
    assert_eq!(strands.len(), 2);
    assert_eq!(
        (strands[0].len(), strands[1].len()),
        (4, 5),
        "one particle a joint, and the tail"
    );
    for (p, j) in strands.iter().flat_map(|s| &s[..s.len() - 1]).zip(&bind) {
        assert!(
            p.distance(*j) < 1e-5,
            "particle {p} is not on its joint {j}"
        );
    }
    // The tail continues the last bone by its length (tail 1.0).
    let tail = strands[0][3] - strands[0][2];
    let last_bone = strands[0][2] - strands[0][1];
    assert!((tail - last_bone).length() < 1e-5, "{tail} vs {last_bone}");
    // Without gravity nothing moves the chains off their bind pose.
    for _ in 0..60 {
        app.update();
    }
    let held = joint_positions(&app, &joints);
    let drift = held
        .iter()
        .zip(&bind)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    assert!(drift < 1e-4, "joints drifted {drift} m from the bind pose");
    assert!(
        seen(&app).iter().any(|s| s == "ready 2"),
        "the chain hair reports ready: {:?}",
        seen(&app)
    );
    // Tubes are not built for it: the character's own mesh is what the chains move.
}

/// What [`shake_run`] saw, joint positions in metres in the head's frame.
pub(super) struct ShakeRun {
    /// Where the joints rested before the shake.
    pub(super) rest: Vec<Vec3>,
    /// At the end of the shake.
    pub(super) shaken: Vec<Vec3>,
    /// Particles at the end of the shake, in the head's frame.
    particles: Vec<Vec3>,
    /// After resting again as long as they settled first.
    pub(super) after: Vec<Vec3>,
    /// The largest distance of a joint from its rest during the shake.
    pub(super) swing: f32,
}

/// Joint positions relative to the head while the head rests for 3 s, shakes for `seconds`
/// and rests for 3 s again, at `fps`, on a rig whose root is `root` and units `unit` metres.
pub(super) fn shake_run(
    fps: f64,
    root: Transform,
    unit: f32,
    seconds: f64,
    motion: fn(f32) -> Quat,
    settings: HairSimSettings,
) -> ShakeRun {
    let mut app = event_app();
    app.insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
        std::time::Duration::from_secs_f64(1.0 / fps),
    ));
    let (root_e, head, joints) = chain_character(&mut app, root, unit);
    app.world_mut().spawn((
        HairBoneChains::matching(root_e, |n| n.starts_with("hair_")),
        settings,
    ));
    let to_head = |app: &App| {
        app.world()
            .get::<GlobalTransform>(head)
            .unwrap()
            .affine()
            .inverse()
    };
    let in_head = |app: &App| -> Vec<Vec3> {
        let h = to_head(app);
        joint_positions(app, &joints)
            .into_iter()
            .map(|p| h.transform_point3(p) * unit)
            .collect()
    };
    let frames = |secs: f64| (secs * fps).round() as u32;
    for _ in 0..frames(3.0) {
        app.update();
    }
    let rest = in_head(&app);
    let mut swing = 0.0f32;
    for f in 0..frames(seconds) {
        let t = (f + 1) as f32 / fps as f32;
        app.world_mut()
            .get_mut::<Transform>(root_e)
            .unwrap()
            .rotation = root.rotation * motion(t);
        app.update();
        let now = in_head(&app);
        swing = swing.max(
            now.iter()
                .zip(&rest)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0, f32::max),
        );
    }
    let shaken = in_head(&app);
    let h = to_head(&app);
    let particles = particles(&mut app)
        .into_iter()
        .flatten()
        .map(|p| h.transform_point3(p) * unit)
        .collect();
    app.world_mut()
        .get_mut::<Transform>(root_e)
        .unwrap()
        .rotation = root.rotation;
    for _ in 0..frames(3.0) {
        app.update();
    }
    ShakeRun {
        rest,
        shaken,
        particles,
        after: in_head(&app),
        swing,
    }
}

pub(super) fn farthest(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f32::max)
}

#[test]
fn chains_swing_in_a_head_shake_and_return_to_rest_within_2_mm() {
    let run = shake_run(
        60.0,
        Transform::default(),
        1.0,
        2.0,
        shake,
        HairSimSettings::default(),
    );
    let back = farthest(&run.after, &run.rest);
    println!(
        "bone chains: swung {:.4} m in the shake, back within {back:e} m",
        run.swing
    );
    assert!(
        run.swing > 0.01,
        "the shake must swing the chains ({} m)",
        run.swing
    );
    assert!(
        back < 0.002,
        "a joint rests {back} m from where it rested before"
    );
}

#[test]
fn chains_on_a_stretched_rig_swing_and_return_to_rest() {
    // Unequal axis scales: each joint's world rotation is read from its parent's matrix.
    let run = shake_run(
        60.0,
        Transform::from_scale(Vec3::new(1.0, 1.3, 0.8)),
        1.0,
        2.0,
        shake,
        HairSimSettings::default(),
    );
    let back = farthest(&run.after, &run.rest);
    println!(
        "bone chains on a stretched rig: swung {:.4} m, back within {back:e} m",
        run.swing
    );
    assert!(
        run.swing > 0.01,
        "the shake must swing the chains ({} m)",
        run.swing
    );
    assert!(
        back < 0.002,
        "a joint rests {back} m from where it rested before"
    );
}

#[test]
fn chains_on_a_rig_of_scale_0_01_move_as_on_a_unit_rig() {
    let unit_rig = shake_run(
        60.0,
        Transform::default(),
        1.0,
        0.7,
        shake,
        HairSimSettings::default(),
    );
    let scaled = shake_run(
        60.0,
        Transform::from_scale(Vec3::splat(0.01)),
        0.01,
        0.7,
        shake,
        HairSimSettings::default(),
    );
    let particles = farthest(&unit_rig.particles, &scaled.particles);
    let joints = farthest(&unit_rig.shaken, &scaled.shaken);
    let rest = farthest(&unit_rig.rest, &scaled.rest);
    println!(
        "bone chains on a 0.01 rig: at rest {rest:e} m, after the shake particles {particles:e} \
         m, joints {joints:e} m from the unit rig"
    );
    assert!(joints < 1e-4, "the 0.01 rig differs by {joints} m");
}

#[test]
fn bind_rotations_a_file_left_unnormalised_still_pose_rigid_joints() {
    // glTF keeps node rotations as written; Bevy's loader does not normalise them. A chain whose
    // bind rotations are 3% long must still pose rotations, not shears.
    let (mut app, root, joints) = chains_app(soft(), Transform::default(), 1.0);
    for &j in &joints {
        let mut t = app.world_mut().get_mut::<Transform>(j).unwrap();
        t.rotation = Quat::from_vec4(Vec4::from(t.rotation) * 1.03);
    }
    let mut worst = 0.0f32;
    for f in 0..90 {
        let t = (f + 1) as f32 / 60.0;
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(t);
        app.update();
        if f < 2 {
            continue;
        }
        for &j in &joints {
            let m = app
                .world()
                .get::<GlobalTransform>(j)
                .unwrap()
                .affine()
                .matrix3;
            // The rig is unscaled: each posed joint's matrix is a rotation.
            let gram = Mat3::from(m.transpose() * m);
            worst = worst.max(
                (gram - Mat3::IDENTITY)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0, f32::max),
            );
        }
    }
    println!("bind rotations 3% long: posed joints at most {worst:e} from a rotation");
    assert!(
        worst < 1e-4,
        "a posed joint's matrix is {worst} from a rotation"
    );
}

#[test]
fn chains_move_alike_at_30_60_and_144_fps() {
    let runs: Vec<ShakeRun> = [30.0, 60.0, 144.0]
        .into_iter()
        .map(|fps| shake_run(fps, Transform::default(), 1.0, 2.0, turn, soft()))
        .collect();
    let (ab, ac) = (
        farthest(&runs[0].shaken, &runs[1].shaken),
        farthest(&runs[0].shaken, &runs[2].shaken),
    );
    println!(
        "bone chains after 2 s of turning: 30 vs 60 fps {ab:e} m, 30 vs 144 fps {ac:e} m (swing {:.3} m)",
        runs[1].swing
    );
    assert!(runs[1].swing > 0.005, "the turn must swing the chains");
    // Stated tolerance, as for groomed strands: 2 mm.
    assert!(
        ab < 2e-3 && ac < 2e-3,
        "30 vs 60 fps: {ab} m, 30 vs 144 fps: {ac} m"
    );
}

#[test]
fn a_shaken_chain_keeps_its_joints_on_its_particles() {
    let (mut app, root, joints) = chains_app(HairSimSettings::default(), Transform::default(), 1.0);
    app.update();
    app.update();
    let hung = particles(&mut app);
    let (mut off, mut swing) = (0.0f32, 0.0f32);
    for f in 0..60 {
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(f as f32 / 60.0);
        app.update();
        let strands = particles(&mut app);
        swing = swing.max(max_deviation(&strands, &hung));
        // Each joint on its particle (the tail particle has no joint).
        let on = joint_positions(&app, &joints)
            .iter()
            .zip(strands.iter().flat_map(|s| &s[..s.len() - 1]))
            .map(|(j, p)| j.distance(*p))
            .fold(0.0, f32::max);
        off = off.max(on);
    }
    println!("a shaken chain: particles moved {swing:e} m, joints at most {off:e} m off them");
    assert!(
        swing > 0.01,
        "the shake moved the chain only {swing} m: no test"
    );
    assert!(off < 0.01, "a joint is {off} m off its particle");
}

#[test]
fn chain_selection_by_name_and_entity_and_a_missing_chain_is_reported() {
    let mut app = event_app();
    let (root, _, joints) = chain_character(&mut app, Transform::default(), 1.0);
    let by_name = app
        .world_mut()
        .spawn(HairBoneChains::named(root, ["hair_b_0"]))
        .id();
    let by_entity = app
        .world_mut()
        .spawn(HairBoneChains {
            root,
            select: ChainSelect::Entities(vec![joints[0]]),
            tail: 0.5,
        })
        .id();
    let missing = app
        .world_mut()
        .spawn(HairBoneChains::named(root, ["J_Sec_Hair1_01"]))
        .id();
    app.update();
    app.update();
    let count = |app: &App, set: Entity| {
        let hairs = &app.world().get::<BoneChainHairs>(set).unwrap().0;
        hairs
            .iter()
            .map(|h| app.world().get::<BoneChainHair>(*h).unwrap().joints.len())
            .sum::<usize>()
    };
    assert_eq!(count(&app, by_name), 1);
    assert_eq!(count(&app, by_entity), 1);
    assert_eq!(count(&app, missing), 0);
    assert!(
        seen(&app)
            .iter()
            .any(|s| s.starts_with("no bone") && s.contains("J_Sec_Hair1_01") && s.contains("hat")),
        "{:?}",
        seen(&app)
    );
}

#[test]
fn chains_stay_out_of_a_head_collider_through_a_fast_shake() {
    // A sphere inside the head, reaching close to where the chains hang; the shake throws them
    // at it. Without the collider they pass through it.
    let run = |with_collider: bool| {
        let (mut app, root, _) = chains_app(soft(), Transform::default(), 1.0);
        let head = app
            .world_mut()
            .query::<(Entity, &Name)>()
            .iter(app.world())
            .find(|(_, n)| n.as_str() == "head")
            .unwrap()
            .0;
        if with_collider {
            app.world_mut().spawn((
                HairCollider {
                    spheres: vec![CollisionSphere {
                        center: Vec3::ZERO,
                        radius: 0.05,
                    }],
                    ..default()
                },
                ChildOf(head),
            ));
        }
        let mut deepest = 0.0f32;
        for f in 0..240 {
            let t = (f + 1) as f32 / 60.0;
            app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(t);
            app.update();
            let centre = app
                .world()
                .get::<GlobalTransform>(head)
                .unwrap()
                .translation();
            let strands = particles(&mut app);
            deepest = deepest.max(
                strands
                    .iter()
                    .flat_map(|s| s.iter().skip(1))
                    .map(|p| 0.05 - p.distance(centre))
                    .fold(0.0, f32::max),
            );
        }
        deepest
    };
    let (with, without) = (run(true), run(false));
    println!(
        "bone chains in a fast shake: {with:e} m inside the head sphere, {without:e} m without it"
    );
    assert!(
        without > 0.005,
        "the shake must throw the chains into the sphere ({without} m)"
    );
    assert!(with < 0.001, "the chains went {with} m into the head");
}

#[test]
fn a_teleported_character_carries_its_chains_without_a_whip() {
    let (mut app, root, joints) = chains_app(HairSimSettings::default(), Transform::default(), 1.0);
    let head = app.world().get::<ChildOf>(joints[0]).unwrap().parent();
    let in_head = |app: &App| -> Vec<Vec3> {
        let h = app
            .world()
            .get::<GlobalTransform>(head)
            .unwrap()
            .affine()
            .inverse();
        joint_positions(app, &joints)
            .into_iter()
            .map(|p| h.transform_point3(p))
            .collect()
    };
    for _ in 0..120 {
        app.update();
    }
    let before = in_head(&app);
    app.world_mut()
        .get_mut::<Transform>(root)
        .unwrap()
        .translation = Vec3::new(100.0, 0.0, -40.0);
    app.update();
    let after = in_head(&app);
    let whip = farthest(&before, &after);
    println!("bone chains across a 108 m teleport: {whip:e} m from their place on the head");
    assert!(
        whip < 1e-3,
        "the teleport moved the chains {whip} m on the head"
    );
}

/// Bevy's transform propagation skips the joints a chain hair poses. What hangs below a posed
/// joint (a clip on a tip, a ribbon with its own child, a clip put on later) still follows it
/// every frame, a joint
/// with more than a leaf below it stays with Bevy (and so do the joints above it), every
/// joint's world transform is its parent's times its local one, and once the hair goes the
/// joints are Bevy's again. On a unit rig, a rig of scale 0.01 and a stretched one.
#[test]
fn what_hangs_below_posed_joints_follows_them_and_the_joints_go_back_to_bevy() {
    for (rig, unit) in [
        (Transform::default(), 1.0),
        (Transform::from_scale(Vec3::splat(0.01)), 0.01),
        (Transform::from_scale(Vec3::new(1.0, 1.3, 0.8)), 1.0),
    ] {
        hanging_below_posed_joints(rig, unit);
    }
}

fn hanging_below_posed_joints(rig: Transform, unit: f32) {
    use bevy::transform::components::TransformTreeChanged;
    let (mut app, root, joints) = chains_app(soft(), rig, unit);
    let world = app.world_mut();
    let offset = Transform::from_xyz(0.0, -0.01 / unit, 0.004 / unit)
        .with_rotation(Quat::from_rotation_x(0.3));
    let clip = world.spawn((offset, ChildOf(joints[2]))).id();
    let ribbon = world.spawn((offset, ChildOf(joints[4]))).id();
    let ribbon_end = world.spawn((offset, ChildOf(ribbon))).id();
    app.update();
    app.update();
    // Chain a (joints 0-2) ends in a leaf: all its joints are the hair's. Chain b's second
    // joint carries a ribbon with a child: joints 3 and 4 stay with Bevy, 5 and 6 do not.
    let bevys = |app: &App| -> Vec<bool> {
        joints
            .iter()
            .map(|j| app.world().entity(*j).contains::<TransformTreeChanged>())
            .collect()
    };
    assert_eq!(bevys(&app), [false, false, false, true, true, false, false]);
    let global = |app: &App, e: Entity| app.world().get::<GlobalTransform>(e).unwrap().affine();
    let local = |app: &App, e: Entity| app.world().get::<Transform>(e).unwrap().compute_affine();
    let parent = |app: &App, e: Entity| app.world().get::<ChildOf>(e).unwrap().parent();
    // How far an entity's world transform is from its parent's times its local one (metres,
    // and matrix entries).
    let off = |app: &App, e: Entity| -> f32 {
        let want = global(app, parent(app, e)) * local(app, e);
        let got = global(app, e);
        (want.translation - got.translation).length().max(
            (want.matrix3 - got.matrix3)
                .to_cols_array()
                .iter()
                .fold(0.0f32, |m, v| m.max(v.abs())),
        )
    };
    // The joints in the head's frame, in metres on the unit rigs.
    let on_head = |app: &App| -> Vec<Vec3> {
        let head = global(app, parent(app, joints[0])).inverse();
        joint_positions(app, &joints)
            .iter()
            .map(|p| head.transform_point3(*p) * unit)
            .collect()
    };
    let rest = on_head(&app);
    let (mut worst, mut swing) = (0.0f32, 0.0f32);
    // A clip put on a posed joint mid-way (whose only child was the chain's next joint) follows
    // it from its first frame.
    let mut late = None;
    for f in 0..90 {
        if f == 45 {
            late = Some(app.world_mut().spawn((offset, ChildOf(joints[1]))).id());
        }
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(f as f32 / 60.0);
        app.update();
        for &e in joints
            .iter()
            .chain([&clip, &ribbon, &ribbon_end])
            .chain(&late)
        {
            worst = worst.max(off(&app, e));
        }
        // The swing on the head: the chains are posed, not carried rigidly.
        swing = on_head(&app)
            .iter()
            .zip(&rest)
            .fold(swing, |m, (p, r)| m.max(p.distance(*r)));
    }
    println!(
        "rig {:?}: posed joints and what hangs below them over 90 shaken frames: at most {worst:e} \
         from parent x local; joints swung up to {swing} m on the head",
        rig.scale
    );
    assert!(
        swing > 0.005,
        "the chains did not swing ({swing} m): nothing was posed"
    );
    assert!(
        worst < 1e-4,
        "an entity is {worst} from its parent's world transform times its local one"
    );
    // The hair goes: its joints are Bevy's again and follow the head with their last pose.
    let set = joints_set(&mut app);
    let hair = app.world().get::<BoneChainHairs>(set).unwrap().0[0];
    app.world_mut().despawn(hair);
    app.update();
    assert_eq!(bevys(&app), [true; 7]);
    for f in 90..120 {
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(f as f32 / 60.0);
        app.update();
    }
    let after = joints
        .iter()
        .chain([&clip, &ribbon, &ribbon_end])
        .map(|e| off(&app, *e))
        .fold(0.0f32, f32::max);
    assert!(
        after < 1e-4,
        "after the hair went, an entity is {after} from its parent's world transform times its \
         local one: Bevy does not propagate the joints"
    );
}

/// The one [`HairBoneChains`] entity of an app.
fn joints_set(app: &mut App) -> Entity {
    let world = app.world_mut();
    world
        .query_filtered::<Entity, With<HairBoneChains>>()
        .single(world)
        .unwrap()
}

/// The step poses a chain hair on its own thread right after its substeps when several hairs
/// step at once, and leaves a hair alone to posing's system after every step: both give the
/// same joints, to the bit, through a shake that throws the chains at a head collider.
#[test]
fn chains_posed_in_the_step_match_chains_posed_after_it() {
    // `others` characters beside the first, 10 m apart: with none the first hair is alone.
    let run = |others: usize| {
        let mut app = event_app();
        let mut first = None;
        for i in 0..=others {
            let (root, head, joints) = chain_character(
                &mut app,
                Transform::from_xyz(10.0 * i as f32, 0.0, 0.0),
                1.0,
            );
            let world = app.world_mut();
            world.spawn((
                HairCollider {
                    spheres: vec![CollisionSphere {
                        center: Vec3::ZERO,
                        radius: 0.05,
                    }],
                    ..default()
                },
                ChildOf(head),
            ));
            world.spawn((
                HairBoneChains::matching(root, |n| n.starts_with("hair_")),
                soft(),
            ));
            first.get_or_insert((root, joints));
        }
        let (root, joints) = first.unwrap();
        let mut frames = Vec::new();
        for f in 0..120 {
            let t = (f + 1) as f32 / 60.0;
            app.world_mut().get_mut::<Transform>(root).unwrap().rotation = shake(t);
            app.update();
            frames.push(
                joints
                    .iter()
                    .map(|&j| {
                        let world = app.world();
                        let local = world.get::<Transform>(j).unwrap().rotation;
                        (local, world.get::<GlobalTransform>(j).unwrap().affine())
                    })
                    .collect::<Vec<_>>(),
            );
        }
        frames
    };
    let (alone, beside) = (run(0), run(2));
    let tip = |frames: &[Vec<(Quat, bevy::math::Affine3A)>], f: usize| {
        Vec3::from(frames[f].last().unwrap().1.translation)
    };
    let swung = (0..alone.len())
        .map(|f| tip(&alone, f).distance(tip(&alone, 0)))
        .fold(0.0, f32::max);
    assert!(swung > 0.01, "the chains must swing ({swung} m)");
    for (f, (a, b)) in alone.iter().zip(&beside).enumerate() {
        assert_eq!(
            a, b,
            "frame {f}: the joints posed alone and beside other hairs differ"
        );
    }
}
