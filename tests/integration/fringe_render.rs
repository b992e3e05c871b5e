//! The fringe shadow: a fringe of hair (drawn with the toon hair material, whose prepass marks
//! the hair mask) over a face (a `StandardMaterial` extended with `FringeShadow`). Rendered with
//! the shadow on and off, the face pixels that change are the shadow: it must lie under the
//! fringe, move when the light moves, keep its width in scene units when the camera moves away
//! or the image is larger, and never touch the hair.

use bevy::camera::RenderTarget;
use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
use bevy::pbr::ExtendedMaterial;
use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{FringeShadow, FringeShadowMaterial};
use libtest_mimic::Failed;

use crate::toon_render::save;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "the_fringe_throws_a_toned_shadow_of_constant_width_on_the_face",
        the_fringe_throws_a_toned_shadow_of_constant_width_on_the_face,
    ),
    (
        "a_cel_shaded_face_takes_two_flat_tones_and_the_fringe_shadow",
        a_cel_shaded_face_takes_two_flat_tones_and_the_fringe_shadow,
    ),
    (
        "a_cut_out_fringe_throws_no_shadow_through_its_holes",
        a_cut_out_fringe_throws_no_shadow_through_its_holes,
    ),
];

/// The fringe: a box, or a card (the box's front face) painted opaque on its left half and
/// with alpha 0 on its right, drawn cut out at 0.5 or opaque.
#[derive(Clone, Copy, PartialEq)]
enum Fringe {
    Box,
    Card { cut: bool },
}

/// The shadow's width in the scene (metres).
const WIDTH: f32 = 0.02;

struct Scene {
    renderer: HeadlessRenderer,
    face: Handle<FringeShadowMaterial>,
    light: Entity,
    camera: Entity,
}

fn scene(width: u32, height: u32) -> Result<Scene, Failed> {
    scene_with(width, height, Fringe::Box)
}

fn scene_with(width: u32, height: u32, fringe: Fringe) -> Result<Scene, Failed> {
    let mut renderer = HeadlessRenderer::new(CaptureSettings {
        width,
        height,
        max_frames: 500,
        ..default()
    })?;
    let target = renderer.target();
    let app = &mut renderer.app;
    app.add_plugins(CartoonHairPlugins);
    let world = app.world_mut();
    let ramp = world.resource::<ToonRamps>().three_tone.clone();
    let mut hair = ToonHairMaterial::new(
        ToonShading {
            base_color: Color::srgb(0.2, 0.25, 0.6),
            ..default()
        },
        ramp,
    );
    if let Fringe::Card { cut } = fringe {
        // White and opaque on the left half, alpha 0 on the right.
        let paint = Image::new(
            bevy::render::render_resource::Extent3d {
                width: 4,
                height: 1,
                depth_or_array_layers: 1,
            },
            bevy::render::render_resource::TextureDimension::D2,
            [
                [255, 255, 255, 255],
                [255, 255, 255, 255],
                [255, 255, 255, 0],
                [255, 255, 255, 0],
            ]
            .concat(),
            bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
            bevy::asset::RenderAssetUsages::default(),
        );
        hair.base_color_texture = Some(world.resource_mut::<Assets<Image>>().add(paint));
        hair.double_sided = true;
        hair.alpha_cutoff = cut.then_some(0.5);
    }
    let hair = world.resource_mut::<Assets<ToonHairMaterial>>().add(hair);
    let face = world
        .resource_mut::<Assets<FringeShadowMaterial>>()
        .add(ExtendedMaterial {
            base: StandardMaterial {
                base_color: Color::srgb(0.95, 0.8, 0.7),
                perceptual_roughness: 1.0,
                ..default()
            },
            extension: FringeShadow {
                width: WIDTH,
                ..default()
            },
        });
    let mut meshes = world.resource_mut::<Assets<Mesh>>();
    let sphere = meshes.add(Sphere::new(0.1).mesh().uv(48, 32));
    // Narrower than the face, so a light from the side shows the shadow past its end.
    let (fringe, z) = match fringe {
        Fringe::Box => (meshes.add(Cuboid::new(0.12, 0.05, 0.02)), 0.1),
        Fringe::Card { .. } => (meshes.add(Rectangle::new(0.12, 0.05)), 0.11),
    };
    world.spawn((Mesh3d(sphere), MeshMaterial3d(face.clone())));
    world.spawn((
        Mesh3d(fringe),
        MeshMaterial3d(hair),
        Transform::from_xyz(0.0, 0.05, z),
    ));
    let light = world
        .spawn((
            DirectionalLight {
                illuminance: 8_000.0,
                ..default()
            },
            Transform::from_xyz(0.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
        ))
        .id();
    let camera = world
        .spawn((
            Camera3d::default(),
            RenderTarget::Image(target.into()),
            Msaa::Off,
            DepthPrepass,
            NormalPrepass,
            Transform::from_xyz(0.0, 0.0, 0.6).looking_at(Vec3::ZERO, Vec3::Y),
        ))
        .id();
    renderer.warm_up(|_| true)?;
    Ok(Scene {
        renderer,
        face,
        light,
        camera,
    })
}

impl Scene {
    /// Changes the face's fringe shadow.
    fn edit_face(&mut self, edit: impl FnOnce(&mut FringeShadow)) -> Result<(), Failed> {
        let mut materials = self
            .renderer
            .app
            .world_mut()
            .resource_mut::<Assets<FringeShadowMaterial>>();
        let mut face = materials.get_mut(&self.face).ok_or("face material")?;
        edit(&mut face.extension);
        Ok(())
    }

    /// Cel shading on the face, or Bevy's PBR shading.
    fn set_cel(&mut self, cel: bool) -> Result<(), Failed> {
        self.edit_face(|f| f.cel = cel)
    }

    /// A frame with the shadow at `strength`.
    fn frame(&mut self, strength: f32) -> Result<CapturedFrame, Failed> {
        self.edit_face(|f| f.strength = strength)?;
        for _ in 0..3 {
            self.renderer.update();
        }
        Ok(self.renderer.capture()?)
    }

    /// The shadow: pixels that change when it is turned on.
    fn shadow(&mut self) -> Result<Shadow, Failed> {
        let on = self.frame(1.0)?;
        let off = self.frame(0.0)?;
        Ok(Shadow::between(&off, &on))
    }
}

/// The pixels the shadow changed, and the fringe (hair-blue) pixels.
struct Shadow {
    width: u32,
    height: u32,
    changed: Vec<bool>,
    hair: Vec<bool>,
    hair_changed: usize,
    on: CapturedFrame,
}

fn is_fringe([r, g, b, _]: [u8; 4]) -> bool {
    u16::from(b) > u16::from(r) + 30 && b > g
}

impl Shadow {
    fn between(off: &CapturedFrame, on: &CapturedFrame) -> Self {
        let (w, h) = (off.width, off.height);
        let mut changed = vec![false; (w * h) as usize];
        let mut hair = vec![false; (w * h) as usize];
        let mut hair_changed = 0;
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (off.pixel(x, y), on.pixel(x, y));
                let d = (0..3)
                    .map(|k| i32::from(a[k]).abs_diff(i32::from(b[k])))
                    .max()
                    .unwrap_or(0);
                let i = (y * w + x) as usize;
                hair[i] = is_fringe(a);
                changed[i] = d > 12;
                if hair[i] && d > 2 {
                    hair_changed += 1;
                }
            }
        }
        Self {
            width: w,
            height: h,
            changed,
            hair,
            hair_changed,
            on: on.clone(),
        }
    }

    fn count(&self) -> usize {
        self.changed.iter().filter(|c| **c).count()
    }

    /// Mean position of the changed pixels.
    fn centroid(&self) -> Vec2 {
        let mut sum = Vec2::ZERO;
        let mut n: f32 = 0.0;
        for y in 0..self.height {
            for x in 0..self.width {
                if self.changed[(y * self.width + x) as usize] {
                    sum += Vec2::new(x as f32, y as f32);
                    n += 1.0;
                }
            }
        }
        sum / n.max(1.0)
    }

    /// Rows of shadow in the middle column below the fringe's lowest pixel there.
    fn band_below_fringe(&self) -> (u32, u32) {
        let x = self.width / 2;
        let bottom = (0..self.height)
            .filter(|y| self.hair[(y * self.width + x) as usize])
            .max()
            .unwrap_or(0);
        let rows = (bottom + 1..self.height)
            .filter(|y| self.changed[(y * self.width + x) as usize])
            .count() as u32;
        (bottom, rows)
    }
}

fn the_fringe_throws_a_toned_shadow_of_constant_width_on_the_face() -> Result<(), Failed> {
    let mut near = scene(320, 240)?;
    let base = near.shadow()?;
    // The light from the upper left instead of above.
    near.renderer
        .app
        .world_mut()
        .entity_mut(near.light)
        .insert(Transform::from_xyz(-1.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y));
    let moved = near.shadow()?;
    near.renderer
        .app
        .world_mut()
        .entity_mut(near.light)
        .insert(Transform::from_xyz(0.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y));
    // The camera twice as far.
    near.renderer
        .app
        .world_mut()
        .entity_mut(near.camera)
        .insert(Transform::from_xyz(0.0, 0.0, 1.2).looking_at(Vec3::ZERO, Vec3::Y));
    let far = near.shadow()?;
    let mut large = scene(640, 480)?;
    let big = large.shadow()?;
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        let dir = std::path::Path::new(&dir);
        base.on.save_png(dir.join("fringe_shadow.png"))?;
        moved
            .on
            .save_png(dir.join("fringe_shadow_light_left.png"))?;
        far.on.save_png(dir.join("fringe_shadow_far.png"))?;
        big.on.save_png(dir.join("fringe_shadow_640.png"))?;
    }
    let (fringe_bottom, rows) = base.band_below_fringe();
    let (_, far_rows) = far.band_below_fringe();
    let (_, big_rows) = big.band_below_fringe();
    let (c, m) = (base.centroid(), moved.centroid());
    // The face under the fringe is about 0.51 m from the camera; with a 45-degree field of view
    // 240 rows span 0.43 m there: 2 cm is 11.3 rows.
    let expected = WIDTH / (2.0 * 0.515 * (std::f32::consts::FRAC_PI_8).tan()) * 240.0;
    println!(
        "fringe shadow: {} px ({rows} rows below the fringe's edge at row {fringe_bottom}, \
         expected about {expected:.1}); light moved left: centroid {c} -> {m}; camera twice as \
         far: {far_rows} rows; 640x480: {big_rows} rows; hair pixels changed: {}, {}, {}, {}",
        base.count(),
        base.hair_changed,
        moved.hair_changed,
        far.hair_changed,
        big.hair_changed
    );
    if base.count() < 200 {
        return Err(format!("only {} face pixels shaded", base.count()).into());
    }
    if (rows as f32 - expected).abs() > 0.25 * expected {
        return Err(format!("{rows} rows of shadow, expected about {expected:.1}").into());
    }
    // The shadow lies below the fringe (screen y grows downward).
    if c.y <= fringe_bottom as f32 - 4.0 {
        return Err(
            format!("shadow centroid {c} is not below the fringe's edge {fringe_bottom}").into(),
        );
    }
    // Light from the left: the shadow falls to the right.
    if m.x < c.x + 3.0 {
        return Err(
            format!("the light moved left but the shadow did not move right: {c} -> {m}").into(),
        );
    }
    // Width in scene units: half the rows at twice the distance, twice the rows at twice the
    // resolution (within two rows for rounding at the edges).
    if (far_rows as f32 - rows as f32 / 2.0).abs() > 2.0 {
        return Err(format!("{far_rows} rows at twice the distance, from {rows}").into());
    }
    if (big_rows as f32 - rows as f32 * 2.0).abs() > 2.0 {
        return Err(format!("{big_rows} rows at 640x480, from {rows}").into());
    }
    let hair_changed = base.hair_changed + moved.hair_changed + far.hair_changed + big.hair_changed;
    if hair_changed > 0 {
        return Err(format!("the shadow changed {hair_changed} hair pixels").into());
    }
    Ok(())
}

/// The face's pixels (neither the fringe nor the background) and the share of them within 8
/// levels of its two main tones (the most common colour, and the most common one more than 8
/// levels from it: the frame's dither splits a flat tone into neighbouring levels).
fn face_tones(frame: &CapturedFrame) -> (usize, f32) {
    let mut count = std::collections::HashMap::new();
    let mut face = Vec::new();
    for y in 0..frame.height {
        for x in 0..frame.width {
            let p = frame.pixel(x, y);
            // The face is a warm skin tone; the fringe is blue, the background dark.
            if !is_fringe(p) && p[0] > 40 && p[0] >= p[2] {
                *count.entry(p).or_insert(0usize) += 1;
                face.push(p);
            }
        }
    }
    let near = |a: [u8; 4], b: [u8; 4]| (0..3).all(|k| a[k].abs_diff(b[k]) <= 8);
    let mut counts: Vec<([u8; 4], usize)> = count.into_iter().collect();
    counts.sort_unstable_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let Some(&(first, _)) = counts.first() else {
        return (0, 0.0);
    };
    let second = counts
        .iter()
        .find(|(c, _)| !near(*c, first))
        .map(|(c, _)| *c);
    let flat = face
        .iter()
        .filter(|p| near(**p, first) || second.is_some_and(|s| near(**p, s)))
        .count();
    (face.len(), flat as f32 / face.len().max(1) as f32)
}

/// `FringeShadow::cel`: the face under a light from above is drawn in two flat tones (its base
/// colour lit, times the shade tone where the light turns away), not PBR's gradient, and still
/// takes the fringe's shadow below the fringe.
fn a_cel_shaded_face_takes_two_flat_tones_and_the_fringe_shadow() -> Result<(), Failed> {
    let mut s = scene(320, 240)?;
    let pbr = s.frame(0.0)?;
    s.set_cel(true)?;
    let shadow = s.shadow()?;
    let cel = s.frame(0.0)?;
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        let dir = std::path::Path::new(&dir);
        pbr.save_png(dir.join("face_pbr.png"))?;
        shadow.on.save_png(dir.join("face_cel.png"))?;
    }
    let (pbr_face, pbr_flat) = face_tones(&pbr);
    let (cel_face, cel_flat) = face_tones(&cel);
    let (fringe_bottom, rows) = shadow.band_below_fringe();
    println!(
        "face: PBR {pbr_face} px, {:.1}% in its 2 main tones; cel {cel_face} px, {:.1}%; the \
         fringe's shadow on the cel face: {} px, {rows} rows below the fringe (row \
         {fringe_bottom}); hair pixels changed {}",
        100.0 * pbr_flat,
        100.0 * cel_flat,
        shadow.count(),
        shadow.hair_changed
    );
    if cel_face < 2_000 || (cel_face as f32) < 0.8 * pbr_face as f32 {
        return Err(format!("the cel face shows {cel_face} px against PBR's {pbr_face}").into());
    }
    if cel_flat < 0.9 {
        return Err(format!("only {cel_flat} of the cel face in two tones").into());
    }
    if pbr_flat > 0.7 {
        return Err(format!("PBR shading drew {pbr_flat} of the face in two tones").into());
    }
    if shadow.count() < 200 || rows == 0 || shadow.hair_changed > 0 {
        return Err(format!(
            "the cel face's fringe shadow: {} px, {rows} rows, {} hair px changed",
            shadow.count(),
            shadow.hair_changed
        )
        .into());
    }
    Ok(())
}

/// A card of a fringe whose right half is cut away (its texture's alpha 0, cut at 0.5): the
/// face takes the fringe's shadow under the left half only. Drawn opaque, the same card shades
/// the face under both halves. Shadow pixels right of the card's middle (past 4 px, where the
/// cut edge's own shadow ends): cut out at most a twentieth of those of the opaque card, which
/// has at least 200; under the left half both have shadow.
fn a_cut_out_fringe_throws_no_shadow_through_its_holes() -> Result<(), Failed> {
    let mut sides = Vec::new();
    for cut in [false, true] {
        let mut s = scene_with(320, 240, Fringe::Card { cut })?;
        let shadow = s.shadow()?;
        save(&shadow.on, &format!("fringe_card_cut_{cut}"))?;
        let middle = shadow.width / 2;
        let (mut left, mut right) = (0, 0);
        for y in 0..shadow.height {
            for x in 0..shadow.width {
                if shadow.changed[(y * shadow.width + x) as usize] {
                    if x + 4 < middle {
                        left += 1;
                    } else if x > middle + 4 {
                        right += 1;
                    }
                }
            }
        }
        sides.push((left, right));
    }
    eprintln!(
        "fringe card shadow pixels (left of the middle, right): opaque {:?}, cut out {:?}",
        sides[0], sides[1]
    );
    let ((open_left, open_right), (cut_left, cut_right)) = (sides[0], sides[1]);
    if open_left < 200 || open_right < 200 || cut_left < 200 || cut_right * 20 > open_right {
        return Err(format!(
            "shadow pixels (left, right): opaque {:?}, cut {:?}",
            sides[0], sides[1]
        )
        .into());
    }
    Ok(())
}
