//! Eyes through the fringe: the ninja in its bangs, whose fringe covers the eyes, seen from the
//! front with the eyes marked [`ShowThroughHair`] (the demo marks its `eyes` material) and
//! without. The eyes are coloured magenta so their pixels are plain; the tone mapping is off so
//! the blend can be read back in linear colour.

use std::time::Duration;

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cartoon_hair::demo::{NinjaHairstyle, NinjaOrbit, NinjaScenePlugin, ninja_scene_ready};
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{SeenThroughOverlayMarker, ShowThroughHair};
use libtest_mimic::Failed;

use crate::toon_render::save;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "eyes_show_through_the_fringe_at_their_opacity_and_nowhere_else",
    eyes_show_through_the_fringe_at_their_opacity_and_nowhere_else,
)];

const MAGENTA: Color = Color::srgb(1.0, 0.0, 1.0);
const OPACITY: f32 = 0.6;

fn linear(c: u8) -> f32 {
    Color::srgb_u8(c, 0, 0).to_linear().red
}

fn is_magenta([r, g, b, _]: [u8; 4]) -> bool {
    r > 60 && b > 60 && u32::from(g) * 2 < u32::from(r.min(b))
}

/// The pixels where `a` and `b` differ by more than 2 levels in a channel.
fn differing(a: &CapturedFrame, b: &CapturedFrame) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for y in 0..a.height {
        for x in 0..a.width {
            let (p, q) = (a.pixel(x, y), b.pixel(x, y));
            if (0..3).any(|i| p[i].abs_diff(q[i]) > 2) {
                out.push((x, y));
            }
        }
    }
    out
}

fn set_eyes(r: &mut HeadlessRenderer, on: bool) {
    let world = r.app.world_mut();
    let mut eyes = world.query_filtered::<Entity, With<EyeMarker>>();
    let eyes: Vec<Entity> = eyes.iter(world).collect();
    for e in eyes {
        if on {
            world.entity_mut(e).insert(ShowThroughHair {
                opacity: OPACITY,
                ..default()
            });
        } else {
            world.entity_mut(e).remove::<ShowThroughHair>();
        }
    }
}

/// The eye meshes, remembered once the demo has marked them.
#[derive(Component)]
struct EyeMarker;

fn set_yaw(r: &mut HeadlessRenderer, yaw: f32) {
    let world = r.app.world_mut();
    let mut orbit = world.query::<&mut NinjaOrbit>();
    for mut o in orbit.iter_mut(world) {
        o.yaw = yaw;
    }
}

fn eyes_show_through_the_fringe_at_their_opacity_and_nowhere_else() -> Result<(), Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings {
        width: 640,
        height: 480,
        max_frames: 5_000,
        ..default()
    })?;
    r.app.add_plugins((
        CartoonHairPlugins,
        NinjaScenePlugin {
            target: Some(r.target()),
            preset: None,
            hairstyle: NinjaHairstyle::Bangs,
        },
    ));
    r.app
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    r.warm_up(|world| {
        ninja_scene_ready(world)
            && world
                .query_filtered::<(), With<SeenThroughOverlayMarker>>()
                .iter(world)
                .count()
                >= 1
    })?;
    crate::look_suite::settle_and_freeze(&mut r);
    let world = r.app.world_mut();
    // Magenta eyes (their own material), no tone mapping.
    let mut marked = world
        .query_filtered::<(Entity, &MeshMaterial3d<StandardMaterial>), With<ShowThroughHair>>();
    let eyes: Vec<(Entity, Handle<StandardMaterial>)> =
        marked.iter(world).map(|(e, m)| (e, m.0.clone())).collect();
    if eyes.is_empty() {
        return Err("the demo marked no eye meshes".into());
    }
    for (e, material) in &eyes {
        world.entity_mut(*e).insert(EyeMarker);
        if let Some(mut m) = world
            .resource_mut::<Assets<StandardMaterial>>()
            .get_mut(material)
        {
            m.base_color = MAGENTA;
            m.unlit = true;
        }
    }
    let mut cameras = world.query_filtered::<Entity, With<Camera3d>>();
    let cameras: Vec<Entity> = cameras.iter(world).collect();
    for c in cameras {
        world.entity_mut(c).insert(Tonemapping::None);
    }
    set_yaw(&mut r, 0.0);
    set_eyes(&mut r, false);
    let off = r.capture()?;
    set_eyes(&mut r, true);
    let on = r.capture()?;
    // From behind, nothing shows through the back of the head.
    set_yaw(&mut r, std::f32::consts::PI);
    let back_on = r.capture()?;
    set_eyes(&mut r, false);
    let back_off = r.capture()?;
    let world = r.app.world_mut();
    let overlays = world
        .query_filtered::<(), With<SeenThroughOverlayMarker>>()
        .iter(world)
        .count();
    // Where the eyes are on screen with no hair over them: the hair despawned.
    let mut hairs = world.query_filtered::<Entity, With<Hair>>();
    let hairs: Vec<Entity> = hairs.iter(world).collect();
    for e in hairs {
        world.entity_mut(e).despawn();
    }
    set_yaw(&mut r, 0.0);
    let bare = r.capture()?;
    save(&off, "see_through_off")?;
    save(&on, "see_through_on")?;
    save(&bare, "see_through_no_hair")?;

    let eye_px = bare.count(is_magenta);
    let open = off.count(is_magenta);
    // The overlay draws the eye's whole mesh, whose rim here sinks under the skin, so what
    // shows through the hair may be up to 3 px larger than the eye seen bare.
    let near_eye = |x: u32, y: u32| {
        (-3i32..=3).any(|dy| {
            (-3i32..=3).any(|dx| {
                let (px, py) = (x as i32 + dx, y as i32 + dy);
                px >= 0
                    && py >= 0
                    && (px as u32) < bare.width
                    && (py as u32) < bare.height
                    && is_magenta(bare.pixel(px as u32, py as u32))
            })
        })
    };
    let changed = differing(&off, &on);
    let stray: Vec<_> = changed.iter().filter(|&&(x, y)| !near_eye(x, y)).collect();
    // The blend read back where the change is whole (not the fade or an antialiased edge):
    // the least-squares share of magenta over the off pixel, in linear colour.
    let mut shares: Vec<f32> = changed
        .iter()
        .filter(|&&(x, y)| !is_magenta(off.pixel(x, y)))
        .map(|&(x, y)| {
            let (p, q) = (off.pixel(x, y), on.pixel(x, y));
            let m = [1.0, 0.0, 1.0];
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..3 {
                let (p, q) = (linear(p[i]), linear(q[i]));
                num += (q - p) * (m[i] - p);
                den += (m[i] - p) * (m[i] - p);
            }
            num / f32::max(den, 1e-6)
        })
        .collect();
    shares.sort_by(f32::total_cmp);
    let median = shares.get(shares.len() / 2).copied().unwrap_or(0.0);
    eprintln!(
        "eyes: {eye_px} px with no hair, {open} px open under the fringe; {} px change with \
         the eyes through the hair ({} away from the eyes), median blend {median:.3}",
        changed.len(),
        stray.len()
    );
    let mut failures = Vec::new();
    if eye_px < 100 {
        failures.push(format!(
            "the eyes cover {eye_px} px with no hair: not in view"
        ));
    }
    if eye_px.saturating_sub(open) < 50 {
        failures.push(format!(
            "the fringe covers {} of {eye_px} eye px: the bangs do not cover the eyes",
            eye_px.saturating_sub(open)
        ));
    }
    if changed.len() * 2 < eye_px.saturating_sub(open) {
        failures.push(format!(
            "only {} px show through, of {} eye px under the hair",
            changed.len(),
            eye_px - open
        ));
    }
    if !stray.is_empty() {
        failures.push(format!(
            "{} px changed away from the eyes, first {:?}",
            stray.len(),
            &stray[..stray.len().min(5)]
        ));
    }
    if (median - OPACITY).abs() > 0.06 {
        failures.push(format!(
            "the eyes blend at {median:.3}, not the opacity {OPACITY}"
        ));
    }
    let back = differing(&back_on, &back_off).len();
    if back > 0 {
        failures.push(format!("{back} px change from behind"));
    }
    if overlays > 0 {
        failures.push(format!("{overlays} overlays left with the setting removed"));
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("; ").into())
    }
}
