//! Asset tests through Bevy's real asset server, and the Blender round trip.

use std::path::{Path, PathBuf};
use std::time::Duration;

use bevy::asset::{AssetPlugin, LoadState};
use bevy::prelude::*;
use bevy_cartoon_hair::asset::{
    HairAnimation, HairAssetPlugin, HairGroom, HeadCollision, parse_groom,
};
use libtest_mimic::Failed;

/// Tests that need no GPU and no Blender.
pub const TESTS: &[(&str, crate::TestFn)] = &[
    (
        "ninja_assets_load_through_the_asset_server",
        ninja_assets_load_through_the_asset_server,
    ),
    (
        "mismatched_keyframes_fail_cleanly_and_lose_nothing",
        mismatched_keyframes_fail_cleanly_and_lose_nothing,
    ),
];

/// Tests that need Blender's `bpy` module.
pub const BLENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "blender_export_round_trips_through_the_loader",
    blender_export_round_trips_through_the_loader,
)];

fn asset_app(root: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin {
            file_path: root.display().to_string(),
            ..default()
        },
        HairAssetPlugin,
    ));
    app
}

/// Updates until `handle` is loaded (with its dependencies) or failed; returns the state.
fn wait(app: &mut App, id: impl Into<bevy::asset::UntypedAssetId> + Copy) -> LoadState {
    for _ in 0..2000 {
        app.update();
        let server = app.world().resource::<AssetServer>();
        let state = server.load_state(id.into());
        let deps = server.is_loaded_with_dependencies(id.into());
        if matches!(state, LoadState::Failed(_)) || deps {
            return state;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    LoadState::NotLoaded
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn ninja_assets_load_through_the_asset_server() -> Result<(), Failed> {
    let mut app = asset_app(&repo().join("assets"));
    let server = app.world().resource::<AssetServer>().clone();
    let anim: Handle<HairAnimation> = server.load("ninja/ninja.hairanim.xml");
    let head: Handle<HeadCollision> = server.load("ninja/ninja.collision.xml");
    let state = wait(&mut app, anim.id());
    if !matches!(state, LoadState::Loaded) {
        return Err(format!("ninja.hairanim.xml: {state:?}").into());
    }
    wait(&mut app, head.id());
    let anims = app.world().resource::<Assets<HairAnimation>>();
    let anim = anims.get(&anim).ok_or("animation missing")?;
    if anim.keys.len() != 3 || !(100..=200).contains(&anim.base().strand_count()) {
        return Err(format!(
            "{} keys, {} strands",
            anim.keys.len(),
            anim.base().strand_count()
        )
        .into());
    }
    if anim.keys.iter().any(|k| !k.pose.same_topology(anim.base())) {
        return Err("keyframes differ in topology".into());
    }
    let heads = app.world().resource::<Assets<HeadCollision>>();
    let head = heads.get(&head).ok_or("collision shape missing")?;
    if head.bone != "head" || head.spheres.is_empty() {
        return Err(format!("collision: {head:?}").into());
    }
    Ok(())
}

fn mismatched_keyframes_fail_cleanly_and_lose_nothing() -> Result<(), Failed> {
    let dir = std::env::temp_dir().join(format!("hair_mismatch_{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    std::fs::write(
        dir.join("base.hair.xml"),
        "<groom version=\"1\"><strand>0 0 0 0 1 0 0 2 0</strand><strand>1 0 0 1 1 0</strand></groom>",
    )?;
    std::fs::write(
        dir.join("other.hair.xml"),
        "<groom version=\"1\"><strand>0 0 0 0 1 0 0 2 0</strand><strand>1 0 0 1 1 0 1 2 0</strand></groom>",
    )?;
    std::fs::write(
        dir.join("bad.hairanim.xml"),
        "<hairanim version=\"1\">\n  <key time=\"0\" groom=\"base.hair.xml\"/>\n  <key time=\"1\" groom=\"other.hair.xml\"/>\n</hairanim>",
    )?;
    let mut app = asset_app(&dir);
    let server = app.world().resource::<AssetServer>().clone();
    let anim: Handle<HairAnimation> = server.load("bad.hairanim.xml");
    let base: Handle<HairGroom> = server.load("base.hair.xml");
    let state = wait(&mut app, anim.id());
    let LoadState::Failed(err) = state else {
        return Err(format!("mismatched keyframes loaded: {state:?}").into());
    };
    let msg = err.to_string();
    if !(msg.contains("bad.hairanim.xml:3:")
        && msg.contains("strand 1 has 3 particles, the base groom has 2"))
    {
        return Err(format!("unclear error: {msg}").into());
    }
    let state = wait(&mut app, base.id());
    if !matches!(state, LoadState::Loaded)
        || app
            .world()
            .resource::<Assets<HairGroom>>()
            .get(&base)
            .is_none()
    {
        return Err(format!("the base groom was lost: {state:?}").into());
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// Real Blender: a scripted Curves hair object exported by our add-on reads back through the Rust
/// loader with the same strands (counts equal, positions within 1e-5 m after scale).
fn blender_export_round_trips_through_the_loader() -> Result<(), Failed> {
    let out = std::env::temp_dir().join(format!("hair_fixture_{}", std::process::id()));
    std::fs::create_dir_all(&out)?;
    let status = std::process::Command::new("python3")
        .arg(repo().join("tools/blender/tests/export_fixture.py"))
        .arg(&out)
        .status()?;
    if !status.success() {
        return Err(format!("export_fixture.py failed: {status}").into());
    }
    let text = std::fs::read_to_string(out.join("fixture.hair.xml"))?;
    let groom = parse_groom("fixture.hair.xml", &text)?;
    let expected = std::fs::read_to_string(out.join("fixture.expected.txt"))?;
    let lines: Vec<&str> = expected.lines().filter(|l| !l.trim().is_empty()).collect();
    if lines.len() != groom.strand_count() {
        return Err(format!(
            "{} strands read, {} expected",
            groom.strand_count(),
            lines.len()
        )
        .into());
    }
    let mut worst = 0.0f32;
    for (s, line) in lines.iter().enumerate() {
        let v: Vec<f32> = line
            .split_whitespace()
            .map(|t| t.parse::<f32>())
            .collect::<Result<_, _>>()?;
        let strand = groom.strand(s);
        if v.len() != strand.len() * 3 {
            return Err(format!(
                "strand {s}: {} particles read, {} expected",
                strand.len(),
                v.len() / 3
            )
            .into());
        }
        for (i, p) in strand.iter().enumerate() {
            worst = worst.max(p.distance(Vec3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2])));
        }
    }
    println!(
        "blender round trip: {} strands, largest error {worst:e} m",
        lines.len()
    );
    if worst > 1e-5 {
        return Err(format!("positions differ by up to {worst} m").into());
    }
    let _ = std::fs::remove_dir_all(&out);
    Ok(())
}

/// Whether `python3` can import Blender's `bpy`.
pub fn blender_available() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import bpy"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}
