//! Capsules, planes and boxes, followed per substep; friction; keep-inside colliders; the broad
//! phase. Headless apps, like `tests.rs`.

use bevy::math::Vec3A;
use bevy::prelude::*;

use super::contact::LocalShape;
use super::solver::ContactShape;
use super::tests::{Harness, spiky_groom};
use super::*;
use crate::asset::{CollisionBox, CollisionCapsule, CollisionPlane, CollisionSphere, HairGroom};
use crate::curve::QuadraticCurve;

/// The harness's bone, world space.
const BONE: Vec3 = Vec3::new(0.0, 1.6, 0.0);

/// Settings with one margin for every strand.
fn one_margin(margin: f32) -> HairSimSettings {
    HairSimSettings {
        margin_min: margin,
        margin_max: margin,
        ..default()
    }
}

/// How deep `x` is inside `shape` (0 when outside).
fn depth(shape: &ContactShape, x: Vec3) -> f32 {
    shape
        .resolve(Vec3A::from(x), 0.0, false)
        .map_or(0.0, |to| to.distance(Vec3A::from(x)))
}

/// The world shapes of a collider entity.
fn world_shapes(h: &mut Harness, collider: Entity) -> Vec<ContactShape> {
    let world = h.app.world();
    let pose = world.get::<GlobalTransform>(collider).unwrap().affine();
    let c = world.get::<HairCollider>(collider).unwrap();
    c.shapes().map(|s| s.at(&pose)).collect()
}

/// Free strands hanging straight down from a row of roots along z.
fn hanging_groom(strands: usize, particles: usize, length: f32) -> HairGroom {
    HairGroom::from_strands(
        "head",
        (0..strands).map(|i| {
            let z = (i as f32 / (strands - 1) as f32 - 0.5) * 0.2;
            (0..particles)
                .map(|k| Vec3::new(0.0, -length * k as f32 / (particles - 1) as f32, z))
                .collect()
        }),
    )
    .unwrap()
}

fn free_hanging() -> HairSimSettings {
    HairSimSettings {
        anchor_stiffness: QuadraticCurve::new(0.0, 0.0, 0.0),
        ..one_margin(0.01)
    }
}

#[test]
fn a_capsule_arm_swept_at_10_m_s_does_not_pass_through_hanging_hair() {
    let mut h = Harness::with(hanging_groom(12, 16, 0.3), None, None, free_hanging(), 60.0);
    for _ in 0..60 {
        h.update();
    }
    let (radius, margin, speed) = (0.04, 0.01, 10.0);
    let y = BONE.y - 0.2;
    let frame = 1.0 / 60.0;
    // The arm's frame-end positions skip over the hair (x = 0): tested only there, it would
    // never touch it (0.06 m from it at the nearest, farther than radius + margin).
    let start = -0.44;
    let arm = h
        .app
        .world_mut()
        .spawn((
            HairCollider {
                capsules: vec![CollisionCapsule {
                    a: Vec3::new(0.0, 0.0, -0.5),
                    b: Vec3::new(0.0, 0.0, 0.5),
                    radius,
                }],
                ..default()
            },
            Transform::from_xyz(start, y, 0.0),
        ))
        .id();
    h.update();
    let mut deepest = 0.0f32;
    let mut cut = 0.0f32;
    for f in 1..=8 {
        let x = start + speed * frame * f as f32;
        *h.app.world_mut().get_mut::<Transform>(arm).unwrap() = Transform::from_xyz(x, y, 0.0);
        h.update();
        let arm_shape = world_shapes(&mut h, arm)[0];
        // The arm grown by 90% of the margin: a particle deeper than 10% of the margin fails.
        let ContactShape::Capsule { a, b, .. } = arm_shape else {
            unreachable!()
        };
        let grown = ContactShape::Capsule {
            a,
            b,
            radius: radius + 0.9 * margin,
        };
        for strand in h.strands() {
            for p in &strand[1..] {
                deepest = deepest.max(depth(&grown, *p));
            }
            // A strand whose segment cuts through the arm went through it between particles.
            for pair in strand.windows(2) {
                for k in 0..=8 {
                    let q = pair[0].lerp(pair[1], k as f32 / 8.0);
                    cut = cut.max(depth(&arm_shape, q));
                }
            }
        }
    }
    let swept = h
        .strands()
        .iter()
        .flatten()
        .map(|p| p.x)
        .fold(f32::MIN, f32::max);
    println!(
        "capsule arm (radius {radius}) at {speed} m/s through 12 strands of 16 particles: deepest \
         particle {deepest:.6} m past 90% of the margin, strand segments {cut:.4} m inside the \
         arm, hair dragged to x = {swept:.3} m"
    );
    assert!(deepest <= 1e-5, "a particle is {deepest} m too deep");
    // Particles are what collide: where a strand wraps around the arm, the straight segment
    // between two particles can cut its edge, but none may cross it.
    assert!(
        cut < 0.25 * radius,
        "a strand passes {cut} m deep through the arm"
    );
    assert!(
        swept > 0.1,
        "the arm swept nothing along (hair reaches x = {swept}): it passed through"
    );
}

/// Strands lying across a horizontal capsule (a shoulder), 20 degrees down its side; how far
/// their tips have slid after one second.
fn slide_on_a_shoulder(friction: f32) -> f32 {
    let (radius, margin) = (0.08, 0.01);
    let slope = 20f32.to_radians();
    let up = Vec3::new(slope.sin(), slope.cos(), 0.0) * (radius + margin);
    let groom = HairGroom::from_strands(
        "head",
        (0..3).map(|i| {
            // 4 mm above the shoulder: the structural particles beside the strand clear it.
            let lift = up + up.normalize() * 0.004;
            (0..12)
                .map(|k| lift + Vec3::new(0.0, 0.0, 0.025 * k as f32 + 0.01 * i as f32))
                .collect()
        }),
    )
    .unwrap();
    let settings = HairSimSettings {
        friction,
        bend_stiffness: 0.0,
        // Structural particles close to the strand, so it lies on the shoulder, not on them.
        structure_offset: 0.1,
        ..free_hanging()
    };
    let mut h = Harness::with(groom, None, None, settings, 60.0);
    h.app.world_mut().spawn((
        HairCollider {
            capsules: vec![CollisionCapsule {
                a: Vec3::new(0.0, 0.0, -0.2),
                b: Vec3::new(0.0, 0.0, 0.6),
                radius,
            }],
            ..default()
        },
        Transform::from_translation(BONE),
    ));
    // Back on its style, at rest, with the shoulder in place (it fell for the harness's first
    // frames).
    let bone = *h.app.world().get::<GlobalTransform>(h.hair).unwrap();
    h.app
        .world_mut()
        .get_mut::<ComputedHair>(h.hair)
        .unwrap()
        .reset(&bone);
    h.update();
    let before: Vec<Vec3> = h.strands().iter().map(|s| *s.last().unwrap()).collect();
    for _ in 0..60 {
        h.update();
    }
    let after: Vec<Vec3> = h.strands().iter().map(|s| *s.last().unwrap()).collect();
    before
        .iter()
        .zip(&after)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max)
}

#[test]
fn friction_keeps_hair_resting_on_a_shoulder_from_sliding_off() {
    let free = slide_on_a_shoulder(0.0);
    let rough = slide_on_a_shoulder(0.8);
    println!(
        "tips on a 20 degree shoulder slide {free:.4} m in 1 s without friction, {rough:.4} m \
         with friction 0.8"
    );
    assert!(free > 0.05, "frictionless hair should slide off ({free} m)");
    assert!(
        rough < 0.2 * free,
        "friction 0.8 on a 20 degree slope should hold: {rough} vs {free} m"
    );
}

#[test]
fn capsules_planes_and_boxes_push_the_hair_out() {
    let cases: [(&str, HairCollider, Vec3); 3] = [
        (
            "capsule",
            HairCollider {
                capsules: vec![CollisionCapsule {
                    a: Vec3::new(-0.1, 0.0, 0.0),
                    b: Vec3::new(0.1, 0.0, 0.0),
                    radius: 0.04,
                }],
                ..default()
            },
            Vec3::new(0.0, 0.2, 0.0),
        ),
        (
            "box",
            HairCollider {
                boxes: vec![CollisionBox {
                    center: Vec3::ZERO,
                    half_extents: Vec3::new(0.08, 0.03, 0.06),
                    rotation: Quat::from_rotation_y(0.4),
                }],
                ..default()
            },
            Vec3::new(0.0, 0.2, 0.0),
        ),
        (
            "plane",
            HairCollider {
                // A ceiling: hair stays below it.
                planes: vec![CollisionPlane {
                    point: Vec3::ZERO,
                    normal: Vec3::new(0.1, -1.0, 0.0),
                }],
                ..default()
            },
            Vec3::new(0.0, 0.17, 0.0),
        ),
    ];
    for (name, collider, at) in cases {
        let mut h = Harness::new(spiky_groom(40, 6), one_margin(0.005), 60.0);
        for _ in 0..10 {
            h.update();
        }
        let e = h
            .app
            .world_mut()
            .spawn((collider, Transform::from_translation(BONE + at)))
            .id();
        h.update();
        let shapes = world_shapes(&mut h, e);
        let deepest_before = h
            .strands()
            .iter()
            .flat_map(|s| s.iter().skip(1))
            .map(|p| depth(&shapes[0], *p))
            .fold(0.0, f32::max);
        // (Already pushed for one frame; the styled hair stood up to 0.1 m into each.)
        for _ in 0..60 {
            h.update();
        }
        let deepest = h
            .strands()
            .iter()
            .flat_map(|s| s.iter().skip(1))
            .map(|p| depth(&shapes[0], *p))
            .fold(0.0, f32::max);
        let touched = h.computed().stats.colliders;
        println!(
            "{name}: deepest particle {deepest:.6} m inside ({deepest_before:.6} m after 1 frame)"
        );
        assert!(deepest < 1e-4, "{name}: a particle is {deepest} m inside");
        // The head sphere and this shape both pass the broad phase.
        assert_eq!(touched, 2, "{name}: colliders tested");
    }
}

#[test]
fn an_inside_collider_keeps_hanging_hair_within_it() {
    let (radius, margin) = (0.2, 0.01);
    let bubble = |mode| {
        let mut h = Harness::with(hanging_groom(8, 8, 0.35), None, None, free_hanging(), 60.0);
        h.app.world_mut().spawn((
            HairCollider {
                spheres: vec![CollisionSphere {
                    center: Vec3::ZERO,
                    radius,
                }],
                mode,
                ..default()
            },
            Transform::from_translation(BONE),
        ));
        for _ in 0..90 {
            h.update();
        }
        h.strands()
            .iter()
            .flat_map(|s| s.iter().skip(1))
            .map(|p| p.distance(BONE))
            .fold(0.0, f32::max)
    };
    let outside = bubble(HairColliderMode::Outside);
    let inside = bubble(HairColliderMode::Inside);
    println!(
        "farthest particle from the bubble's centre: {outside:.4} m (outside mode), {inside:.4} m \
         (inside mode, radius {radius}, margin {margin})"
    );
    assert!(
        outside > radius + margin,
        "the hair starts within the bubble"
    );
    assert!(
        inside <= radius - 0.9 * margin,
        "a particle left the bubble: {inside} m from its centre"
    );
}

#[test]
fn far_colliders_cost_nothing_and_near_ones_are_tested() {
    let mut h = Harness::new(spiky_groom(20, 6), HairSimSettings::default(), 60.0);
    let far: Vec<Entity> = (0..300)
        .map(|i| {
            h.app
                .world_mut()
                .spawn((
                    HairCollider {
                        capsules: vec![CollisionCapsule {
                            a: Vec3::ZERO,
                            b: Vec3::X,
                            radius: 0.1,
                        }],
                        ..default()
                    },
                    Transform::from_xyz(20.0 + i as f32, 0.0, 0.0),
                ))
                .id()
        })
        .collect();
    h.update();
    h.update();
    assert_eq!(
        h.computed().stats.colliders,
        1,
        "only the head sphere is near"
    );
    // One of them moves into the hair: it is tested on the frame it arrives, per substep.
    *h.app.world_mut().get_mut::<Transform>(far[7]).unwrap() =
        Transform::from_translation(BONE + Vec3::new(-0.5, 0.15, 0.0));
    h.update();
    assert_eq!(h.computed().stats.colliders, 2);
    // A keep-inside collider is never skipped, wherever it is.
    h.app
        .world_mut()
        .get_mut::<HairCollider>(far[8])
        .unwrap()
        .mode = HairColliderMode::Inside;
    h.update();
    assert_eq!(h.computed().stats.colliders, 3);
}

/// Where a collider's shapes were last frame is kept from then, but taken again from its
/// shapes when they changed: a sphere that grew while it moved away is tested by the hair it
/// sweeps past.
#[test]
fn a_collider_that_changed_is_looked_for_where_its_new_shapes_were() {
    let mut h = Harness::new(spiky_groom(20, 6), HairSimSettings::default(), 60.0);
    let ball = h
        .app
        .world_mut()
        .spawn((
            HairCollider::spheres(vec![CollisionSphere {
                center: Vec3::ZERO,
                radius: 0.05,
            }]),
            Transform::from_translation(BONE + Vec3::new(1.2, 0.0, 0.0)),
        ))
        .id();
    h.update();
    h.update();
    assert_eq!(h.computed().stats.colliders, 1, "only the head is near");
    // It grows to reach within 0.15 m of the bone where it was, and moves 0.9 m away (less than
    // the teleport distance): where it is now it is 1.05 m from the bone, but over the frame
    // it sweeps from where its new size covered the hair.
    h.app
        .world_mut()
        .get_mut::<HairCollider>(ball)
        .unwrap()
        .spheres[0]
        .radius = 1.05;
    *h.app.world_mut().get_mut::<Transform>(ball).unwrap() =
        Transform::from_translation(BONE + Vec3::new(2.1, 0.0, 0.0));
    h.update();
    assert_eq!(
        h.computed().stats.colliders,
        2,
        "the grown sphere's sweep was not looked for where it began"
    );
    // Still there the next frame: far from the hair.
    h.update();
    assert_eq!(h.computed().stats.colliders, 1);
}

#[test]
fn broken_collider_shapes_are_skipped_not_spread() {
    let c = HairCollider {
        spheres: vec![CollisionSphere {
            center: Vec3::NAN,
            radius: 0.1,
        }],
        planes: vec![CollisionPlane {
            point: Vec3::ZERO,
            normal: Vec3::ZERO,
        }],
        boxes: vec![CollisionBox {
            center: Vec3::ZERO,
            half_extents: Vec3::splat(0.1),
            rotation: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
        }],
        ..default()
    };
    let shapes: Vec<LocalShape> = c.shapes().collect();
    // The NaN sphere goes, and so does the plane without a normal (it has no side to keep);
    // the zero rotation becomes the identity.
    assert_eq!(shapes.len(), 1);
    assert!(matches!(shapes[0], LocalShape::Box(_, q, _) if q == Quat::IDENTITY));
}

/// A point field (a blast source coming up beside the head) and a directional
/// one (a fan) push the hair their way, the same at 30, 60 and 144 fps; a field out of reach
/// changes nothing, bit for bit.
#[test]
fn force_fields_blow_hair_their_way_at_any_frame_rate() {
    let run = |fps: f64, field: Option<(HairForceField, Vec3, Vec3)>| {
        let mut h = Harness::new(spiky_groom(16, 6), HairSimSettings::default(), fps);
        let frames = |secs: f64| (secs * fps).round() as usize;
        for _ in 0..frames(1.0) {
            h.update();
        }
        let calm = h.strands();
        let spawned = field.map(|(f, from, _)| {
            h.app
                .world_mut()
                .spawn((f, Transform::from_translation(BONE + from)))
                .id()
        });
        let n = frames(1.0);
        for i in 0..n {
            if let (Some(e), Some((_, from, to))) = (spawned, &field) {
                // The source moves past the head at a steady speed.
                let at = BONE + from.lerp(*to, (i + 1) as f32 / n as f32);
                *h.app.world_mut().get_mut::<Transform>(e).unwrap() =
                    Transform::from_translation(at).looking_to(Vec3::X, Vec3::Y);
            }
            h.update();
        }
        (calm, h.strands())
    };
    // Mean shift of the tips along x.
    let tips_x = |(calm, blown): &(Vec<Vec<Vec3>>, Vec<Vec<Vec3>>)| {
        calm.iter()
            .zip(blown)
            .map(|(a, b)| b[5].x - a[5].x)
            .sum::<f32>()
            / calm.len() as f32
    };
    // A blast source coming up on the head's left (-x) from behind, ending beside it.
    let blast = HairForceField {
        speed: 15.0,
        radius: 0.6,
        ..default()
    };
    let left = (blast, Vec3::new(-0.3, 0.1, -0.4), Vec3::new(-0.3, 0.1, 0.0));
    let b60 = run(60.0, Some(left));
    let (b30, b144) = (run(30.0, Some(left)), run(144.0, Some(left)));
    let pushed = tips_x(&b60);
    let (d30, d144) = (
        max_deviation(&b60.1, &b30.1),
        max_deviation(&b60.1, &b144.1),
    );
    // A fan at the head's left blowing toward +x (its -Z turned to +x).
    let fan = HairForceField {
        kind: HairForceFieldKind::Directional,
        speed: 10.0,
        radius: 1.0,
        ..default()
    };
    let fanned = tips_x(&run(
        60.0,
        Some((fan, Vec3::new(-0.4, 0.1, 0.0), Vec3::new(-0.4, 0.1, 0.0))),
    ));
    // Far away: nothing.
    let far = run(
        60.0,
        Some((blast, Vec3::new(5.0, 0.0, 0.0), Vec3::new(5.0, 0.0, 0.0))),
    );
    let still = run(60.0, None);
    let untouched = max_deviation(&far.1, &still.1);
    println!(
        "blast coming up on the left: tips {pushed:.4} m toward +x (60 vs 30 fps {d30:.5} m, 60 vs \
         144 fps {d144:.5} m); fan: tips {fanned:.4} m toward +x; a field 5 m away moved the hair \
         {untouched} m"
    );
    assert!(
        pushed > 0.01,
        "the blast did not push the hair away ({pushed} m)"
    );
    assert!(fanned > 0.01, "the fan did not blow the hair ({fanned} m)");
    assert!(
        d30 < 2e-3 && d144 < 2e-3,
        "frame rate changed the result: {d30} {d144}"
    );
    assert_eq!(untouched, 0.0, "a field out of reach moved the hair");
}

fn max_deviation(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> f32 {
    a.iter()
        .zip(b)
        .flat_map(|(s, t)| s.iter().zip(t).map(|(p, q)| p.distance(*q)))
        .fold(0.0, f32::max)
}

/// Once every hair is built, the Attach stage's sync points do not run; a new
/// hair brings them back for the frames it needs.
#[test]
fn the_attach_stage_has_no_sync_points_when_nothing_attaches() {
    let mut h = Harness::new(spiky_groom(10, 5), HairSimSettings::default(), 60.0);
    // Whether the frame `update` runs queued work for each sync point (bones, strands).
    let work = |h: &mut Harness| {
        let before = h.app.world().read_change_tick();
        h.update();
        let now = h.app.world().read_change_tick();
        let w = h.app.world().resource::<super::attach_work::AttachWork>();
        (
            w.bones.is_newer_than(before, now),
            w.strands.is_newer_than(before, now),
        )
    };
    assert_eq!(work(&mut h), (false, false), "steady state still syncs");
    let bone = h.bone;
    let groom = h.app.world().get::<Hair>(h.hair).unwrap().groom.clone();
    let second = h
        .app
        .world_mut()
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings::default(),
            AttachToBone::entity(bone),
        ))
        .id();
    assert_eq!(
        work(&mut h),
        (true, true),
        "a new hair must get its sync points"
    );
    assert!(h.app.world().get::<ComputedHair>(second).is_some());
    assert_eq!(work(&mut h), (false, false));
}

/// In steady state the step reuses every per-frame buffer (none is
/// reallocated across 60 frames), with colliders, friction, wind and a force field in play.
#[test]
fn a_steady_frame_reuses_the_step_buffers() {
    let mut h = Harness::new(spiky_groom(40, 6), one_margin(0.005), 60.0);
    h.app.insert_resource(HairWind {
        velocity: Vec3::new(3.0, 0.0, 0.0),
        ..default()
    });
    h.app.world_mut().spawn((
        HairCollider {
            capsules: vec![CollisionCapsule {
                a: Vec3::new(-0.2, 0.0, 0.0),
                b: Vec3::new(0.2, 0.0, 0.0),
                radius: 0.05,
            }],
            ..default()
        },
        Transform::from_translation(BONE + Vec3::new(0.0, -0.15, 0.0)),
    ));
    h.app.world_mut().spawn((
        HairForceField::default(),
        Transform::from_translation(BONE + Vec3::new(-0.5, 0.0, 0.0)),
    ));
    for _ in 0..10 {
        h.update();
    }
    let before = h.computed().scratch.footprint();
    for _ in 0..60 {
        h.update();
    }
    let after = h.computed().scratch.footprint();
    assert!(
        before.iter().any(|&(_, capacity)| capacity > 0),
        "the buffers were never filled"
    );
    assert_eq!(
        before, after,
        "a step buffer was reallocated in steady state"
    );
}

/// Hostile collider and field values (huge, NaN, zero, negative) never make a particle
/// non-finite and never panic: shapes with non-finite numbers are skipped, the rest are
/// clamped by the solver's own limits, and strands that still blow up are reset.
#[test]
fn hostile_colliders_and_fields_keep_the_hair_finite() {
    let mut h = Harness::new(spiky_groom(20, 6), HairSimSettings::default(), 60.0);
    let world = h.app.world_mut();
    world.spawn((
        HairCollider {
            spheres: vec![CollisionSphere {
                center: Vec3::ZERO,
                radius: 1e30,
            }],
            capsules: vec![CollisionCapsule {
                a: Vec3::splat(f32::MAX),
                b: Vec3::splat(-f32::MAX),
                radius: -1.0,
            }],
            planes: vec![CollisionPlane {
                point: Vec3::new(0.0, 1e20, 0.0),
                normal: Vec3::new(0.0, 1e-30, 0.0),
            }],
            boxes: vec![CollisionBox {
                center: Vec3::ZERO,
                half_extents: Vec3::new(f32::INFINITY, 0.0, -1.0),
                rotation: Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0),
            }],
            mode: HairColliderMode::Inside,
        },
        Transform::from_translation(BONE),
    ));
    world.spawn((
        HairForceField {
            speed: f32::INFINITY,
            radius: f32::NAN,
            drag: -5.0,
            ..default()
        },
        Transform::from_translation(BONE),
    ));
    world.spawn((
        HairForceField {
            speed: 1e30,
            radius: 1e30,
            drag: 1e30,
            ..default()
        },
        Transform::from_translation(BONE).with_scale(Vec3::splat(1e20)),
    ));
    for _ in 0..30 {
        h.update();
    }
    let strands = h.strands();
    assert!(
        strands.iter().flatten().all(|p| p.is_finite()),
        "a particle is not finite"
    );
}

/// Found by the solver fuzz target: a collider built in code with a sphere of negative radius
/// 100 km away, in inside mode, threw the hair 145 km off its head. Shapes of no size, far out
/// or with a zero plane normal are left out; the usable ones still act.
#[test]
fn colliders_of_no_size_or_far_out_are_left_out() {
    let mut h = Harness::new(spiky_groom(8, 5), HairSimSettings::default(), 60.0);
    h.app.world_mut().spawn((
        HairCollider {
            spheres: vec![
                CollisionSphere {
                    center: Vec3::new(0.0, -102_286.0, -102_287.0),
                    radius: -102_287.0,
                },
                CollisionSphere {
                    center: Vec3::splat(2e6),
                    radius: 1.0,
                },
            ],
            planes: vec![CollisionPlane {
                point: Vec3::new(0.0, 1.0, 0.0),
                normal: Vec3::ZERO,
            }],
            boxes: vec![CollisionBox {
                center: Vec3::ZERO,
                half_extents: Vec3::new(0.0, 1.0, 1.0),
                rotation: Quat::IDENTITY,
            }],
            mode: HairColliderMode::Inside,
            ..default()
        },
        ChildOf(h.bone),
    ));
    for _ in 0..60 {
        h.update();
    }
    let head = Vec3::new(0.0, 1.6, 0.0);
    let far = h
        .strands()
        .iter()
        .flatten()
        .map(|p| p.distance(head))
        .fold(0.0, f32::max);
    assert!(far < 0.5, "the hair went {far} m from the head");
    let usable = HairCollider {
        spheres: vec![
            CollisionSphere {
                center: Vec3::ZERO,
                radius: -1.0,
            },
            CollisionSphere {
                center: Vec3::ZERO,
                radius: 0.1,
            },
        ],
        planes: vec![CollisionPlane {
            point: Vec3::ZERO,
            normal: Vec3::ZERO,
        }],
        ..default()
    };
    assert_eq!(
        usable.shapes().count(),
        1,
        "only the sphere of radius 0.1 is used"
    );
}
