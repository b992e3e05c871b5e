//! Tonal art maps (TAMs) for pen-and-ink hatching, after Praun, Hoppe, Webb and Finkelstein,
//! "Real-time hatching" (SIGGRAPH 2001).
//!
//! A TAM is a sequence of hatching textures, one per tone, from the lightest to the darkest,
//! each with its own hand-built mip chain. [`generate`] builds one with Praun's algorithm:
//!
//! * **Nesting.** Tones are filled from light to dark and each tone starts as a copy of the
//!   lighter one, so every stroke of a lighter tone is in every darker tone, at every mip level.
//!   Blending between neighbouring tones in a shader then only ever adds strokes.
//! * **Best of N candidates.** Each new stroke is the candidate, among
//!   [`TamSettings::candidates`] random ones, that adds the most ink where the images are still
//!   white: its *tone contribution*, summed over the mip levels that take it and, as in Praun,
//!   over an image pyramid of each (the same strokes drawn at half, quarter, ... size and
//!   width), which sees how crowded a candidate's neighbourhood is and so spaces the strokes
//!   evenly. The sum is taken per unit of stroke length, so that random length variation does
//!   not outweigh spacing.
//! * **Custom mipmaps.** A stroke is drawn into every mip level with the same width in pixels
//!   (its position and length scale with the level, its width does not), so distant hatching
//!   stays crisp lines instead of blurring to grey. Because a stroke of constant pixel width
//!   darkens a coarse level more than a fine one, a coarse level skips a stroke when drawing it
//!   would move its tone further from the finest level's tone (see
//!   [`TamSettings::match_mip_tones`]).
//! * **Tiling.** Strokes that cross an edge wrap around, so every image tiles seamlessly.
//!
//! The module is plain `std`: the caller turns the 8-bit grayscale images of a [`TonalArtMap`]
//! into GPU textures. Generation is deterministic for a given [`TamSettings::seed`] (and
//! platform), and the default settings take about a tenth of a second in a release build: a
//! candidate is scored only over the pixels it touches, and strokes are rasterised by sampling
//! a prefiltered (anti-aliased) copy of the [`StrokeImage`] along the stroke's axis.

use std::f32::consts::PI;

use super::raster::{Canvas, Stroke};
use super::settings::{TamError, TamSettings};
use super::stroke_image::StrokeImage;

/// Number of levels of the scoring pyramid below the finest level.
const PYRAMID_DEPTH: usize = 5;
/// Smallest size of a scoring pyramid level.
const PYRAMID_MIN_SIZE: usize = 16;

/// One mip level of a [`TonalArtMap`]: one square grayscale image per tone.
#[derive(Debug, Clone, PartialEq)]
pub struct TamLevel {
    /// Width and height in pixels.
    pub size: usize,
    /// Per tone (0 = lightest), a `size * size` row-major 8-bit grayscale image: `255` is white
    /// paper, `0` full ink.
    pub tones: Vec<Vec<u8>>,
}

impl TamLevel {
    /// Mean ink coverage of `tone` in this level: `0.0` for white paper, `1.0` for solid black.
    ///
    /// # Panics
    ///
    /// If `tone` is out of range.
    pub fn mean_ink(&self, tone: usize) -> f32 {
        mean_ink_of(&self.tones[tone])
    }
}

fn mean_ink_of(image: &[u8]) -> f32 {
    if image.is_empty() {
        return 0.0;
    }
    let white: u64 = image.iter().map(|&b| u64::from(b)).sum();
    1.0 - (white as f64 / (255.0 * image.len() as f64)) as f32
}

/// A generated tonal art map: hatching images for `tones` tones at each mip level.
#[derive(Debug, Clone, PartialEq)]
pub struct TonalArtMap {
    /// Number of tones; tone 0 is the lightest, tone `tones - 1` the darkest.
    pub tones: usize,
    /// Mip levels, level 0 the finest (`resolution x resolution`), each further level half the
    /// size of the previous one.
    pub levels: Vec<TamLevel>,
}

impl TonalArtMap {
    /// Mean ink coverage (`0.0` white to `1.0` black) of every image, indexed
    /// `[level][tone]`.
    pub fn mean_ink_table(&self) -> Vec<Vec<f32>> {
        self.levels
            .iter()
            .map(|level| (0..level.tones.len()).map(|t| level.mean_ink(t)).collect())
            .collect()
    }

    /// Width and height in pixels of level 0, or 0 if there are no levels.
    pub fn resolution(&self) -> usize {
        self.levels.first().map_or(0, |level| level.size)
    }
}

/// SplitMix64: a tiny, fast, deterministic generator; plenty for scattering strokes.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[-1, 1)`.
    fn next_signed(&mut self) -> f32 {
        self.next_f32() * 2.0 - 1.0
    }
}

/// One output mip level while generating, with its running ink sum and its scoring pyramid.
struct LevelState {
    canvas: Canvas,
    ink_sum: f64,
    /// Praun's image pyramid of this level, used only to score candidates: each pyramid level
    /// halves the size *and* the stroke width (a plain downsampling of this level), so it
    /// measures how crowded a candidate's neighbourhood is at ever coarser scales, which spaces
    /// the strokes evenly.
    pyramid: Vec<Canvas>,
}

impl LevelState {
    fn new(stroke: &StrokeImage, size: usize, max_length: f32, width_px: f32) -> Self {
        LevelState {
            canvas: Canvas::new(stroke, size, max_length, width_px),
            ink_sum: 0.0,
            pyramid: (1..=PYRAMID_DEPTH)
                .map(|k| (size >> k, width_px / (1 << k) as f32))
                .take_while(|&(size, _)| size >= PYRAMID_MIN_SIZE)
                .map(|(size, width)| Canvas::new(stroke, size, max_length, width))
                .collect(),
        }
    }

    fn mean(&self) -> f64 {
        self.ink_sum / (self.canvas.size * self.canvas.size) as f64
    }

    /// The tone contribution of a stroke to this level (`own`, already computed) averaged with
    /// its contributions to this level's pyramid.
    fn score(&self, own: f64, stroke: &Stroke) -> f64 {
        let blurred: f64 = self.pyramid.iter().map(|c| c.contribution(stroke)).sum();
        (own + blurred) / (1 + self.pyramid.len()) as f64
    }

    fn draw(&mut self, stroke: &Stroke) {
        self.ink_sum += self.canvas.draw(stroke);
        for canvas in &mut self.pyramid {
            canvas.draw(stroke);
        }
    }
}

/// Levels (bit `l` = level `l`) that a stroke with per-level contributions `contributions`
/// should be drawn into: always level 0; with `match_tones`, a coarser level only if that takes
/// its mean ink closer to the finest level's mean after the stroke.
fn accepted_levels(levels: &[LevelState], contributions: &[f64], match_tones: bool) -> u64 {
    if !match_tones {
        return (1u64 << levels.len()) - 1;
    }
    let finest_after = levels[0].mean() + contributions[0];
    let mut mask = 1;
    for (l, (level, added)) in levels.iter().zip(contributions).enumerate().skip(1) {
        let before = (level.mean() - finest_after).abs();
        let after = (level.mean() + added - finest_after).abs();
        if after < before {
            mask |= 1 << l;
        }
    }
    mask
}

/// Generates a tonal art map with Praun et al.'s algorithm (see the module documentation).
///
/// Tones are filled from light to dark; each starts as a copy of the lighter one and gets
/// strokes until its finest level reaches [`TamSettings::target_ink`] or
/// [`TamSettings::strokes_per_tone`] strokes were added. Each stroke is the best of
/// [`TamSettings::candidates`] random candidates by tone contribution summed over the mip
/// levels (and their scoring pyramids), and is drawn with the same width in pixels into the
/// finest level and into each coarser level whose tone it brings closer to the finest one's
/// (every level, without [`TamSettings::match_mip_tones`]), wrapping around the edges so the
/// images tile.
///
/// `progress(done, total)` is called after every stroke and at the end of every tone, with
/// `total = tones * strokes_per_tone` (a tone that reaches its target early jumps `done` to the
/// end of its budget); the last call is `progress(total, total)`.
///
/// # Errors
///
/// Without panicking, the error of [`TamSettings::validate`] or [`StrokeImage::validate`] if
/// `settings` or `stroke` is invalid.
pub fn generate(
    stroke: &StrokeImage,
    settings: &TamSettings,
    mut progress: impl FnMut(usize, usize),
) -> Result<TonalArtMap, TamError> {
    settings.validate()?;
    stroke.validate()?;
    let max_length = (settings.stroke_length * (1.0 + settings.length_jitter)).min(1.0);
    let width = settings.stroke_width_px;
    let mut levels: Vec<LevelState> = (0..settings.mip_levels)
        .map(|l| LevelState::new(stroke, settings.level_size(l), max_length, width))
        .collect();
    let mut rng = SplitMix64(settings.seed ^ 0x5441_4D5F_5345_4544);
    let angle_jitter = settings.angle_jitter_deg.to_radians();
    let total = settings.tones * settings.strokes_per_tone;
    let mut images: Vec<Vec<Vec<u8>>> = vec![Vec::with_capacity(settings.tones); levels.len()];
    let mut contributions = vec![0.0f64; levels.len()];

    for tone in 0..settings.tones {
        let target = f64::from(settings.target_ink(tone));
        let base_angle = match settings.cross_hatch_from_tone {
            Some(first) if tone >= first => 0.5 * PI,
            _ => 0.0,
        };
        let mut added = 0;
        while added < settings.strokes_per_tone && levels[0].mean() < target {
            let mut best: Option<(f64, Stroke)> = None;
            for _ in 0..settings.candidates {
                let candidate = Stroke {
                    cx: rng.next_f32(),
                    cy: rng.next_f32(),
                    angle: base_angle + rng.next_signed() * angle_jitter,
                    length: (settings.stroke_length
                        * (1.0 + rng.next_signed() * settings.length_jitter))
                        .min(1.0),
                };
                // Tone contribution (ink added as a fraction of the image) to each output
                // level that would take the stroke, averaged with its pyramid, summed over
                // those levels, per unit of stroke length so that length jitter does not
                // outweigh spacing.
                for (c, level) in contributions.iter_mut().zip(&levels) {
                    *c = level.canvas.contribution(&candidate);
                }
                let mask = accepted_levels(&levels, &contributions, settings.match_mip_tones);
                let score = levels
                    .iter()
                    .zip(&contributions)
                    .enumerate()
                    .filter(|(l, _)| mask & (1 << l) != 0)
                    .map(|(_, (level, &own))| level.score(own, &candidate))
                    .sum::<f64>()
                    / f64::from(candidate.length);
                if best.is_none_or(|(best_score, _)| score > best_score) {
                    best = Some((score, candidate));
                }
            }
            if let Some((_, chosen)) = best {
                for (c, level) in contributions.iter_mut().zip(&levels) {
                    *c = level.canvas.contribution(&chosen);
                }
                let mask = accepted_levels(&levels, &contributions, settings.match_mip_tones);
                for (l, level) in levels.iter_mut().enumerate() {
                    if mask & (1 << l) != 0 {
                        level.draw(&chosen);
                    }
                }
            }
            added += 1;
            progress(tone * settings.strokes_per_tone + added, total);
        }
        if added < settings.strokes_per_tone {
            progress((tone + 1) * settings.strokes_per_tone, total);
        }
        for (level, out) in levels.iter().zip(&mut images) {
            out.push(level.canvas.to_luma8());
        }
    }

    Ok(TonalArtMap {
        tones: settings.tones,
        levels: levels
            .iter()
            .zip(images)
            .map(|(level, tones)| TamLevel {
                size: level.canvas.size,
                tones,
            })
            .collect(),
    })
}
