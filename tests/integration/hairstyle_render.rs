//! The ninja's long hairstyles in motion: through the idle animation's quick head shake
//! (+-25 degrees at 4 Hz), long hair stays outside the head, shoulders, chest and back, and
//! returns to its style afterwards.

use bevy::prelude::*;
use bevy_cartoon_hair::demo::{NinjaHairstyle, NinjaOrbit, NinjaScenePlugin, ninja_scene_ready};
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::sim::{ComputedHair, HairCollider, HairStrands, Strand, StrandParticles};
use libtest_mimic::Failed;

use crate::toon_render::save;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "long_hairstyles_stay_outside_the_body_through_a_head_shake",
    long_hairstyles_stay_outside_the_body_through_a_head_shake,
)];

const FRAME: f32 = 1.0 / 30.0;

/// The deepest any particle but a root lies inside a sphere or capsule of any collider
/// (metres; negative: the closest it comes to one from outside).
fn deepest(world: &mut World) -> f32 {
    let mut colliders = world.query::<(&HairCollider, &GlobalTransform)>();
    let shapes: Vec<(HairCollider, GlobalTransform)> = colliders
        .iter(world)
        .map(|(c, g)| (c.clone(), *g))
        .collect();
    let mut particles = world.query::<&StrandParticles>();
    let mut worst = f32::NEG_INFINITY;
    for strand in particles.iter(world) {
        for &p in strand.positions.iter().skip(1) {
            for (collider, global) in &shapes {
                let local = global.affine().inverse().transform_point3(p);
                for s in &collider.spheres {
                    worst = worst.max(s.radius - local.distance(s.center));
                }
                for c in &collider.capsules {
                    let ab = c.b - c.a;
                    let t = ((local - c.a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                    worst = worst.max(c.radius - local.distance(c.a + ab * t));
                }
            }
        }
    }
    worst
}

/// Mean distance of the strands' tips from their rest places (the groom carried by the head
/// bone), metres.
fn tip_error(world: &mut World) -> Result<f32, Failed> {
    let mut hairs = world.query::<(&Hair, &GlobalTransform, &HairStrands)>();
    let (hair, bone, strands) = hairs.single(world)?;
    let (groom, bone) = (hair.groom.clone(), *bone);
    let strands: Vec<Entity> = strands.iter().collect();
    let grooms = world.resource::<Assets<HairGroom>>();
    let groom = grooms.get(&groom).ok_or("the groom is not loaded")?;
    let rest: Vec<Vec3> = groom
        .strands()
        .map(|s| bone.transform_point(s[s.len() - 1]))
        .collect();
    let (mut sum, mut n) = (0.0, 0);
    for e in strands {
        let (Some(strand), Some(particles)) =
            (world.get::<Strand>(e), world.get::<StrandParticles>(e))
        else {
            continue;
        };
        if let (Some(tip), Some(rest)) =
            (particles.positions.last(), rest.get(strand.index as usize))
        {
            sum += tip.distance(*rest);
            n += 1;
        }
    }
    if n == 0 {
        return Err("no strand has particles".into());
    }
    Ok(sum / n as f32)
}

/// The long hair and the twin tails on the ninja, simulated at 30 fps through the first 4.5 s of
/// the idle animation: the quick head shake runs from 3.0 to 3.5 s. Over every frame no particle
/// but a root lies more than 3 mm inside the head's spheres or the shoulders', chest's and
/// back's capsules; a second after the shake the tips are back within 2 cm (or 1.5x) of how far
/// from their style they were just before it; and the head does shake (turns at least
/// [`HEAD_SHAKE_LEAST`] from its pose just before). Frames of the shake are saved
/// (`hairstyle_*`).
fn long_hairstyles_stay_outside_the_body_through_a_head_shake() -> Result<(), Failed> {
    let mut failures = Vec::new();
    for style in [NinjaHairstyle::Long, NinjaHairstyle::TwinTails] {
        let mut r = HeadlessRenderer::new(CaptureSettings {
            width: 240,
            height: 240,
            max_frames: 5_000,
            ..default()
        })?;
        r.app.add_plugins((
            CartoonHairPlugins,
            NinjaScenePlugin {
                target: Some(r.target()),
                preset: HairPreset::look("anime_locks").transpose()?,
                hairstyle: style,
            },
        ));
        // The clock stands still while the scene loads, so the idle animation (and its shake)
        // starts at 0 s in every run, however long loading takes.
        r.app
            .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
                std::time::Duration::ZERO,
            ));
        r.warm_up(ninja_scene_ready)?;
        let world = r.app.world_mut();
        let mut hairs = world.query::<(&GlobalTransform, &mut ComputedHair)>();
        for (bone, mut hair) in hairs.iter_mut(world) {
            hair.reset(bone);
        }
        let mut orbit = world.query::<&mut NinjaOrbit>();
        for mut o in orbit.iter_mut(world) {
            (o.yaw, o.distance, o.target) = (0.8, 1.6, Vec3::new(0.0, 1.5, 0.0));
        }
        let (mut worst, mut worst_at) = (f32::NEG_INFINITY, 0.0);
        let mut before = 0.0;
        let mut after = Vec::new();
        // How far the head turned in the shake from where it was just before.
        let (mut head_before, mut shook) = (Quat::IDENTITY, 0.0f32);
        for frame in 1..=135u32 {
            r.update_by(FRAME);
            let t = frame as f32 * FRAME;
            let world = r.app.world_mut();
            let depth = deepest(world);
            if depth > worst {
                (worst, worst_at) = (depth, t);
            }
            let head = head_rotation(world)?;
            if frame == 89 {
                before = tip_error(world)?;
                head_before = head;
            }
            if (90..=110).contains(&frame) {
                shook = shook.max(head.angle_between(head_before));
            }
            if frame >= 120 {
                after.push(tip_error(world)?);
            }
            if (88..=110).contains(&frame) && frame % 4 == 0 {
                let shot = r.capture()?;
                save(&shot, &format!("hairstyle_{}_{frame:03}", style.name()))?;
            }
        }
        let settled = *after.last().ok_or("no frame after the shake")?;
        if shook < HEAD_SHAKE_LEAST {
            failures.push(format!(
                "{}: the head turned only {:.1} degrees in the shake",
                style.name(),
                shook.to_degrees()
            ));
        }
        eprintln!(
            "{}: head turned {:.1} degrees in the shake; deepest particle {:.1} mm at {worst_at:.2} s; tips {:.1} mm from their rest \
             before the shake, at most {:.1} mm 0.5-1.0 s after it, {:.1} mm at 4.5 s",
            style.name(),
            shook.to_degrees(),
            1000.0 * worst,
            1000.0 * before,
            1000.0 * after.iter().copied().fold(0.0, f32::max),
            1000.0 * settled,
        );
        if worst > 0.003 {
            failures.push(format!(
                "{}: a particle {:.1} mm inside a collider at {worst_at:.2} s",
                style.name(),
                1000.0 * worst
            ));
        }
        if settled > (before * 1.5).max(before + 0.02) {
            failures.push(format!(
                "{}: tips {:.1} mm from their style after the shake, {:.1} mm before",
                style.name(),
                1000.0 * settled,
                1000.0 * before
            ));
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("\n").into())
    }
}

/// The least the head must turn in the idle animation's shake for the shake test to mean
/// anything, radians.
const HEAD_SHAKE_LEAST: f32 = 0.1;

/// The rotation of the bone the first hair hangs on.
fn head_rotation(world: &mut World) -> Result<Quat, Failed> {
    let mut hairs = world.query_filtered::<&GlobalTransform, With<ComputedHair>>();
    Ok(hairs
        .iter(world)
        .next()
        .ok_or("no hair")?
        .compute_transform()
        .rotation)
}
