//! The ninja-head example (placeholder scene until the bundled character lands): a window, a lit
//! head, and the hair plugins installed.
//!
//! Run: `tools/run-example.sh` (or `cargo run --example ninja_head`).
//! Flags: `--screenshot FILE` saves the window at frame 60 and exits (used to check it renders).

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy_cartoon_hair::prelude::*;

#[derive(Resource)]
struct ScreenshotRequest(String);

fn main() {
    let mut args = std::env::args().skip(1);
    let mut screenshot = None;
    while let Some(arg) = args.next() {
        if arg == "--screenshot" {
            screenshot = args.next();
        }
    }
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "bevy_cartoon_hair: ninja head".into(),
                resolution: (1280, 720).into(),
                ..default()
            }),
            ..default()
        }),
        CartoonHairPlugins,
    ))
    .insert_resource(ClearColor(Color::srgb(0.85, 0.88, 0.95)))
    .add_systems(Startup, setup);
    if let Some(path) = screenshot {
        app.insert_resource(ScreenshotRequest(path))
            .add_systems(Update, take_screenshot);
    }
    app.run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(0.5).mesh().uv(48, 24))),
        MeshMaterial3d(materials.add(Color::srgb(0.95, 0.78, 0.65))),
        Transform::from_xyz(0.0, 1.6, 0.0),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            ..default()
        },
        Transform::from_xyz(2.0, 4.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 1.8, 2.5).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y),
    ));
}

fn take_screenshot(
    mut commands: Commands,
    request: Res<ScreenshotRequest>,
    mut frame: Local<u32>,
    mut exit: MessageWriter<AppExit>,
) {
    *frame += 1;
    if *frame == 60 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(request.0.clone()));
    }
    if *frame == 90 {
        exit.write(AppExit::Success);
    }
}
