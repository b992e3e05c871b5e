//! Attaching hair to bones and characters, load order, failed files, colliders.

use std::time::Duration;

use bevy::prelude::*;

use super::*;

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

/// A system's type, as the schedule holds it.
fn system_type<M>(system: impl IntoSystem<(), (), M>) -> std::any::TypeId {
    let system = IntoSystem::into_system(system);
    system.system_type()
}

/// Which of these `PostUpdate` systems (by type, see [`system_type`]) ran in one frame of `h`.
fn ran_in_a_frame(h: &mut Harness, systems: &[std::any::TypeId]) -> Vec<bool> {
    let last_runs = |app: &App| {
        let schedule = app.get_schedule(PostUpdate).unwrap();
        let all: Vec<(std::any::TypeId, u32)> = schedule
            .systems()
            .unwrap()
            .map(|(_, s)| (s.system_type(), s.get_last_run().get()))
            .collect();
        systems
            .iter()
            .map(|id| {
                let found: Vec<u32> = all
                    .iter()
                    .filter(|(t, _)| t == id)
                    .map(|(_, t)| *t)
                    .collect();
                assert_eq!(found.len(), 1, "one such system");
                found[0]
            })
            .collect::<Vec<_>>()
    };
    let before = last_runs(&h.app);
    h.update();
    let after = last_runs(&h.app);
    before.iter().zip(&after).map(|(b, a)| a != b).collect()
}

#[test]
fn systems_with_nothing_to_look_at_do_not_run() {
    use super::super::{attach, bone, chain_pose, chains, reload, step, vrm, write_out};
    let mut h = Harness::new(spiky_groom(10, 5), HairSimSettings::default(), 60.0);
    let idle = [
        system_type(bone::attach_to_bones),
        system_type(vrm::build_vrm_springs),
        system_type(vrm::report_failed_vrm_loads),
        system_type(chains::build_bone_chains),
        system_type(reload::mark_reloaded_hairs),
        system_type(reload::report_failed_reloads),
        system_type(attach::build_hair_strands),
        system_type(chain_pose::pose_bone_chains),
    ];
    let busy = [
        system_type(step::step_hair_strands),
        system_type(write_out::write_hair_state),
    ];
    h.update();
    // A built hair hung on its bone as a child, no chains, no VRM, no reloads, its bone not
    // scaled since: only the step and the write run.
    assert_eq!(ran_in_a_frame(&mut h, &idle), vec![false; idle.len()]);
    assert_eq!(ran_in_a_frame(&mut h, &busy), vec![true; busy.len()]);
    // Its bone scaled: the build runs that frame (and rebuilds the hair), then rests again.
    let build = [system_type(attach::build_hair_strands)];
    let builds = h.app.world().get::<HairStatus>(h.hair).unwrap().builds;
    h.app
        .world_mut()
        .get_mut::<Transform>(h.bone)
        .unwrap()
        .scale = Vec3::splat(1.5);
    assert_eq!(ran_in_a_frame(&mut h, &build), vec![true]);
    assert_eq!(
        h.app.world().get::<HairStatus>(h.hair).unwrap().builds,
        builds + 1
    );
    assert_eq!(ran_in_a_frame(&mut h, &build), vec![false]);
    // A hair hung by bone search, and bone chains: their systems run while they have work.
    let bone = h.bone;
    let groom = h.app.world().get::<Hair>(h.hair).unwrap().groom.clone();
    h.app.world_mut().spawn((
        Hair { groom, ..default() },
        HairSimSettings::default(),
        AttachToBone::entity(bone),
    ));
    let joint = h
        .app
        .world_mut()
        .spawn((
            Name::new("lock_0"),
            Transform::from_xyz(0.05, 0.0, 0.0),
            ChildOf(bone),
        ))
        .id();
    h.app.world_mut().spawn((
        Name::new("lock_1"),
        Transform::from_xyz(0.0, -0.04, 0.0),
        ChildOf(joint),
    ));
    let root = h.app.world_mut().spawn(Transform::default()).id();
    h.app.world_mut().entity_mut(bone).insert(ChildOf(root));
    h.app.world_mut().spawn((
        HairBoneChains::matching(root, |n| n.starts_with("lock_")),
        HairSimSettings::default(),
    ));
    let first = [
        system_type(bone::attach_to_bones),
        system_type(chains::build_bone_chains),
    ];
    assert_eq!(ran_in_a_frame(&mut h, &first), vec![true; first.len()]);
    // The chains built: the step poses them beside the other hairs and writes their joints
    // (and the strands), so posing's own system rests, as do the chain build and the write.
    let next = [
        system_type(chain_pose::pose_bone_chains),
        system_type(chains::build_bone_chains),
        system_type(write_out::write_hair_state),
    ];
    assert_eq!(ran_in_a_frame(&mut h, &next), vec![false, false, false]);
    let lock = h
        .app
        .world()
        .get::<GlobalTransform>(joint)
        .unwrap()
        .affine();
    assert!(
        lock.translation.distance(Vec3A::ZERO) > 0.01,
        "the joint was written where its bone is, not left at the origin: {lock:?}"
    );
    // The chain hair alone (a hair alone shares its batches out over the threads, so the step
    // leaves it): posing's own system poses it, and the write after writes its joints, every
    // frame.
    let others: Vec<Entity> = h
        .app
        .world_mut()
        .query_filtered::<Entity, (With<Hair>, Without<BoneChainHair>)>()
        .iter(h.app.world())
        .collect();
    for e in others {
        h.app.world_mut().entity_mut(e).despawn();
    }
    h.update();
    let posing = [
        system_type(chain_pose::pose_bone_chains),
        system_type(write_out::write_hair_state),
    ];
    assert_eq!(ran_in_a_frame(&mut h, &posing), vec![true, true]);
    assert_eq!(ran_in_a_frame(&mut h, &posing), vec![true, true]);
}

/// A character whose scene does not load (here a path with no file) leaves no hair waiting
/// for bones forever: the hair hung with `AttachToBone` and the set of `HairBoneChains` are
/// each told once, with a `HairAssetFailed` of kind `Character` naming the file, and stop
/// waiting.
#[test]
fn a_character_whose_scene_does_not_load_is_reported_not_waited_for() {
    let mut app = event_app();
    let scene = crate::test_support::missing_scene(&mut app);
    let root = app.world_mut().spawn((Transform::default(), scene)).id();
    let groom = app
        .world_mut()
        .resource_mut::<Assets<HairGroom>>()
        .add(spiky_groom(5, 4));
    let hair = app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            AttachToBone::named(root, "head"),
        ))
        .id();
    let chains = app
        .world_mut()
        .spawn(HairBoneChains::matching(root, |n| n.starts_with("hair_")))
        .id();
    crate::test_support::update_until(&mut app, |app| seen(app).len() >= 2);
    for _ in 0..10 {
        app.update();
    }
    let events = seen(&app);
    assert_eq!(events.len(), 2, "each told once: {events:?}");
    for event in &events {
        assert!(
            event.starts_with("failed Character characters/missing.glb | ") && event.len() > 45,
            "{events:?}"
        );
    }
    assert_eq!(
        app.world().get::<BoneSearch>(hair),
        Some(&BoneSearch::NotFound)
    );
    assert!(app.world().get::<ChildOf>(hair).is_none());
    assert!(app.world().get::<BoneChainHairs>(chains).is_some());
    assert_eq!(strand_count(&mut app), 0);
}
