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

use bevy::prelude::ReflectDefault;
use std::f32::consts::PI;
use std::fmt;

/// Why a TAM could not be generated: a setting or the stroke image is out of range.
#[derive(Debug, Clone, PartialEq)]
pub enum TamError {
    /// A field of [`TamSettings`] has a value the generator cannot use.
    InvalidSetting {
        /// The name of the offending [`TamSettings`] field.
        field: &'static str,
        /// What is wrong with it, including the value that was given.
        reason: String,
    },
    /// The [`StrokeImage`] cannot be used as a pen stroke.
    InvalidStroke {
        /// What is wrong with it.
        reason: String,
    },
}

impl fmt::Display for TamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TamError::InvalidSetting { field, reason } => {
                write!(f, "invalid tonal art map setting `{field}`: {reason}")
            }
            TamError::InvalidStroke { reason } => {
                write!(f, "invalid tonal art map stroke image: {reason}")
            }
        }
    }
}

impl std::error::Error for TamError {}

fn setting_error(field: &'static str, reason: String) -> TamError {
    TamError::InvalidSetting { field, reason }
}

fn stroke_error(reason: String) -> TamError {
    TamError::InvalidStroke { reason }
}

/// The largest width or height accepted for a [`StrokeImage`].
pub const MAX_STROKE_IMAGE_SIZE: usize = 8192;

/// A pen stroke: an ink coverage image that is stretched along the length of every hatching
/// stroke and squeezed across it to [`TamSettings::stroke_width_px`].
///
/// The stroke runs left to right: columns go along the stroke, rows across it.
#[derive(Debug, Clone, PartialEq)]
pub struct StrokeImage {
    /// Number of columns (along the stroke).
    pub width: usize,
    /// Number of rows (across the stroke).
    pub height: usize,
    /// Ink coverage per pixel, row-major, `0.0` (no ink) to `1.0` (full ink); `width * height`
    /// values.
    pub alpha: Vec<f32>,
}

impl StrokeImage {
    /// A generated pen stroke, no file needed: a long thin horizontal mark with tapered ends, a
    /// slight wobble of its centre line and varying pressure (ink density and thickness).
    ///
    /// `width` is clamped to `4..=`[`MAX_STROKE_IMAGE_SIZE`] and `height` to
    /// `2..=`[`MAX_STROKE_IMAGE_SIZE`]; `256 x 16` (the [`Default`]) is a good size.
    /// The result is always the same for the same size.
    pub fn default_stroke(width: usize, height: usize) -> Self {
        let width = width.clamp(4, MAX_STROKE_IMAGE_SIZE);
        let height = height.clamp(2, MAX_STROKE_IMAGE_SIZE);
        let h = height as f32;
        let mut alpha = vec![0.0; width * height];
        for x in 0..width {
            let t = (x as f32 + 0.5) / width as f32;
            // The pen lands quickly and lifts off more slowly.
            let ends = smoothstep(0.0, 0.12, t) * smoothstep(0.0, 0.2, 1.0 - t);
            let pressure = 0.88
                + 0.08 * (2.0 * PI * (1.7 * t + 0.13)).sin()
                + 0.04 * (2.0 * PI * (4.3 * t + 0.61)).sin();
            let centre = 0.5 * h + 0.1 * h * (2.0 * PI * (1.1 * t + 0.3)).sin();
            let half_thickness = 0.4 * h * (0.35 + 0.65 * ends.sqrt()) * pressure;
            let density = (pressure * (0.3 + 0.7 * ends)).min(1.0);
            for y in 0..height {
                let distance = (y as f32 + 0.5 - centre).abs();
                let coverage = (half_thickness - distance + 0.5).clamp(0.0, 1.0);
                alpha[y * width + x] = coverage * density;
            }
        }
        StrokeImage {
            width,
            height,
            alpha,
        }
    }

    /// A user-supplied stroke from 8-bit grayscale pixels, row-major, where dark is ink
    /// (`0` = full ink, `255` = no ink). The stroke must run left to right.
    ///
    /// # Errors
    ///
    /// [`TamError::InvalidStroke`] if a size is zero or above [`MAX_STROKE_IMAGE_SIZE`], if
    /// `bytes.len()` is not `width * height`, or if the image has no ink at all.
    pub fn from_luma8(width: usize, height: usize, bytes: &[u8]) -> Result<Self, TamError> {
        check_stroke_size(width, height)?;
        if bytes.len() != width * height {
            return Err(stroke_error(format!(
                "{width}x{height} needs {} bytes of 8-bit grayscale, got {}",
                width * height,
                bytes.len()
            )));
        }
        let image = StrokeImage {
            width,
            height,
            alpha: bytes.iter().map(|&b| 1.0 - f32::from(b) / 255.0).collect(),
        };
        image.validate()?;
        Ok(image)
    }

    /// Checks that the image can be used as a stroke: sizes in `1..=`[`MAX_STROKE_IMAGE_SIZE`],
    /// `alpha.len() == width * height`, every value finite and in `0..=1`, and some ink.
    ///
    /// # Errors
    ///
    /// [`TamError::InvalidStroke`], saying which of these checks failed.
    pub fn validate(&self) -> Result<(), TamError> {
        check_stroke_size(self.width, self.height)?;
        if self.alpha.len() != self.width * self.height {
            return Err(stroke_error(format!(
                "{}x{} needs {} alpha values, got {}",
                self.width,
                self.height,
                self.width * self.height,
                self.alpha.len()
            )));
        }
        if let Some(bad) = self
            .alpha
            .iter()
            .find(|a| !a.is_finite() || !(0.0..=1.0).contains(*a))
        {
            return Err(stroke_error(format!(
                "alpha values must be finite and in 0..=1, found {bad}"
            )));
        }
        if self.alpha.iter().all(|&a| a < 1.0 / 255.0) {
            return Err(stroke_error(
                "the image has no ink (dark pixels are ink; it is all white)".into(),
            ));
        }
        Ok(())
    }
}

impl Default for StrokeImage {
    /// [`StrokeImage::default_stroke`] at `256 x 16`.
    fn default() -> Self {
        StrokeImage::default_stroke(256, 16)
    }
}

fn check_stroke_size(width: usize, height: usize) -> Result<(), TamError> {
    if width == 0 || height == 0 || width > MAX_STROKE_IMAGE_SIZE || height > MAX_STROKE_IMAGE_SIZE
    {
        return Err(stroke_error(format!(
            "size {width}x{height} must be between 1x1 and \
             {MAX_STROKE_IMAGE_SIZE}x{MAX_STROKE_IMAGE_SIZE}"
        )));
    }
    Ok(())
}

fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How to build a [`TonalArtMap`]; see [`generate`]. Check a hand-made value with
/// [`TamSettings::validate`] ([`generate`] does it too).
#[derive(Debug, Clone, PartialEq, bevy::reflect::Reflect)]
#[reflect(Debug, PartialEq, Default)]
pub struct TamSettings {
    /// Number of tones (hatching images), from the lightest to the darkest. `1..=64`.
    /// Default: `6`.
    pub tones: usize,
    /// Width and height in pixels of the finest mip level (level 0). A power of two in
    /// `8..=4096`. Default: `512`.
    pub resolution: usize,
    /// Number of mip levels built, each half the size of the previous one. At least 1, and the
    /// smallest level must stay at least 8 pixels wide (`resolution >> (mip_levels - 1) >= 8`).
    /// A renderer can fill the levels below with ordinary box-filtered mipmaps. Default: `3`.
    pub mip_levels: usize,
    /// Budget of strokes per tone, `1..=100_000`. A tone stops early when its finest level
    /// reaches its target ink ([`TamSettings::target_ink`]); if the budget runs out first the
    /// tone stays lighter than its target. With the other settings at their defaults the
    /// default budget (the thesis's) adds about 10% of ink per tone and the darkest tone ends
    /// near `0.59`; raise it, lower the resolution or widen the strokes for darker tones.
    /// Default: `78`.
    pub strokes_per_tone: usize,
    /// Number of random candidate strokes tried for each stroke added; the one adding the most
    /// ink where the images are still white (per unit length, over the mip levels and their
    /// scoring pyramids) wins. More candidates give more even hatching and take proportionally
    /// longer. `1..=1000`. Default: `10`.
    pub candidates: usize,
    /// Seed of the random number generator: the same seed and settings give the same bytes.
    /// Default: `1`.
    pub seed: u64,
    /// Length of a stroke as a fraction of the texture width, `(0, 1]`. Default: `0.3`.
    pub stroke_length: f32,
    /// Random variation of the stroke length: each stroke is `stroke_length * (1 ± j)` with `j`
    /// uniform in `[-length_jitter, length_jitter]`, capped at the texture width. `0..=0.9`.
    /// Default: `0.2`.
    pub length_jitter: f32,
    /// Random rotation of each stroke, in degrees, uniform in `±angle_jitter_deg` around
    /// horizontal (or vertical, for cross-hatching). `0..=45`. Default: `5.0`.
    pub angle_jitter_deg: f32,
    /// Width of a stroke in pixels, the same at every mip level (so coarser levels have
    /// relatively thicker strokes, as in Praun's custom mipmaps). `(0, 64]`, and at most half
    /// the smallest level. Wider strokes darken every tone: with the other defaults, 5 px gives
    /// mean ink from 0.12 (lightest) to 0.59 (darkest), 2 px only 0.05 to 0.27.
    /// Default: `5.0`.
    pub stroke_width_px: f32,
    /// Target mean ink (`0` = white, `1` = black) of the darkest tone. The targets of the tones
    /// are spaced evenly: tone `i` of `n` aims at `darkest_tone * (i + 1) / n`, so tone 0 is
    /// light but not blank. `(0, 0.98]`. Default: `0.75`.
    pub darkest_tone: f32,
    /// First tone (0-based) whose new strokes are vertical instead of horizontal, giving
    /// cross-hatching in the darker tones; `None` keeps every stroke horizontal, as does a value
    /// of at least [`TamSettings::tones`]. Default: `None`.
    pub cross_hatch_from_tone: Option<usize>,
    /// When `true`, a coarser mip level skips a stroke if drawing it there would move that
    /// level's mean ink further from the finest level's (Praun's rule for dropping strokes once
    /// a coarse level is dark enough), so every level of a tone has about the same tone. When
    /// `false`, every stroke is drawn into every level and coarser levels come out darker.
    /// Default: `true`.
    pub match_mip_tones: bool,
}

impl Default for TamSettings {
    fn default() -> Self {
        TamSettings {
            tones: 6,
            resolution: 512,
            mip_levels: 3,
            strokes_per_tone: 78,
            candidates: 10,
            seed: 1,
            stroke_length: 0.3,
            length_jitter: 0.2,
            angle_jitter_deg: 5.0,
            stroke_width_px: 5.0,
            darkest_tone: 0.75,
            cross_hatch_from_tone: None,
            match_mip_tones: true,
        }
    }
}

impl TamSettings {
    /// Checks every field against the ranges documented on it; the error names the first field
    /// out of range. Nothing is clamped silently.
    ///
    /// # Errors
    ///
    /// [`TamError::InvalidSetting`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), TamError> {
        if !(1..=64).contains(&self.tones) {
            return Err(setting_error(
                "tones",
                format!("must be in 1..=64, got {}", self.tones),
            ));
        }
        if !self.resolution.is_power_of_two() || !(8..=4096).contains(&self.resolution) {
            return Err(setting_error(
                "resolution",
                format!(
                    "must be a power of two in 8..=4096, got {}",
                    self.resolution
                ),
            ));
        }
        let max_levels = (self.resolution / 8).trailing_zeros() as usize + 1;
        if self.mip_levels == 0 || self.mip_levels > max_levels {
            return Err(setting_error(
                "mip_levels",
                format!(
                    "must be in 1..={max_levels} so that the smallest level of a {res}x{res} \
                     map is at least 8 pixels wide, got {}",
                    self.mip_levels,
                    res = self.resolution
                ),
            ));
        }
        if !(1..=100_000).contains(&self.strokes_per_tone) {
            return Err(setting_error(
                "strokes_per_tone",
                format!("must be in 1..=100000, got {}", self.strokes_per_tone),
            ));
        }
        if !(1..=1000).contains(&self.candidates) {
            return Err(setting_error(
                "candidates",
                format!("must be in 1..=1000, got {}", self.candidates),
            ));
        }
        check_float(
            "stroke_length",
            self.stroke_length,
            self.stroke_length > 0.0 && self.stroke_length <= 1.0,
            "(0, 1]",
        )?;
        check_float(
            "length_jitter",
            self.length_jitter,
            (0.0..=0.9).contains(&self.length_jitter),
            "0..=0.9",
        )?;
        check_float(
            "angle_jitter_deg",
            self.angle_jitter_deg,
            (0.0..=45.0).contains(&self.angle_jitter_deg),
            "0..=45",
        )?;
        let smallest = self.level_size(self.mip_levels - 1);
        let max_width = (smallest as f32 / 2.0).min(64.0);
        check_float(
            "stroke_width_px",
            self.stroke_width_px,
            self.stroke_width_px > 0.0 && self.stroke_width_px <= max_width,
            &format!("(0, {max_width}] (at most 64 and half the smallest level, {smallest} px)"),
        )?;
        check_float(
            "darkest_tone",
            self.darkest_tone,
            self.darkest_tone > 0.0 && self.darkest_tone <= 0.98,
            "(0, 0.98]",
        )?;
        Ok(())
    }

    /// The target mean ink of `tone` (0-based): `darkest_tone * (tone + 1) / tones`.
    pub fn target_ink(&self, tone: usize) -> f32 {
        self.darkest_tone * (tone + 1) as f32 / self.tones.max(1) as f32
    }

    /// Width and height in pixels of mip level `level` (0 = finest).
    pub fn level_size(&self, level: usize) -> usize {
        self.resolution.checked_shr(level as u32).unwrap_or(0)
    }
}

fn check_float(field: &'static str, value: f32, ok: bool, range: &str) -> Result<(), TamError> {
    if !value.is_finite() {
        return Err(setting_error(
            field,
            format!("must be a finite number, got {value}"),
        ));
    }
    if !ok {
        return Err(setting_error(
            field,
            format!("must be in {range}, got {value}"),
        ));
    }
    Ok(())
}

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

/// One stroke in texture space: centre in `[0, 1)²`, angle in radians, length as a fraction
/// of the texture width.
#[derive(Debug, Clone, Copy)]
struct Stroke {
    cx: f32,
    cy: f32,
    angle: f32,
    length: f32,
}

/// Number of levels of the scoring pyramid below the finest level.
const PYRAMID_DEPTH: usize = 5;
/// Smallest size of a scoring pyramid level.
const PYRAMID_MIN_SIZE: usize = 16;

/// Substeps per pixel of the footprint's cross-section table.
const FOOTPRINT_SUBSTEPS: f32 = 4.0;

/// The stroke image prefiltered for one mip level: resampled along the stroke to about the
/// stroke's length in pixels, and across it to `width_px` pixels convolved with a one-pixel box
/// (so coverage is area coverage, anti-aliased), tabulated every quarter pixel.
struct Footprint {
    cols: usize,
    rows: usize,
    half_width: f32,
    /// `rows x cols`, row `j` at cross-section offset `-half_width - 0.5 + j / 4` pixels.
    data: Vec<f32>,
}

impl Footprint {
    fn new(stroke: &StrokeImage, length_px: f32, width_px: f32) -> Self {
        let cols = (length_px.ceil().max(1.0) as usize).min(stroke.width);
        let half_width = 0.5 * width_px;
        let rows = ((width_px + 1.0) * FOOTPRINT_SUBSTEPS).ceil() as usize + 1;
        // Along the stroke: area-resample every source row to `cols` columns.
        let resampled: Vec<Vec<f32>> = stroke
            .alpha
            .chunks_exact(stroke.width)
            .map(|row| resample_area(row, cols))
            .collect();
        // Across: integrate the piecewise-constant profile over a one-pixel window.
        let row_px = width_px / stroke.height as f32;
        let mut data = vec![0.0; rows * cols];
        let mut cumulative = vec![0.0f32; stroke.height + 1];
        for col in 0..cols {
            for (r, row) in resampled.iter().enumerate() {
                cumulative[r + 1] = cumulative[r] + row[col] * row_px;
            }
            let integral = |v: f32| {
                let pos = ((v + half_width) / row_px).clamp(0.0, stroke.height as f32);
                let r = (pos as usize).min(stroke.height - 1);
                cumulative[r] + (pos - r as f32) * (cumulative[r + 1] - cumulative[r])
            };
            for j in 0..rows {
                let v = -half_width - 0.5 + j as f32 / FOOTPRINT_SUBSTEPS;
                data[j * cols + col] = (integral(v + 0.5) - integral(v - 0.5)).clamp(0.0, 1.0);
            }
        }
        Footprint {
            cols,
            rows,
            half_width,
            data,
        }
    }

    /// Coverage at table coordinates: `col` along the stroke (`-0.5..=cols - 0.5` covers it,
    /// column centres at integers) and `row` across it (see [`Footprint::data`]).
    #[inline]
    fn sample(&self, col: f32, row: f32) -> f32 {
        let last_row = (self.rows - 1) as f32;
        let last_col = (self.cols - 1) as f32;
        if !(0.0..last_row).contains(&row) || !(-0.5..=last_col + 0.5).contains(&col) {
            return 0.0;
        }
        let c = col.clamp(0.0, last_col);
        let (c0, r0) = (c as usize, row as usize);
        let (fc, fr) = (c - c0 as f32, row - r0 as f32);
        let c1 = (c0 + 1).min(self.cols - 1);
        let top = r0 * self.cols;
        let bottom = top + self.cols;
        let a = self.data[top + c0] + (self.data[top + c1] - self.data[top + c0]) * fc;
        let b = self.data[bottom + c0] + (self.data[bottom + c1] - self.data[bottom + c0]) * fc;
        a + (b - a) * fr
    }
}

/// Area-averages `src` into `n` samples (`n <= src.len()`).
fn resample_area(src: &[f32], n: usize) -> Vec<f32> {
    if n == src.len() {
        return src.to_vec();
    }
    let scale = src.len() as f64 / n as f64;
    (0..n)
        .map(|k| {
            let (a, b) = (k as f64 * scale, (k + 1) as f64 * scale);
            let mut acc = 0.0;
            let mut i = a.floor() as usize;
            while (i as f64) < b && i < src.len() {
                let overlap = b.min(i as f64 + 1.0) - a.max(i as f64);
                acc += f64::from(src[i]) * overlap.max(0.0);
                i += 1;
            }
            (acc / scale) as f32
        })
        .collect()
}

/// Calls `visit(pixel_index, coverage)` for every pixel of a `size x size` image that `stroke`
/// covers, wrapping around the edges. Walks the stroke's major axis (x for strokes closer to
/// horizontal, y otherwise) and, per column or row, only the pixels within reach of the stroke.
fn rasterize(
    size: usize,
    footprint: &Footprint,
    stroke: &Stroke,
    mut visit: impl FnMut(usize, f32),
) {
    let s = size as f32;
    let (sin, cos) = stroke.angle.sin_cos();
    let (cx, cy) = (stroke.cx * s, stroke.cy * s);
    let half_length = 0.5 * stroke.length * s;
    let half_width = footprint.half_width;
    // Footprint table coordinates are affine in the pixel offset (dx, dy) from the centre:
    // col = u * col_per_px + col_offset with u = dx cos + dy sin along the stroke, and
    // row = v * FOOTPRINT_SUBSTEPS + row_offset with v = dy cos - dx sin across it.
    let col_per_px = footprint.cols as f32 / (2.0 * half_length);
    let col_offset = 0.5 * footprint.cols as f32 - 0.5;
    let row_offset = (half_width + 0.5) * FOOTPRINT_SUBSTEPS;
    let table = |dx: f32, dy: f32| {
        (
            (dx * cos + dy * sin) * col_per_px + col_offset,
            (dy * cos - dx * sin) * FOOTPRINT_SUBSTEPS + row_offset,
        )
    };
    let horizontal = cos.abs() >= sin.abs();
    // Major/minor axis coordinates of the centre and of the direction, and the change of the
    // table coordinates per pixel step along the minor axis.
    let (cm, cn, dm, dn) = if horizontal {
        (cx, cy, cos, sin)
    } else {
        (cy, cx, sin, cos)
    };
    let (col_step, row_step) = if horizontal {
        table(0.0, 1.0)
    } else {
        table(1.0, 0.0)
    };
    let (col_step, row_step) = (col_step - col_offset, row_step - row_offset);
    let extent = (half_length + 0.5) * dm.abs() + (half_width + 0.5) * dn.abs();
    let slope = dn / dm;
    let reach = (half_width + 0.5) / dm.abs();
    // Sizes are powers of two, so wrapping is a mask (also for negative coordinates).
    debug_assert!(size.is_power_of_two());
    let wrap = size as i64 - 1;
    for m in floor(cm - extent)..=ceil(cm + extent) {
        let centre_n = cn + (m as f32 + 0.5 - cm) * slope;
        let first = floor(centre_n - reach - 0.5);
        let (x, y) = if horizontal { (m, first) } else { (first, m) };
        let (mut col, mut row) = table(x as f32 + 0.5 - cx, y as f32 + 0.5 - cy);
        let m_wrapped = (m & wrap) as usize;
        for n in first..=ceil(centre_n + reach - 0.5) {
            let coverage = footprint.sample(col, row);
            if coverage > 0.0 {
                let n_wrapped = (n & wrap) as usize;
                let index = if horizontal {
                    n_wrapped * size + m_wrapped
                } else {
                    m_wrapped * size + n_wrapped
                };
                visit(index, coverage);
            }
            col += col_step;
            row += row_step;
        }
    }
}

/// `x.floor()` as an integer, without a libm call.
fn floor(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x { t - 1 } else { t }
}

/// `x.ceil()` as an integer, without a libm call.
fn ceil(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) < x { t + 1 } else { t }
}

/// An ink image (`0` white, `1` black, as floats) with the footprint strokes are drawn with.
struct Canvas {
    size: usize,
    ink: Vec<f32>,
    footprint: Footprint,
}

impl Canvas {
    fn new(stroke: &StrokeImage, size: usize, max_length: f32, width_px: f32) -> Self {
        Canvas {
            size,
            ink: vec![0.0; size * size],
            footprint: Footprint::new(stroke, max_length * size as f32, width_px),
        }
    }

    /// Mean ink this stroke would add: the ink it puts where the image is still white.
    fn contribution(&self, stroke: &Stroke) -> f64 {
        contribution(self.size, &self.footprint, &self.ink, stroke)
    }

    /// Composites the stroke over the image; returns the total ink added.
    fn draw(&mut self, stroke: &Stroke) -> f64 {
        draw(self.size, &self.footprint, &mut self.ink, stroke)
    }

    fn to_luma8(&self) -> Vec<u8> {
        self.ink
            .iter()
            .map(|&ink| ((1.0 - ink.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
            .collect()
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

/// Mean ink `stroke` would add to `ink`, a `size x size` image.
fn contribution(size: usize, footprint: &Footprint, ink: &[f32], stroke: &Stroke) -> f64 {
    let mut added = 0.0f32;
    rasterize(size, footprint, stroke, |i, c| added += c * (1.0 - ink[i]));
    f64::from(added) / (size * size) as f64
}

/// Composites `stroke` over `ink`; returns the total ink added.
fn draw(size: usize, footprint: &Footprint, ink: &mut [f32], stroke: &Stroke) -> f64 {
    let mut added = 0.0f64;
    rasterize(size, footprint, stroke, |i, c| {
        let delta = c * (1.0 - ink[i]);
        ink[i] += delta;
        added += f64::from(delta);
    });
    added
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

#[cfg(test)]
mod tests {
    use super::*;

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
            calls.push((done, total))
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
}
