//! [`StrokeImage`]: the pen stroke every hatching line is drawn with.

use std::f32::consts::PI;

use super::settings::{TamError, stroke_error};

/// The largest width or height accepted for a [`StrokeImage`].
pub const MAX_STROKE_IMAGE_SIZE: usize = 8192;

/// A pen stroke: an ink coverage image that is stretched along the length of every hatching
/// stroke and squeezed across it to [`TamSettings::stroke_width_px`](super::TamSettings::stroke_width_px).
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

pub(super) fn check_stroke_size(width: usize, height: usize) -> Result<(), TamError> {
    if width == 0 || height == 0 || width > MAX_STROKE_IMAGE_SIZE || height > MAX_STROKE_IMAGE_SIZE
    {
        return Err(stroke_error(format!(
            "size {width}x{height} must be between 1x1 and \
             {MAX_STROKE_IMAGE_SIZE}x{MAX_STROKE_IMAGE_SIZE}"
        )));
    }
    Ok(())
}

pub(super) fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
