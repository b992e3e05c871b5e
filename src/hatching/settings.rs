//! [`TamSettings`], how a tonal art map is built, and [`TamError`], why it could not be.

use bevy::prelude::{Reflect, ReflectDefault};

/// Why a TAM could not be generated: a setting or the stroke image is out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TamError {
    /// A field of [`TamSettings`] has a value the generator cannot use.
    #[error("invalid tonal art map setting `{field}`: {reason}")]
    InvalidSetting {
        /// The name of the offending [`TamSettings`] field.
        field: &'static str,
        /// What is wrong with it, including the value that was given.
        reason: String,
    },
    /// The [`StrokeImage`](super::StrokeImage) cannot be used as a pen stroke.
    #[error("invalid tonal art map stroke image: {reason}")]
    InvalidStroke {
        /// What is wrong with it.
        reason: String,
    },
}

pub(super) fn setting_error(field: &'static str, reason: String) -> TamError {
    TamError::InvalidSetting { field, reason }
}

pub(super) fn stroke_error(reason: String) -> TamError {
    TamError::InvalidStroke { reason }
}

/// How to build a [`TonalArtMap`](super::TonalArtMap); see [`generate`](super::generate). Check a hand-made value with
/// [`TamSettings::validate`] ([`generate`](super::generate) does it too).
#[derive(Debug, Clone, PartialEq, Reflect)]
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
