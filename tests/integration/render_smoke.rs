//! The harness itself: a lit mesh renders and the pixels come back.

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer};
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[("lit_mesh_renders", lit_mesh_renders)];

/// A red sphere lit from the front fills the centre of the frame; the corners show the clear
/// colour (blue). Both are asserted on pixels read back from the GPU.
fn lit_mesh_renders() -> Result<(), Failed> {
    let mut r = HeadlessRenderer::new(CaptureSettings::default())?;
    let target = r.target();
    let world = r.app.world_mut();
    let mesh = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(1.0).mesh().uv(32, 16));
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::srgb(0.9, 0.1, 0.1),
            perceptual_roughness: 1.0,
            ..default()
        });
    world.spawn((Mesh3d(mesh), MeshMaterial3d(material)));
    world.spawn((
        DirectionalLight {
            illuminance: 10_000.0,
            ..default()
        },
        Transform::from_xyz(0.0, 0.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.0, 0.0, 1.0)),
            ..default()
        },
        RenderTarget::Image(target.into()),
        Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let frame = r.capture()?;
    let (w, h) = (frame.width, frame.height);
    let centre = frame.pixel(w / 2, h / 2).map(u32::from);
    // Red dominates (tonemapping lifts green and blue a little on a brightly lit sphere).
    if !(centre[0] > 150 && centre[0] > centre[1] + 80 && centre[0] > centre[2] + 80) {
        return Err(format!("centre pixel {centre:?} is not the lit red sphere").into());
    }
    for (x, y) in [(1, 1), (w - 2, 1), (1, h - 2), (w - 2, h - 2)] {
        let p = frame.pixel(x, y);
        if !(p[2] > 150 && p[0] < 60 && p[1] < 60) {
            return Err(format!("corner ({x}, {y}) is {p:?}, not the blue background").into());
        }
    }
    let red = frame.count(|p| p[0] > 60 && u32::from(p[0]) > u32::from(p[2]) + 40);
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        frame.save_png(std::path::Path::new(&dir).join("lit_mesh_renders.png"))?;
    }
    // The sphere (radius 1 at distance 4, 45 degree fov) covers roughly 15% of the frame.
    let share = red as f32 / (w * h) as f32;
    if !(0.05..0.5).contains(&share) {
        return Err(format!("sphere covers {share:.3} of the frame, expected 0.05..0.5").into());
    }
    Ok(())
}
