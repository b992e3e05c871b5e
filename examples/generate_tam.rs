//! Generates a tonal art map and writes every tone and mip level as a PNG.
//!
//! `cargo run --release --example generate_tam -- --out tam [--tones 6] [--resolution 512]
//!  [--mips 3] [--strokes 78] [--candidates 10] [--seed 1] [--width 2.0]`
//!
//! Files: `OUT/tone{T}_mip{L}.png`, tone 0 the lightest, mip 0 the finest.

use std::io::Write;

use bevy::asset::RenderAssetUsages;
use bevy::image::Image;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy_cartoon_hair::hatching::{StrokeImage, TamSettings, generate};

fn main() {
    if let Err(e) = run() {
        eprintln!("generate_tam: {e}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let mut settings = TamSettings::default();
    let mut out = std::path::PathBuf::from("tam");
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        let num = |v: String| v.parse::<f64>().map_err(|e| format!("{flag} {v:?}: {e}"));
        match flag.as_str() {
            "--out" => out = value()?.into(),
            "--tones" => settings.tones = num(value()?)? as usize,
            "--resolution" => settings.resolution = num(value()?)? as usize,
            "--mips" => settings.mip_levels = num(value()?)? as usize,
            "--strokes" => settings.strokes_per_tone = num(value()?)? as usize,
            "--candidates" => settings.candidates = num(value()?)? as usize,
            "--seed" => settings.seed = num(value()?)? as u64,
            "--width" => settings.stroke_width_px = num(value()?)? as f32,
            "--help" | "-h" => {
                println!("see the header of examples/generate_tam.rs");
                return Ok(());
            }
            other => return Err(format!("unknown flag {other:?} (try --help)")),
        }
    }
    settings.validate().map_err(|e| e.to_string())?;
    let start = std::time::Instant::now();
    let map = generate(&StrokeImage::default(), &settings, |done, total| {
        let filled = done * 40 / total.max(1);
        eprint!(
            "\r[{}{}] {done}/{total} strokes",
            "#".repeat(filled),
            " ".repeat(40 - filled)
        );
        let _ = std::io::stderr().flush();
    })
    .map_err(|e| e.to_string())?;
    eprintln!("\ngenerated in {:.2} s", start.elapsed().as_secs_f32());
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    for (l, level) in map.levels.iter().enumerate() {
        for (t, pixels) in level.tones.iter().enumerate() {
            let image = Image::new(
                Extent3d {
                    width: level.size as u32,
                    height: level.size as u32,
                    depth_or_array_layers: 1,
                },
                TextureDimension::D2,
                pixels.clone(),
                TextureFormat::R8Unorm,
                RenderAssetUsages::default(),
            );
            let path = out.join(format!("tone{t}_mip{l}.png"));
            image
                .try_into_dynamic()
                .map_err(|e| e.to_string())?
                .save(&path)
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
    }
    println!(
        "wrote {} PNGs to {}",
        map.levels.len() * map.tones,
        out.display()
    );
    Ok(())
}
