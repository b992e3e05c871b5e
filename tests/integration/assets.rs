//! Asset tests through Bevy's real asset server, and the Blender round trip.

use std::path::{Path, PathBuf};
use std::time::Duration;

use bevy::asset::{AssetPlugin, LoadState};
use bevy::prelude::*;
use bevy_cartoon_hair::asset::{
    HairAnimation, HairAssetPlugin, HairGroom, HeadCollision, parse_collision, parse_groom,
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
    (
        "hostile_keys_and_devices_are_refused_through_the_asset_server",
        hostile_keys_and_devices_are_refused_through_the_asset_server,
    ),
    (
        "an_animation_shares_one_particle_budget_among_its_keys",
        an_animation_shares_one_particle_budget_among_its_keys,
    ),
    #[cfg(unix)]
    (
        "the_regular_file_source_refuses_fifos_and_devices",
        the_regular_file_source_refuses_fifos_and_devices,
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

use crate::repo;

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
        && msg.contains("strand 1 has 3 particles, the base groom has 2")
        && !msg.contains("it strand"))
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
            .map(str::parse::<f32>)
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
    // The collision shapes exported beside it: a sphere, a capsule rigid body and a plane.
    let text = std::fs::read_to_string(out.join("fixture.collision.xml"))?;
    let shapes = parse_collision("fixture.collision.xml", &text)?;
    let expected = std::fs::read_to_string(out.join("fixture.collision.expected.txt"))?;
    let mut got = Vec::new();
    for s in &shapes.spheres {
        got.push(("sphere", vec![s.center.x, s.center.y, s.center.z, s.radius]));
    }
    for c in &shapes.capsules {
        let (a, b) = (c.a, c.b);
        got.push(("capsule", vec![a.x, a.y, a.z, b.x, b.y, b.z, c.radius]));
    }
    for p in &shapes.planes {
        let (x, n) = (p.point, p.normal);
        got.push(("plane", vec![x.x, x.y, x.z, n.x, n.y, n.z]));
    }
    let want: Vec<(&str, Vec<f32>)> = expected
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut parts = l.split_whitespace();
            let kind = parts.next().unwrap_or("");
            (kind, parts.filter_map(|v| v.parse().ok()).collect())
        })
        .collect();
    if got.len() != want.len()
        || got
            .iter()
            .zip(&want)
            .any(|(g, w)| g.0 != w.0 || g.1.len() != w.1.len())
    {
        return Err(format!("collision shapes read {got:?}, expected {want:?}").into());
    }
    let shape_error = got
        .iter()
        .zip(&want)
        .flat_map(|(g, w)| g.1.iter().zip(&w.1).map(|(a, b)| (a - b).abs()))
        .fold(0.0f32, f32::max);
    println!(
        "blender round trip: {} collision shapes (sphere, capsule, plane), largest error {shape_error:e}",
        got.len()
    );
    if shape_error > 1e-5 {
        return Err(format!("collision shapes differ by up to {shape_error}").into());
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

const OK_GROOM: &str = "<groom version=\"1\"><strand>0 0 0 0 1 0</strand></groom>";

/// A fresh folder under the system's temp dir.
fn scratch(name: &str) -> Result<PathBuf, Failed> {
    let dir = std::env::temp_dir().join(format!("hair_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn animation_with_key(key: &str) -> String {
    format!("<hairanim version=\"1\">\n  <key time=\"0\" groom=\"{key}\"/>\n</hairanim>\n")
}

/// Loads `path` and returns the error text of its failure, or an error if it did not fail.
fn load_error<A: Asset>(app: &mut App, path: &str) -> Result<String, Failed> {
    let handle: Handle<A> = app.world().resource::<AssetServer>().load(path.to_string());
    match wait(app, handle.id()) {
        LoadState::Failed(e) => Ok(e.to_string()),
        other => Err(format!("{path} did not fail: {other:?}").into()),
    }
}

/// Attacks on the loaders through Bevy's own asset server: keys that leave the asset folder are
/// refused before anything is opened (the file outside exists and is a valid groom), and a device
/// behind a link inside the folder is cut off at the groom's byte limit.
fn hostile_keys_and_devices_are_refused_through_the_asset_server() -> Result<(), Failed> {
    let root = scratch("hostile")?;
    let assets = root.join("assets");
    std::fs::create_dir_all(assets.join("pack"))?;
    std::fs::create_dir_all(assets.join("shared"))?;
    std::fs::create_dir_all(root.join("outside"))?;
    std::fs::write(root.join("outside/ok.hair.xml"), OK_GROOM)?;
    std::fs::write(assets.join("shared/base.hair.xml"), OK_GROOM)?;
    let cases = [
        (
            "escape",
            "../../outside/ok.hair.xml",
            "leads outside the asset folder",
        ),
        (
            "zero",
            "../../../../../../../../dev/zero",
            "does not name a .hair.xml",
        ),
        (
            "zero2",
            "../../../../../../../../dev/zero.hair.xml",
            "outside the asset folder",
        ),
        ("passwd", "/etc/passwd.hair.xml", "is absolute"),
        ("source", "embedded://x.hair.xml", "names an asset source"),
    ];
    for (name, key, _) in &cases {
        std::fs::write(
            assets.join(format!("pack/{name}.hairanim.xml")),
            animation_with_key(key),
        )?;
    }
    std::fs::write(
        assets.join("pack/fine.hairanim.xml"),
        animation_with_key("../shared/base.hair.xml"),
    )?;
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", assets.join("pack/zero.hair.xml"))?;
        std::fs::write(
            assets.join("pack/device.hairanim.xml"),
            animation_with_key("zero.hair.xml"),
        )?;
    }
    let mut app = asset_app(&assets);
    for (name, key, says) in &cases {
        let msg = load_error::<HairAnimation>(&mut app, &format!("pack/{name}.hairanim.xml"))?;
        let at = format!("pack/{name}.hairanim.xml:2:3: key 0: groom path {key:?}");
        if !msg.contains(&at) || !msg.contains(says) {
            return Err(format!("key {key:?}: unclear error: {msg}").into());
        }
    }
    #[cfg(unix)]
    for (path, is_anim) in [
        ("pack/zero.hair.xml", false),
        ("pack/device.hairanim.xml", true),
    ] {
        let msg = if is_anim {
            load_error::<HairAnimation>(&mut app, path)?
        } else {
            load_error::<HairGroom>(&mut app, path)?
        };
        let limit =
            bevy_cartoon_hair::asset::groom_byte_limit(bevy_cartoon_hair::asset::MAX_PARTICLES);
        if !msg.contains("zero.hair.xml") || !msg.contains(&format!("larger than {limit} bytes")) {
            return Err(format!("{path}: the device was not cut off clearly: {msg}").into());
        }
    }
    // A key that climbs only inside the folder loads.
    let fine: Handle<HairAnimation> = app
        .world()
        .resource::<AssetServer>()
        .load("pack/fine.hairanim.xml");
    let state = wait(&mut app, fine.id());
    if !matches!(state, LoadState::Loaded) {
        return Err(format!("a key inside the folder failed: {state:?}").into());
    }
    let _ = std::fs::remove_dir_all(&root);
    Ok(())
}

/// Two keys of a 1.2 million particle groom exceed the animation's 2 million particle budget: the
/// second key is loaded with only what is left and refused while it is read.
fn an_animation_shares_one_particle_budget_among_its_keys() -> Result<(), Failed> {
    use bevy_cartoon_hair::asset::MAX_ANIMATION_PARTICLES;
    let dir = scratch("budget")?;
    // 1,200,000 particles: one key of it fits the 2,000,000 budget, two do not.
    let (strands, per_strand) = (100_000, 12);
    let strand: String = (0..per_strand).map(|k| format!("0 {k} 0 ")).collect();
    let mut text = String::with_capacity(strands * (strand.len() + 20) + 64);
    text.push_str("<groom version=\"1\">\n");
    for _ in 0..strands {
        text.push_str("<strand>");
        text.push_str(&strand);
        text.push_str("</strand>\n");
    }
    text.push_str("</groom>\n");
    std::fs::write(dir.join("big.hair.xml"), &text)?;
    std::fs::write(
        dir.join("two.hairanim.xml"),
        "<hairanim version=\"1\">\n<key time=\"0\" groom=\"big.hair.xml\"/>\n\
         <key time=\"1\" groom=\"big.hair.xml\"/>\n</hairanim>",
    )?;
    std::fs::write(
        dir.join("one.hairanim.xml"),
        animation_with_key("big.hair.xml"),
    )?;
    let mut app = asset_app(&dir);
    let left = MAX_ANIMATION_PARTICLES - per_strand * strands;
    let msg = load_error::<HairAnimation>(&mut app, "two.hairanim.xml")?;
    if !(msg.contains("two.hairanim.xml:3:1: key 1")
        && msg.contains(&format!("may bring in {left} more particles"))
        && msg.contains(&format!("more than {left} particles in all")))
    {
        return Err(format!("unclear budget error: {msg}").into());
    }
    // One key of the same groom is within the budget.
    let one: Handle<HairAnimation> = app
        .world()
        .resource::<AssetServer>()
        .load("one.hairanim.xml");
    let state = wait(&mut app, one.id());
    if !matches!(state, LoadState::Loaded) {
        return Err(format!("one key within the budget failed: {state:?}").into());
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

/// With [`regular_file_source`] as the default source, a FIFO (which blocks Bevy's own file
/// reader for ever) and a link to a device fail at once with an error naming what they are.
#[cfg(unix)]
fn the_regular_file_source_refuses_fifos_and_devices() -> Result<(), Failed> {
    use bevy::asset::io::AssetSourceId;
    use bevy_cartoon_hair::asset::regular_file_source;
    let dir = scratch("special")?;
    std::fs::write(dir.join("ok.hair.xml"), OK_GROOM)?;
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.hair.xml"))?;
    let status = std::process::Command::new("mkfifo")
        .arg(dir.join("pipe.hair.xml"))
        .status()?;
    if !status.success() {
        return Err("mkfifo failed".into());
    }
    std::fs::write(
        dir.join("pipe.hairanim.xml"),
        animation_with_key("pipe.hair.xml"),
    )?;
    let mut app = App::new();
    app.register_asset_source(
        AssetSourceId::Default,
        regular_file_source(&dir.display().to_string()),
    );
    app.add_plugins((MinimalPlugins, AssetPlugin::default(), HairAssetPlugin));
    for (path, says) in [
        (
            "pipe.hair.xml",
            "is a FIFO (named pipe), not a regular file",
        ),
        ("zero.hair.xml", "is a device, not a regular file"),
    ] {
        let msg = load_error::<HairGroom>(&mut app, path)?;
        if !msg.contains(path) || !msg.contains(says) {
            return Err(format!("{path}: unclear error: {msg}").into());
        }
    }
    let msg = load_error::<HairAnimation>(&mut app, "pipe.hairanim.xml")?;
    if !msg.contains("pipe.hairanim.xml:2:3: key 0") || !msg.contains("FIFO") {
        return Err(format!("a FIFO key: unclear error: {msg}").into());
    }
    let ok: Handle<HairGroom> = app.world().resource::<AssetServer>().load("ok.hair.xml");
    let state = wait(&mut app, ok.id());
    if !matches!(state, LoadState::Loaded) {
        return Err(format!("a regular file failed to load: {state:?}").into());
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
