//! Drawing strokes into grayscale canvases: a stroke's prefiltered footprint, sampled along its
//! axis with wrap-around so every image tiles.

use super::stroke_image::StrokeImage;

/// One stroke in texture space: centre in `[0, 1)²`, angle in radians, length as a fraction
/// of the texture width.
#[derive(Debug, Clone, Copy)]
pub(super) struct Stroke {
    pub(super) cx: f32,
    pub(super) cy: f32,
    pub(super) angle: f32,
    pub(super) length: f32,
}

/// Substeps per pixel of the footprint's cross-section table.
pub(super) const FOOTPRINT_SUBSTEPS: f32 = 4.0;

/// The stroke image prefiltered for one mip level: resampled along the stroke to about the
/// stroke's length in pixels, and across it to `width_px` pixels convolved with a one-pixel box
/// (so coverage is area coverage, anti-aliased), tabulated every quarter pixel.
pub(super) struct Footprint {
    pub(super) cols: usize,
    pub(super) rows: usize,
    pub(super) half_width: f32,
    /// `rows x cols`, row `j` at cross-section offset `-half_width - 0.5 + j / 4` pixels.
    pub(super) data: Vec<f32>,
}

impl Footprint {
    pub(super) fn new(stroke: &StrokeImage, length_px: f32, width_px: f32) -> Self {
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
    pub(super) fn sample(&self, col: f32, row: f32) -> f32 {
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
pub(super) fn resample_area(src: &[f32], n: usize) -> Vec<f32> {
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
pub(super) fn rasterize(
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
pub(super) fn floor(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x { t - 1 } else { t }
}

/// `x.ceil()` as an integer, without a libm call.
pub(super) fn ceil(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) < x { t + 1 } else { t }
}

/// An ink image (`0` white, `1` black, as floats) with the footprint strokes are drawn with.
pub(super) struct Canvas {
    pub(super) size: usize,
    pub(super) ink: Vec<f32>,
    pub(super) footprint: Footprint,
}

impl Canvas {
    pub(super) fn new(stroke: &StrokeImage, size: usize, max_length: f32, width_px: f32) -> Self {
        Canvas {
            size,
            ink: vec![0.0; size * size],
            footprint: Footprint::new(stroke, max_length * size as f32, width_px),
        }
    }

    /// Mean ink this stroke would add: the ink it puts where the image is still white.
    pub(super) fn contribution(&self, stroke: &Stroke) -> f64 {
        contribution(self.size, &self.footprint, &self.ink, stroke)
    }

    /// Composites the stroke over the image; returns the total ink added.
    pub(super) fn draw(&mut self, stroke: &Stroke) -> f64 {
        draw(self.size, &self.footprint, &mut self.ink, stroke)
    }

    pub(super) fn to_luma8(&self) -> Vec<u8> {
        self.ink
            .iter()
            .map(|&ink| ((1.0 - ink.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
            .collect()
    }
}

/// Mean ink `stroke` would add to `ink`, a `size x size` image.
pub(super) fn contribution(
    size: usize,
    footprint: &Footprint,
    ink: &[f32],
    stroke: &Stroke,
) -> f64 {
    let mut added = 0.0f32;
    rasterize(size, footprint, stroke, |i, c| added += c * (1.0 - ink[i]));
    f64::from(added) / (size * size) as f64
}

/// Composites `stroke` over `ink`; returns the total ink added.
pub(super) fn draw(size: usize, footprint: &Footprint, ink: &mut [f32], stroke: &Stroke) -> f64 {
    let mut added = 0.0f64;
    rasterize(size, footprint, stroke, |i, c| {
        let delta = c * (1.0 - ink[i]);
        ink[i] += delta;
        added += f64::from(delta);
    });
    added
}
