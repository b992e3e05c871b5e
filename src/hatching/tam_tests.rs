//! Tests of the tonal art map generator.

use super::raster::*;
use super::settings::*;
use super::stroke_image::*;
use super::tam::*;

/// Small settings that keep debug-build tests fast.
fn small() -> TamSettings {
    TamSettings {
        tones: 4,
        resolution: 64,
        mip_levels: 2,
        strokes_per_tone: 400,
        candidates: 4,
        darkest_tone: 0.6,
        ..TamSettings::default()
    }
}

fn stroke() -> StrokeImage {
    StrokeImage::default_stroke(128, 12)
}

fn build(settings: &TamSettings) -> TonalArtMap {
    generate(&stroke(), settings, |_, _| {}).expect("valid settings")
}

fn ink(byte: u8) -> f32 {
    1.0 - f32::from(byte) / 255.0
}

#[test]
fn darker_tones_contain_every_stroke_of_lighter_ones() {
    for settings in [
        small(),
        TamSettings {
            cross_hatch_from_tone: Some(2),
            seed: 7,
            ..small()
        },
    ] {
        let map = build(&settings);
        assert_eq!(map.levels.len(), settings.mip_levels);
        for (l, level) in map.levels.iter().enumerate() {
            assert_eq!(level.size, settings.resolution >> l);
            assert_eq!(level.tones.len(), settings.tones);
            for pair in level.tones.windows(2) {
                assert_eq!(pair[0].len(), level.size * level.size);
                let removed = pair[0].iter().zip(&pair[1]).filter(|(a, b)| b > a).count();
                assert_eq!(
                    removed, 0,
                    "level {l}: darker tone lost ink at {removed} px"
                );
            }
        }
    }
}

#[test]
fn mean_ink_increases_evenly_and_reaches_targets() {
    let settings = small();
    let map = build(&settings);
    let table = map.mean_ink_table();
    let means = &table[0];
    assert!(means[0] > 0.05, "tone 0 must not be blank: {means:?}");
    let steps: Vec<f32> = means.windows(2).map(|w| w[1] - w[0]).collect();
    let average = steps.iter().sum::<f32>() / steps.len() as f32;
    for (i, step) in steps.iter().enumerate() {
        // Each step within 50% of the average step.
        assert!(
            (step - average).abs() <= 0.5 * average,
            "step {i} is {step}, average {average}: {means:?}"
        );
    }
    for (tone, mean) in means.iter().enumerate() {
        let target = settings.target_ink(tone);
        assert!(
            (mean - target).abs() < 0.03,
            "tone {tone}: mean {mean}, target {target}"
        );
    }
}

#[test]
fn coarser_levels_keep_the_tone_of_the_finest() {
    let settings = TamSettings {
        mip_levels: 3,
        ..small()
    };
    let table = build(&settings).mean_ink_table();
    for (l, level) in table.iter().enumerate().skip(1) {
        for (tone, mean) in level.iter().enumerate() {
            let finest = table[0][tone];
            assert!(
                (mean - finest).abs() < 0.03,
                "level {l} tone {tone}: {mean} vs finest {finest}"
            );
        }
    }
    // Without the rule, constant-pixel-width strokes make coarse levels clearly darker.
    let unmatched = build(&TamSettings {
        match_mip_tones: false,
        ..settings
    })
    .mean_ink_table();
    assert!(unmatched[2][0] > unmatched[0][0] + 0.1, "{unmatched:?}");
}

#[test]
fn strokes_crossing_an_edge_wrap_around() {
    let settings = small();
    let size = settings.resolution;
    let footprint = Footprint::new(&stroke(), 0.3 * size as f32, settings.stroke_width_px);
    // Horizontal stroke centred just right of the left edge, vertically centred on the top
    // edge: ink must appear at both the left/right and the top/bottom edges.
    let crossing = Stroke {
        cx: 0.02,
        cy: 0.0,
        angle: 0.0,
        length: 0.3,
    };
    let mut image = vec![0.0f32; size * size];
    rasterize(size, &footprint, &crossing, |i, c| image[i] += c);
    let column = |x: usize| (0..size).map(|y| image[y * size + x]).sum::<f32>();
    let row = |y: usize| (0..size).map(|x| image[y * size + x]).sum::<f32>();
    assert!(column(0) > 0.5 && column(size - 1) > 0.5);
    assert!(column(size / 2) == 0.0, "the stroke is only 30% long");
    assert!(row(0) > 1.0 && row(size - 1) > 1.0);

    // Statistically, the edges of a generated map continue each other like interior
    // neighbours do.
    let map = build(&TamSettings {
        tones: 2,
        mip_levels: 1,
        ..settings
    });
    let image = &map.levels[0].tones[1];
    let column_difference = |a: usize, b: usize| {
        (0..size)
            .map(|y| (ink(image[y * size + a]) - ink(image[y * size + b])).abs())
            .sum::<f32>()
            / size as f32
    };
    let interior = (1..size - 2)
        .map(|x| column_difference(x, x + 1))
        .sum::<f32>()
        / (size - 3) as f32;
    let across_edge = column_difference(size - 1, 0);
    assert!(
        across_edge < 1.6 * interior,
        "edge difference {across_edge} vs interior {interior}"
    );
    // Two unrelated columns differ clearly more, so the statistic can tell.
    let random_pair = column_difference(0, size / 2);
    assert!(random_pair > 1.6 * interior, "{random_pair} vs {interior}");
}

#[test]
fn stroke_width_in_pixels_is_the_same_at_every_level() {
    let settings = TamSettings {
        tones: 1,
        resolution: 256,
        mip_levels: 3,
        strokes_per_tone: 1,
        candidates: 1,
        angle_jitter_deg: 0.0,
        length_jitter: 0.0,
        stroke_width_px: 3.0,
        match_mip_tones: false,
        ..TamSettings::default()
    };
    let map = build(&settings);
    let mut widths = Vec::new();
    for level in &map.levels {
        let size = level.size;
        let image = &level.tones[0];
        // The column through the stroke with the most ink, away from the tapered ends.
        let (x, integrated) = (0..size)
            .map(|x| (x, (0..size).map(|y| ink(image[y * size + x])).sum::<f32>()))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("non-empty");
        let inked_rows = (0..size).filter(|y| image[y * size + x] < 255).count();
        widths.push((integrated, inked_rows));
    }
    let (finest_ink, finest_rows) = widths[0];
    assert!(finest_ink > 2.0, "a 3 px stroke: {widths:?}");
    for &(ink, rows) in &widths[1..] {
        assert!(rows.abs_diff(finest_rows) <= 1, "{widths:?}");
        assert!((ink - finest_ink).abs() < 0.5, "{widths:?}");
    }
}

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    let settings = TamSettings {
        tones: 2,
        strokes_per_tone: 30,
        ..small()
    };
    let a = build(&settings);
    assert_eq!(a, build(&settings));
    let b = build(&TamSettings {
        seed: 2,
        ..settings
    });
    assert_ne!(a.levels[0].tones, b.levels[0].tones);
}

#[test]
fn absurd_settings_are_errors_not_panics() {
    let cases: Vec<(&str, TamSettings)> = vec![
        (
            "tones",
            TamSettings {
                tones: 0,
                ..small()
            },
        ),
        (
            "resolution",
            TamSettings {
                resolution: 100,
                ..small()
            },
        ),
        (
            "resolution",
            TamSettings {
                resolution: 8192,
                ..small()
            },
        ),
        (
            "mip_levels",
            TamSettings {
                mip_levels: 0,
                ..small()
            },
        ),
        (
            "mip_levels",
            TamSettings {
                mip_levels: 5,
                ..small()
            },
        ),
        (
            "strokes_per_tone",
            TamSettings {
                strokes_per_tone: 100_001,
                ..small()
            },
        ),
        (
            "candidates",
            TamSettings {
                candidates: 0,
                ..small()
            },
        ),
        (
            "candidates",
            TamSettings {
                candidates: 1001,
                ..small()
            },
        ),
        (
            "stroke_length",
            TamSettings {
                stroke_length: f32::NAN,
                ..small()
            },
        ),
        (
            "stroke_length",
            TamSettings {
                stroke_length: 0.0,
                ..small()
            },
        ),
        (
            "length_jitter",
            TamSettings {
                length_jitter: -0.1,
                ..small()
            },
        ),
        (
            "angle_jitter_deg",
            TamSettings {
                angle_jitter_deg: f32::INFINITY,
                ..small()
            },
        ),
        (
            "stroke_width_px",
            TamSettings {
                stroke_width_px: 0.0,
                ..small()
            },
        ),
        (
            "stroke_width_px",
            TamSettings {
                stroke_width_px: 17.0,
                ..small()
            },
        ),
        (
            "darkest_tone",
            TamSettings {
                darkest_tone: 1.5,
                ..small()
            },
        ),
    ];
    for (field, settings) in cases {
        let Err(error) = generate(&stroke(), &settings, |_, _| {}) else {
            panic!("{field}: absurd settings accepted");
        };
        match &error {
            TamError::InvalidSetting { field: f, .. } => assert_eq!(*f, field),
            other => panic!("{field}: unexpected {other:?}"),
        }
        assert!(error.to_string().contains(field), "{error}");
    }
    assert!(TamSettings::default().validate().is_ok());

    assert!(StrokeImage::from_luma8(4, 2, &[0; 7]).is_err());
    assert!(StrokeImage::from_luma8(0, 2, &[]).is_err());
    assert!(
        StrokeImage::from_luma8(2, 1, &[255, 255]).is_err(),
        "no ink"
    );
    let user = StrokeImage::from_luma8(3, 1, &[255, 0, 128]).expect("valid stroke");
    assert_eq!(user.alpha[1], 1.0);
    let broken = StrokeImage {
        width: 2,
        height: 2,
        alpha: vec![0.5; 3],
    };
    let Err(error) = generate(&broken, &small(), |_, _| {}) else {
        panic!("a stroke with too few alpha values was accepted");
    };
    assert!(matches!(error, TamError::InvalidStroke { .. }), "{error}");
}

#[test]
fn tiny_settings_generate_and_report_progress() {
    let settings = TamSettings {
        tones: 2,
        resolution: 64,
        mip_levels: 2,
        strokes_per_tone: 5,
        candidates: 3,
        ..TamSettings::default()
    };
    let mut calls = Vec::new();
    let map = generate(&stroke(), &settings, |done, total| {
        calls.push((done, total));
    })
    .expect("valid settings");
    assert_eq!(map.resolution(), 64);
    assert_eq!(map.levels[1].size, 32);
    assert_eq!(calls.last(), Some(&(10, 10)));
    assert!(calls.windows(2).all(|w| w[0].0 <= w[1].0));
    assert!(map.levels[0].mean_ink(0) > 0.0);
}

#[test]
fn default_stroke_is_a_tapered_horizontal_mark() {
    let s = StrokeImage::default_stroke(200, 16);
    assert!(s.validate().is_ok());
    let column_ink = |x: usize| (0..s.height).map(|y| s.alpha[y * s.width + x]).sum::<f32>();
    assert!(column_ink(100) > 5.0, "{}", column_ink(100));
    assert!(column_ink(0) < 0.5 * column_ink(100), "tapered start");
    assert!(column_ink(199) < 0.5 * column_ink(100), "tapered end");
    assert!(
        s.alpha[..s.width].iter().all(|&a| a < 0.5),
        "thin: top row light"
    );
}
