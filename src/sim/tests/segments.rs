//! Segment collision: a collider smaller than a bone cannot pass through a chain between its
//! joints.

use bevy::prelude::*;

use super::*;
use crate::asset::CollisionCapsule;

/// Distance from `p` to the segment `a`-`b`.
fn to_segment(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(1e-12)).clamp(0.0, 1.0);
    p.distance(a + ab * t)
}

/// A chain of three 15 cm bones hanging from a head, and a 2 cm sphere (or an upright capsule,
/// as a [`HairCollider`] of its own) swept sideways at 1 m/s through the middle of its first
/// bone. Returns the deepest any posed bone got into the shape over the sweep (metres), with
/// the chain colliding with it or (`collide` false) not.
fn swept_through_a_long_bone(capsule: bool, collide: bool) -> f32 {
    const RADIUS: f32 = 0.02;
    const BONE: f32 = 0.15;
    let mut app = event_app();
    let (root, head) = character(&mut app, Transform::default(), Vec3::new(0.0, 1.6, 0.0));
    let world = app.world_mut();
    let mut joints = Vec::new();
    let mut parent = head;
    for k in 0..3 {
        let at = if k == 0 {
            Vec3::new(0.0, -0.02, 0.0)
        } else {
            Vec3::new(0.0, -BONE, 0.0)
        };
        parent = world
            .spawn((
                Name::new(format!("hair_{k}")),
                Transform::from_translation(at),
                ChildOf(parent),
            ))
            .id();
        joints.push(parent);
    }
    let chains = world
        .spawn((
            HairBoneChains::matching(root, |n| n.starts_with("hair_")),
            HairSimSettings::default(),
        ))
        .id();
    if !collide {
        world.entity_mut(chains).insert(HairCollidesOnly(vec![]));
    }
    // Level with the first bone's middle, a little off its plane so it is pushed to one side.
    let start = Vec3::new(-0.2, 1.6 - 0.02 - 0.5 * BONE, 0.004);
    let (spheres, capsules) = if capsule {
        let half = Vec3::Y * 0.01;
        (
            vec![],
            vec![CollisionCapsule {
                a: -half,
                b: half,
                radius: RADIUS,
            }],
        )
    } else {
        (
            vec![CollisionSphere {
                center: Vec3::ZERO,
                radius: RADIUS,
            }],
            vec![],
        )
    };
    let ball = world
        .spawn((
            HairCollider {
                spheres,
                capsules,
                ..default()
            },
            Transform::from_translation(start),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let mut deepest = 0.0f32;
    let frames = 24;
    for f in 1..=frames {
        let centre = start + Vec3::X * (0.4 * f as f32 / frames as f32);
        app.world_mut()
            .get_mut::<Transform>(ball)
            .unwrap()
            .translation = centre;
        app.update();
        let p = super::chains::joint_positions(&app, &joints);
        for bone in p.windows(2) {
            // A capsule's axis is short: its nearest point to the bone is near its centre.
            let core = if capsule {
                let a = centre - Vec3::Y * 0.01;
                let b = centre + Vec3::Y * 0.01;
                (0..=20)
                    .map(|i| {
                        let q = a.lerp(b, i as f32 / 20.0);
                        to_segment(q, bone[0], bone[1])
                    })
                    .fold(f32::INFINITY, f32::min)
            } else {
                to_segment(centre, bone[0], bone[1])
            };
            deepest = deepest.max(RADIUS - core);
        }
    }
    deepest
}

/// The posed bones stay out of the swept shape, which would go through them were the chain to
/// ignore it.
fn kept_out(capsule: bool) {
    let shape = if capsule { "capsule" } else { "sphere" };
    let (deepest, through) = (
        swept_through_a_long_bone(capsule, true),
        swept_through_a_long_bone(capsule, false),
    );
    eprintln!(
        "a 2 cm {shape} swept through a 15 cm bone: the posed bones at most {:.2} mm inside it \
         ({:.2} mm when the chain ignores it)",
        deepest * 1000.0,
        through * 1000.0
    );
    assert!(
        through > 0.015,
        "the sweep must cross the bone ({through} m deep without collision)"
    );
    assert!(
        deepest < 1e-3,
        "a bone went {} mm into the {shape}",
        deepest * 1000.0
    );
}

#[test]
fn a_sphere_smaller_than_a_bone_cannot_pass_through_it() {
    // Without segment collision the sphere passes between the joints: 16 mm deep.
    kept_out(false);
}

#[test]
fn a_capsule_smaller_than_a_bone_cannot_pass_through_it() {
    kept_out(true);
}
