//! The ninja-head example: the bundled ninja plays its idle animation (head turns and a quick
//! shake); spiky anime hair is attached to its `head` bone, simulated, animated between keyframe
//! styles, collides with the head, and is drawn with the toon material.
//!
//! Run: `tools/run-example.sh` (or `cargo run --example ninja_head`).
//!
//! Keys: arrows orbit the camera, Page Up / Page Down zoom, M toggles the tuning panel, P pauses
//! the hair, Enter steps it one frame.
//!
//! Flags: `--screenshot FILE` saves the window at frame 150 and exits.

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy::world_serialization::WorldInstanceReady;
use bevy_cartoon_hair::prelude::*;

#[derive(Resource)]
struct ScreenshotRequest(String);

/// The idle animation to start once the character's scene is spawned.
#[derive(Component)]
struct IdleAnimation {
    graph: Handle<AnimationGraph>,
    node: AnimationNodeIndex,
}

/// Orbit camera state: around the head.
#[derive(Component)]
struct Orbit {
    yaw: f32,
    pitch: f32,
    distance: f32,
    target: Vec3,
}

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
    .insert_resource(ClearColor(Color::srgb(0.80, 0.86, 0.95)))
    .insert_resource(GlobalAmbientLight {
        color: Color::WHITE,
        brightness: 600.0,
        ..default()
    })
    .add_systems(Startup, setup)
    .add_systems(Update, (orbit_camera, hair_keys));
    if let Some(path) = screenshot {
        app.insert_resource(ScreenshotRequest(path))
            .add_systems(Update, take_screenshot);
    }
    app.run();
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut hair_materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
) {
    let (graph, node) = AnimationGraph::from_clip(
        assets.load(GltfAssetLabel::Animation(0).from_asset("ninja/ninja.glb")),
    );
    let hair = Hair {
        groom: assets.load("ninja/ninja.hair.xml"),
        animation: Some(assets.load("ninja/ninja.hairanim.xml")),
        collision: Some(assets.load("ninja/ninja.collision.xml")),
    };
    let material = hair_materials.add(ToonHairMaterial {
        base_color: Color::srgb(0.98, 0.62, 0.12),
        ramp: ramps.three_tone.clone(),
        specular_strength: 0.35,
        shininess: 60.0,
        back_light_strength: 0.25,
        back_light_power: 0.6,
        ..default()
    });
    commands
        .spawn((
            Name::new("ninja"),
            bevy::world_serialization::WorldAssetRoot(
                assets.load(GltfAssetLabel::Scene(0).from_asset("ninja/ninja.glb")),
            ),
            IdleAnimation {
                graph: graphs.add(graph),
                node,
            },
            AttachHair {
                bone: "head".into(),
                hair,
                settings: HairSimSettings::default(),
            },
        ))
        .observe(play_idle_when_ready);
    commands.insert_resource(ExampleHairMaterial(material));
    commands.spawn((
        Name::new("ground"),
        Mesh3d(meshes.add(Circle::new(2.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.55, 0.6, 0.5))),
        Transform::from_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(1.5, 3.0, 2.0).looking_at(Vec3::new(0.0, 1.5, 0.0), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Orbit {
            yaw: 0.5,
            pitch: 0.15,
            distance: 1.1,
            target: Vec3::new(0.0, 1.68, 0.0),
        },
        Transform::default(),
    ));
}

/// The toon material the example gives its hair.
#[derive(Resource)]
struct ExampleHairMaterial(Handle<ToonHairMaterial>);

fn play_idle_when_ready(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    children: Query<&Children>,
    idle: Query<&IdleAnimation>,
    mut players: Query<&mut AnimationPlayer>,
) {
    let Ok(idle) = idle.get(ready.entity) else {
        return;
    };
    for child in children.iter_descendants(ready.entity) {
        if let Ok(mut player) = players.get_mut(child) {
            player.play(idle.node).repeat();
            commands
                .entity(child)
                .insert(AnimationGraphHandle(idle.graph.clone()));
        }
    }
}

fn orbit_camera(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut cameras: Query<(&mut Orbit, &mut Transform)>,
    hairs: Query<Entity, (With<Hair>, Without<HairMaterial>)>,
    material: Res<ExampleHairMaterial>,
    mut commands: Commands,
) {
    // Hair appears once the scene is in; give it the example's material.
    for hair in &hairs {
        commands
            .entity(hair)
            .insert(HairMaterial(material.0.clone()));
    }
    let dt = time.delta_secs();
    for (mut orbit, mut transform) in &mut cameras {
        if keys.pressed(KeyCode::ArrowLeft) {
            orbit.yaw -= 1.5 * dt;
        }
        if keys.pressed(KeyCode::ArrowRight) {
            orbit.yaw += 1.5 * dt;
        }
        if keys.pressed(KeyCode::ArrowUp) {
            orbit.pitch = (orbit.pitch + dt).min(1.3);
        }
        if keys.pressed(KeyCode::ArrowDown) {
            orbit.pitch = (orbit.pitch - dt).max(-1.3);
        }
        if keys.pressed(KeyCode::PageUp) {
            orbit.distance = (orbit.distance * (1.0 - dt)).max(0.3);
        }
        if keys.pressed(KeyCode::PageDown) {
            orbit.distance = (orbit.distance * (1.0 + dt)).min(6.0);
        }
        let offset = Quat::from_euler(EulerRot::YXZ, orbit.yaw, -orbit.pitch, 0.0)
            * Vec3::new(0.0, 0.0, orbit.distance);
        *transform =
            Transform::from_translation(orbit.target + offset).looking_at(orbit.target, Vec3::Y);
    }
}

fn hair_keys(keys: Res<ButtonInput<KeyCode>>, mut control: ResMut<HairSimControl>) {
    if keys.just_pressed(KeyCode::KeyP) {
        control.paused = !control.paused;
    }
    if keys.just_pressed(KeyCode::Enter) {
        control.step_once = true;
    }
}

fn take_screenshot(
    mut commands: Commands,
    request: Res<ScreenshotRequest>,
    mut frame: Local<u32>,
    mut exit: MessageWriter<AppExit>,
) {
    *frame += 1;
    if *frame == 150 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(request.0.clone()));
    }
    if *frame == 180 {
        exit.write(AppExit::Success);
    }
}
