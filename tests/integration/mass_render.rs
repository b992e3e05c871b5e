//! Render tests of hair-mass normals (`HairMeshSettings::mass_normals`): a curtain of strands in
//! one hair, lit from the side, shades as one shape instead of one band per strand.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::{CapturedFrame, HeadlessRenderer};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::ToonLighting;
use libtest_mimic::Failed;

use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "mass_normals_merge_the_strands_shadows",
    mass_normals_merge_the_strands_shadows,
)];

/// Nine vertical strands side by side in one hair, held still, each `radius` thick.
fn spawn_curtain(r: &mut HeadlessRenderer, mass_normals: f32) {
    let ramp = ramps(r).three_tone;
    let world = r.app.world_mut();
    let strands: Vec<Vec<Vec3>> = (0..9)
        .map(|i| {
            let x = -0.48 + 0.12 * i as f32;
            let z = if i % 2 == 0 { 0.0 } else { -0.03 };
            (0..6)
                .map(|k| Vec3::new(x, 0.6 - 0.24 * k as f32, z))
                .collect()
        })
        .collect();
    let groom = HairGroom::from_strands("", strands).unwrap();
    let groom = world.resource_mut::<Assets<HairGroom>>().add(groom);
    // The thesis's lighting (no shadow maps): the strands would also shadow each other, which
    // is not what this measures.
    let material = world
        .resource_mut::<Assets<ToonHairMaterial>>()
        .add(ToonHairMaterial::new(
            ToonShading {
                lighting: ToonLighting::FirstDirectional,
                specular_strength: 0.0,
                ..default()
            },
            ramp,
        ));
    world.spawn((
        Hair { groom, ..default() },
        HairSimSettings {
            gravity: Vec3::ZERO,
            anchor_stiffness: QuadraticCurve::constant(1.0),
            ..default()
        },
        HairMeshSettings {
            radius: 0.08,
            taper: QuadraticCurve::constant(1.0),
            hair_resolution: 24,
            shape_resolution: 24,
            mass_normals,
            ..default()
        },
        HairMaterial(material),
        SilhouetteSettings {
            enabled: false,
            ..default()
        },
    ));
}

fn luma(p: [u8; 4]) -> f32 {
    0.2126 * f32::from(p[0]) + 0.7152 * f32::from(p[1]) + 0.0722 * f32::from(p[2])
}

/// The darkest tone's pixels: hair pixels nearer the darkest luma than the middle of the range.
fn shadow_mask(frame: &CapturedFrame) -> (Vec<bool>, usize) {
    let lumas: Vec<Option<f32>> = (0..frame.width * frame.height)
        .map(|i| {
            let p = frame.pixel(i % frame.width, i / frame.width);
            (p != BACKGROUND).then(|| luma(p))
        })
        .collect();
    let (lo, hi) = lumas
        .iter()
        .flatten()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    let cut = lo + 0.25 * (hi - lo);
    let mask: Vec<bool> = lumas.iter().map(|l| l.is_some_and(|l| l < cut)).collect();
    let hair = lumas.iter().flatten().count();
    (mask, hair)
}

/// Connected (4-neighbour) regions of `mask` of at least `min_size` pixels, largest first.
fn regions(mask: &[bool], width: usize, min_size: usize) -> Vec<usize> {
    let mut seen = vec![false; mask.len()];
    let mut sizes = Vec::new();
    for start in 0..mask.len() {
        if !mask[start] || seen[start] {
            continue;
        }
        let mut stack = vec![start];
        seen[start] = true;
        let mut size = 0;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % width, i / width);
            let mut visit = |j: usize| {
                if mask[j] && !seen[j] {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < width {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - width);
            }
            if i + width < mask.len() {
                visit(i + width);
            }
        }
        if size >= min_size {
            sizes.push(size);
        }
    }
    sizes.sort_unstable_by(|a, b| b.cmp(a));
    sizes
}

/// Lit from the right, the curtain's shadow tone with each strand's own normals (blend 0) is one
/// band down the left side of every strand (9 regions of equal size); with the default blend and
/// with 1 it is at most half as many regions, the two largest holding 80% of it, on the left of
/// the whole curtain.
fn mass_normals_merge_the_strands_shadows() -> Result<(), Failed> {
    let mut counts = Vec::new();
    for blend in [0.0, HairMeshSettings::default().mass_normals, 1.0] {
        let mut r = scene(Vec3::new(1.0, 0.2, 0.5), Vec3::new(0.0, 0.0, 3.0))?;
        spawn_curtain(&mut r, blend);
        let frame = r.capture()?;
        save(&frame, &format!("mass_normals_{blend}"))?;
        let (mask, hair) = shadow_mask(&frame);
        let found = regions(&mask, frame.width as usize, 20);
        let shadow: usize = mask.iter().filter(|m| **m).count();
        // Where the shadow lies: the mean x of its pixels, relative to the image's width.
        let mean_x = mask
            .iter()
            .enumerate()
            .filter(|(_, m)| **m)
            .map(|(i, _)| (i % frame.width as usize) as f32)
            .sum::<f32>()
            / shadow.max(1) as f32
            / frame.width as f32;
        eprintln!(
            "blend {blend}: {} shadow regions {found:?}, {shadow} of {hair} hair pixels, mean x {mean_x:.2}",
            found.len()
        );
        if hair < 5000 || shadow < hair / 20 {
            return Err(format!("blend {blend}: {hair} hair pixels, {shadow} in shadow").into());
        }
        // The share of the shadow in its two largest regions.
        let two: usize = found.iter().take(2).sum();
        counts.push((found.len(), two as f32 / shadow as f32, mean_x));
    }
    let fail = |m: &str| -> Result<(), Failed> { Err(format!("{m}: {counts:?}").into()) };
    let [own, default, full] = counts[..] else {
        unreachable!()
    };
    if own.0 < 9 || own.1 > 0.4 {
        return fail("own normals: expected one shadow band per strand");
    }
    for (blend, (n, two, mean_x)) in [("default", default), ("1", full)] {
        if n > own.0 / 2 || two < 0.8 || mean_x > 0.45 {
            return fail(&format!(
                "blend {blend}: expected a few large shadow regions on the left"
            ));
        }
    }
    Ok(())
}
