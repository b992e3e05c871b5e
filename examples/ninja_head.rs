//! The ninja-head example: the bundled ninja plays its idle animation (head turns and a quick
//! shake); spiky anime hair is attached to its `head` bone, simulated, animated between keyframe
//! styles, collides with the head, and is drawn with the toon material. The scene itself is
//! `bevy_cartoon_hair::demo::NinjaScenePlugin`, shared with the tests.
//!
//! Run: `tools/run-example.sh` (or `cargo run --example ninja_head`).
//!
//! Keys: arrows orbit the camera, Page Up / Page Down zoom, M toggles the tuning panel, P pauses
//! the hair, Enter steps it one frame, G toggles a gusty 8 m/s wind, F toggles a fan (a local
//! `HairForceField`) blowing at the head from its right (the panel's Force fields edit it).
//! Three props show the other collider kinds (the panel's Colliders section lists them): H
//! toggles a hood (a sphere keeping the hair inside), W a wall behind the head (a plane), B a
//! board sweeping over the head (a box).
//!
//! Flags:
//! - `--screenshot FILE`: save the window at frame 150 and exit.
//! - `--preset FILE|LOOK`: start from a hair preset (saved from the panel's Preset section), or
//!   one of the shipped looks by name (`thesis`, `clean_anime`, `sketch`, `anime_locks`;
//!   `assets/presets/`).
//! - `--hairstyle NAME`: the hair the ninja wears: `spiky` (the default, keyframe-animated),
//!   `long`, `bangs` or `twin_tails` (simulated with the shoulders, chest and back as colliders).
//! - `--no-ui`: start with the tuning panel hidden.
//! - `--hood`, `--wall`, `--board`: start with that prop (also in headless clips).
//! - `--yaw RADIANS`: headless clips look from this angle around the head (0: the face).
//! - `--headless --frames N --out DIR`: no window; render N consecutive frames at 1/30 s each
//!   to `DIR/frame_0000.png`, ... (any Vulkan adapter, lavapipe included), then exit.
//!   `--size WxH` sets the image size (default 640x360).

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy_cartoon_hair::demo::{
    ClipSettings, NinjaHairstyle, NinjaOrbit, NinjaProps, NinjaScenePlugin, record_clip,
};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::ui::tuning_ui_wants_keyboard;

#[derive(Resource)]
struct ScreenshotRequest(String);

#[derive(Default)]
struct Args {
    screenshot: Option<String>,
    preset: Option<String>,
    headless: bool,
    no_ui: bool,
    clip: ClipSettings,
}

fn parse_args() -> Result<Args, String> {
    let mut parsed = Args::default();
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--screenshot" => parsed.screenshot = Some(value()?),
            "--preset" => parsed.preset = Some(value()?),
            "--hairstyle" => {
                let v = value()?;
                parsed.clip.hairstyle = NinjaHairstyle::from_name(&v).ok_or(format!(
                    "--hairstyle {v:?}: expected one of {}",
                    NinjaHairstyle::ALL.map(NinjaHairstyle::name).join(", ")
                ))?;
            }
            "--headless" => parsed.headless = true,
            "--no-ui" => parsed.no_ui = true,
            "--hood" => parsed.clip.props.hood = true,
            "--wall" => parsed.clip.props.wall = true,
            "--board" => parsed.clip.props.board = true,
            "--yaw" => {
                let v = value()?;
                parsed.clip.orbit.yaw = v.parse().map_err(|e| format!("--yaw {v:?}: {e}"))?;
            }
            "--frames" => {
                let v = value()?;
                parsed.clip.frames = v.parse().map_err(|e| format!("--frames {v:?}: {e}"))?;
            }
            "--out" => parsed.clip.out = value()?.into(),
            "--size" => {
                let v = value()?;
                let (w, h) = v
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                    .ok_or(format!("--size {v:?}: expected WIDTHxHEIGHT"))?;
                (parsed.clip.width, parsed.clip.height) = (w, h);
            }
            "--help" | "-h" => return Err("see the header of examples/ninja_head.rs".into()),
            other => return Err(format!("unknown flag {other:?} (try --help)")),
        }
    }
    Ok(parsed)
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("ninja_head: {e}");
            std::process::exit(2);
        }
    };
    // A shipped look by name, else a file.
    let load = |p: &str| HairPreset::look(p).unwrap_or_else(|| HairPreset::load(p));
    let preset = match args.preset.as_deref().map(load).transpose() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("ninja_head: {e}");
            std::process::exit(2);
        }
    };
    if args.headless {
        let clip = ClipSettings {
            preset,
            ..args.clip
        };
        match record_clip(&clip) {
            Ok(frames) => println!("wrote {} frames to {}", frames.len(), clip.out.display()),
            Err(e) => {
                eprintln!("ninja_head: {e}");
                std::process::exit(1);
            }
        }
        return;
    }
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: Some(Window {
                    title: "bevy_cartoon_hair: ninja head".into(),
                    resolution: (1280, 720).into(),
                    ..default()
                }),
                ..default()
            })
            // Hair work spreads over the compute pool; give it every core.
            .set(bevy_cartoon_hair::compute_on_every_core()),
        CartoonHairPlugins,
        // The tuning panel is a development tool, not part of the plugin group.
        HairTuningUiPlugin,
        NinjaScenePlugin {
            target: None,
            preset,
            hairstyle: args.clip.hairstyle,
        },
    ))
    .insert_resource(HairTuningUi {
        visible: !args.no_ui,
        ..default()
    })
    .insert_resource(args.clip.props)
    .add_systems(
        Update,
        // Typing a preset file name must not orbit the camera or pause the hair.
        (orbit_keys, hair_keys, fan_key).run_if(not(tuning_ui_wants_keyboard)),
    );
    if let Some(path) = args.screenshot {
        app.insert_resource(ScreenshotRequest(path))
            .add_systems(Update, take_screenshot);
    }
    app.run();
}

fn orbit_keys(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut cameras: Query<&mut NinjaOrbit>,
) {
    let dt = time.delta_secs();
    for mut orbit in &mut cameras {
        let mut o = orbit.clone();
        if keys.pressed(KeyCode::ArrowLeft) {
            o.yaw -= 1.5 * dt;
        }
        if keys.pressed(KeyCode::ArrowRight) {
            o.yaw += 1.5 * dt;
        }
        if keys.pressed(KeyCode::ArrowUp) {
            o.pitch = (o.pitch + dt).min(1.3);
        }
        if keys.pressed(KeyCode::ArrowDown) {
            o.pitch = (o.pitch - dt).max(-1.3);
        }
        if keys.pressed(KeyCode::PageUp) {
            o.distance = (o.distance * (1.0 - dt)).max(0.3);
        }
        if keys.pressed(KeyCode::PageDown) {
            o.distance = (o.distance * (1.0 + dt)).min(6.0);
        }
        orbit.set_if_neq(o);
    }
}

/// The fan F toggles.
#[derive(Component)]
struct Fan;

/// F: a fan half a metre to the head's right, blowing at it, or none again.
fn fan_key(
    keys: Res<ButtonInput<KeyCode>>,
    mut commands: Commands,
    fans: Query<Entity, With<Fan>>,
    hairs: Query<&GlobalTransform, With<Hair>>,
) {
    if keys.just_pressed(KeyCode::KeyF) {
        if fans.is_empty() {
            // A field's air goes along its -Z: looking at the head blows at it.
            let head = hairs
                .iter()
                .next()
                .map_or(Vec3::Y, GlobalTransform::translation);
            commands.spawn((
                Name::new("fan"),
                Fan,
                HairForceField {
                    kind: HairForceFieldKind::Directional,
                    speed: 12.0,
                    radius: 1.2,
                    ..default()
                },
                Transform::from_translation(head + Vec3::new(0.5, 0.1, 0.0))
                    .looking_at(head, Vec3::Y),
            ));
        } else {
            for fan in &fans {
                commands.entity(fan).despawn();
            }
        }
    }
}

fn hair_keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut hair_time: ResMut<Time<HairTime>>,
    mut ui: ResMut<HairTuningUi>,
    mut wind: ResMut<HairWind>,
    mut props: ResMut<NinjaProps>,
) {
    if keys.just_pressed(KeyCode::KeyH) {
        props.hood = !props.hood;
    }
    if keys.just_pressed(KeyCode::KeyW) {
        props.wall = !props.wall;
    }
    if keys.just_pressed(KeyCode::KeyB) {
        props.board = !props.board;
    }
    if keys.just_pressed(KeyCode::KeyG) {
        // A gusty breeze from the character's left, or calm again.
        wind.velocity = if wind.velocity == Vec3::ZERO {
            Vec3::new(8.0, 0.0, 0.0)
        } else {
            Vec3::ZERO
        };
    }
    if keys.just_pressed(KeyCode::KeyM) {
        ui.toggle();
    }
    if keys.just_pressed(KeyCode::KeyP) {
        hair_time.toggle_pause();
    }
    if keys.just_pressed(KeyCode::Enter) {
        hair_time.step_once();
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
