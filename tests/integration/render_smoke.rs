//! The harness itself: a lit mesh renders and the pixels come back.

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer};
use libtest_mimic::Failed;

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    ("lit_mesh_renders", lit_mesh_renders),
    (
        "sixty_renderers_share_one_gpu_instance",
        sixty_renderers_share_one_gpu_instance,
    ),
];

/// Resident memory of this process, bytes (`/proc/self/statm`).
fn resident_bytes() -> Result<u64, Failed> {
    let statm = std::fs::read_to_string("/proc/self/statm")?;
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|p| p.parse().ok())
        .ok_or("cannot read /proc/self/statm")?;
    Ok(pages * 4096)
}

/// How much the process's resident memory may grow from the 2nd renderer to the 60th. A driver
/// that leaves a device behind per renderer grew 15-30 MB a renderer (over 800 MB for 58); a
/// shared device leaves the renderers' own allocations, which the allocator reuses. Other tests
/// may run on another thread meanwhile, so this is a bound, not a measurement.
const RENDERER_MEMORY_BOUND: u64 = 96 << 20;

/// Sixty renderers are started, draw one frame each and are dropped, one after another, in this
/// one process: every one finds the adapter, the process has made one GPU instance in all (the
/// crate's counter, and every renderer's render world holds that one), and
/// its memory after the 60th is within [`RENDERER_MEMORY_BOUND`] of what it was after the 2nd.
fn sixty_renderers_share_one_gpu_instance() -> Result<(), Failed> {
    let mut after_second = 0;
    let mut first_instance = None;
    for i in 0..60u32 {
        let mut r = HeadlessRenderer::new(CaptureSettings {
            width: 32,
            height: 32,
            ..default()
        })?;
        // A colour of this renderer's own, so the frame is known to be its.
        let red = (i * 4) as u8;
        let target = r.target();
        r.app.world_mut().spawn((
            Camera3d::default(),
            Camera {
                clear_color: ClearColorConfig::Custom(Color::srgb_u8(red, 0, 255)),
                ..default()
            },
            bevy::core_pipeline::tonemapping::Tonemapping::None,
            RenderTarget::Image(target.into()),
        ));
        let frame = r.capture()?;
        let p = frame.pixel(16, 16);
        if p[0].abs_diff(red) > 1 || p[2] != 255 {
            return Err(format!("renderer {i}: pixel {p:?}, expected red {red} on blue").into());
        }
        // Bevy's render world holds the process's one instance, not one of its own.
        let instance = (**r
            .app
            .sub_app(bevy::render::RenderApp)
            .world()
            .resource::<bevy::render::renderer::RenderInstance>())
        .clone();
        match &first_instance {
            None => first_instance = Some(instance),
            Some(first) if *first != instance => {
                return Err(format!("renderer {i} has a GPU instance of its own").into());
            }
            Some(_) => {}
        }
        drop(r);
        if i == 1 {
            after_second = resident_bytes()?;
        }
    }
    let after_sixtieth = resident_bytes()?;
    let created = bevy_cartoon_hair::headless::gpu_instances_created();
    eprintln!(
        "60 renderers: {created} GPU instance(s); resident memory after the 2nd {:.1} MB, after \
         the 60th {:.1} MB",
        after_second as f64 / 1e6,
        after_sixtieth as f64 / 1e6
    );
    if created != 1 {
        return Err(format!("{created} GPU instances were created, expected 1").into());
    }
    if after_sixtieth > after_second + RENDERER_MEMORY_BOUND {
        return Err(format!(
            "resident memory grew from {} to {} bytes over 58 renderers (bound {})",
            after_second, after_sixtieth, RENDERER_MEMORY_BOUND
        )
        .into());
    }
    Ok(())
}

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
