//! The solver on hostile motion: any groom the checks accept, any bone motion (teleports, zero,
//! negative and NaN scales, NaN positions, unnormalised rotations), any time step (0 to 65 s)
//! and any collider shapes (NaN radii and normals included), stepped through the real plugin.
//!
//! Asserted after every frame: every particle is finite, and lies within `max_stretch` times
//! its strand's rest length (at the largest scale the bone has had) of its root, the root
//! being where the last bone transform the solver accepted puts it.
#![no_main]

use std::time::Duration;

use arbitrary::Arbitrary;
use bevy::asset::AssetPlugin;
use bevy::math::{Quat, Vec3};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cartoon_hair::HairSchedulePlugin;
use bevy_cartoon_hair::asset::{
    CollisionBox, CollisionCapsule, CollisionPlane, CollisionSphere, HairAssetPlugin, HairGroom,
};
use bevy_cartoon_hair::sim::{
    ComputedHair, Hair, HairCollider, HairColliderMode, HairSimSettings, HairSimulationPlugin,
    Strand, StrandParticles,
};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    strands: Vec<StrandShape>,
    stiffness: [u8; 4],
    damping: u8,
    stretch: u8,
    style_limit: Option<u8>,
    gravity: [i8; 3],
    shapes: Vec<Shape>,
    inside: bool,
    frames: Vec<Frame>,
}

#[derive(Arbitrary, Debug)]
struct StrandShape {
    /// Direction of the root on the scalp and of each segment, as small integers.
    root: [i8; 3],
    segments: Vec<[i8; 3]>,
}

#[derive(Arbitrary, Debug)]
enum Shape {
    Sphere([f32; 3], f32),
    Capsule([f32; 3], [f32; 3], f32),
    Plane([f32; 3], [f32; 3]),
    Box([f32; 3], [f32; 3], [f32; 4]),
}

#[derive(Arbitrary, Debug)]
struct Frame {
    translation: [f32; 3],
    rotation: [f32; 4],
    scale: Scale,
    /// Milliseconds.
    dt: u16,
}

#[derive(Arbitrary, Debug)]
enum Scale {
    One,
    Uniform(u8),
    Raw([f32; 3]),
}

const MAX_STRANDS: usize = 8;
const MAX_SEGMENTS: usize = 8;
const MAX_FRAMES: usize = 48;

fn v(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

fn groom(shapes: &[StrandShape]) -> Option<HairGroom> {
    let strands = shapes.iter().take(MAX_STRANDS).map(|s| {
        let dir = |d: [i8; 3]| Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32) / 127.0;
        let mut p = dir(s.root).normalize_or(Vec3::Y) * 0.1;
        let mut strand = vec![p];
        for d in s.segments.iter().take(MAX_SEGMENTS) {
            p += dir(*d) * 0.05;
            strand.push(p);
        }
        strand
    });
    HairGroom::from_strands("", strands).ok()
}

fn collider(input: &Input) -> HairCollider {
    let mut c = HairCollider {
        mode: if input.inside {
            HairColliderMode::Inside
        } else {
            HairColliderMode::Outside
        },
        ..default()
    };
    for s in input.shapes.iter().take(8) {
        match *s {
            Shape::Sphere(center, radius) => c.spheres.push(CollisionSphere {
                center: v(center),
                radius,
            }),
            Shape::Capsule(a, b, radius) => c.capsules.push(CollisionCapsule {
                a: v(a),
                b: v(b),
                radius,
            }),
            Shape::Plane(point, normal) => c.planes.push(CollisionPlane {
                point: v(point),
                normal: v(normal),
            }),
            Shape::Box(center, half, q) => c.boxes.push(CollisionBox {
                center: v(center),
                half_extents: v(half),
                rotation: Quat::from_array(q),
            }),
        }
    }
    c
}

/// How far from the bone's origin the collider's shapes reach (the solver's own rule for which
/// shapes it uses: finite, sizes above 0 and within 1e5, points within 1e5); `None` with a plane.
fn shapes_reach(c: &HairCollider) -> Option<f32> {
    let ok = |p: Vec3| p.is_finite() && p.abs().max_element() <= 1e5;
    let size = |r: f32| r > 0.0 && r <= 1e5;
    let mut far = 0.0f32;
    for s in &c.spheres {
        if ok(s.center) && size(s.radius) {
            far = far.max(s.center.length() + s.radius);
        }
    }
    for s in &c.capsules {
        if ok(s.a) && ok(s.b) && size(s.radius) {
            far = far.max(s.a.length().max(s.b.length()) + s.radius);
        }
    }
    for b in &c.boxes {
        let h = b.half_extents.abs();
        if ok(b.center) && size(h.min_element()) && size(h.max_element()) {
            far = far.max(b.center.length() + h.length());
        }
    }
    let plane = c
        .planes
        .iter()
        .any(|p| ok(p.point) && p.normal.is_finite() && p.normal.length_squared() > 0.0);
    (!plane).then_some(far)
}

fn transform(f: &Frame) -> Transform {
    let q = Quat::from_array(f.rotation);
    let rotation = if q.is_finite() && q.length() > 1e-3 {
        q.normalize()
    } else {
        q
    };
    let scale = match f.scale {
        Scale::One => Vec3::ONE,
        Scale::Uniform(s) => Vec3::splat(s as f32 / 64.0),
        Scale::Raw(s) => v(s),
    };
    Transform {
        translation: v(f.translation),
        rotation,
        scale,
    }
}

/// The solver's rule for a bone it follows (`usable_frame`): finite, invertible, within 1e6 m
/// of the origin, axis scales within 1e-4..=1e3.
fn usable(m: &bevy::math::Affine3A) -> bool {
    let axes = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    m.is_finite()
        && m.translation.abs().max_element() <= 1e6
        && axes.iter().all(|a| (1e-4..=1e3).contains(&a.length()))
        && m.matrix3.determinant().abs() > 1e-12
}

fuzz_target!(|input: Input| {
    if std::env::var_os("FUZZ_PRINT").is_some() {
        eprintln!("{input:#?}");
    }
    let Some(groom) = groom(&input.strands) else {
        return;
    };
    let unit = |b: u8| b as f32 / 255.0;
    let settings = HairSimSettings {
        edge_stiffness: unit(input.stiffness[0]),
        bend_stiffness: unit(input.stiffness[1]),
        torsion_stiffness: unit(input.stiffness[2]),
        anchor_stiffness: bevy_cartoon_hair::curve::QuadraticCurve::constant(unit(
            input.stiffness[3],
        )),
        damping: unit(input.damping),
        max_stretch: 1.0 + input.stretch as f32 / 64.0,
        style_limit: input.style_limit.map(|l| l as f32 / 255.0),
        gravity: Vec3::new(
            input.gravity[0] as f32,
            input.gravity[1] as f32,
            input.gravity[2] as f32,
        ) / 4.0,
        ..default()
    };
    let max_stretch = settings.max_stretch;
    // What the solver bounds: with loose edges (stiffness 0) the particles are unconnected and
    // fall freely (only finiteness is asserted); a plane may push a particle anywhere on its side.
    // Otherwise each particle stays within max_stretch times its rest length along the strand of
    // its root, or, pushed by a collider, within that collider's reach from the bone.
    let connected = input.stiffness[0] > 0;
    let collider = collider(&input);
    let reach_of_shapes = shapes_reach(&collider);
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
    ));
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(
        16,
    )));
    let world = app.world_mut();
    let handle = world.resource_mut::<Assets<HairGroom>>().add(groom.clone());
    let bone = world.spawn(Transform::from_xyz(0.0, 1.6, 0.0)).id();
    let hair = world
        .spawn((
            Hair {
                groom: handle,
                animation: None,
                collision: None,
            },
            settings,
            ChildOf(bone),
        ))
        .id();
    world.spawn((collider, ChildOf(bone)));
    app.update();
    app.update();
    // Rest length from the root to each particle, in groom units.
    let reach: Vec<Vec<f32>> = groom
        .strands()
        .map(|s| {
            let mut d = 0.0;
            let mut out = vec![0.0];
            for w in s.windows(2) {
                d += w[0].distance(w[1]);
                out.push(d);
            }
            out
        })
        .collect();
    let mut accepted;
    let mut largest_scale = 1.0f32;
    let mut invalid = 0;
    for f in input.frames.iter().take(MAX_FRAMES) {
        *app.world_mut().get_mut::<Transform>(bone).unwrap() = transform(f);
        app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(
            u64::from(f.dt),
        )));
        app.update();
        let mut q = app.world_mut().query::<(&Strand, &StrandParticles)>();
        for (strand, particles) in q.iter(app.world()) {
            for (k, p) in particles.positions.iter().enumerate() {
                assert!(
                    p.is_finite(),
                    "strand {} particle {k} is {p} after {f:?}",
                    strand.index
                );
            }
        }
        let Some(computed) = app.world().get::<ComputedHair>(hair) else {
            // Not built (yet): nothing more to check.
            continue;
        };
        let now = app.world().get::<GlobalTransform>(hair).unwrap().affine();
        let stepped = computed.stats.invalid_bone_frames == invalid;
        invalid = computed.stats.invalid_bone_frames;
        // A frame of no time steps nothing (paused hair stays where it was, as the bone moves),
        // and a bone the solver refuses is not followed: neither moves the reference.
        if f.dt == 0 || !stepped || !usable(&now) {
            continue;
        }
        {
            accepted = now;
            let m = accepted.matrix3;
            largest_scale = largest_scale
                .max(m.x_axis.length())
                .max(m.y_axis.length())
                .max(m.z_axis.length());
        }
        let mut q = app.world_mut().query::<(&Strand, &StrandParticles)>();
        for (strand, particles) in q.iter(app.world()) {
            let s = strand.index as usize;
            let root = accepted.transform_point3(groom.strand(s)[0]);
            for (k, p) in particles.positions.iter().enumerate() {
                let Some(shapes) = reach_of_shapes else {
                    continue;
                };
                if !connected {
                    continue;
                }
                let root_out = groom.strand(s)[0].length();
                let bound =
                    (reach[s][k] * max_stretch * 1.01 + root_out + shapes) * largest_scale + 1e-3;
                let d = p.distance(root);
                assert!(
                    d <= bound || !root.is_finite(),
                    "strand {s} particle {k}: {d} m from its root, bound {bound} m, after {f:?}"
                );
            }
        }
    }
});
