//! Render tests of the angel ring on spiky and long hair: the ring follows the hair's mass
//! (tangents leaned down the mass's meridians), so it stays one band across spikes pointing
//! every way, as the head turns.

use bevy::prelude::*;
use bevy_cartoon_hair::headless::CapturedFrame;
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{AngelRingProfile, ToonLighting};
use libtest_mimic::Failed;

use crate::mass_render::{RING, falling_strands, is_ring, spawn_still_hair};
use crate::toon_render::{BACKGROUND, ramps, save, scene};

pub const RENDER_TESTS: &[(&str, crate::TestFn)] = &[(
    "angel_ring_is_one_band_on_spiky_and_long_hair_as_it_turns",
    angel_ring_is_one_band_on_spiky_and_long_hair_as_it_turns,
)];

/// 240 straight spikes on the upper half of a head of radius 0.5 at the origin (a golden-angle
/// spiral from 5 to 85 degrees off the top), each 0.25 long, leaning up from the scalp's
/// normal and twisted sideways by turns, as the ninja's hair is.
pub(crate) fn spikes() -> Vec<Vec<Vec3>> {
    (0..240)
        .map(|i| {
            let around = i as f32 * 2.399_963;
            let polar = (5.0 + 80.0 * (i as f32 + 0.5) / 240.0).to_radians();
            let normal = Vec3::new(
                polar.sin() * around.sin(),
                polar.cos(),
                polar.sin() * around.cos(),
            );
            let side = Vec3::Y.cross(normal).normalize_or(Vec3::X);
            let twist = if i % 2 == 0 { 0.5 } else { -0.5 };
            let direction = (normal + Vec3::Y * 0.6 + side * twist).normalize();
            let root = normal * 0.5;
            (0..6)
                .map(|k| root + direction * (0.25 * k as f32 / 5.0))
                .collect()
        })
        .collect()
}

/// The ring as a band: the share of the hair's columns it crosses, and how far (root mean
/// square, pixels) the ring's mean row in each column strays from the mean of those. One band
/// across the hair crosses most columns at one height; pieces along spikes scatter.
fn ring_band(frame: &CapturedFrame) -> (f32, f32) {
    let (w, h) = (frame.width, frame.height);
    let mut hair_columns = 0;
    let mut rows = Vec::new();
    for x in 0..w {
        let ys: Vec<u32> = (0..h).filter(|&y| is_ring(frame.pixel(x, y))).collect();
        if (0..h).any(|y| frame.pixel(x, y) != BACKGROUND) {
            hair_columns += 1;
        }
        if !ys.is_empty() {
            rows.push(ys.iter().sum::<u32>() as f32 / ys.len() as f32);
        }
    }
    let mean = rows.iter().sum::<f32>() / rows.len().max(1) as f32;
    let spread =
        (rows.iter().map(|y| (y - mean).powi(2)).sum::<f32>() / rows.len().max(1) as f32).sqrt();
    (rows.len() as f32 / hair_columns.max(1) as f32, spread)
}

/// Long hair: 72 strands from near the crown down the sides of the head to 40 degrees below
/// its equator, 2 cm off the scalp, as straight hair falls.
fn long_hair() -> Vec<Vec<Vec3>> {
    falling_strands(10.0, 130.0, 10)
}

/// Spiky and long hair lit from the front, the ring's even profile: with the default mass
/// normals (0.8) the ring is one band, crossing at least 70% of the hair's columns at one height
/// (the rows of the columns' ring pixels within 8 px of their mean, root mean square), in each
/// of five frames while the head turns 0.8 rad; on the spikes with none (each spike on its own,
/// the thesis's strands) it runs along the spikes, spread at least twice as far.
fn angel_ring_is_one_band_on_spiky_and_long_hair_as_it_turns() -> Result<(), Failed> {
    let mut results = Vec::new();
    for (groom, mass_normals) in [("spikes", 0.8), ("spikes", 0.0), ("long", 0.8)] {
        let mut r = scene(Vec3::new(0.0, 0.6, 1.0), Vec3::new(0.0, 0.3, 3.0))?;
        let ramp = ramps(&r).three_tone;
        let shading = ToonShading {
            lighting: ToonLighting::FirstDirectional,
            angel_ring: 1.0,
            angel_ring_color: RING,
            angel_ring_profile: AngelRingProfile::Even,
            ..default()
        };
        let strands = if groom == "spikes" {
            spikes()
        } else {
            long_hair()
        };
        let hair = spawn_still_hair(
            r.app.world_mut(),
            strands,
            ToonHairMaterial::new(shading, ramp),
            HairMeshSettings {
                radius: 0.03,
                taper: QuadraticCurve::new(0.0, -0.9, 1.0),
                mass_normals,
                ..default()
            },
        );
        for step in 0..5 {
            let yaw = 0.2 * step as f32;
            r.app
                .world_mut()
                .entity_mut(hair)
                .insert(Transform::from_rotation(Quat::from_rotation_y(yaw)));
            let frame = r.capture()?;
            save(&frame, &format!("angel_ring_{groom}_{mass_normals}_{step}"))?;
            let (crossed, spread) = ring_band(&frame);
            let n = frame.count(is_ring);
            eprintln!(
                "{groom}, mass normals {mass_normals}, yaw {yaw:.1}: {n} ring px, {:.0}% of the \
                 hair's columns crossed, rows spread {spread:.1} px",
                100.0 * crossed
            );
            results.push((groom, mass_normals, step, n, crossed, spread));
        }
    }
    for &(groom, mass, step, n, crossed, spread) in &results {
        if mass > 0.0 && (n < 150 || crossed < 0.7 || spread > 8.0) {
            return Err(format!(
                "{groom} step {step}: the ring on the mass is {n} px, crosses {:.0}% of the \
                 hair's columns, its rows spread {spread:.1} px",
                100.0 * crossed
            )
            .into());
        }
    }
    let mean_spread = |m: f32| {
        let r: Vec<f32> = results
            .iter()
            .filter(|r| r.0 == "spikes" && r.1 == m)
            .map(|r| r.5)
            .collect();
        r.iter().sum::<f32>() / r.len() as f32
    };
    if mean_spread(0.0) < 2.0 * mean_spread(0.8) {
        return Err(format!(
            "the strands' own ring is as much one band as the mass's: {results:?}"
        )
        .into());
    }
    Ok(())
}
