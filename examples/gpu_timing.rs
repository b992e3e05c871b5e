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
//! `--no-shadows`, `--cpu` (tubes, strokes and quads built on the CPU), `--whole-quads`
//! (strokes and quads drawn whole, not by count: `render::HairCompactQuads(false)`), `--rings N` and
//! `--sides N` (every hair's tube resolution in place of the workload's), `--radius M` (the
//! tubes' root radius in metres, in place of the default 0.016), `--silhouette-error PX`
//! (`HairLod::silhouette_error`, 0 for the level's sides at any width), `--reverse-strands` (the
//! strands drawn in the opposite order: how much a pass's overdraw depends on it),
//! `--closed-tubes` (`HairLod::half_tubes` off), `--ribbon-pixels PX` (`HairLod::ribbon_pixels`,
//! 0 for no ribbons), `--shadow-caster ribbons|tubes|off`
//! (`HairShadowCaster`), `--cards N` (N hair cards of 30 cm, double-sided and painted with
//! strand tips in alpha, dressed by a `ToonHairMeshes` and cut out as their glTF material is,
//! spread over the heads), `--opaque-cards` (the same cards drawn opaque), `--outline` (the
//! camera's `ImageSpaceOutline` with the hair, the mass outline in black) and
//! `--outline-hair-colour` (the same in the hair's colour, `hair_tint`). The hairs'
//! strand width on screen and the tube resolution the level of detail chose are printed.
//!
//! The scene: one directional light with shadow cascades, a grey ground and a head-sized sphere
//! under every hair, the default look. Each pass is timed with Bevy's `RenderDiagnosticsPlugin`
//! (GPU timestamps) and counted with pipeline statistics; the crate's passes
//! (`hair_gpu_tubes`, `hair_gpu_strokes`, `hair_gpu_highlights`, `hair_gpu_draw_order`,
//! `hair_gpu_shadows`, `outline_*`) have spans of
//! their own, and each compute pass's dispatches and strands built a frame
//! (`HairGpuPasses::dispatches`) are printed beside them. The hair's share of a pass is the
//! pass with hair minus the same scene without. The hair turns on Bevy's depth and normal
//! prepasses (its strokes and outline read them), which then draw the whole scene a second time;
//! a third scene, without hair but with those prepasses, gives the hair's share in a game that
//! has them already.
//!
//! Bevy 0.20 records the shadow passes as one time span (`per_view_shadow_pass`), without
//! pipeline statistics; `shadow_casters/primitives` counts instead the triangles of every mesh
//! Bevy's cascade culling keeps in each cascade (what the shadow passes are sent), summed over
//! the cascades (`shadow_casters/cascades`).
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
    compact_quads: bool,
    reverse_strands: bool,
    rings: Option<u32>,
    sides: Option<u32>,
    radius: Option<f32>,
    silhouette_error: Option<f32>,
    ribbon_pixels: Option<f32>,
    closed_tubes: bool,
    caster: bevy_cartoon_hair::mesh::HairShadowCaster,
    cards: u32,
    opaque_cards: bool,
    /// The camera's image-space outline with hair (`None`: no outline), its hair tint.
    outline: Option<Option<Color>>,
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
        compact_quads: true,
        reverse_strands: false,
        rings: None,
        sides: None,
        radius: None,
        silhouette_error: None,
        ribbon_pixels: None,
        closed_tubes: false,
        caster: default(),
        cards: 0,
        opaque_cards: false,
        outline: None,
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
            "--whole-quads" => out.compact_quads = false,
            "--reverse-strands" => out.reverse_strands = true,
            "--closed-tubes" => out.closed_tubes = true,
            "--opaque-cards" => out.opaque_cards = true,
            "--outline" => out.outline = Some(None),
            "--outline-hair-colour" => out.outline = Some(Some(Color::srgb(0.45, 0.3, 0.3))),
            "--cards" => {
                out.cards = value("--cards")?
                    .parse()
                    .map_err(|_| "--cards is a count")?;
                if out.cards > 10_000 {
                    return Err("--cards is at most 10000".into());
                }
            }
            "--shadow-caster" => {
                use bevy_cartoon_hair::mesh::HairShadowCaster;
                out.caster = match value("--shadow-caster")?.as_str() {
                    "ribbons" => HairShadowCaster::Ribbons,
                    "tubes" => HairShadowCaster::Tubes,
                    "off" => HairShadowCaster::Off,
                    other => {
                        return Err(format!("--shadow-caster {other}: ribbons, tubes or off"));
                    }
                };
            }
            "--silhouette-error" => {
                let e: f32 = value("--silhouette-error")?
                    .parse()
                    .map_err(|_| "--silhouette-error is pixels")?;
                if !(0.0..=16.0).contains(&e) {
                    return Err("--silhouette-error is from 0 to 16 px".into());
                }
                out.silhouette_error = Some(e);
            }
            "--ribbon-pixels" => {
                let px: f32 = value("--ribbon-pixels")?
                    .parse()
                    .map_err(|_| "--ribbon-pixels is pixels")?;
                if !(0.0..=64.0).contains(&px) {
                    return Err("--ribbon-pixels is from 0 to 64 px".into());
                }
                out.ribbon_pixels = Some(px);
            }
            "--radius" => {
                let r: f32 = value("--radius")?
                    .parse()
                    .map_err(|_| "--radius is metres")?;
                if !(1e-4..=0.1).contains(&r) {
                    return Err("--radius is from 0.0001 to 0.1 m".into());
                }
                out.radius = Some(r);
            }
            "--rings" | "--sides" => {
                let n: u32 = value(&a)?.parse().map_err(|_| format!("{a} is a count"))?;
                let limit = if a == "--rings" { 2..=64 } else { 3..=32 };
                if !limit.contains(&n) {
                    return Err(format!("{a} is from {} to {}", limit.start(), limit.end()));
                }
                if a == "--rings" {
                    out.rings = Some(n);
                } else {
                    out.sides = Some(n);
                }
            }
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

/// What a measured scene holds besides the ground, the spheres and the light.
#[derive(Clone, Copy, PartialEq)]
enum Scene {
    /// Nothing more: no prepass either.
    Bare,
    /// The depth and normal prepasses the hair's outline and strokes turn on, without hair: a
    /// game with a prepass of its own (for SSAO, TAA ...) pays these already.
    Prepass,
    /// The hair (which turns the prepasses on).
    Hair,
}

/// Renders the scene and returns the mean of every render diagnostic over `args.frames`
/// frames.
fn measure(args: &Args, heads: &[common::Head], scene: Scene) -> Result<Figures, String> {
    let hair = scene == Scene::Hair;
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
    r.app
        .insert_resource(bevy_cartoon_hair::render::HairCompactQuads(
            args.compact_quads,
        ));
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
    let camera = world
        .spawn((
            Camera3d::default(),
            if args.msaa == 4 {
                Msaa::Sample4
            } else {
                Msaa::Off
            },
            RenderTarget::Image(target.into()),
            Transform::IDENTITY,
        ))
        .id();
    if let Some(hair_tint) = args.outline.filter(|_| hair) {
        world
            .entity_mut(camera)
            .insert(bevy_cartoon_hair::render::ImageSpaceOutline {
                hair_tint,
                ..default()
            });
    }
    if scene == Scene::Prepass {
        world.entity_mut(camera).insert((
            bevy::core_pipeline::prepass::DepthPrepass,
            bevy::core_pipeline::prepass::NormalPrepass,
        ));
    }
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
            let mut head = *head;
            head.rings = args.rings.unwrap_or(head.rings);
            head.sides = args.sides.unwrap_or(head.sides);
            let mut strands = common::strands(head.strands, head.particles);
            if args.reverse_strands {
                strands.reverse();
            }
            let hair = common::spawn_head_with(world, &head, strands);
            let lod = bevy_cartoon_hair::mesh::HairLod::default();
            world.entity_mut(hair).insert((
                bevy_cartoon_hair::mesh::HairLod {
                    silhouette_error: args.silhouette_error.unwrap_or(lod.silhouette_error),
                    half_tubes: !args.closed_tubes,
                    ribbon_pixels: args.ribbon_pixels.unwrap_or(lod.ribbon_pixels),
                    ..lod
                },
                args.caster,
            ));
            if let Some(radius) = args.radius {
                world
                    .entity_mut(hair)
                    .get_mut::<bevy_cartoon_hair::mesh::HairMeshSettings>()
                    .ok_or("the hair has no mesh settings")?
                    .radius = radius;
            }
        }
    }
    if hair && args.cards > 0 {
        spawn_cards(world, heads, args.cards, args.opaque_cards);
    }
    r.warm_up(|_| true).map_err(|e| e.to_string())?;
    // Diagnostics arrive a few frames late; let them settle.
    for _ in 0..8 {
        r.update();
    }
    if hair {
        // What the level of detail chose: the widest strands on screen and the tubes.
        let world = r.app.world_mut();
        let mut lod = world.query::<(
            &bevy_cartoon_hair::mesh::HairLodLevel,
            &bevy_cartoon_hair::mesh::ComputedHairMesh,
        )>();
        for (level, mesh) in lod.iter(world) {
            println!(
                "hair: {:.1} px tall, strands {:.1} px wide, level {}, tubes {} rings x {} sides{}",
                level.pixels,
                level.strand_pixels,
                level.level,
                mesh.topology.rings(),
                mesh.topology.closed_sides(),
                if mesh.topology.is_ribbon() {
                    ", ribbons".to_string()
                } else if mesh.topology.is_facing() {
                    format!(", half tubes of {} vertices a ring", mesh.topology.sides())
                } else {
                    String::new()
                }
            );
        }
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
        // What Bevy sends into the shadow cascades: every triangle of each mesh its cascade
        // culling keeps, cascade by cascade (the shadow passes have no pipeline statistics).
        let (casts, cascades) = shadow_primitives(r.app.world_mut(), camera);
        for (figure, v) in [("primitives", casts), ("cascades", cascades)] {
            let e = sums
                .entry(format!("render/shadow_casters/{figure}"))
                .or_default();
            e.0 += v as f64;
            e.1 += 1;
        }
        // The crate's own count of its compute work: dispatches and strands built.
        let built = r.app.world().resource::<HairGpuPasses>().dispatches();
        for (pass, work, what) in [
            ("hair_gpu_tubes", built.tubes, "strands_built"),
            ("hair_gpu_strokes", built.strokes, "strands_built"),
            ("hair_gpu_highlights", built.highlights, "strands_built"),
            ("hair_gpu_draw_order", built.draw_order, "indices_ordered"),
            ("hair_gpu_shadows", built.shadows, "strands_built"),
            (
                "hair_gpu_quad_compaction",
                built.compact,
                "strands_compacted",
            ),
        ] {
            for (figure, v) in [("dispatches", work.dispatches), (what, work.invocations)] {
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

/// The triangles of every mesh Bevy's cascade culling keeps in each shadow cascade of every
/// directional light for `camera`, summed over the cascades; and the cascades.
fn shadow_primitives(world: &mut World, camera: Entity) -> (usize, usize) {
    let mut lights = world.query::<&bevy::camera::visibility::CascadesVisibleEntities>();
    let mut meshes_of = world.query::<&Mesh3d>();
    let meshes = world.resource::<Assets<Mesh>>();
    let (mut primitives, mut cascades) = (0, 0);
    for visible in lights.iter(world) {
        let Some(per_cascade) = visible.entities.get(&camera) else {
            continue;
        };
        cascades += per_cascade.len();
        for cascade in per_cascade {
            for &entity in &cascade.entities {
                let triangles = meshes_of
                    .get(world, entity)
                    .ok()
                    .and_then(|m| meshes.get(&m.0))
                    .map_or(0, |m| {
                        m.indices()
                            .map_or(m.count_vertices(), bevy::mesh::Indices::len)
                            / 3
                    });
                primitives += triangles;
            }
        }
    }
    (primitives, cascades)
}

/// `count` hair cards (30 cm squares, double-sided, painted with strand tips in alpha: a 32 x 32
/// texture whose lower half is teeth) in front of and around the heads, in a glTF-like material
/// cut out at 0.5 (or opaque), dressed by one `ToonHairMeshes` with its default material.
fn spawn_cards(world: &mut World, heads: &[common::Head], count: u32, opaque: bool) {
    use bevy::asset::RenderAssetUsages;
    use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
    let mut texels = Vec::with_capacity(32 * 32 * 4);
    for y in 0..32u8 {
        for x in 0..32u8 {
            let tooth = 16.0 * (1.0 - (f32::from(x % 8) - 3.5).abs() / 4.0);
            let alpha = if f32::from(y) < 14.0 + tooth { 255 } else { 0 };
            texels.extend([200 - 3 * y, 110 - y, 230, alpha]);
        }
    }
    let texture = world.resource_mut::<Assets<Image>>().add(Image::new(
        Extent3d {
            width: 32,
            height: 32,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        texels,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    ));
    let gltf = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color_texture: Some(texture),
            alpha_mode: if opaque {
                AlphaMode::Opaque
            } else {
                AlphaMode::Mask(0.5)
            },
            double_sided: true,
            cull_mode: None,
            ..default()
        });
    let card = world
        .resource_mut::<Assets<Mesh>>()
        .add(Rectangle::new(0.3, 0.3));
    let root = world
        .spawn((
            Transform::default(),
            Visibility::default(),
            bevy_cartoon_hair::render::ToonHairMeshes::matching(|n| n == "card"),
        ))
        .id();
    let per_head = count.div_ceil(heads.len().max(1) as u32).max(1);
    for k in 0..count {
        let Some(head) = heads.get((k / per_head) as usize) else {
            break;
        };
        // Fanned around the head, each a little in front of the one before.
        let i = (k % per_head) as f32;
        let angle = 0.6 * (i - 0.5 * (per_head - 1) as f32) / per_head as f32;
        world.spawn((
            Name::new("card"),
            Mesh3d(card.clone()),
            MeshMaterial3d(gltf.clone()),
            Transform::from_translation(head.at + Vec3::new(angle, 0.05, 0.12 + 0.002 * i))
                .with_rotation(Quat::from_rotation_z(angle)),
            ChildOf(root),
        ));
    }
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
    let mut figures = Vec::new();
    for scene in [Scene::Bare, Scene::Prepass, Scene::Hair] {
        match measure(&args, &heads, scene) {
            Ok(f) => figures.push(f),
            Err(e) => {
                eprintln!("gpu_timing: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let [without, prepass, with] = <[Figures; 3]>::try_from(figures).expect("three scenes");
    let strands: usize = heads.iter().map(|h| h.strands).sum();
    println!(
        "gpu_timing: {} ({} heads, {strands} strands{}{}{}), {}x{}, MSAA {}, shadows {}, built on \
         the {}; adapter: {adapter}; {} frames",
        args.workload,
        heads.len(),
        args.rings.map_or(String::new(), |n| format!(", {n} rings")),
        args.sides.map_or(String::new(), |n| format!(", {n} sides")),
        if args.reverse_strands {
            ", strands reversed"
        } else {
            ""
        },
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
        "columns: the scene with hair; without hair; without hair but with the depth and normal \
         prepasses the hair turns on; the hair's share (with - without); its share over a scene \
         that has those prepasses already (with - prepassed)"
    );
    println!(
        "{:<44} {:>12} {:>12} {:>12} {:>12} {:>12}",
        "pass / figure", "with hair", "without", "prepassed", "hair", "hair/prepass"
    );
    let mut total = [0.0; 3];
    let mut seen_gpu = false;
    for (path, value) in &with {
        let base = without.get(path).copied().unwrap_or(0.0);
        let pre = prepass.get(path).copied().unwrap_or(0.0);
        let name = path.trim_start_matches("render/");
        if name.ends_with("elapsed_cpu") {
            continue;
        }
        if name.ends_with("elapsed_gpu") {
            seen_gpu = true;
            // Only the outermost spans: nested ones are inside their parents.
            if name.matches('/').count() == 1 {
                total[0] += value;
                total[1] += base;
                total[2] += pre;
            }
            println!(
                "{name:<44} {value:>9.3} ms {base:>9.3} ms {pre:>9.3} ms {:>9.3} ms {:>9.3} ms",
                value - base,
                value - pre
            );
        } else {
            println!(
                "{name:<44} {value:>12.0} {base:>12.0} {pre:>12.0} {:>12.0} {:>12.0}",
                value - base,
                value - pre
            );
        }
    }
    if seen_gpu {
        let [value, base, pre] = total;
        println!(
            "{:<44} {value:>9.3} ms {base:>9.3} ms {pre:>9.3} ms {:>9.3} ms {:>9.3} ms",
            "all passes (outermost spans)",
            value - base,
            value - pre
        );
    } else {
        println!("no GPU timestamps: the adapter has no timestamp queries (counts above only)");
    }
    ExitCode::SUCCESS
}
