//! The ninja scene rendered headless: the clip recorder of the `ninja_head` example, and the
//! tuning panel with debug drawing.

use std::path::{Path, PathBuf};

use bevy::asset::RenderAssetUsages;
use bevy::image::{CompressedImageFormats, ImageSampler, ImageType};
use bevy::prelude::*;
use bevy_cartoon_hair::demo::{
    ClipSettings, NinjaProps, NinjaScenePlugin, ninja_scene_ready, record_clip,
};
use bevy_cartoon_hair::headless::{CaptureSettings, CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::ui::HairDebugDraw;
use libtest_mimic::Failed;

/// Tests of the demo that need no GPU.
pub const TESTS: &[(&str, crate::TestFn)] = &[(
    "the_demo_names_a_missing_asset_folder_at_once",
    the_demo_names_a_missing_asset_folder_at_once,
)];

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[
    (
        "clip_recorder_writes_consecutive_deterministic_frames_with_hair",
        clip_recorder_writes_consecutive_deterministic_frames_with_hair,
    ),
    (
        "clip_recorder_names_every_broken_file_and_writes_no_clip",
        clip_recorder_names_every_broken_file_and_writes_no_clip,
    ),
    (
        "tuning_panel_and_debug_drawing_render",
        tuning_panel_and_debug_drawing_render,
    ),
    (
        "demo_props_hood_and_board_shape_the_hair",
        demo_props_hood_and_board_shape_the_hair,
    ),
];

/// The demo hair, `srgb(0.98, 0.62, 0.12)`, in any of its toon tones: orange, unlike the red
/// headband (too little green), the skin (too much blue) and the grey-green ground.
fn is_hair([r, g, b, _]: [u8; 4]) -> bool {
    let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
    r > 90.0 && g > 0.35 * r && g < 0.85 * r && b < 0.5 * g
}

fn read_png(path: &Path) -> Result<CapturedFrame, Failed> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let image = Image::from_buffer(
        &bytes,
        ImageType::Extension("png"),
        CompressedImageFormats::NONE,
        true,
        ImageSampler::Default,
        RenderAssetUsages::default(),
    )
    .map_err(|e| format!("{}: {e}", path.display()))?;
    let image = image
        .convert(bevy::render::render_resource::TextureFormat::Rgba8UnormSrgb)
        .ok_or("PNG is not convertible to RGBA8")?;
    Ok(CapturedFrame {
        width: image.width(),
        height: image.height(),
        rgba: image.data.unwrap_or_default(),
    })
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bevy_cartoon_hair_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A copy of the scene's files in which the collision file has a sphere of negative radius on
/// line 3 and the animation names a key outside its folder: the recorder writes no frame and
/// returns both failures with the loaders' `file:line:col`, as the example prints them before
/// it exits non-zero.
fn clip_recorder_names_every_broken_file_and_writes_no_clip() -> Result<(), Failed> {
    let assets = temp_dir("broken_assets");
    let ninja = assets.join("ninja");
    std::fs::create_dir_all(&ninja)?;
    let source = crate::repo().join("assets/ninja");
    for entry in std::fs::read_dir(&source)? {
        let entry = entry?;
        std::fs::copy(entry.path(), ninja.join(entry.file_name()))?;
    }
    std::fs::write(
        ninja.join("ninja.collision.xml"),
        "<?xml version=\"1.0\"?>\n<collision version=\"1\" bone=\"head\">\n  \
         <sphere x=\"0\" y=\"0.09\" z=\"0\" r=\"-0.1\"/>\n</collision>\n",
    )?;
    std::fs::write(
        ninja.join("ninja.hairanim.xml"),
        "<hairanim version=\"1\" duration=\"1\">\n  <key time=\"0\" groom=\"ninja.hair.xml\"/>\n  \
         <key time=\"0.5\" groom=\"../../secret.hair.xml\"/>\n</hairanim>\n",
    )?;
    let out = temp_dir("broken_clip");
    let settings = ClipSettings {
        frames: 3,
        out: out.clone(),
        width: 160,
        height: 90,
        asset_folder: Some(assets.clone()),
        ..default()
    };
    let result = record_clip(&settings);
    let _ = std::fs::remove_dir_all(&assets);
    let written = std::fs::read_dir(&out).map_or(0, Iterator::count);
    let _ = std::fs::remove_dir_all(&out);
    let error = match result {
        Ok(paths) => return Err(format!("a clip of broken files was written: {paths:?}").into()),
        Err(e) => e.to_string(),
    };
    println!("{error}");
    if written != 0 {
        return Err(format!("{written} frames written beside the error").into());
    }
    for needle in [
        "2 of the scene's files failed to load",
        "ninja.collision.xml:3:",
        "radius must be greater than 0",
        "ninja.hairanim.xml:3:",
        "secret.hair.xml",
    ] {
        if !error.contains(needle) {
            return Err(format!("`{needle}` missing from: {error}").into());
        }
    }
    Ok(())
}

/// Records three frames twice: the PNGs exist with the right names and size, show the orange
/// hair, differ from frame to frame (the clip moves), and are identical between the two runs
/// (fixed time step, same start).
fn clip_recorder_writes_consecutive_deterministic_frames_with_hair() -> Result<(), Failed> {
    let mut runs = Vec::new();
    for run in 0..2 {
        let out = temp_dir(&format!("clip{run}"));
        let settings = ClipSettings {
            frames: 3,
            out: out.clone(),
            width: 320,
            height: 180,
            ..default()
        };
        let paths = record_clip(&settings)?;
        let expected: Vec<PathBuf> = (0..3)
            .map(|i| out.join(format!("frame_{i:04}.png")))
            .collect();
        if paths != expected {
            return Err(format!("wrote {paths:?}, expected {expected:?}").into());
        }
        let frames = paths
            .iter()
            .map(|p| read_png(p))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
            frames[0].save_png(Path::new(&dir).join("clip_frame_0000.png"))?;
        }
        let _ = std::fs::remove_dir_all(&out);
        runs.push(frames);
    }
    for (i, frame) in runs[0].iter().enumerate() {
        if (frame.width, frame.height) != (320, 180) {
            return Err(format!("frame {i} is {}x{}", frame.width, frame.height).into());
        }
        let hair = frame.count(is_hair);
        // The hair covers about 2.5% of the frame at this zoom.
        if hair < 320 * 180 / 100 {
            return Err(format!("frame {i} has only {hair} hair-coloured pixels").into());
        }
    }
    for i in 1..3 {
        if runs[0][i].rgba == runs[0][i - 1].rgba {
            return Err(format!(
                "frames {} and {i} are the same: time did not advance",
                i - 1
            )
            .into());
        }
    }
    for (i, (a, b)) in runs[0].iter().zip(&runs[1]).enumerate() {
        if a.rgba != b.rgba {
            let differing = a
                .rgba
                .chunks_exact(4)
                .zip(b.rgba.chunks_exact(4))
                .filter(|(a, b)| a != b)
                .count();
            return Err(format!("frame {i} differs between runs in {differing} pixels").into());
        }
    }
    Ok(())
}

/// The panel at 1280x720 and 1920x1080: its windows fit the screen without covering one another,
/// and the debug drawing shows the particles (magenta) in front of the hair.
fn tuning_panel_and_debug_drawing_render() -> Result<(), Failed> {
    for (width, height) in [(1280, 720), (1920, 1080)] {
        tuning_panel_at(width, height)?;
    }
    Ok(())
}

/// The panel at one window size: its three windows drawn, inside the screen, none covering
/// another, and the debug drawing's particles visible.
fn tuning_panel_at(width: u32, height: u32) -> Result<(), Failed> {
    use bevy_cartoon_hair::ui::TuningPanelLayout;
    use bevy_cartoon_hair::ui::bevy_egui::egui;
    let mut r = HeadlessRenderer::new(CaptureSettings {
        width,
        height,
        max_frames: 5_000,
        ..default()
    })?;
    r.app.add_plugins((
        CartoonHairPlugins,
        HairTuningUiPlugin,
        NinjaScenePlugin {
            target: Some(r.target()),
            preset: None,
            hairstyle: default(),
        },
    ));
    r.app
        .insert_resource(HairTuningUi {
            visible: true,
            ..default()
        })
        .insert_resource(HairDebugDraw {
            particles: true,
            springs: true,
            anchors: false,
            colliders: true,
        });
    r.warm_up(ninja_scene_ready)?;
    let frame = r.capture()?;
    if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
        frame.save_png(Path::new(&dir).join(format!("tuning_panel_{width}x{height}.png")))?;
    }
    let layout = *r.app.world().resource::<TuningPanelLayout>();
    // Headless, one egui point is one pixel.
    let screen =
        egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(width as f32, height as f32));
    let windows: Vec<(&str, egui::Rect)> = [
        ("Debug", layout.debug),
        ("Effects", layout.effects),
        ("Hair properties", layout.properties),
    ]
    .into_iter()
    .filter_map(|(name, rect)| rect.map(|r| (name, r)))
    .collect();
    println!("panel at {width}x{height}: {windows:?}");
    if windows.len() != 3 {
        return Err(format!("{width}x{height}: windows drawn {windows:?}").into());
    }
    for (i, (a, ra)) in windows.iter().enumerate() {
        if !screen.expand(0.5).contains_rect(*ra) {
            return Err(
                format!("{width}x{height}: {a} {ra:?} leaves the screen {screen:?}").into(),
            );
        }
        for (b, rb) in &windows[i + 1..] {
            if ra.intersect(*rb).is_positive() {
                return Err(format!("{width}x{height}: {a} {ra:?} covers {b} {rb:?}").into());
            }
        }
    }
    let total = (frame.width * frame.height) as f32;
    // egui's dark theme fills windows with grey 27 (the scene's background is light blue).
    let panel = frame.count(|[r, g, b, _]| r.abs_diff(g) < 6 && g.abs_diff(b) < 6 && r < 50) as f32;
    if panel / total < 0.08 {
        return Err(format!("egui windows cover only {:.3} of the frame", panel / total).into());
    }
    // Particle gizmos: srgb(1.0, 0.1, 0.6).
    let particles = frame.count(|[r, g, b, _]| r > 200 && g < 90 && (110..200).contains(&b));
    if particles < 50 {
        return Err(format!("only {particles} magenta particle pixels").into());
    }
    Ok(())
}

/// The ninja example's props, rendered 1.5 s in (the head is upright and the board over it):
/// - the hood (a sphere keeping hair inside) lowers the hair's top by at least 10 px of 240
///   (its spikes reach 0.31 m from the head's centre, the hood 0.2 m);
/// - above the board (a box) there is almost no hair, where without it the spikes stand.
fn demo_props_hood_and_board_shape_the_hair() -> Result<(), Failed> {
    let clip = |name: &str, props: NinjaProps| -> Result<CapturedFrame, Failed> {
        let out = temp_dir(&format!("props_{name}"));
        let paths = record_clip(&ClipSettings {
            frames: 46,
            out: out.clone(),
            width: 320,
            height: 240,
            props,
            ..default()
        })?;
        let frame = read_png(paths.last().ok_or("no frames")?)?;
        if let Some(dir) = std::env::var_os("HAIR_TEST_PNG_DIR") {
            frame.save_png(Path::new(&dir).join(format!("props_{name}.png")))?;
        }
        let _ = std::fs::remove_dir_all(&out);
        Ok(frame)
    };
    let none = clip("none", NinjaProps::default())?;
    let hood = clip(
        "hood",
        NinjaProps {
            hood: true,
            ..default()
        },
    )?;
    let board = clip(
        "board",
        NinjaProps {
            board: true,
            ..default()
        },
    )?;
    let row_count = |f: &CapturedFrame, y: u32, test: &dyn Fn([u8; 4]) -> bool| {
        (0..f.width).filter(|&x| test(f.pixel(x, y))).count()
    };
    let top = |f: &CapturedFrame| (0..f.height).find(|&y| row_count(f, y, &is_hair) >= 2);
    let (Some(top_none), Some(top_hood)) = (top(&none), top(&hood)) else {
        return Err("no hair in the frames".into());
    };
    println!("hair top row: {top_none} without props, {top_hood} under the hood");
    if top_hood < top_none + 10 {
        return Err(
            format!("the hood lowered the hair's top from {top_none} to {top_hood}").into(),
        );
    }
    // The board's wood, lit or shaded: warm and unsaturated, unlike the hair, sky and skin.
    let is_wood = |[r, g, b, _]: [u8; 4]| {
        let (r, g, b) = (f32::from(r), f32::from(g), f32::from(b));
        r > g && g > b && r - b > 30.0 && r - b < 110.0 && b > 0.55 * g && r < 230.0
    };
    let rows: Vec<u32> = (0..board.height / 2)
        .filter(|&y| row_count(&board, y, &is_wood) >= 20)
        .collect();
    let Some(&board_bottom) = rows.last() else {
        return Err("no board in the frame".into());
    };
    let above = |f: &CapturedFrame| {
        (0..board_bottom)
            .map(|y| row_count(f, y, &is_hair))
            .sum::<usize>()
    };
    let (with_board, without) = (above(&board), above(&none));
    println!(
        "hair pixels above the board's bottom row {board_bottom}: {with_board} (without the \
         board: {without})"
    );
    if without < 100 || with_board * 20 > without {
        return Err(
            format!("hair above the board: {with_board} pixels, {without} without it").into(),
        );
    }
    Ok(())
}

/// The example and the recorder check their files first: without them they name the missing
/// path instead of waiting for assets that never load.
fn the_demo_names_a_missing_asset_folder_at_once() -> Result<(), Failed> {
    use bevy_cartoon_hair::demo::{check_ninja_assets, check_ninja_assets_in};
    let empty = temp_dir("no_assets");
    std::fs::create_dir_all(&empty)?;
    match check_ninja_assets_in(&empty) {
        Err(path) if path == empty.join("ninja/ninja.glb") => {}
        other => return Err(format!("an empty asset folder gave {other:?}").into()),
    }
    std::fs::create_dir_all(empty.join("ninja"))?;
    std::fs::write(empty.join("ninja/ninja.glb"), b"")?;
    match check_ninja_assets_in(&empty) {
        Err(path) if path == empty.join("ninja/ninja.hair.xml") => {}
        other => return Err(format!("a folder without the groom gave {other:?}").into()),
    }
    let _ = std::fs::remove_dir_all(&empty);
    // The repository's own folder (what `cargo test` and `cargo run` use) has everything.
    check_ninja_assets().map_err(|p| format!("{} is missing from the repository", p.display()))?;
    let message =
        bevy_cartoon_hair::demo::ClipError::MissingAsset("x/assets/ninja/ninja.glb".into())
            .to_string();
    if !message.contains("x/assets/ninja/ninja.glb is missing")
        || !message.contains("BEVY_ASSET_ROOT")
    {
        return Err(format!("unclear error: {message}").into());
    }
    Ok(())
}
