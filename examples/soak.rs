//! A soak run: a crowd with hair through a whole play session of hostile frames, without a window.
//!
//! ```text
//! cargo run --release --example soak -- [--frames N] [--seed S] [--report N]
//! ```
//!
//! With `SOAK_EXIT_EARLY` set it exits right after the last frame, without dropping the app or
//! checking, so that a heap profiler (`heaptrack`) lists everything still held as leaked.
//!
//! 16 characters wear the ninja's hair (two grooms, one collision file, from a scratch copy of
//! the asset folder). For `--frames` frames (default 100,000) it steps every CPU stage of the hair
//! (simulation, tube meshes, silhouette strokes) with time steps drawn from 1/144 s to 1/10 s and
//! a single 1 s frame every 10,000, while it shakes the heads, teleports characters 50 m and back,
//! gives bones a zero scale or a NaN position for a frame, despawns and respawns hairs, and
//! rewrites the groom and collision files on disk: re-saved, broken, and restored, each reloaded
//! through the asset server as a file watcher would. Then the heads stop and the hair settles.
//!
//! Every 10,000 frames (`--report`) it prints the process's resident memory, its live heap (the
//! bytes allocated and not freed, counted by the soak's allocator), the live hair, strand and mesh
//! counts (each mesh becomes the GPU buffers a renderer would hold) and the largest distance of any
//! strand tip from its style. At the end it checks, and exits 1 naming what failed:
//! - memory flat after the warm-up (a quarter of the run, at least 15,000 frames: every kind of
//!   event has happened by then and the buffers have grown to their working sizes): the live
//!   heap grows by at most [`HEAP_BOUND_MB`] and resident memory by at most
//!   [`MEMORY_BOUND_MB`] (the allocator may keep what was freed);
//! - no particle ever non-finite, and no panic (a panic exits non-zero by itself);
//! - every hair back within [`RETURN_BOUND_M`] of where it rested before the motion;
//! - every broken file reported as a [`HairAssetFailed`] event naming it;
//! - as many hairs and meshes as at the start.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use bevy::asset::AssetPlugin;
use bevy::camera::primitives::Frustum;
use bevy::camera::{CameraProjection, RenderTargetInfo};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_cartoon_hair::HairSchedulePlugin;
use bevy_cartoon_hair::asset::{HairAssetPlugin, HairGroom};
use bevy_cartoon_hair::mesh::{HairMeshPlugin, HairMeshSettings};
use bevy_cartoon_hair::silhouette::{HairSilhouettePlugin, SilhouetteSettings};
use bevy_cartoon_hair::sim::{
    Hair, HairAssetFailed, HairSimSettings, HairSimulationPlugin, Strand, StrandParticles,
};

/// Characters in the crowd.
const CHARACTERS: usize = 16;
/// Growth of resident memory allowed after the warm-up.
const MEMORY_BOUND_MB: f64 = 32.0;
/// Growth of the live heap allowed after the warm-up: a reload of a file every hair uses holds
/// up to 0.7 MB for a while (seen at 18,000 frames), and a leak of 50 bytes a frame would pass
/// 4 MB within the 85,000 frames after a 100,000-frame run's warm-up.
const HEAP_BOUND_MB: f64 = 4.0;
/// How far from its resting place a particle may be once the motion has stopped and settled.
const RETURN_BOUND_M: f32 = 0.002;
/// Frames the heads rest at the end.
const SETTLE_FRAMES: u64 = 3000;
/// Frames a reload may take to be reported before it counts as lost.
const REPORT_FRAMES: u64 = 2000;

/// The system allocator, counting the bytes the process holds: live heap, the part of resident
/// memory a leak grows (resident memory also holds what the allocator keeps after a free).
struct Counting;

static LIVE_BYTES: AtomicUsize = AtomicUsize::new(0);

#[expect(
    unsafe_code,
    reason = "a global allocator is an unsafe trait: this one forwards to the system's"
)]
// SAFETY: every call goes to the system allocator with the caller's own arguments; the counter
// only adds and subtracts the sizes the caller passes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, as `GlobalAlloc::alloc` requires.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) };
        LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(layout.size(), Ordering::Relaxed);
        }
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: `ptr` came from this allocator with `layout`.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE_BYTES.fetch_add(new_size, Ordering::Relaxed);
            LIVE_BYTES.fetch_sub(layout.size(), Ordering::Relaxed);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

fn live_mb() -> f64 {
    LIVE_BYTES.load(Ordering::Relaxed) as f64 / 1e6
}

/// A small deterministic generator (xorshift).
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Broken saves and what was reported.
#[derive(Resource, Default)]
struct Reports {
    /// `(path, error)` of every failed load reported with the last good version kept.
    kept: Vec<(String, String)>,
}

/// One file event of the run, done at a frame.
#[derive(Clone, Copy, Debug)]
enum FileStep {
    /// Re-save a good file (same content): a reload that rebuilds.
    Resave(usize),
    /// Replace it with a broken one.
    Break(usize),
    /// Put the good one back.
    Restore,
}

/// The files of the scratch asset folder: two grooms and a collision file.
const FILES: [(&str, &str); 3] = [
    ("a.hair.xml", "ninja/ninja.hair.xml"),
    ("b.hair.xml", "ninja/ninja_flip.hair.xml"),
    ("head.collision.xml", "ninja/ninja.collision.xml"),
];

/// A broken version of `good`: a number that is not one, on its third line.
fn broken(good: &str, round: u64) -> String {
    let mut lines: Vec<String> = good.lines().map(str::to_owned).collect();
    let bad = ["NaN", "1e99", "x", "&lol;"][(round % 4) as usize];
    if let Some(line) = lines.get_mut(2) {
        *line = if line.contains("<strand>") {
            line.replacen("<strand>", &format!("<strand>{bad} "), 1)
        } else {
            line.replacen("r=\"", &format!("r=\"{bad}"), 1)
        };
    }
    lines.join("\n")
}

fn resident_mb() -> f64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<f64>().ok())
        .map_or(0.0, |pages| pages * 4096.0 / 1e6)
}

fn camera(world: &mut World) {
    let transform =
        Transform::from_xyz(0.0, 1.6, 6.0).looking_at(Vec3::new(0.0, 1.6, 0.0), Vec3::Y);
    let projection = PerspectiveProjection {
        aspect_ratio: 16.0 / 9.0,
        ..default()
    };
    let mut camera = Camera::default();
    camera.computed.clip_from_view = projection.get_clip_from_view();
    camera.computed.target_info = Some(RenderTargetInfo {
        physical_size: UVec2::new(1280, 720),
        scale_factor: 1.0,
    });
    let global = GlobalTransform::from(transform);
    let projection = Projection::Perspective(projection);
    let frustum: Frustum = projection.compute_frustum(&global);
    world.spawn((
        Camera3d::default(),
        camera,
        projection,
        transform,
        global,
        frustum,
    ));
}

/// Where character `i` stands.
fn home(i: usize) -> Transform {
    Transform::from_xyz((i % 4) as f32 * 0.8 - 1.2, 1.6, -((i / 4) as f32) * 0.8)
}

fn spawn_hair(world: &mut World, server: &AssetServer, bone: Entity, i: usize) -> Entity {
    world
        .spawn((
            Hair {
                groom: server.load(FILES[i % 2].0),
                animation: None,
                collision: Some(server.load(FILES[2].0)),
            },
            HairSimSettings::default(),
            HairMeshSettings::default(),
            SilhouetteSettings::default(),
            ChildOf(bone),
        ))
        .id()
}

/// Every hair's particles, by character, strands in order.
fn particles(app: &mut App, hairs: &[Entity]) -> Vec<Vec<Vec3>> {
    let mut q = app
        .world_mut()
        .query::<(&Strand, &StrandParticles, &bevy_cartoon_hair::sim::StrandOf)>();
    let mut out = vec![Vec::new(); hairs.len()];
    let mut rows: Vec<_> = q
        .iter(app.world())
        .map(|(s, p, of)| (of.0, s.index, p.positions.clone()))
        .collect();
    rows.sort_by_key(|r| r.1);
    for (hair, _, positions) in rows {
        if let Some(i) = hairs.iter().position(|h| *h == hair) {
            out[i].extend(positions);
        }
    }
    out
}

/// Largest distance of a strand tip from its style (the groom placed on the hair's bone).
fn tip_from_style(app: &mut App) -> f32 {
    let mut q = app
        .world_mut()
        .query::<(&Strand, &StrandParticles, &bevy_cartoon_hair::sim::StrandOf)>();
    let grooms = app.world().resource::<Assets<HairGroom>>();
    let mut far = 0.0f32;
    for (strand, p, of) in q.iter(app.world()) {
        let (Some(hair), Some(bone)) = (
            app.world().get::<Hair>(of.0),
            app.world().get::<GlobalTransform>(of.0),
        ) else {
            continue;
        };
        let (Some(groom), Some(tip)) = (grooms.get(&hair.groom), p.positions.last()) else {
            continue;
        };
        if strand.index as usize >= groom.strand_count() || !bone.affine().is_finite() {
            continue;
        }
        let Some(styled) = groom.strand(strand.index as usize).last() else {
            continue;
        };
        far = far.max(bone.transform_point(*styled).distance(*tip));
    }
    far
}

struct Args {
    frames: u64,
    seed: u64,
    report: u64,
}

fn args() -> Result<Args, String> {
    let mut a = Args {
        frames: 100_000,
        seed: 0x5eed,
        report: 10_000,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = |name: &str| -> Result<u64, String> {
            it.next()
                .and_then(|v| v.parse().ok())
                .ok_or(format!("{name} needs a whole number"))
        };
        match flag.as_str() {
            "--frames" => a.frames = value("--frames")?.max(SETTLE_FRAMES + 1000),
            "--seed" => a.seed = value("--seed")?.max(1),
            "--report" => a.report = value("--report")?.max(1),
            other => {
                return Err(format!(
                    "unknown argument {other:?}; use --frames N, --seed S, --report N"
                ));
            }
        }
    }
    Ok(a)
}

fn scratch_assets() -> std::io::Result<PathBuf> {
    let dir = std::env::temp_dir().join(format!("hair_soak_{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let assets = bevy::asset::io::file::FileAssetReader::get_base_path().join("assets");
    for (name, from) in FILES {
        std::fs::copy(assets.join(from), dir.join(name))?;
    }
    Ok(dir)
}

fn main() -> ExitCode {
    let args = match args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("soak: {e}");
            return ExitCode::from(2);
        }
    };
    let dir = match scratch_assets() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("soak: cannot make the scratch asset folder: {e}");
            return ExitCode::FAILURE;
        }
    };
    let good: Vec<String> = FILES
        .iter()
        .map(|(n, _)| std::fs::read_to_string(dir.join(n)).unwrap_or_default())
        .collect();
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(bevy_cartoon_hair::compute_on_every_core()),
        TransformPlugin,
        AssetPlugin {
            file_path: dir.display().to_string(),
            ..default()
        },
        HairAssetPlugin,
        HairSchedulePlugin,
        HairSimulationPlugin,
        HairMeshPlugin,
        HairSilhouettePlugin,
    ))
    .init_asset::<Mesh>()
    .init_resource::<Reports>()
    .add_observer(|e: On<HairAssetFailed>, mut r: ResMut<Reports>| {
        if e.kept_last_good {
            r.kept.push((e.path.clone(), e.error.clone()));
        }
    });
    camera(app.world_mut());
    let server = app.world().resource::<AssetServer>().clone();
    let bones: Vec<Entity> = (0..CHARACTERS)
        .map(|i| app.world_mut().spawn(home(i)).id())
        .collect();
    let mut hairs: Vec<Entity> = bones
        .iter()
        .enumerate()
        .map(|(i, b)| spawn_hair(app.world_mut(), &server, *b, i))
        .collect();
    let step = |app: &mut App, dt: f64| {
        app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            dt,
        )));
        app.update();
    };
    for _ in 0..600 {
        step(&mut app, 1.0 / 60.0);
        std::thread::sleep(Duration::from_millis(1));
    }
    let rest = particles(&mut app, &hairs);
    if rest.iter().any(Vec::is_empty) {
        eprintln!("soak: not every hair was built after 600 frames");
        return ExitCode::FAILURE;
    }
    let meshes_at_start = app.world().resource::<Assets<Mesh>>().len();
    println!(
        "soak: {} frames, {CHARACTERS} characters, {} particles each, seed {}",
        args.frames,
        rest[0].len(),
        args.seed
    );
    println!(
        "{:>8} {:>8} {:>8} {:>6} {:>7} {:>6} {:>11} {:>8} {:>7}",
        "frame",
        "RSS MB",
        "heap MB",
        "hairs",
        "strands",
        "meshes",
        "tip->style",
        "reports",
        "seconds"
    );

    let mut rng = Rng(args.seed);
    let motion_end = args.frames - SETTLE_FRAMES;
    let mut failures: Vec<String> = Vec::new();
    let mut non_finite = 0u64;
    let mut max_tip = 0.0f32;
    let mut memory_start = 0.0;
    let mut memory_peak = 0.0f64;
    let mut heap_start = 0.0;
    let mut heap_peak = 0.0f64;
    let mut despawned: Option<(usize, u64)> = None;
    let mut teleported: Option<(usize, u64)> = None;
    // The file step in flight: what, when, and how many reports there were before it.
    let mut pending: Option<(FileStep, u64, usize)> = None;
    let mut broken_saves = 0usize;
    let mut rounds = 0u64;
    let started = Instant::now();
    let warm = (args.frames / 4).max(15_000).min(motion_end - 1);
    for frame in 0..args.frames {
        let moving = frame < motion_end;
        let t = frame as f32 / 60.0;
        // Time step: mostly 1/144 to 1/10 s, a single 1 s frame every 10,000.
        let dt = if moving && frame % 10_000 == 5_000 {
            1.0
        } else if moving {
            1.0 / 144.0 + f64::from(rng.unit()) * (0.1 - 1.0 / 144.0)
        } else {
            1.0 / 60.0
        };
        for (i, bone) in bones.iter().enumerate() {
            let mut pose = home(i);
            if moving {
                let phase = i as f32 * 0.7;
                pose.rotation = Quat::from_rotation_y(1.2 * (5.0 * t + phase).sin())
                    * Quat::from_rotation_x(0.4 * (3.0 * t + phase).cos());
            }
            if let Some((who, since)) = teleported
                && who == i
                && frame - since < 100
            {
                pose.translation.x += 50.0;
            }
            if moving && frame % 997 == 0 && i == (frame as usize / 997) % CHARACTERS {
                pose.scale = Vec3::ZERO;
            }
            if moving && frame % 1009 == 0 && i == (frame as usize / 1009 + 5) % CHARACTERS {
                pose.translation.y = f32::NAN;
            }
            if let Some(mut tf) = app.world_mut().get_mut::<Transform>(*bone) {
                *tf = pose;
            }
        }
        if moving && frame % 2500 == 1200 {
            teleported = Some(((frame as usize / 2500) % CHARACTERS, frame));
        }
        // Despawn a hair, respawn it 10 frames later.
        if moving && frame % 5000 == 2500 {
            let i = (frame as usize / 5000 + 3) % CHARACTERS;
            app.world_mut().entity_mut(hairs[i]).despawn();
            despawned = Some((i, frame));
        }
        if let Some((i, since)) = despawned
            && frame - since >= 10
        {
            hairs[i] = spawn_hair(app.world_mut(), &server, bones[i], i);
            despawned = None;
        }
        // Files: every 7,000 frames a round of re-save, break and restore of one file.
        let reports = app.world().resource::<Reports>().kept.len();
        match pending {
            None if moving && frame % 7000 == 3000 => {
                let file = (rounds % 3) as usize;
                let _ = std::fs::write(dir.join(FILES[file].0), &good[file]);
                server.reload(FILES[file].0);
                pending = Some((FileStep::Resave(file), frame, reports));
            }
            Some((FileStep::Resave(file), since, _)) if frame - since >= 300 => {
                let _ = std::fs::write(dir.join(FILES[file].0), broken(&good[file], rounds));
                server.reload(FILES[file].0);
                broken_saves += 1;
                pending = Some((FileStep::Break(file), frame, reports));
            }
            Some((FileStep::Break(file), since, before)) => {
                let seen = app.world().resource::<Reports>().kept[before..]
                    .iter()
                    .any(|(path, _)| path.contains(FILES[file].0));
                if seen || frame - since >= REPORT_FRAMES {
                    if !seen {
                        failures.push(format!(
                            "the broken save of {} at frame {since} was not reported within \
                             {REPORT_FRAMES} frames",
                            FILES[file].0
                        ));
                    }
                    let _ = std::fs::write(dir.join(FILES[file].0), &good[file]);
                    server.reload(FILES[file].0);
                    pending = Some((FileStep::Restore, frame, reports));
                }
            }
            Some((FileStep::Restore, since, _)) if frame - since >= 300 => {
                pending = None;
                rounds += 1;
            }
            _ => {}
        }

        step(&mut app, dt);

        if frame % 100 == 0 {
            let now = particles(&mut app, &hairs);
            non_finite += now.iter().flatten().filter(|p| !p.is_finite()).count() as u64;
            if moving {
                max_tip = max_tip.max(tip_from_style(&mut app));
            }
        }
        if frame == warm {
            memory_start = resident_mb();
            heap_start = live_mb();
        }
        if frame > warm {
            memory_peak = memory_peak.max(resident_mb());
            heap_peak = heap_peak.max(live_mb());
        }
        if frame % args.report == 0 || frame + 1 == args.frames {
            let world = app.world_mut();
            let hair_count = world.query::<&Hair>().iter(world).count();
            let strand_count = world.query::<&Strand>().iter(world).count();
            let meshes = world.resource::<Assets<Mesh>>().len();
            let kept = world.resource::<Reports>().kept.len();
            println!(
                "{frame:>8} {:>8.1} {:>8.1} {hair_count:>6} {strand_count:>7} {meshes:>6} \
                 {:>9.3} m {kept:>8} {:>7.0}",
                resident_mb(),
                live_mb(),
                max_tip,
                started.elapsed().as_secs_f64()
            );
            max_tip = 0.0;
        }
    }

    if std::env::var_os("SOAK_EXIT_EARLY").is_some() {
        std::process::exit(0);
    }
    // Checks.
    let end = particles(&mut app, &hairs);
    let mut back = 0.0f32;
    for (a, b) in rest.iter().zip(&end) {
        if a.len() != b.len() {
            failures.push(format!(
                "a hair came back with {} particles, had {}",
                b.len(),
                a.len()
            ));
            continue;
        }
        for (p, q) in a.iter().zip(b) {
            back = back.max(p.distance(*q));
        }
    }
    let reported = app.world().resource::<Reports>().kept.clone();
    let hair_count = {
        let world = app.world_mut();
        world.query::<&Hair>().iter(world).count()
    };
    let meshes = app.world().resource::<Assets<Mesh>>().len();
    println!(
        "soak: {:.0} s; resident memory {memory_start:.1} MB after the warm-up (frame {warm}), at \
         most {memory_peak:.1} MB after; live heap {heap_start:.1} MB, at most {heap_peak:.1} MB \
         after; {non_finite} non-finite particles seen; every hair within {:.3} mm of its \
         rest after {SETTLE_FRAMES} still frames; {broken_saves} broken saves, {} reports \
         (one per hair using the file)",
        started.elapsed().as_secs_f64(),
        back * 1000.0,
        reported.len()
    );
    if let Some((path, error)) = reported.first() {
        println!("soak: a report: {path}: {error}");
    }
    if memory_peak - memory_start > MEMORY_BOUND_MB {
        failures.push(format!(
            "resident memory grew {:.1} MB after the warm-up (bound {MEMORY_BOUND_MB} MB)",
            memory_peak - memory_start
        ));
    }
    if heap_peak - heap_start > HEAP_BOUND_MB {
        failures.push(format!(
            "the live heap grew {:.1} MB after the warm-up (bound {HEAP_BOUND_MB} MB)",
            heap_peak - heap_start
        ));
    }
    if non_finite > 0 {
        failures.push(format!("{non_finite} non-finite particles"));
    }
    if back > RETURN_BOUND_M {
        failures.push(format!(
            "a hair rests {:.2} mm from where it rested before the motion (bound {} mm)",
            back * 1000.0,
            RETURN_BOUND_M * 1000.0
        ));
    }
    if broken_saves == 0 {
        failures.push("the run was too short to break a file".into());
    }
    if hair_count != CHARACTERS || meshes != meshes_at_start {
        failures.push(format!(
            "{hair_count} hairs and {meshes} meshes at the end, {CHARACTERS} and \
             {meshes_at_start} at the start"
        ));
    }
    let _ = std::fs::remove_dir_all(&dir);
    if failures.is_empty() {
        println!("soak: passed");
        ExitCode::SUCCESS
    } else {
        for f in &failures {
            eprintln!("soak: FAILED: {f}");
        }
        ExitCode::FAILURE
    }
}
