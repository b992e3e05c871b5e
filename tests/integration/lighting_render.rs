//! Render tests of `ToonLighting::Scene`: the toon ramp lit by every Bevy light, with shadows.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::ToonLighting;
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, ramps, save, scene, spawn_strand};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "scene_lighting_ignores_a_far_light_and_sees_a_near_one",
        scene_lighting_ignores_a_far_light_and_sees_a_near_one,
    ),
    (
        "scene_lighting_darkens_where_a_shadow_falls",
        scene_lighting_darkens_where_a_shadow_falls,
    ),
    (
        "scene_lighting_takes_the_light_colour",
        scene_lighting_takes_the_light_colour,
    ),
    (
        "scene_lighting_darkens_under_a_point_light_shadow",
        scene_lighting_darkens_under_a_point_light_shadow,
    ),
    (
        "scene_lighting_darkens_under_a_spot_light_shadow",
        scene_lighting_darkens_under_a_spot_light_shadow,
    ),
];

/// A thick horizontal strand across the view, shaded by every light of the scene.
fn lit_strand(r: &mut HeadlessRenderer) {
    let ramp = ramps(r).three_tone;
    spawn_strand(
        r,
        Vec3::new(-1.2, 0.0, 0.0),
        Vec3::new(1.2, 0.0, 0.0),
        0.35,
        ToonHairMaterial::new(
            ToonShading {
                lighting: ToonLighting::Scene,
                full_light_lux: 5_000.0,
                ..default()
            },
            ramp,
        ),
    );
}

/// The hair's pixels in columns `x0..x1`.
fn hair(frame: &CapturedFrame, x0: u32, x1: u32) -> Vec<[u8; 4]> {
    let mut v = Vec::new();
    for y in 0..frame.height {
        for x in x0..x1.min(frame.width) {
            let p = frame.pixel(x, y);
            if p != BACKGROUND {
                v.push(p);
            }
        }
    }
    v
}

fn mean(pixels: &[[u8; 4]], channel: usize) -> f32 {
    pixels.iter().map(|p| f32::from(p[channel])).sum::<f32>() / pixels.len().max(1) as f32
}

fn mean_luma(pixels: &[[u8; 4]]) -> f32 {
    0.299 * mean(pixels, 0) + 0.587 * mean(pixels, 1) + 0.114 * mean(pixels, 2)
}

/// Mean luma of the hair's right half minus its left half (a 20 px strip in the middle left out).
fn halves_gap(frame: &CapturedFrame) -> f32 {
    let w = frame.width;
    mean_luma(&hair(frame, w / 2 + 20, w)) - mean_luma(&hair(frame, 0, w / 2 - 20))
}

/// A grey board (a flat box of `size`) at `at`: a shadow caster.
fn spawn_board(r: &mut HeadlessRenderer, size: Vec3, at: Vec3) {
    let world = r.app.world_mut();
    let mesh = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::from_size(size));
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::default());
    world.spawn((
        Mesh3d(mesh),
        MeshMaterial3d(material),
        Transform::from_translation(at),
    ));
}

/// Pixels that differ by more than 2 levels in any channel.
fn changed(a: &CapturedFrame, b: &CapturedFrame) -> usize {
    a.rgba
        .chunks_exact(4)
        .zip(b.rgba.chunks_exact(4))
        .filter(|(p, q)| (0..3).any(|i| p[i].abs_diff(q[i]) > 2))
        .count()
}

/// A point light 200 m away (beyond its range, and far too weak there) leaves the picture as
/// it was; the same light 1 m in front of the strand changes it.
fn scene_lighting_ignores_a_far_light_and_sees_a_near_one() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
    lit_strand(&mut r);
    let before = r.capture()?;
    let hair_pixels = hair(&before, 0, before.width).len();
    if hair_pixels < 2000 {
        return Err(format!("only {hair_pixels} hair pixels rendered").into());
    }
    let light = r
        .app
        .world_mut()
        .spawn((PointLight::default(), Transform::from_xyz(200.0, 0.0, 0.0)))
        .id();
    let far = r.capture()?;
    save(&far, "scene_lighting_far_light")?;
    let far_changed = changed(&before, &far);
    r.app
        .world_mut()
        .entity_mut(light)
        .insert(Transform::from_xyz(0.3, -0.6, 1.0));
    let near = r.capture()?;
    save(&near, "scene_lighting_near_light")?;
    let near_changed = changed(&before, &near);
    println!(
        "scene lighting: {far_changed} of {hair_pixels} hair pixels changed by a light 200 m \
         away, {near_changed} by the same light 1 m away"
    );
    if far_changed != 0 {
        return Err(format!("a light 200 m away changed {far_changed} pixels").into());
    }
    if near_changed < hair_pixels / 10 {
        return Err(format!("a light 1 m away changed only {near_changed} pixels").into());
    }
    Ok(())
}

/// A board above the left half of the strand, out of view, shadows it from the light overhead:
/// the left half turns darker than the right, which it was not before.
fn scene_lighting_darkens_where_a_shadow_falls() -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 3.0))?;
    {
        let world = r.app.world_mut();
        let mut lights = world.query::<&mut DirectionalLight>();
        for mut light in lights.iter_mut(world) {
            light.shadow_maps_enabled = true;
        }
    }
    lit_strand(&mut r);
    let open = r.capture()?;
    save(&open, "scene_lighting_no_shadow")?;
    let open_gap = halves_gap(&open);
    spawn_board(&mut r, Vec3::new(1.6, 0.05, 1.6), Vec3::new(-0.9, 2.5, 0.0));
    let shaded = r.capture()?;
    save(&shaded, "scene_lighting_shadow")?;
    let shaded_gap = halves_gap(&shaded);
    println!(
        "scene lighting: right minus left half, mean luma: {open_gap:.1} without the board, \
         {shaded_gap:.1} with its shadow on the left"
    );
    if open_gap.abs() > 3.0 {
        return Err(format!("the halves differ by {open_gap} before any shadow").into());
    }
    if shaded_gap < 15.0 {
        return Err(format!("the shadow darkened the left half by only {shaded_gap}").into());
    }
    Ok(())
}

/// A red light makes the hair redder than a white light of the same illuminance does.
fn scene_lighting_takes_the_light_colour() -> Result<(), Failed> {
    let ratio = |color: Color| -> Result<f32, Failed> {
        let mut r = scene(Vec3::new(0.0, 1.0, 0.6), Vec3::new(0.0, 0.0, 3.0))?;
        {
            let world = r.app.world_mut();
            let mut lights = world.query::<&mut DirectionalLight>();
            for mut light in lights.iter_mut(world) {
                light.color = color;
            }
        }
        lit_strand(&mut r);
        let frame = r.capture()?;
        let pixels = hair(&frame, 0, frame.width);
        Ok(mean(&pixels, 0) / mean(&pixels, 1).max(1.0))
    };
    let white = ratio(Color::WHITE)?;
    let red = ratio(Color::srgb(1.0, 0.55, 0.55))?;
    println!("scene lighting: red / green of the hair {white:.2} under white, {red:.2} under red");
    if red < white * 1.2 {
        return Err(format!("red light: red/green {red} vs {white} under white").into());
    }
    Ok(())
}

/// About 5,000 lux on the strand's top from a lamp 4 m up, 3.65 m above it: a point light's
/// intensity of 4 pi * 5,000 * 3.65^2 lumens (Bevy's spot light is measured the same way).
const LAMP_LUMENS: f32 = 4.0 * std::f32::consts::PI * 5_000.0 * 3.65 * 3.65;

/// A lamp's shadow map darkens the hair it shadows: the sun off, `lamp` 4 m above the lit strand,
/// then a board between them whose shadow falls on the left half (x = -1.17..-0.15). The left
/// half must darken by at least 10 luma against the right.
fn lamp_shadow_darkens_hair(name: &str, lamp: impl Bundle) -> Result<(), Failed> {
    let mut r = scene(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.0, 3.0))?;
    {
        let world = r.app.world_mut();
        let mut suns = world.query::<&mut DirectionalLight>();
        for mut sun in suns.iter_mut(world) {
            sun.illuminance = 0.0;
        }
        world.spawn(lamp);
    }
    lit_strand(&mut r);
    let open = r.capture()?;
    let lit = open.count(|p| p != BACKGROUND);
    if lit < 5000 {
        return Err(format!("the {name} light shows only {lit} hair pixels").into());
    }
    let open_gap = halves_gap(&open);
    spawn_board(
        &mut r,
        Vec3::new(0.7, 0.05, 1.0),
        Vec3::new(-0.45, 1.5, 0.0),
    );
    let shaded = r.capture()?;
    save(&shaded, &format!("scene_lighting_{name}_shadow"))?;
    let shaded_gap = halves_gap(&shaded);
    println!(
        "scene lighting, {name} light: right minus left half, mean luma: {open_gap:.1} without \
         the board, {shaded_gap:.1} with its shadow on the left"
    );
    if shaded_gap < open_gap + 10.0 {
        return Err(format!(
            "the {name} light's shadow darkened the left half by only {}",
            shaded_gap - open_gap
        )
        .into());
    }
    Ok(())
}

/// A point light's cube shadow map darkens the hair it shadows.
fn scene_lighting_darkens_under_a_point_light_shadow() -> Result<(), Failed> {
    lamp_shadow_darkens_hair(
        "point",
        (
            PointLight {
                intensity: LAMP_LUMENS,
                range: 10.0,
                shadow_maps_enabled: true,
                ..default()
            },
            Transform::from_xyz(0.0, 4.0, 0.0),
        ),
    )
}

/// A spot light's shadow map darkens the hair it shadows: the same lamp as a cone pointing down.
fn scene_lighting_darkens_under_a_spot_light_shadow() -> Result<(), Failed> {
    lamp_shadow_darkens_hair(
        "spot",
        (
            SpotLight {
                intensity: LAMP_LUMENS,
                range: 10.0,
                outer_angle: 0.9,
                inner_angle: 0.8,
                shadow_maps_enabled: true,
                ..default()
            },
            Transform::from_xyz(0.0, 4.0, 0.0).looking_at(Vec3::ZERO, Vec3::Z),
        ),
    )
}
