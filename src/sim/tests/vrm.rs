//! VRM spring bones as hair: the parameter mapping, chains and colliders built from what a file
//! says (on hand-made node trees; the glTF side is tested on real files by the render tests),
//! collider groups, VRM 0.x branches and tails, and a broken file's report.

use bevy::prelude::*;

use super::chains::{ShakeRun, farthest, shake_run, turn};
use super::*;
use crate::asset::{
    JointLimit, JointLimitShape, VrmCollider, VrmJoint, VrmNode, VrmShape, VrmSpring,
    VrmSpringBones, VrmSprings, VrmVersion,
};
use crate::sim::{
    HairCollidesOnly, VRM0_TAIL, VrmSpringChains, VrmSpringsFailed, anchor_for_rate,
    compliance_factor, vrm_sim_settings,
};

fn joint(stiffness: f32, drag_force: f32, gravity_power: f32) -> VrmJoint {
    VrmJoint {
        hit_radius: 0.01,
        stiffness,
        gravity_power,
        gravity_dir: Vec3::NEG_Y,
        drag_force,
        limit: None,
    }
}

#[test]
fn vrm_parameters_map_to_per_second_settings() {
    let spring = VrmSpring {
        name: "bangs".into(),
        nodes: vec![1, 2, 3],
        joints: vec![
            joint(2.0, 0.4, 0.1),
            joint(1.0, 0.4, 0.1),
            joint(50.0, 0.0, 9.0),
        ],
        groups: vec![],
        center: Some(0),
    };
    let s = vrm_sim_settings(&spring, VrmVersion::V1, 0.05);
    // The last joint is only a tail: its parameters are unused.
    let damping = -60.0 * (1.0f32 - 0.4).ln();
    assert!((s.damping - damping).abs() < 1e-4, "{}", s.damping);
    assert!((s.damping - 30.65).abs() < 0.01);
    // Gravity falls at the speed VRM settles at: g / d a frame, 60 frames a second.
    let g = 0.1 * damping / 0.4;
    assert!(
        (s.gravity - Vec3::new(0.0, -g, 0.0)).length() < 1e-4,
        "{}",
        s.gravity
    );
    // Stiffness s (m/s) on 5 cm bones -> a return rate of s / 0.05 a second at each joint.
    let h = s.substep();
    let (a0, a1) = (
        anchor_for_rate(2.0 / 0.05, h),
        anchor_for_rate(1.0 / 0.05, h),
    );
    assert!((s.anchor_stiffness.eval(0.0) - a0).abs() < 1e-5);
    assert!((s.anchor_stiffness.eval(1.0) - a1).abs() < 1e-5);
    assert!(a0 > a1 && a1 > 0.3, "{a0} {a1}");
    // The anchor removes that rate: per substep, rate * h of the offset.
    for rate in [2.0, 20.0, 100.0] {
        let f = compliance_factor(anchor_for_rate(rate, h), h, 1.0);
        assert!((f / (rate * h) - 1.0).abs() < 1e-3, "{rate}: {f}");
    }
    assert!((s.bend_stiffness - (a0 + a1) / 2.0).abs() < 1e-5);
    assert!((s.torsion_stiffness - 0.5 * s.bend_stiffness).abs() < 1e-6);
    assert_eq!((s.margin_min, s.margin_max), (0.01, 0.01));
    // `center` is an inertia frame on the spawned chains, not a damping frame.
    assert_eq!(s.damping_frame, HairDampingFrame::World);
    // Without drag gravity is g a frame at 60 fps; VRM 0.x uses its one entry.
    let free = VrmSpring {
        joints: vec![joint(0.0, 0.0, 0.2)],
        center: None,
        ..spring
    };
    let s = vrm_sim_settings(&free, VrmVersion::V0, 0.05);
    assert!((s.gravity.y + 12.0).abs() < 1e-4, "{}", s.gravity);
    assert_eq!(s.damping, 0.0);
    assert_eq!(s.anchor_stiffness.eval(0.5), 0.0);
    assert_eq!(s.damping_frame, HairDampingFrame::World);
}

#[test]
fn vrm_mapped_chains_move_alike_at_30_60_and_144_fps() {
    let spring = VrmSpring {
        name: String::new(),
        nodes: vec![],
        joints: vec![
            joint(0.3, 0.1, 0.05),
            joint(0.2, 0.1, 0.05),
            joint(1.0, 0.5, 0.0),
        ],
        groups: vec![],
        center: None,
    };
    // The test chains' bones are about 4 cm.
    let settings = vrm_sim_settings(&spring, VrmVersion::V1, 0.04);
    let runs: Vec<ShakeRun> = [30.0, 60.0, 144.0]
        .into_iter()
        .map(|fps| shake_run(fps, Transform::default(), 1.0, 2.0, turn, settings.clone()))
        .collect();
    let (ab, ac) = (
        farthest(&runs[0].shaken, &runs[1].shaken),
        farthest(&runs[0].shaken, &runs[2].shaken),
    );
    println!(
        "VRM-mapped chains: 30 vs 60 fps {ab:e} m, 30 vs 144 fps {ac:e} m (swing {:.3} m)",
        runs[1].swing
    );
    assert!(runs[1].swing > 0.005, "the turn must swing the chains");
    assert!(
        ab < 2e-3 && ac < 2e-3,
        "30 vs 60 fps: {ab} m, 30 vs 144 fps: {ac} m"
    );
    let back = farthest(&runs[1].after, &runs[1].rest);
    assert!(back < 2e-3, "back within {back} m of rest");
}

/// A scene root with VRM nodes: 0 the head; chain A 1 -> 2 -> 3 at x = +0.05 and chain B
/// 4 -> 5 -> 6 at x = -0.05, hanging down 5 cm a joint. Returns the root and the nodes.
fn vrm_scene(app: &mut App, springs: VrmSprings) -> (Entity, Vec<Entity>) {
    let world = app.world_mut();
    let root = world
        .spawn((
            Name::new("vrm"),
            Transform::default(),
            VrmSpringBones {
                file: "test.vrm".into(),
                springs,
                error: None,
            },
        ))
        .id();
    let head = world
        .spawn((
            Name::new("head"),
            VrmNode(0),
            Transform::from_xyz(0.0, 1.6, 0.0),
            ChildOf(root),
        ))
        .id();
    let mut nodes = vec![head];
    for x in [0.05, -0.05] {
        let mut parent = head;
        for k in 0..3 {
            let at = if k == 0 {
                Vec3::new(x, 0.0, 0.0)
            } else {
                Vec3::new(0.0, -0.05, 0.0)
            };
            let index = nodes.len() as u32;
            let e = world
                .spawn((
                    VrmNode(index),
                    Transform::from_translation(at),
                    ChildOf(parent),
                ))
                .id();
            nodes.push(e);
            parent = e;
        }
    }
    (root, nodes)
}

fn sphere(at: Vec3) -> VrmCollider {
    VrmCollider {
        node: 0,
        shape: VrmShape::Sphere {
            offset: at,
            radius: 0.02,
            inside: false,
        },
    }
}

/// Two springs and two spheres, each sphere on the *other* chain's middle joint; `a_groups`
/// are spring A's collider groups (group 0: the sphere on A, group 1: the sphere on B).
fn crossed(a_groups: Vec<u32>) -> VrmSprings {
    let still = VrmJoint {
        gravity_power: 0.0,
        ..joint(1.0, 0.4, 0.0)
    };
    VrmSprings {
        version: VrmVersion::V1,
        colliders: vec![
            sphere(Vec3::new(0.05, -0.05, 0.0)),
            sphere(Vec3::new(-0.05, -0.05, 0.0)),
        ],
        groups: vec![vec![0], vec![1]],
        springs: vec![
            VrmSpring {
                name: "a".into(),
                nodes: vec![1, 2, 3],
                joints: vec![still; 3],
                groups: a_groups,
                center: None,
            },
            VrmSpring {
                name: "b".into(),
                nodes: vec![4, 5, 6],
                joints: vec![still; 3],
                groups: vec![0],
                center: None,
            },
        ],
    }
}

fn positions(app: &App, nodes: &[Entity]) -> Vec<Vec3> {
    nodes
        .iter()
        .map(|e| {
            app.world()
                .get::<GlobalTransform>(*e)
                .unwrap()
                .translation()
        })
        .collect()
}

#[test]
fn vrm_springs_become_chains_that_collide_only_with_their_groups() {
    let mut app = event_app();
    let (root, nodes) = vrm_scene(&mut app, crossed(vec![1]));
    app.update();
    let bind = positions(&app, &nodes);
    for _ in 0..60 {
        app.update();
    }
    let built = app
        .world()
        .get::<VrmSpringChains>(root)
        .expect("springs built")
        .clone();
    assert_eq!((built.springs.len(), built.colliders.len()), (2, 2));
    // Each collider is a child of its node.
    for c in &built.colliders {
        assert_eq!(app.world().get::<ChildOf>(*c).unwrap().parent(), nodes[0]);
        assert!(app.world().get::<HairCollider>(*c).is_some());
    }
    // Spring A collides only with group 1 (the sphere on B), B only with group 0 (on A):
    // neither sphere touches the chain that sees it, so both rest at their bind pose.
    let hairs: Vec<Entity> = built
        .springs
        .iter()
        .map(|s| app.world().get::<BoneChainHairs>(*s).unwrap().0[0])
        .collect();
    assert_eq!(
        app.world().get::<HairCollidesOnly>(hairs[0]).unwrap().0,
        vec![built.colliders[1]]
    );
    let drift = farthest(&positions(&app, &nodes), &bind);
    assert!(
        drift < 1e-4,
        "chains left their bind pose by {drift} m: a collider of another group acted"
    );
    // The tail joint moves with its chain but is not turned.
    let driven = app.world().get::<BoneChainHair>(hairs[0]).unwrap();
    assert_eq!(driven.joints[0], vec![nodes[1], nodes[2], nodes[3]]);

    // Spring A now naming group 0: its own sphere, centred on the middle joint's bind
    // position (5 cm below the first joint), pushes that joint out of it.
    let mut app = event_app();
    let (_, nodes) = vrm_scene(&mut app, crossed(vec![0]));
    app.update();
    let bind = positions(&app, &nodes);
    for _ in 0..60 {
        app.update();
    }
    let now = positions(&app, &nodes);
    let centre = bind[1] + Vec3::new(0.0, -0.05, 0.0);
    let pushed = now[2].distance(centre);
    assert!(
        pushed > 0.02,
        "the sphere in A's group (radius 0.02 m) left its joint {pushed} m from its centre"
    );
    let other = farthest(&now[4..], &bind[4..]);
    assert!(other < 1e-4, "B moved {other} m");
}

/// How many particles of every chain hair's strands differ between the solver and the strand
/// entities (which show them after posing moved them).
fn strand_particles_not_shown(app: &mut App) -> usize {
    let mut strands = app
        .world_mut()
        .query::<(&StrandOf, &Strand, &StrandParticles)>();
    strands
        .iter(app.world())
        .map(|(of, strand, shown)| {
            let computed = app.world().get::<ComputedHair>(of.0).unwrap();
            let s = strand.index as usize;
            shown
                .positions
                .iter()
                .enumerate()
                .filter(|&(i, p)| *p != computed.particle(s, i))
                .count()
        })
        .sum()
}

/// Chain A blown sideways (gravity along +X, no stiffness) for two seconds, its first two joints
/// with `limit`; returns each turned bone's largest angle in the second second from the bone
/// before it (the first from its bind direction, straight down), in degrees, and how many strand
/// particles the strand entities did not show where the solver has them.
fn swung_chain_angles(limit: Option<JointLimit>) -> ([f32; 2], usize) {
    let mut app = event_app();
    let mut springs = crossed(vec![]);
    springs.springs[0].joints = vec![
        VrmJoint {
            gravity_dir: Vec3::X,
            limit,
            ..joint(0.0, 0.2, 0.5)
        };
        3
    ];
    let (_, nodes) = vrm_scene(&mut app, springs);
    // The chain still swings after a second: the largest angle of the second second (a
    // snapshot would depend on the swing's phase).
    let (mut angles, mut not_shown) = ([0.0f32; 2], 0);
    for frame in 0..120 {
        app.update();
        not_shown += strand_particles_not_shown(&mut app);
        if frame < 60 {
            continue;
        }
        let p = positions(&app, &nodes);
        let first = (p[2] - p[1]).normalize();
        let second = (p[3] - p[2]).normalize();
        angles[0] = angles[0].max(first.angle_between(Vec3::NEG_Y).to_degrees());
        angles[1] = angles[1].max(second.angle_between(first).to_degrees());
    }
    eprintln!("limit {limit:?}: bones at most at {angles:?} degrees");
    (angles, not_shown)
}

#[test]
fn a_vrm_angle_limit_keeps_each_posed_bone_inside_it() {
    let (free, _) = swung_chain_angles(None);
    assert!(
        free[0] > 45.0,
        "without a limit the wind swings the first bone only {free:?} degrees: no test"
    );
    // Bones straight down: the draft's half turn about X makes the cone's axis the bone.
    let (cone, not_shown) = swung_chain_angles(Some(JointLimit {
        shape: JointLimitShape::Cone {
            angle: 20f32.to_radians(),
        },
        rotation: Quat::IDENTITY,
    }));
    // The limit moves the particles it turns the bones from; the strand entities show them
    // where the limit left them.
    assert_eq!(
        not_shown, 0,
        "strand particles shown before the limit moved them"
    );
    for (k, a) in cone.iter().enumerate() {
        assert!(
            *a <= 20.05,
            "bone {k}: {a} degrees in a 20 degree cone ({cone:?}, free {free:?})"
        );
    }
    assert!(
        cone[0].max(cone[1]) > 19.0,
        "the limited chain did not swing to its limit: {cone:?}"
    );
    // A hinge about X lets the bones swing only in the Y-Z plane: the +X wind cannot turn them.
    let (hinge, _) = swung_chain_angles(Some(JointLimit {
        shape: JointLimitShape::Hinge {
            angle: 60f32.to_radians(),
        },
        rotation: Quat::IDENTITY,
    }));
    assert!(hinge[0] < 0.5 && hinge[1] < 0.5, "hinge {hinge:?}");
    // The same hinge turned a quarter about Y hinges about Z: the wind turns the bones up to 60.
    let (turned, _) = swung_chain_angles(Some(JointLimit {
        shape: JointLimitShape::Hinge {
            angle: 60f32.to_radians(),
        },
        rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
    }));
    assert!(
        turned[0] > 40.0 && turned[0] <= 60.05,
        "turned hinge {turned:?}"
    );
}

#[test]
fn a_vrm_tail_joint_follows_unturned() {
    let mut app = event_app();
    // Loose and hardly damped, so the turn swings the chain.
    let mut springs = crossed(vec![]);
    springs.springs[0].joints = vec![joint(0.0, 0.05, 0.0); 3];
    let (root, nodes) = vrm_scene(&mut app, springs);
    for _ in 0..30 {
        app.update();
    }
    let tail_rotation = app.world().get::<Transform>(nodes[3]).unwrap().rotation;
    for f in 0..30 {
        app.world_mut().get_mut::<Transform>(root).unwrap().rotation = turn(f as f32 / 60.0);
        app.update();
    }
    let world = app.world();
    let turned = world
        .get::<Transform>(nodes[1])
        .unwrap()
        .rotation
        .angle_between(Quat::IDENTITY);
    assert!(turned > 0.01, "the first joint did not turn ({turned} rad)");
    assert_eq!(
        world.get::<Transform>(nodes[3]).unwrap().rotation,
        tail_rotation
    );
    // Its global transform follows its turned parent.
    let expected = world
        .get::<GlobalTransform>(nodes[2])
        .unwrap()
        .mul_transform(*world.get::<Transform>(nodes[3]).unwrap());
    let actual = world.get::<GlobalTransform>(nodes[3]).unwrap();
    assert!(actual.translation().distance(expected.translation()) < 1e-5);
}

#[test]
fn a_vrm_0_group_swings_every_branch_with_a_7_cm_tail() {
    let mut app = event_app();
    let mut springs = crossed(vec![]);
    springs.version = VrmVersion::V0;
    // One group rooted at node 1 (chain A); B (4) is moved under node 1 as a branch.
    springs.springs = vec![VrmSpring {
        name: "hair".into(),
        nodes: vec![1],
        joints: vec![joint(1.0, 0.4, 0.0)],
        groups: vec![],
        center: None,
    }];
    let (root, nodes) = vrm_scene(&mut app, springs);
    app.world_mut()
        .entity_mut(nodes[4])
        .insert(ChildOf(nodes[1]));
    for _ in 0..3 {
        app.update();
    }
    let built = app.world().get::<VrmSpringChains>(root).unwrap().clone();
    assert_eq!(built.springs.len(), 1);
    let chains = app
        .world()
        .get::<HairBoneChains>(built.springs[0])
        .unwrap()
        .clone();
    let ChainSelect::Joints(chains) = chains.select else {
        panic!("VRM chains list their joints");
    };
    assert_eq!(chains.len(), 2, "{chains:?}");
    assert_eq!(&chains[0][..3], &[nodes[1], nodes[2], nodes[3]]);
    assert_eq!(&chains[1][..3], &[nodes[4], nodes[5], nodes[6]]);
    for chain in &chains {
        let tail = *chain.last().unwrap();
        let world = app.world();
        assert_eq!(world.get::<Name>(tail).unwrap().as_str(), "VRM 0.x tail");
        let t = world.get::<Transform>(tail).unwrap().translation;
        // Along the leaf's own bone (straight down here), 7 cm.
        assert!((t - Vec3::new(0.0, -VRM0_TAIL, 0.0)).length() < 1e-6, "{t}");
    }
    // Both chains simulate (the branch hangs from the joint it branches at).
    let hairs = app.world().get::<BoneChainHairs>(built.springs[0]).unwrap();
    assert_eq!(hairs.0.len(), 2, "one hair per bone the chains hang from");
}

#[test]
fn a_broken_vrm_is_reported_once_and_simulates_nothing() {
    let mut app = event_app();
    #[derive(Resource, Default)]
    struct Failed(Vec<String>);
    app.init_resource::<Failed>()
        .add_observer(|e: On<VrmSpringsFailed>, mut f: ResMut<Failed>| {
            f.0.push(format!("{} | {}", e.file, e.error));
        });
    let (root, _) = vrm_scene(&mut app, VrmSprings::default());
    let message =
        "broken.vrm: extensions.VRMC_springBone.springs[0].joints[1].node: node 99 does not exist";
    app.world_mut()
        .get_mut::<VrmSpringBones>(root)
        .unwrap()
        .error = Some(message.into());
    app.world_mut()
        .get_mut::<VrmSpringBones>(root)
        .unwrap()
        .file = "broken.vrm".into();
    for _ in 0..10 {
        app.update();
    }
    assert_eq!(
        app.world().resource::<Failed>().0,
        vec![format!("broken.vrm | {message}")]
    );
    let built = app.world().get::<VrmSpringChains>(root).unwrap();
    assert!(built.springs.is_empty() && built.colliders.is_empty());
    assert_eq!(strand_count(&mut app), 0);
}

/// A `.vrm` that fails to load while no scene root names it (a game that loads its avatars
/// with bevy_vrm1) still reaches the game: the event goes to global observers, on the
/// placeholder entity, naming the file and the loader's reason. A scene root already told of
/// the file is not told again, and then nothing goes to the placeholder.
#[test]
fn a_failed_vrm_no_scene_root_waits_for_reaches_global_observers() {
    use bevy::asset::io::AssetReaderError;
    use bevy::asset::{AssetLoadError, AssetPath, UntypedAssetLoadFailedEvent};
    let mut app = event_app();
    app.add_message::<UntypedAssetLoadFailedEvent>();
    #[derive(Resource, Default)]
    struct Failed(Vec<(Entity, String, String)>);
    app.init_resource::<Failed>()
        .add_observer(|e: On<VrmSpringsFailed>, mut f: ResMut<Failed>| {
            f.0.push((e.entity, e.file.clone(), e.error.clone()));
        });
    let fail = |app: &mut App| {
        app.world_mut().write_message(UntypedAssetLoadFailedEvent {
            id: AssetId::<Mesh>::default().untyped(),
            path: AssetPath::from("avatars/missing.vrm").into_owned(),
            error: AssetLoadError::AssetReaderError(AssetReaderError::NotFound(
                "avatars/missing.vrm".into(),
            )),
        });
        app.update();
        app.update();
    };
    fail(&mut app);
    // A scene root of the file that was told already (it has its empty chains).
    app.init_asset::<bevy::world_serialization::WorldAsset>();
    let scene = app
        .world()
        .resource::<AssetServer>()
        .load(bevy::gltf::GltfAssetLabel::Scene(0).from_asset("avatars/missing.vrm"));
    app.world_mut().spawn((
        bevy::world_serialization::WorldAssetRoot(scene),
        VrmSpringChains::default(),
    ));
    fail(&mut app);
    let failed = &app.world().resource::<Failed>().0;
    assert_eq!(failed.len(), 1, "{failed:?}");
    let (entity, file, error) = &failed[0];
    assert_eq!(*entity, Entity::PLACEHOLDER);
    assert_eq!(file, "avatars/missing.vrm");
    assert!(
        error.starts_with("avatars/missing.vrm: the VRM file did not load")
            && error.contains("not found"),
        "{error}"
    );
}

/// A VRM whose spring-bone extension holds no springs (empty bone groups) simulates nothing
/// and says so once, as an event a game can act on, naming the file.
#[test]
fn a_vrm_without_usable_springs_is_reported() {
    let mut app = event_app();
    #[derive(Resource, Default)]
    struct Failed(Vec<String>);
    app.init_resource::<Failed>()
        .add_observer(|e: On<VrmSpringsFailed>, mut f: ResMut<Failed>| {
            f.0.push(format!("{} | {}", e.file, e.error));
        });
    let (root, _) = vrm_scene(&mut app, VrmSprings::default());
    app.world_mut()
        .get_mut::<VrmSpringBones>(root)
        .unwrap()
        .file = "empty.vrm".into();
    for _ in 0..10 {
        app.update();
    }
    let failed = &app.world().resource::<Failed>().0;
    assert_eq!(failed.len(), 1, "{failed:?}");
    assert!(
        failed[0].starts_with("empty.vrm | empty.vrm: no usable spring bones"),
        "{failed:?}"
    );
    assert_eq!(strand_count(&mut app), 0);
}

#[test]
fn a_vrm_collider_radius_follows_its_node_scale() {
    // The head (and everything under it) at twice the size: the 2 cm sphere on chain A's middle
    // joint is 4 cm in the world, and the joint rests outside it by its hit radius (measured:
    // 5.0 cm from the centre). Were the radius not scaled, at most 2 cm + 2 cm.
    let mut app = event_app();
    let (_, nodes) = vrm_scene(&mut app, crossed(vec![0]));
    app.world_mut()
        .get_mut::<Transform>(nodes[0])
        .unwrap()
        .scale = Vec3::splat(2.0);
    for _ in 0..90 {
        app.update();
    }
    let world = app.world();
    let head = world.get::<GlobalTransform>(nodes[0]).unwrap();
    let centre = head.transform_point(Vec3::new(0.05, -0.05, 0.0));
    let joint = world
        .get::<GlobalTransform>(nodes[2])
        .unwrap()
        .translation();
    let out = joint.distance(centre);
    assert!(
        out > 0.045,
        "the joint is {out} m from the sphere's centre: its radius did not scale"
    );
}

#[test]
fn despawning_a_vrm_character_leaves_no_springs_hairs_or_colliders() {
    let mut app = event_app();
    let (root, _) = vrm_scene(&mut app, crossed(vec![1]));
    for _ in 0..5 {
        app.update();
    }
    assert!(strand_count(&mut app) > 0);
    app.world_mut().entity_mut(root).despawn();
    for _ in 0..3 {
        app.update();
    }
    let world = app.world_mut();
    let chains = world.query::<&HairBoneChains>().iter(world).count();
    let colliders = world.query::<&HairCollider>().iter(world).count();
    let hairs = world.query::<&Hair>().iter(world).count();
    assert_eq!((chains, colliders, hairs), (0, 0, 0));
    assert_eq!(strand_count(&mut app), 0);
}

/// Chain A (joints 5 cm apart, hanging from the head) pushed along `wind` against a capsule on
/// the head, the head scaled by 1.5 and turned 0.4 rad about Z and 0.3 about Y; returns the capsule's world axis
/// and radius and, after two seconds, chain A's particles and its posed joints 2 and 3.
fn capsule_run(inside: bool, radius: f32, wind: Vec3) -> ((Vec3, Vec3, f32), Vec<Vec3>, [Vec3; 2]) {
    let mut app = event_app();
    let (a, b) = (
        Vec3::new(0.05, -0.075, -0.05),
        Vec3::new(0.05, -0.075, 0.05),
    );
    let mut springs = crossed(vec![0]);
    springs.colliders[0] = VrmCollider {
        node: 0,
        shape: VrmShape::Capsule {
            offset: a,
            tail: b,
            radius,
            inside,
        },
    };
    // No stiffness, so the collider is what holds the chain against `wind`.
    springs.springs[0].joints = vec![
        VrmJoint {
            gravity_dir: wind,
            hit_radius: 0.0,
            ..joint(0.0, 0.3, 0.3)
        };
        3
    ];
    let (root, nodes) = vrm_scene(&mut app, springs);
    *app.world_mut().get_mut::<Transform>(nodes[0]).unwrap() = Transform::from_xyz(0.0, 1.6, 0.0)
        .with_scale(Vec3::splat(1.5))
        .with_rotation(Quat::from_rotation_z(0.4) * Quat::from_rotation_y(0.3));
    for _ in 0..120 {
        app.update();
    }
    let head = *app.world().get::<GlobalTransform>(nodes[0]).unwrap();
    let axis = (
        head.transform_point(a),
        head.transform_point(b),
        radius * 1.5,
    );
    let hair = app
        .world()
        .get::<VrmSpringChains>(root)
        .map(|c| c.springs[0]);
    let particles = hair
        .and_then(|s| app.world().get::<BoneChainHairs>(s))
        .map(|h| {
            let strands = app.world().get::<HairStrands>(h.0[0]).unwrap();
            strands
                .iter()
                .flat_map(|s| {
                    app.world()
                        .get::<StrandParticles>(s)
                        .unwrap()
                        .positions
                        .clone()
                })
                .collect()
        })
        .unwrap_or_default();
    let p = positions(&app, &nodes);
    (axis, particles, [p[2], p[3]])
}

/// Distance from `p` to the segment `a`-`b`.
fn to_segment(p: Vec3, (a, b): (Vec3, Vec3)) -> f32 {
    let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
    p.distance(a + (b - a) * t)
}

#[test]
fn a_vrm_capsule_holds_particles_and_posed_joints_on_a_scaled_turned_node() {
    // Outside: the capsule lies across the chain's rest and the chain falls onto it.
    let ((a, b, r), particles, joints) = capsule_run(false, 0.02, Vec3::NEG_Y);
    assert_eq!(particles.len(), 3, "chain A's particles");
    let gaps: Vec<f32> = particles
        .iter()
        .chain(&joints)
        .map(|p| to_segment(*p, (a, b)) - r)
        .collect();
    eprintln!("outside a capsule of {r} m: particles then joints 2 and 3 lie {gaps:?} m out");
    for (i, g) in gaps.iter().enumerate() {
        assert!(
            *g > -1e-3,
            "point {i} is {g} m inside the capsule: {gaps:?}"
        );
    }
    // Inside: a capsule around the chain keeps it in against a sideways wind (the root, pinned
    // to its bone above the capsule, is not checked).
    let ((a, b, r), particles, joints) = capsule_run(true, 0.06, Vec3::X);
    let gaps: Vec<f32> = particles[1..]
        .iter()
        .chain(&joints)
        .map(|p| r - to_segment(*p, (a, b)))
        .collect();
    eprintln!("inside a capsule of {r} m: particles 1, 2 then joints 2, 3 lie {gaps:?} m in");
    for (i, g) in gaps.iter().enumerate() {
        assert!(
            *g > -1e-3,
            "point {i} is {} m outside the capsule: {gaps:?}",
            -g
        );
    }
}

/// Chain A's tip relative to the head, farthest from where it rested, while the character
/// (the scene root) jumps from standing to 6 m/s and runs for half a second; spring A with
/// `center` set to node `center`.
fn tip_swing_while_running(center: Option<u32>) -> f32 {
    let mut app = event_app();
    let mut springs = crossed(vec![]);
    springs.springs[0].joints = vec![joint(0.2, 0.2, 0.0); 3];
    springs.springs[0].center = center;
    let (root, nodes) = vrm_scene(&mut app, springs);
    for _ in 0..30 {
        app.update();
    }
    let relative = |app: &App| {
        let head = app.world().get::<GlobalTransform>(nodes[0]).unwrap();
        let tip = app.world().get::<GlobalTransform>(nodes[3]).unwrap();
        head.affine().inverse().transform_point3(tip.translation())
    };
    let rest = relative(&app);
    let mut farthest = 0.0f32;
    for f in 1..=30 {
        app.world_mut()
            .get_mut::<Transform>(root)
            .unwrap()
            .translation
            .x = 0.1 * f as f32;
        app.update();
        farthest = farthest.max(relative(&app).distance(rest));
    }
    farthest
}

#[test]
fn a_vrm_center_carries_its_spring_with_it() {
    let world = tip_swing_while_running(None);
    let centred = tip_swing_while_running(Some(0));
    eprintln!("tip swing while running: {world} m in the world frame, {centred} m with center");
    assert!(
        world > 0.01,
        "without a center the run swings the tip only {world} m"
    );
    assert!(
        centred < 1e-3,
        "with the head as center the tip still swings {centred} m"
    );
}

/// A 3 cm sphere on a node of its own swept at 0.5 m/s through chain A's middle; the deepest
/// any of chain A's particles and any of its posed joints gets inside it over the sweep.
fn swept_sphere_depths() -> (f32, f32) {
    let mut app = event_app();
    let mut springs = crossed(vec![0]);
    springs.colliders[0] = VrmCollider {
        node: 7,
        shape: VrmShape::Sphere {
            offset: Vec3::ZERO,
            radius: 0.03,
            inside: false,
        },
    };
    springs.springs[0].joints = vec![
        VrmJoint {
            hit_radius: 0.0,
            ..joint(0.5, 0.4, 0.1)
        };
        3
    ];
    let (root, nodes) = vrm_scene(&mut app, springs);
    let start = Vec3::new(-0.15, 1.6 - 0.07, 0.0);
    let ball = app
        .world_mut()
        .spawn((
            VrmNode(7),
            Transform::from_translation(start),
            ChildOf(root),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let (mut particles_deepest, mut joints_deepest) = (0.0f32, 0.0f32);
    for f in 0..60 {
        app.world_mut()
            .get_mut::<Transform>(ball)
            .unwrap()
            .translation = start + Vec3::X * (0.5 * f as f32 / 60.0);
        app.update();
        let centre = app
            .world()
            .get::<GlobalTransform>(ball)
            .unwrap()
            .translation();
        let hairs = app.world().get::<VrmSpringChains>(root).unwrap().springs[0];
        let hair = app.world().get::<BoneChainHairs>(hairs).unwrap().0[0];
        for s in app.world().get::<HairStrands>(hair).unwrap().iter() {
            for p in &app.world().get::<StrandParticles>(s).unwrap().positions {
                particles_deepest = particles_deepest.max(0.03 - p.distance(centre));
            }
        }
        for p in &positions(&app, &nodes)[2..4] {
            joints_deepest = joints_deepest.max(0.03 - p.distance(centre));
        }
    }
    (particles_deepest, joints_deepest)
}

#[test]
fn a_sphere_swept_through_a_vrm_chain_leaves_its_posed_joints_out() {
    let (particles, joints) = swept_sphere_depths();
    eprintln!(
        "sphere swept through the chain: particles at most {:.2} mm inside, posed joints {:.2} mm",
        particles * 1000.0,
        joints * 1000.0
    );
    // A collider may hold a particle nearer its joint than the bone is long; posed at the
    // bone's length, the middle joint went 9.0 mm into the sphere before the posed joints were
    // kept off the colliders too.
    assert!(
        particles < 1e-3,
        "particles {} mm inside",
        particles * 1000.0
    );
    assert!(joints < 1e-3, "posed joints {} mm inside", joints * 1000.0);
}
