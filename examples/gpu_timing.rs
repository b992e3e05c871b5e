//! The hair's GPU cost a frame, pass by pass: renders one of the benches' workloads headless,
//! with and without its hair, and prints each render pass's GPU time and pipeline statistics.
//!
//! ```text
//! cargo run --release --example gpu_timing --features demo -- w2
//! cargo run --release --example gpu_timing --features demo -- w1 --size 1280x720 --frames 50
//! ```
//!
//! Workloads (those of `benches/`): `w1` (100 x 6 strands), `w6` (16 heads of 160 x 7), `w2`
//! (10,000 x 16), `w40k` (40,000 x 16). Options: `--size WxH` (default 1920x1080), `--msaa N`
//! (1 or 4, default 4), `--frames N` (default 200; frames measured after the warm-up),
//! `--no-shadows`, `--cpu` (tubes, strokes and quads built on the CPU).
//!
//! The scene: one directional light with shadow cascades, a grey ground and a head-sized sphere
//! under every hair, the default look. Each pass is timed with Bevy's `RenderDiagnosticsPlugin`
//! (GPU timestamps) and counted with pipeline statistics; the crate's passes
//! (`hair_gpu_tubes`, `hair_gpu_strokes`, `hair_gpu_highlights`, `outline_*`) have spans of
//! their own, and each compute pass's dispatches and strands built a frame
//! (`HairGpuPasses::dispatches`) are printed beside them. The hair's share of a pass is the
//! pass with hair minus the same scene without (both with the depth and normal prepasses the
//! hair's outline uses).
//!
//! Bevy 0.20 records the shadow passes as one time span (`per_view_shadow_pass`), without
//! pipeline statistics.
//!
//! Pipeline statistics (vertex, fragment and compute invocations, primitives) are counts: the
//! same on Mesa's CPU rasteriser (lavapipe) as on a GPU. On lavapipe the times are the CPU
//! rasteriser's, not a GPU's; the tool says which adapter it ran on.

use std::collections::BTreeMap;
use std::process::ExitCode;

use bevy::camera::RenderTarget;
use bevy::diagnostic::DiagnosticsStore;
use bevy::prelude::*;
use bevy::render::diagnostic::RenderDiagnosticsPlugin;
use bevy_cartoon_hair::headless::{CaptureSettings, HeadlessRenderer, find_adapter};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{HairGpuPasses, HairMeshBuilder};

/// The benches' workloads and how they spawn a head of hair.
#[path = "../benches/common/mod.rs"]
mod common;

struct Args {
    workload: String,
    width: u32,
    height: u32,
    msaa: u32,
    frames: u32,
    shadows: bool,
    cpu: bool,
}

fn args() -> Result<Args, String> {
    let mut out = Args {
        workload: String::new(),
        width: 1920,
        height: 1080,
        msaa: 4,
        frames: 200,
        shadows: true,
        cpu: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--size" => {
                let v = value("--size")?;
                let (w, h) = v.split_once('x').ok_or("--size is WIDTHxHEIGHT")?;
                out.width = w.parse().map_err(|_| format!("--size {v}: bad width"))?;
                out.height = h.parse().map_err(|_| format!("--size {v}: bad height"))?;
            }
            "--msaa" => {
                out.msaa = value("--msaa")?.parse().map_err(|_| "--msaa is 1 or 4")?;
                if ![1, 4].contains(&out.msaa) {
                    return Err("--msaa is 1 or 4".into());
                }
            }
            "--frames" => {
                out.frames = value("--frames")?
                    .parse()
                    .map_err(|_| "--frames is a count")?;
            }
            "--no-shadows" => out.shadows = false,
            "--cpu" => out.cpu = true,
            w if !w.starts_with('-') && out.workload.is_empty() => out.workload = w.to_string(),
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if out.workload.is_empty() {
        return Err("name a workload: w1, w6, w2 or w40k".into());
    }
    Ok(out)
}

fn heads(workload: &str) -> Result<Vec<common::Head>, String> {
    Ok(match workload {
        "w1" => common::w1(),
        "w6" => common::w6(),
        "w2" => common::w2(),
        "w40k" => {
            let mut heads = common::w2();
            heads[0].strands = 40_000;
            heads
        }
        other => return Err(format!("unknown workload {other}: w1, w6, w2 or w40k")),
    })
}

/// Mean of each `render/...` diagnostic over the measured frames, by path.
type Figures = BTreeMap<String, f64>;

/// Renders the scene (with or without its hair) and returns the mean of every render
/// diagnostic over `args.frames` frames.
fn measure(args: &Args, heads: &[common::Head], hair: bool) -> Result<Figures, String> {
    let mut r = HeadlessRenderer::new(CaptureSettings {
        width: args.width,
        height: args.height,
        max_frames: 20_000,
        ..default()
    })
    .map_err(|e| e.to_string())?;
    r.app
        .add_plugins((CartoonHairPlugins, RenderDiagnosticsPlugin));
    if args.cpu {
        r.app.insert_resource(HairMeshBuilder::Cpu);
    }
    let target = r.target();
    let world = r.app.world_mut();
    world.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: args.shadows,
            ..default()
        },
        Transform::from_xyz(1.0, 2.0, 1.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    world.spawn((
        Camera3d::default(),
        if args.msaa == 4 {
            Msaa::Sample4
        } else {
            Msaa::Off
        },
        RenderTarget::Image(target.into()),
        Transform::IDENTITY,
    ));
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(Color::srgb(0.6, 0.6, 0.6));
    let ground = world
        .resource_mut::<Assets<Mesh>>()
        .add(Plane3d::default().mesh().size(60.0, 60.0));
    let sphere = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(0.1).mesh().uv(32, 16));
    world.spawn((
        Mesh3d(ground),
        MeshMaterial3d(grey.clone()),
        Transform::from_xyz(0.0, -0.4, 0.0),
    ));
    for head in heads {
        world.spawn((
            Mesh3d(sphere.clone()),
            MeshMaterial3d(grey.clone()),
            Transform::from_translation(head.at),
        ));
        if hair {
            common::spawn_head(world, head);
        }
    }
    r.warm_up(|_| true).map_err(|e| e.to_string())?;
    // Diagnostics arrive a few frames late; let them settle.
    for _ in 0..8 {
        r.update();
    }
    let mut sums: BTreeMap<String, (f64, u32)> = BTreeMap::new();
    for _ in 0..args.frames {
        r.update();
        let store = r.app.world().resource::<DiagnosticsStore>();
        for d in store.iter() {
            let path = d.path().as_str();
            if !path.starts_with("render/") {
                continue;
            }
            if let Some(v) = d.measurement().map(|m| m.value) {
                let e = sums.entry(path.to_string()).or_default();
                e.0 += v;
                e.1 += 1;
            }
        }
        // The crate's own count of its compute work: dispatches and strands built.
        let built = r.app.world().resource::<HairGpuPasses>().dispatches();
        for (pass, work) in [
            ("hair_gpu_tubes", built.tubes),
            ("hair_gpu_strokes", built.strokes),
            ("hair_gpu_highlights", built.highlights),
        ] {
            for (figure, v) in [
                ("dispatches", work.dispatches),
                ("strands_built", work.invocations),
            ] {
                let e = sums.entry(format!("render/{pass}/{figure}")).or_default();
                e.0 += f64::from(v);
                e.1 += 1;
            }
        }
    }
    Ok(sums
        .into_iter()
        .map(|(k, (sum, n))| (k, sum / f64::from(n.max(1))))
        .collect())
}

fn main() -> ExitCode {
    let args = match args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("gpu_timing: {e}");
            return ExitCode::FAILURE;
        }
    };
    let heads = match heads(&args.workload) {
        Ok(h) => h,
        Err(e) => {
            eprintln!("gpu_timing: {e}");
            return ExitCode::FAILURE;
        }
    };
    let adapter = match find_adapter() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("gpu_timing: {e}");
            return ExitCode::FAILURE;
        }
    };
    let (without, with) = match (measure(&args, &heads, false), measure(&args, &heads, true)) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("gpu_timing: {e}");
            return ExitCode::FAILURE;
        }
    };
    let strands: usize = heads.iter().map(|h| h.strands).sum();
    println!(
        "gpu_timing: {} ({} heads, {strands} strands), {}x{}, MSAA {}, shadows {}, built on the \
         {}; adapter: {adapter}; {} frames",
        args.workload,
        heads.len(),
        args.width,
        args.height,
        args.msaa,
        if args.shadows { "on" } else { "off" },
        if args.cpu { "CPU" } else { "GPU" },
        args.frames
    );
    if adapter.to_lowercase().contains("llvmpipe") || adapter.to_lowercase().contains("lavapipe") {
        println!(
            "note: this adapter is Mesa's CPU rasteriser: its times are CPU time, not a GPU's; \
             the pipeline statistics (counts) are what any GPU would count"
        );
    }
    println!(
        "{:<44} {:>14} {:>14} {:>14}",
        "pass / figure", "with hair", "without", "hair's share"
    );
    let mut total = (0.0, 0.0);
    let mut seen_gpu = false;
    for (path, value) in &with {
        let base = without.get(path).copied().unwrap_or(0.0);
        let name = path.trim_start_matches("render/");
        if name.ends_with("elapsed_cpu") {
            continue;
        }
        if name.ends_with("elapsed_gpu") {
            seen_gpu = true;
            // Only the outermost spans: nested ones are inside their parents.
            if name.matches('/').count() == 1 {
                total.0 += value;
                total.1 += base;
            }
            println!(
                "{name:<44} {value:>11.3} ms {base:>11.3} ms {:>11.3} ms",
                value - base
            );
        } else {
            println!(
                "{name:<44} {value:>14.0} {base:>14.0} {:>14.0}",
                value - base
            );
        }
    }
    if seen_gpu {
        println!(
            "{:<44} {:>11.3} ms {:>11.3} ms {:>11.3} ms",
            "all passes (outermost spans)",
            total.0,
            total.1,
            total.0 - total.1
        );
    } else {
        println!("no GPU timestamps: the adapter has no timestamp queries (counts above only)");
    }
    ExitCode::SUCCESS
}
