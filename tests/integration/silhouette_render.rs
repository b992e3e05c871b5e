//! Render tests of object-space silhouette strokes.

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_cartoon_hair::asset::HairGroom;
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "strokes_outline_the_boundary_not_the_face",
        strokes_outline_the_boundary_not_the_face,
    ),
    (
        "self_overlap_hides_its_own_outline",
        self_overlap_hides_its_own_outline,
    ),
    (
        "strokes_switch_off_and_on_again",
        strokes_switch_off_and_on_again,
    ),
    (
        "each_camera_sees_its_own_strokes",
        each_camera_sees_its_own_strokes,
    ),
];

pub(crate) fn scene() -> Result<HeadlessRenderer, Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings::default())?;
    r.app.add_plugins(CartoonHairPlugins);
    let target = r.target();
    let world = r.app.world_mut();
    world.spawn((
        DirectionalLight {
            illuminance: 5_000.0,
            ..default()
        },
        Transform::from_xyz(0.0, 1.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.0, 0.0, 1.0)),
            ..default()
        },
        bevy::core_pipeline::tonemapping::Tonemapping::Linear,
        Msaa::Off,
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    Ok(r)
}

pub(crate) fn spawn(r: &mut HeadlessRenderer, points: Vec<Vec3>, radius: f32) -> Entity {
    let world = r.app.world_mut();
    let groom = world
        .resource_mut::<Assets<HairGroom>>()
        .add(HairGroom::from_strands("", [points]).unwrap());
    world
        .spawn((
            Hair { groom, ..default() },
            HairSimSettings {
                gravity: Vec3::ZERO,
                anchor_stiffness: QuadraticCurve::constant(1.0),
                ..default()
            },
            HairMeshSettings {
                radius,
                taper: QuadraticCurve::constant(1.0),
                hair_resolution: 48,
                shape_resolution: 24,
                // The strand's own normals: these tests look at one tube.
                mass_normals: 0.0,
                ..default()
            },
            SilhouetteSettings {
                width_px: 4.0,
                fade: QuadraticCurve::constant(1.0),
                color: Color::BLACK,
                // Every strand's silhouette: these tests look at one tube's outlines.
                scope: StrokeScope::Strands,
                ..default()
            },
        ))
        .id()
}

/// Down column `x`, the runs of ink (separated by at least 2 pixels without).
fn ink_runs(frame: &CapturedFrame, x: u32) -> usize {
    let mut runs = 0;
    let mut gap = 2;
    for y in 0..frame.height {
        if is_ink(frame.pixel(x, y)) {
            if gap >= 2 {
                runs += 1;
            }
            gap = 0;
        } else {
            gap += 1;
        }
    }
    runs
}

/// Darker than anything else in these scenes: the darkest hair band has a channel above 170 and
/// the background is pure blue.
pub(crate) fn is_ink(p: [u8; 4]) -> bool {
    p[0].max(p[1]).max(p[2]) < 110
}

fn is_background(p: [u8; 4]) -> bool {
    p[2] > 200 && p[0] < 40 && p[1] < 40
}

/// Ink pixels near the background (within `near` px) and ink pixels deep inside the hair (no
/// background within `far` px).
fn ink_near_and_inside(frame: &CapturedFrame, near: i32, far: i32) -> (usize, usize) {
    let (w, h) = (frame.width as i32, frame.height as i32);
    let bg_within = |x: i32, y: i32, d: i32| {
        (-d..=d).any(|dy| {
            (-d..=d).any(|dx| {
                let (px, py) = (x + dx, y + dy);
                px >= 0
                    && py >= 0
                    && px < w
                    && py < h
                    && is_background(frame.pixel(px as u32, py as u32))
            })
        })
    };
    let (mut boundary, mut inside) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            if !is_ink(frame.pixel(x as u32, y as u32)) {
                continue;
            }
            if bg_within(x, y, near) {
                boundary += 1;
            } else if !bg_within(x, y, far) {
                inside += 1;
            }
        }
    }
    (boundary, inside)
}

fn save(frame: &CapturedFrame, name: &str) -> Result<(), Failed> {
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        frame.save_png(std::path::Path::new(&dir).join(format!("{name}.png")))?;
    }
    Ok(())
}

fn strokes_outline_the_boundary_not_the_face() -> Result<(), Failed> {
    let mut r = scene()?;
    let points = (0..6)
        .map(|i| Vec3::new(-1.0 + 0.4 * i as f32, 0.0, 0.0))
        .collect();
    spawn(&mut r, points, 0.35);
    let frame = r.capture()?;
    save(&frame, "strokes_boundary")?;
    let (boundary, inside) = ink_near_and_inside(&frame, 4, 10);
    println!("object-space strokes: {boundary} ink pixels on the boundary, {inside} inside");
    // Two long sides of ~230 px at >= 2 px of ink each.
    if boundary < 700 || inside > 0 {
        return Err(format!("{boundary} boundary ink pixels, {inside} inside the face").into());
    }
    Ok(())
}

/// Left to right in front, a U-turn, then right to left behind and a little lower: the back
/// half's outline passes behind the front half.
pub(crate) fn fold_strand() -> Vec<Vec3> {
    let mut points: Vec<Vec3> = (0..5)
        .map(|i| Vec3::new(-1.0 + 0.45 * i as f32, 0.08, 0.3))
        .collect();
    points.push(Vec3::new(1.2, 0.0, 0.0));
    points.extend((0..5).map(|i| Vec3::new(0.8 - 0.45 * i as f32, -0.08, -0.3)));
    points
}

fn self_overlap_hides_its_own_outline() -> Result<(), Failed> {
    let mut r = scene()?;
    let hair = spawn(&mut r, fold_strand(), 0.22);
    let frame = r.capture()?;
    save(&frame, "strokes_self_overlap")?;
    // Down each column where both halves show: the front half's top and bottom outlines and the
    // back half's bottom outline are 3 runs of ink. The back half's top outline lies behind the
    // front half; drawing it through the front face would make a 4th run.
    let mut columns = 0;
    for x in frame.width / 5..frame.width * 3 / 5 {
        let runs = ink_runs(&frame, x);
        if runs > 3 {
            return Err(
                format!("column {x}: {runs} outline runs; a hidden outline shows through").into(),
            );
        }
        if runs == 3 {
            columns += 1;
        }
    }
    println!("self-overlap: {columns} columns with exactly the 3 visible outlines");
    if columns < frame.width / 4 {
        return Err(format!("only {columns} columns show both halves outlined").into());
    }
    // The mass's outline: the front half's lower edge, lying on the back half, is inside the
    // hair and gets no stroke; the outer edges keep theirs.
    r.app
        .world_mut()
        .get_mut::<SilhouetteSettings>(hair)
        .ok_or("the hair is gone")?
        .scope = StrokeScope::Mass;
    let mass = r.capture()?;
    save(&mass, "strokes_self_overlap_mass")?;
    let (mut two, mut more) = (0, 0);
    for x in frame.width / 5..frame.width * 3 / 5 {
        match ink_runs(&mass, x) {
            2 => two += 1,
            n if n > 2 => more += 1,
            _ => {}
        }
    }
    println!("self-overlap, mass scope: {two} columns with 2 outlines, {more} with more");
    if two < columns * 3 / 4 || more > columns / 10 {
        return Err(format!(
            "mass scope: {two} columns with the 2 outer outlines and {more} with more (every \
             strand: {columns} with 3)"
        )
        .into());
    }
    Ok(())
}

fn strokes_switch_off_and_on_again() -> Result<(), Failed> {
    let mut r = scene()?;
    let points = (0..6)
        .map(|i| Vec3::new(-1.0 + 0.4 * i as f32, 0.0, 0.0))
        .collect();
    let hair = spawn(&mut r, points, 0.35);
    let mut counts = Vec::new();
    for enabled in [true, false, true, false, true] {
        r.app
            .world_mut()
            .get_mut::<SilhouetteSettings>(hair)
            .ok_or("settings")?
            .enabled = enabled;
        let frame = r.capture()?;
        let ink = frame.count(is_ink);
        counts.push(ink);
        if enabled != (ink > 500) {
            return Err(
                format!("enabled={enabled}: {ink} ink pixels (sequence {counts:?})").into(),
            );
        }
    }
    Ok(())
}

fn each_camera_sees_its_own_strokes() -> Result<(), Failed> {
    use bevy::camera::visibility::RenderLayers;
    use bevy_cartoon_hair::silhouette::ComputedSilhouettes;
    use bevy_cartoon_hair::silhouette::strokes::FIRST_STROKE_LAYER;

    let mut r = scene()?;
    // A second camera looks down on the strand from above, into an image of its own. Its
    // outlines (the strand's front and back edges) would cross the middle of the lit face the
    // first camera sees, were they drawn for it.
    let world = r.app.world_mut();
    let mut image = Image::new_target_texture(
        64,
        64,
        bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb,
        None,
    );
    image.texture_descriptor.usage |= bevy::render::render_resource::TextureUsages::COPY_SRC;
    let top = world.resource_mut::<Assets<Image>>().add(image);
    let top = world
        .spawn((
            Camera3d::default(),
            Camera {
                order: 1,
                ..default()
            },
            RenderTarget::Image(top.into()),
            Transform::from_xyz(0.0, 3.0, 0.0).looking_at(Vec3::ZERO, Vec3::Z),
        ))
        .id();
    let mut marked = world.query_filtered::<Entity, With<Camera3d>>();
    let cameras: Vec<Entity> = marked.iter(world).collect();
    for camera in &cameras {
        world.entity_mut(*camera).insert(SilhouetteCamera);
    }
    let points = (0..6)
        .map(|i| Vec3::new(-1.0 + 0.4 * i as f32, 0.0, 0.0))
        .collect();
    let hair = spawn(&mut r, points, 0.35);
    let frame = r.capture()?;
    save(&frame, "strokes_two_cameras")?;
    let (boundary, inside) = ink_near_and_inside(&frame, 4, 10);
    println!("two cameras: {boundary} ink pixels on the boundary, {inside} inside");
    if boundary < 700 || inside > 0 {
        return Err(format!("{boundary} boundary ink pixels, {inside} inside the face").into());
    }
    // Each camera got strokes of its own, on its own layer, which it sees.
    let world = r.app.world();
    let computed = world
        .get::<ComputedSilhouettes>(hair)
        .ok_or("no silhouettes")?;
    let mut layers: Vec<(Entity, Option<usize>)> =
        computed.views.iter().map(|v| (v.camera, v.layer)).collect();
    layers.sort();
    let mut expected: Vec<(Entity, Option<usize>)> = cameras.iter().map(|c| (*c, None)).collect();
    expected.sort();
    for (slot, e) in expected.iter_mut().enumerate() {
        e.1 = Some(FIRST_STROKE_LAYER + slot);
    }
    if layers != expected {
        return Err(format!("stroke views {layers:?}, expected {expected:?}").into());
    }
    for (camera, layer) in &expected {
        let seen = world
            .get::<RenderLayers>(*camera)
            .is_some_and(|l| l.intersects(&RenderLayers::layer(layer.unwrap_or(0))));
        if !seen {
            return Err(format!("camera {camera} does not see its stroke layer").into());
        }
    }
    // Back to one camera with strokes: its strokes and the camera leave the extra layers, and the
    // outline still shows.
    let front = *cameras
        .iter()
        .find(|c| **c != top)
        .ok_or("no front camera")?;
    r.app
        .world_mut()
        .entity_mut(top)
        .remove::<SilhouetteCamera>();
    let frame = r.capture()?;
    let (boundary, inside) = ink_near_and_inside(&frame, 4, 10);
    let world = r.app.world();
    let views: Vec<(Entity, Option<usize>)> = world
        .get::<ComputedSilhouettes>(hair)
        .ok_or("no silhouettes")?
        .views
        .iter()
        .map(|v| (v.camera, v.layer))
        .collect();
    let layers = world
        .get::<RenderLayers>(front)
        .cloned()
        .unwrap_or_default();
    println!("one camera again: {boundary} boundary ink pixels, {inside} inside; {views:?}");
    if views.len() != 1 || views[0].1.is_some() || layers != RenderLayers::default() {
        return Err(format!("views {views:?}, front camera layers {layers:?}").into());
    }
    if boundary < 700 || inside > 0 {
        return Err(format!("{boundary} boundary ink pixels, {inside} inside the face").into());
    }
    Ok(())
}
