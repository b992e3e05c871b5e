//! Hair volume: strands kept apart, fuller hanging hair, density.

use bevy::prelude::*;

use super::*;

/// Strands from `roots` to `tips` (straight, 8 particles), roots on the bone.
fn straight_groom(pairs: &[(Vec3, Vec3)]) -> HairGroom {
    HairGroom::from_strands(
        "head",
        pairs.iter().map(|&(a, b)| {
            (0..8)
                .map(|k| a.lerp(b, k as f32 / 7.0))
                .collect::<Vec<_>>()
        }),
    )
    .unwrap()
}

/// Two strands styled into each other (their tips meet) end their radius sum
/// apart with the volume at stiffness 1 (0.0320 m for 0.032 m), 0.0275 m at 0.5, and 0.001 m
/// (where the style puts them) without it.
#[test]
fn hair_volume_keeps_two_crossing_strands_apart() {
    let groom = straight_groom(&[
        (Vec3::new(-0.05, 0.0, 0.0), Vec3::new(0.0, -0.2, 0.0)),
        (Vec3::new(0.05, 0.0, 0.0), Vec3::new(0.0, -0.2, 0.001)),
    ]);
    let radius = 0.016;
    let tips = |volume: Option<HairVolume>| {
        let settings = HairSimSettings {
            gravity: Vec3::ZERO,
            volume,
            ..default()
        };
        let mut h = Harness::with(groom.clone(), None, None, settings, 60.0);
        for _ in 0..120 {
            h.update();
        }
        let s = h.strands();
        assert!(s.iter().flatten().all(|p| p.is_finite()));
        (
            s[0].last().unwrap().distance(*s[1].last().unwrap()),
            h.computed().stats.volume_pairs,
        )
    };
    let (off, _) = tips(None);
    let (on, pairs) = tips(Some(HairVolume {
        stiffness: 1.0,
        radius: Some(radius),
    }));
    let (half, _) = tips(Some(HairVolume {
        stiffness: 0.5,
        radius: Some(radius),
    }));
    println!(
        "tips apart: {off:.4} m without volume, {half:.4} m at stiffness 0.5, {on:.4} m at 1 \
         ({pairs} pairs pushed in the last frame); radius sum {:.3} m",
        2.0 * radius
    );
    assert!(off < 0.005, "without volume the tips meet: {off}");
    // Stiffness 1 removes the whole overlap at the end of each frame: they touch.
    assert!(
        on >= 2.0 * radius * 0.999,
        "tips {on} m apart, radius sum {}",
        2.0 * radius
    );
    assert!(half > off + radius, "stiffness 0.5: {half} m");
}

/// A hair of straight strands from `roots` styled to meet 0.25 m under the bone (each tip at
/// 5% of its root's offset from the axis), hanging under gravity for 3 s with `volume`; the
/// harness and the tips' mean distance from the bone's vertical axis.
fn hanging_tips(roots: &[Vec3], volume: Option<HairVolume>) -> (Harness, f32) {
    let pairs: Vec<(Vec3, Vec3)> = roots
        .iter()
        .map(|&root| (root, Vec3::new(0.0, -0.25, 0.0) + root * 0.05))
        .collect();
    let settings = HairSimSettings {
        volume,
        ..default()
    };
    let mut h = Harness::with(straight_groom(&pairs), None, None, settings, 60.0);
    for _ in 0..180 {
        h.update();
    }
    let axis = Vec3::from(h.bone_affine().translation);
    let s = h.strands();
    assert!(s.iter().flatten().all(|p| p.is_finite()));
    let spread = s
        .iter()
        .map(|p| {
            let d = *p.last().unwrap() - axis;
            Vec2::new(d.x, d.z).length()
        })
        .sum::<f32>()
        / s.len() as f32;
    (h, spread)
}

/// A cone of strands styled to meet under the bone, hanging under gravity,
/// keeps more volume with the volume on: its tips' mean distance from the axis is larger
/// (measured: 0.0042 m without, 0.0187 m with the defaults; 0.0399 m when crowded particles'
/// pushes were summed instead of averaged).
#[test]
fn hair_volume_keeps_a_hanging_hair_fuller() {
    let n = 24;
    let roots: Vec<Vec3> = (0..n)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            Vec3::new(a.cos(), 0.0, a.sin()) * 0.05
        })
        .collect();
    let (_, off) = hanging_tips(&roots, None);
    let (_, on) = hanging_tips(&roots, Some(HairVolume::default()));
    println!("hanging cone: tips {off:.4} m from the axis without volume, {on:.4} m with it");
    assert!(on > off + 0.01, "volume {on} vs none {off}");
}

/// Hair far denser than its volume radius (1,000 strands 8 mm apart at the
/// roots with 16 mm tubes: it cannot be kept apart) is spread by its density and stays calm.
/// Measured over 30 frames after 2 s at rest: 0.0001 m mean and 0.0073 m largest motion per
/// frame, with about 14,760 of its 15,000 particles crowded. (With pairs alone and averaged
/// pushes it moved 0.00078 m a frame on average and up to 0.0119 m, and the list was rebuilt
/// in 20 of 30 frames; with summed pushes 0.039 m and up to 0.21 m.) Hair a tube apart (4 mm)
/// keeps its pair list in all 30 frames.
#[test]
fn hair_volume_keeps_dense_hair_calm() {
    for (radius, dense) in [(0.004f32, false), (0.016, true)] {
        let settings = HairSimSettings {
            volume: Some(HairVolume {
                radius: Some(radius),
                ..default()
            }),
            ..default()
        };
        let mut h = Harness::with(spiky_groom(1000, 16), None, None, settings, 60.0);
        for _ in 0..120 {
            h.update();
        }
        let mut prev = h.strands();
        let (mut worst, mut mean, mut rebuilds) = (0f32, 0f32, 0);
        for _ in 0..30 {
            h.update();
            let now = h.strands();
            let moved: Vec<f32> = now
                .iter()
                .flatten()
                .zip(prev.iter().flatten())
                .map(|(a, b)| a.distance(*b))
                .collect();
            worst = moved.iter().copied().fold(worst, f32::max);
            mean += moved.iter().sum::<f32>() / moved.len() as f32 / 30.0;
            rebuilds += usize::from(h.computed().volume.reused == 0);
            prev = now;
        }
        let c = h.computed();
        let (pairs, spread) = (c.stats.volume_pairs, c.stats.volume_spread);
        println!(
            "volume radius {radius}: per-frame motion {mean:.6} m mean, {worst:.5} m largest; \
             {pairs} pairs pushed, {spread} particles spread by density ({} crowded); \
             pair list rebuilt in {rebuilds} of 30 frames",
            c.volume.crowded_count
        );
        assert_eq!(c.volume.dense, dense, "radius {radius}: spread by density");
        if dense {
            assert!(
                spread > 10_000 && pairs == 0,
                "radius {radius}: {spread} spread"
            );
        } else {
            assert!(pairs > 0 && spread == 0, "radius {radius}: {pairs} pairs");
            assert_eq!(rebuilds, 0, "radius {radius}: the list was rebuilt");
        }
        assert!(
            mean < 0.0005,
            "radius {radius}: {mean} m a frame on average"
        );
        assert!(
            worst < radius,
            "radius {radius}: a particle moved {worst} m in a frame"
        );
    }
}

/// The density spreads crowded hair out, and a hair that stops being crowded
/// goes back to pairs. A ponytail of 1,000 strands (roots on a 5 cm disc, styled to meet under
/// it) hanging under gravity with the default 16 mm volume is spread by its density: its tips'
/// mean distance from the axis is over 3 times what it is without volume (measured: 0.0117 m
/// against 0.0031 m; 0.0194 m with pairs alone, at 4 times the cost). Then the radius drops to 0.2 mm: the hair leaves the density and pushes pairs.
#[test]
fn hair_volume_density_spreads_crowded_hair_and_lets_go() {
    let n = 1000;
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let roots: Vec<Vec3> = (0..n)
        .map(|i| {
            let (r, a) = (
                0.05 * ((i as f32 + 0.5) / n as f32).sqrt(),
                golden * i as f32,
            );
            Vec3::new(r * a.cos(), 0.0, r * a.sin())
        })
        .collect();
    let (_, off) = hanging_tips(&roots, None);
    let (mut h, on) = hanging_tips(&roots, Some(HairVolume::default()));
    let c = h.computed();
    println!(
        "ponytail of {n}: tips {on:.4} m from the axis with the volume ({} crowded, {} \
         spread), {off:.4} m without",
        c.volume.crowded_count, c.stats.volume_spread
    );
    assert!(c.volume.dense, "not spread by density");
    assert!(on > 3.0 * off, "density {on} vs none {off}");
    h.app
        .world_mut()
        .get_mut::<HairSimSettings>(h.hair)
        .unwrap()
        .volume = Some(HairVolume {
        radius: Some(0.0002),
        ..default()
    });
    for _ in 0..3 {
        h.update();
    }
    let c = h.computed();
    println!(
        "at 0.2 mm: {} crowded, {} pairs pushed",
        c.volume.crowded_count, c.stats.volume_pairs
    );
    assert!(!c.volume.dense, "still spread by density at 0.2 mm");
    assert!(c.stats.volume_pairs > 0, "no pairs pushed at 0.2 mm");
}

/// The density pass gives the same bits on the AVX2 and the portable path.
#[test]
fn hair_volume_density_is_the_same_on_both_paths() {
    let run = || {
        let settings = HairSimSettings {
            volume: Some(HairVolume {
                radius: Some(0.016),
                ..default()
            }),
            ..default()
        };
        let mut h = Harness::with(spiky_groom(1000, 16), None, None, settings, 60.0);
        for f in 0..40 {
            h.set_bone(
                Transform::from_xyz(0.0, 1.6, 0.0)
                    .with_rotation(Quat::from_rotation_y(0.5 * (f as f32 / 10.0).sin())),
            );
            h.update();
        }
        assert!(h.computed().volume.dense);
        h.hash()
    };
    let (portable, vector) = crate::simd::on_both_paths(run);
    println!("state hash: {portable:#018x} portable, {vector:x?} AVX2");
    assert_eq!(
        vector.unwrap_or(portable),
        portable,
        "AVX2 and portable differ"
    );
}

/// The volume's pair list, kept while the hair moves with its bone, pushes
/// exactly what a list built from scratch pushes: the head turns 90 degrees and moves 0.3 m in
/// 4 s; each frame the pass is run again on a copy of the hair with the kept list and with a
/// new one.
#[test]
fn hair_volume_pair_list_matches_a_fresh_one() {
    let settings = HairSimSettings {
        volume: Some(HairVolume {
            radius: Some(0.008),
            ..default()
        }),
        ..default()
    };
    let mut h = Harness::with(spiky_groom(300, 12), None, None, settings, 60.0);
    for _ in 0..60 {
        h.update();
    }
    let (mut kept, mut compared) = (0, 0);
    let frames = 240;
    for f in 1..=frames {
        let t = f as f32 / frames as f32;
        h.set_bone(Transform {
            translation: Vec3::new(0.3 * t, 1.6, 0.0),
            rotation: Quat::from_rotation_y(std::f32::consts::FRAC_PI_2 * t),
            ..default()
        });
        h.update();
        let c = h.computed();
        kept += usize::from(c.volume.reused > 0);
        let bone = h.bone_affine();
        let (mut a, mut b) = (c.batches.clone(), c.batches.clone());
        let (mut list, mut fresh) = (c.volume.clone(), VolumeScratch::default());
        let pa = keep_apart(&mut a, 0.008, 0.5, &bone, &mut list);
        let pb = keep_apart(&mut b, 0.008, 0.5, &bone, &mut fresh);
        assert_eq!(pa, pb, "frame {f}: pairs pushed");
        compared += pa;
        for (x, y) in a.iter().zip(&b) {
            for (nx, ny) in x.nodes.iter().zip(&y.nodes) {
                for c in 0..3 {
                    for l in 0..LANES {
                        assert!(
                            (nx.x[c][l] - ny.x[c][l]).abs() <= 1e-6,
                            "frame {f}: kept and fresh lists differ"
                        );
                    }
                }
            }
        }
    }
    println!(
        "pair list kept in {kept} of {frames} frames of head motion; {compared} pushes compared"
    );
    assert!(
        kept >= frames / 2,
        "the list was kept in only {kept} frames"
    );
    assert!(compared > 0, "nothing was pushed");
}

/// Hostile values: the volume pass (pairs, and density) on particles at
/// +-3e38 m, piled on one point or NaN, with radii from the smallest float to `f32::MAX`,
/// returns and leaves every finite particle finite; the bounds measured part by part (as the
/// solver's pass does for the density) are the whole hair's.
#[test]
fn hair_volume_survives_hostile_positions_and_radii() {
    let settings = HairSimSettings {
        volume: Some(HairVolume::default()),
        ..default()
    };
    let h = Harness::with(spiky_groom(40, 8), None, None, settings, 60.0);
    let bone = h.bone_affine();
    let mut rng = Rng(7);
    let picks = [3e38, -3e38, 0.0, 1e-30, 1e30, f32::NAN, f32::INFINITY];
    for radius in [1e-45, 1e-30, 0.016, 1e30, 3e38, f32::MAX, -1.0, f32::NAN] {
        let mut batches = h.computed().batches.clone();
        for b in &mut batches {
            for node in &mut b.nodes {
                for c in 0..3 {
                    for l in 0..LANES {
                        let r = rng.unit();
                        if r < 0.5 {
                            node.x[c][l] = picks[(r * 14.0) as usize % picks.len()];
                        }
                    }
                }
            }
        }
        let before: Vec<bool> = batches
            .iter()
            .flat_map(|b| b.nodes.iter().flat_map(|n| n.x.iter().flatten()))
            .map(|v| v.is_finite())
            .collect();
        // The bounds the solver's pass measures part by part are the hair's.
        let whole = crate::sim::volume::bounds_of(&batches);
        for size in 1..=3 {
            let parts = batches
                .chunks(size)
                .map(crate::sim::volume::bounds_of)
                .fold(
                    crate::sim::volume::NO_BOUNDS,
                    crate::sim::volume::merge_bounds,
                );
            assert_eq!(parts, whole, "bounds measured {size} batches at a time");
        }
        let mut scratch = VolumeScratch::default();
        for _ in 0..2 {
            keep_apart(&mut batches, radius, 1.0, &bone, &mut scratch);
        }
        // And spread by density, as crowded hair is, with the bounds measured as the pass does
        // (checked against the batches under debug assertions).
        scratch.dense = true;
        for _ in 0..2 {
            scratch.measure(crate::sim::volume::bounds_of(&batches));
            keep_apart(&mut batches, radius, 1.0, &bone, &mut scratch);
        }
        let after = batches
            .iter()
            .flat_map(|b| b.nodes.iter().flat_map(|n| n.x.iter().flatten()));
        for (was, v) in before.iter().zip(after) {
            assert!(
                !was || v.is_finite(),
                "radius {radius}: a finite particle became {v}"
            );
        }
    }
}
