//! Screen-space stroke strips: each silhouette polyline becomes a stroke of constant pixel width
//! (Northrup & Markosian 2000, Kalnins et al. 2003) for a [`StrokeCamera`], with the thesis's
//! angle, depth and stroke scaling, stroke limit and E-curve fade, unprojected back to world
//! space so that an ordinary mesh pipeline draws it. An AVX2 kernel projects and offsets runs of
//! points where the CPU has it; the portable path gives the same result.
#![cfg_attr(
    target_arch = "x86_64",
    expect(
        unsafe_code,
        reason = "AVX2 kernels, chosen after runtime feature detection"
    )
)]

use bevy::math::{Mat4, Vec2, Vec3, Vec4};

use super::adjacency::Viewer;
use super::chain::SilhouetteChain;
use crate::curve::QuadraticCurve;

/// How silhouette polylines become strokes; the widths are in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeParams {
    /// Stroke width in pixels (at depth `1` when `depth_scale` is not `0`). Default `2.0`.
    pub width_px: f32,
    /// Angle scaling in `[0, 1]`: how much of the miter compensation `1 / cos(half the turn)` is
    /// applied at corners, so that a corner keeps the stroke's width across each segment (`1`)
    /// or is drawn with a plain, thinner joint (`0`). The compensation is capped at 4x (turns
    /// sharper than about 150°). Default `1.0`.
    pub angle_scale: f32,
    /// Depth scaling: the width is multiplied by `(1 / w)^depth_scale`, `w` the clip-space `w`
    /// (the view depth for a perspective camera; always `1` for an orthographic one). `0` keeps
    /// a constant pixel width, `1` shrinks far strokes like world-space geometry. Default `0.0`.
    pub depth_scale: f32,
    /// A global multiplier on the width. Default `1.0`.
    pub stroke_scale: f32,
    /// The most a stroke may be wide, in pixels, after every scaling: each side's half-width is
    /// clamped to half of it. Default `8.0`.
    pub stroke_limit_px: f32,
    /// The **E** curve `[a, b, c]`: alpha `a*x^2 + b*x + c` (clamped to `[0, 1]`) at `x` from `0`
    /// at the root to `1` at the tip. Default: constant `1` (opaque).
    pub fade: QuadraticCurve,
    /// Pixels of stroke per texture repeat: `u = arc length in px / texture_length_px`.
    /// Default `64.0`.
    pub texture_length_px: f32,
    /// World-space distance each stroke point is pulled toward the camera's viewer (see
    /// [`StrokeCamera::with_viewer`]; nothing is pulled without one) before it is projected. A
    /// point moved along its eye ray keeps its place on screen, so the stroke keeps its shape and
    /// pixel width, but it is drawn in front of the surface it outlines. Default `0.0`.
    pub depth_bias: f32,
    /// Linear RGBA stroke colour; each vertex gets it with its alpha multiplied by the **E**
    /// curve. Default opaque black.
    pub color: [f32; 4],
}

impl Default for StrokeParams {
    fn default() -> Self {
        Self {
            width_px: 2.0,
            angle_scale: 1.0,
            depth_scale: 0.0,
            stroke_scale: 1.0,
            stroke_limit_px: 8.0,
            fade: QuadraticCurve::constant(1.0),
            texture_length_px: 64.0,
            depth_bias: 0.0,
            color: [0.0, 0.0, 0.0, 1.0],
        }
    }
}

/// The camera strokes are built for: the view-projection matrix, its inverse and the viewport.
/// Build it once per frame and camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeCamera {
    view_proj: Mat4,
    /// World-space (homogeneous) offset per pixel along screen x and y, per unit clip `w`.
    unproject_x: Vec4,
    unproject_y: Vec4,
    half_viewport: Vec2,
    viewer: Option<Viewer>,
}

impl StrokeCamera {
    /// A camera with `view_proj` (clip from world; wgpu conventions: NDC `y` up) and a viewport
    /// `viewport` pixels in size. A singular matrix gives zero-width strokes; a non-positive
    /// viewport size counts as one pixel.
    pub fn new(view_proj: Mat4, viewport: Vec2) -> Self {
        let half_viewport = (viewport * 0.5).max(Vec2::splat(0.5));
        let half_viewport = if half_viewport.is_finite() {
            half_viewport
        } else {
            Vec2::splat(0.5)
        };
        let inverse = view_proj.inverse();
        let (unproject_x, unproject_y) = if inverse.is_finite() && view_proj.determinant() != 0.0 {
            (
                inverse.x_axis / half_viewport.x,
                inverse.y_axis / half_viewport.y,
            )
        } else {
            (Vec4::ZERO, Vec4::ZERO)
        };
        Self {
            view_proj,
            unproject_x,
            unproject_y,
            half_viewport,
            viewer: None,
        }
    }

    /// The camera whose view (the camera's world transform) and projection are given: its
    /// viewer is the camera's position for a perspective projection (the projection's last row
    /// depends on depth) and its backward direction otherwise.
    pub fn from_view(world_from_view: Mat4, clip_from_view: Mat4, viewport: Vec2) -> Self {
        let view_from_world = world_from_view.inverse();
        let orthographic = clip_from_view.row(3) == Vec4::W;
        let viewer = if orthographic {
            Viewer::Direction(world_from_view.z_axis.truncate())
        } else {
            Viewer::Point(world_from_view.w_axis.truncate())
        };
        Self::new(clip_from_view * view_from_world, viewport).with_viewer(viewer)
    }

    /// This camera, seen from `viewer`: the eye point of a perspective camera, or the direction
    /// toward an orthographic one. It is what [`StrokeParams::depth_bias`] pulls toward and
    /// what the facing test of [`silhouette_edges`](super::adjacency::silhouette_edges) should be given.
    pub fn with_viewer(mut self, viewer: Viewer) -> Self {
        let finite = match viewer {
            Viewer::Point(p) => p.is_finite(),
            Viewer::Direction(d) => d.is_finite() && d != Vec3::ZERO,
        };
        self.viewer = finite.then_some(viewer);
        self
    }

    /// The viewer given by [`StrokeCamera::with_viewer`] or [`StrokeCamera::from_view`].
    pub fn viewer(&self) -> Option<Viewer> {
        self.viewer
    }

    /// The viewport size in pixels.
    pub fn viewport(&self) -> Vec2 {
        self.half_viewport * 2.0
    }

    /// Clip from world (the view-projection matrix).
    pub fn view_proj(&self) -> Mat4 {
        self.view_proj
    }

    /// The world-space (homogeneous) offsets of one pixel along screen x and y, per unit clip
    /// `w`: zero for a singular camera.
    pub fn unproject(&self) -> (Vec4, Vec4) {
        (self.unproject_x, self.unproject_y)
    }

    /// `p` in pixels from the viewport centre (`y` up) and its clip `w`.
    pub fn project(&self, p: Vec3) -> (Vec2, f32) {
        let clip = self.view_proj * p.extend(1.0);
        (
            clip.truncate().truncate() / clip.w * self.half_viewport,
            clip.w,
        )
    }
}

/// The points of a stroke being built, one array per quantity so that the passes over them
/// vectorise.
#[derive(Clone, Debug, Default)]
struct Run {
    /// World position (after the depth bias).
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Pixels from the viewport centre, `y` up.
    sx: Vec<f32>,
    sy: Vec<f32>,
    /// Clip-space `w`; NaN for a point behind the camera or not finite.
    w: Vec<f32>,
    /// Position along the strand on input, alpha after projection.
    alpha: Vec<f32>,
    /// Unit screen direction to the next point (to the first for the last point of a loop) and
    /// the screen distance to it in pixels.
    dx: Vec<f32>,
    dy: Vec<f32>,
    length: Vec<f32>,
    /// Width factor of depth scaling.
    depth: Vec<f32>,
    /// The stroke's left and right vertices (world space).
    left: [Vec<f32>; 3],
    right: [Vec<f32>; 3],
}

impl Run {
    /// Makes every array at least `n` long (contents unspecified): the passes use the first `n`
    /// entries, so arrays never shrink and refill between strokes.
    fn reserve_points(&mut self, n: usize) {
        if self.x.len() >= n {
            return;
        }
        for v in self.point_arrays() {
            v.resize(n, 0.0);
        }
        for v in [
            &mut self.dx,
            &mut self.dy,
            &mut self.length,
            &mut self.depth,
        ]
        .into_iter()
        .chain(&mut self.left)
        .chain(&mut self.right)
        {
            v.resize(n, 0.0);
        }
    }

    /// The per-point arrays that survive projection.
    fn point_arrays(&mut self) -> [&mut Vec<f32>; 7] {
        [
            &mut self.x,
            &mut self.y,
            &mut self.z,
            &mut self.sx,
            &mut self.sy,
            &mut self.w,
            &mut self.alpha,
        ]
    }

    fn valid(&self, i: usize) -> bool {
        !self.w[i].is_nan()
    }

    fn screen_distance_squared(&self, i: usize, j: usize) -> f32 {
        let (dx, dy) = (self.sx[i] - self.sx[j], self.sy[i] - self.sy[j]);
        dx * dx + dy * dy
    }
}

/// Stroke geometry: world-space triangles of screen-space strokes, appended to by
/// [`build_stroke_strip`] and [`build_chain_strip`].
#[derive(Clone, Debug, Default)]
pub struct StrokeVertices {
    /// World-space positions.
    pub positions: Vec<[f32; 3]>,
    /// `u` along the stroke (arc length in pixels / [`StrokeParams::texture_length_px`]), `v`
    /// across it: `0` on the left side, `1` on the right side (seen from the camera, walking the
    /// stroke forward).
    pub uvs: Vec<[f32; 2]>,
    /// [`StrokeParams::color`] per vertex, its alpha multiplied by the **E** curve.
    pub colors: Vec<[f32; 4]>,
    /// Triangle list into the vertices, counter-clockwise as seen from the camera.
    pub indices: Vec<u32>,
    run: Run,
}

impl StrokeVertices {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Removes every vertex and index, keeping the buffers.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.uvs.clear();
        self.colors.clear();
        self.indices.clear();
    }
}

/// Points closer than this on screen (pixels) are merged.
const MIN_SEGMENT_PX: f32 = 1e-3;
/// Points with a clip `w` at most this are behind the camera (or on its plane) and skipped.
const MIN_CLIP_W: f32 = 1e-6;
/// The largest miter compensation.
const MAX_MITER: f32 = 4.0;

/// Appends a screen-space stroke along the world-space polyline `points_world` to `out`.
///
/// The points are projected to pixels. At each point the stroke is offset both ways
/// perpendicular to the normalised sum of the adjacent segment directions (a miter), by half the
/// width times: the miter compensation (see [`StrokeParams::angle_scale`]), the depth scaling,
/// and [`StrokeParams::stroke_scale`], then clamped by [`StrokeParams::stroke_limit_px`]. The
/// offset points are unprojected back to world space at the original point's depth, so the
/// stroke keeps its pixel width wherever it is drawn from this camera. `along_strand[i]` (`0` at
/// the root, `1` at the tip; missing values count as `0`) gives point `i`'s alpha from the
/// **E** curve. A closed polyline wraps around (its first vertex pair is repeated at the end so
/// that `u` runs on).
///
/// Points behind the camera (clip `w` near or below zero) or not finite split the stroke into
/// pieces; points within a thousandth of a pixel of the previous one are merged. Pieces of fewer
/// than two points add nothing. The output is always finite for finite cameras.
pub fn build_stroke_strip(
    points_world: &[Vec3],
    along_strand: &[f32],
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    build_strip(
        points_world.len(),
        |i| (points_world[i], along_strand.get(i).copied().unwrap_or(0.0)),
        closed,
        camera,
        params,
        out,
    );
}

/// [`build_stroke_strip`] for a chain of mesh vertices, without copying them out first:
/// `positions` and `along_strand` are indexed by the chain's vertex indices (for a strand tube,
/// `along_strand` is the `v` of [`TubeTopology::uvs`](crate::mesh::tube::TubeTopology::uvs);
/// missing values count as `0`).
///
/// # Panics
///
/// If a chain vertex is out of range of `positions`.
pub fn build_chain_strip(
    chain: SilhouetteChain<'_>,
    positions: &[[f32; 3]],
    along_strand: &[f32],
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    build_strip(
        chain.vertices.len(),
        |i| {
            let v = chain.vertices[i] as usize;
            (
                Vec3::from_array(positions[v]),
                along_strand.get(v).copied().unwrap_or(0.0),
            )
        },
        chain.closed,
        camera,
        params,
        out,
    );
}

/// The stroke along `n` points given by `point(i) = (world position, along strand)`.
fn build_strip(
    n: usize,
    point: impl Fn(usize) -> (Vec3, f32),
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    if n < 2 {
        return;
    }
    let mut run = std::mem::take(&mut out.run);
    run.reserve_points(n);
    {
        let (x, y, z, a) = (
            &mut run.x[..n],
            &mut run.y[..n],
            &mut run.z[..n],
            &mut run.alpha[..n],
        );
        for i in 0..n {
            let (p, along) = point(i);
            (x[i], y[i], z[i], a[i]) = (p.x, p.y, p.z, along);
        }
    }
    project(&mut run, n, camera, params);
    // A closed polyline with a bad point is cut open just after its last bad point.
    let mut wrap = closed;
    if closed && let Some(bad) = (0..n).rposition(|i| !run.valid(i)) {
        for v in run.point_arrays() {
            v[..n].rotate_left(bad + 1);
        }
        wrap = false;
    }
    // Emit each stretch of valid points, merging near-duplicates in place.
    let mut i = 0;
    while i < n {
        if !run.valid(i) {
            i += 1;
            continue;
        }
        let start = i;
        while i < n && run.valid(i) {
            i += 1;
        }
        let kept = merge_duplicates(&mut run, start, i);
        let len = kept - start;
        // Only a closed polyline without bad points (one stretch) wraps; its end may repeat its
        // start.
        let len = if wrap
            && len > 2
            && run.screen_distance_squared(start, kept - 1) < MIN_SEGMENT_PX * MIN_SEGMENT_PX
        {
            len - 1
        } else {
            len
        };
        emit_run(&mut run, start, len, wrap, camera, params, out);
    }
    out.run = run;
}

/// Drops the points of `start..end` closer than [`MIN_SEGMENT_PX`] on screen to the point kept
/// before them, moving the rest down; returns the new end.
fn merge_duplicates(run: &mut Run, start: usize, end: usize) -> usize {
    let close = |run: &Run, i: usize, j: usize| {
        run.screen_distance_squared(i, j) < MIN_SEGMENT_PX * MIN_SEGMENT_PX
    };
    // Usually there are none: then nothing moves (tested without an early exit, which
    // vectorises).
    let any = (start + 1..end).fold(false, |any, i| any | close(run, i, i - 1));
    if !any {
        return end;
    }
    let Some(first) = (start + 1..end).find(|&i| close(run, i, i - 1)) else {
        return end;
    };
    let mut kept = first;
    for i in first + 1..end {
        if !close(run, i, kept - 1) {
            for v in run.point_arrays() {
                v[kept] = v[i];
            }
            kept += 1;
        }
    }
    kept
}

/// Moves the run's points toward the viewer by the depth bias, projects them, and turns their
/// position along the strand into alpha.
fn project(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        unsafe { project_avx2(run, n, camera, params) };
        return;
    }
    project_portable(run, n, camera, params);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn project_avx2(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    project_portable(run, n, camera, params);
}

/// The projection pass: straight-line arithmetic per point, so that it vectorises.
#[inline(always)]
fn project_portable(run: &mut Run, n: usize, camera: &StrokeCamera, params: &StrokeParams) {
    let bias = if params.depth_bias.is_finite() {
        params.depth_bias
    } else {
        0.0
    };
    // Pull toward an eye point (`eye_weight = 1`) or along a direction (`0`).
    let (eye, eye_weight, direction) = match camera.viewer {
        _ if bias == 0.0 => (Vec3::ZERO, 0.0, Vec3::ZERO),
        Some(Viewer::Point(eye)) => (eye, 1.0, Vec3::ZERO),
        Some(Viewer::Direction(d)) => (Vec3::ZERO, 0.0, d.normalize_or_zero() * bias),
        None => (Vec3::ZERO, 0.0, Vec3::ZERO),
    };
    let m = camera.view_proj;
    let (hx, hy) = (camera.half_viewport.x, camera.half_viewport.y);
    let fade = params.fade;
    let Run {
        x,
        y,
        z,
        sx,
        sy,
        w,
        alpha,
        ..
    } = run;
    let (x, y, z) = (&mut x[..n], &mut y[..n], &mut z[..n]);
    let (sx, sy, w, alpha) = (&mut sx[..n], &mut sy[..n], &mut w[..n], &mut alpha[..n]);
    for i in 0..n {
        let (mut px, mut py, mut pz) = (x[i], y[i], z[i]);
        // Toward the eye: (eye - p) / |eye - p| * bias (nothing at the eye itself).
        let (tx, ty, tz) = (eye.x - px, eye.y - py, eye.z - pz);
        let d2 = tx * tx + ty * ty + tz * tz;
        let k = if d2 > 0.0 {
            eye_weight * bias / d2.sqrt()
        } else {
            0.0
        };
        px += tx * k + direction.x;
        py += ty * k + direction.y;
        pz += tz * k + direction.z;
        let cx = m.x_axis.x * px + m.y_axis.x * py + m.z_axis.x * pz + m.w_axis.x;
        let cy = m.x_axis.y * px + m.y_axis.y * py + m.z_axis.y * pz + m.w_axis.y;
        let cz = m.x_axis.z * px + m.y_axis.z * py + m.z_axis.z * pz + m.w_axis.z;
        let cw = m.x_axis.w * px + m.y_axis.w * py + m.z_axis.w * pz + m.w_axis.w;
        // Non-finite points give non-finite clip coordinates.
        let finite = cx.is_finite() & cy.is_finite() & cz.is_finite() & cw.is_finite();
        let valid = finite & (cw > MIN_CLIP_W);
        (x[i], y[i], z[i]) = (px, py, pz);
        let inv_w = cw.recip();
        sx[i] = cx * hx * inv_w;
        sy[i] = cy * hy * inv_w;
        w[i] = if valid { cw } else { f32::NAN };
        alpha[i] = fade.eval_unit(alpha[i]);
    }
}

/// Appends the strip of the `m` valid, distinct points of `run` from `start`.
fn emit_run(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    if m < 2 {
        return;
    }
    let closed = closed && m > 2;
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        unsafe { emit_run_avx2(run, start, m, closed, camera, params, out) };
        return;
    }
    emit_run_portable(run, start, m, closed, camera, params, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn emit_run_avx2(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    emit_run_portable(run, start, m, closed, camera, params, out);
}

/// What every stroke point's offset needs.
#[derive(Clone, Copy)]
struct OffsetParams {
    half_width: f32,
    half_limit: f32,
    angle_scale: f32,
    /// Whether offsets leave the homogeneous `w` alone (the usual cameras): no division.
    affine: bool,
    unproject_x: Vec4,
    unproject_y: Vec4,
}

/// The left and right stroke vertices of a point at world `p` with clip `w` and depth-scaling
/// factor `depth`, between screen directions `incoming` and `outgoing`: offset both ways
/// perpendicular to the miter, unprojected at the point's depth.
#[inline(always)]
fn offset_point(
    o: &OffsetParams,
    incoming: (f32, f32),
    outgoing: (f32, f32),
    p: (f32, f32, f32),
    w: f32,
    depth: f32,
) -> ([f32; 3], [f32; 3]) {
    let (sx, sy) = (incoming.0 + outgoing.0, incoming.1 + outgoing.1);
    let sum_length = (sx * sx + sy * sy).sqrt();
    // cos of the angle between the miter and each segment's normal is |sum| / 2.
    let turned = sum_length > 1e-6;
    let inv = if turned { sum_length.recip() } else { 0.0 };
    let (tx, ty) = if turned {
        (sx * inv, sy * inv)
    } else {
        incoming
    };
    // 1 / cos, with cos = max(|sum| / 2, 1 / MAX_MITER).
    let inv_cos = (2.0 * inv).min(MAX_MITER);
    let miter = if turned {
        1.0 + o.angle_scale * (inv_cos - 1.0)
    } else {
        1.0
    };
    let hw = o.half_width * miter * depth;
    let hw = if hw.is_finite() {
        hw.clamp(0.0, o.half_limit)
    } else {
        0.0
    };
    // The perpendicular (-ty, tx) scaled to the half-width, in pixels, then in world units at
    // clip depth `w` (homogeneous: the `w` offset is zero for the usual cameras, and dividing by
    // exactly one changes nothing).
    let (ox, oy) = (-ty * hw * w, tx * hw * w);
    let (ux, uy) = (o.unproject_x, o.unproject_y);
    let (kx, ky, kz, kw) = (
        ux.x * ox + uy.x * oy,
        ux.y * ox + uy.y * oy,
        ux.z * ox + uy.z * oy,
        ux.w * ox + uy.w * oy,
    );
    let (lw, rw) = if o.affine {
        (1.0, 1.0)
    } else {
        ((1.0 + kw).recip(), (1.0 - kw).recip())
    };
    let left = [(p.0 + kx) * lw, (p.1 + ky) * lw, (p.2 + kz) * lw];
    let right = [(p.0 - kx) * rw, (p.1 - ky) * rw, (p.2 - kz) * rw];
    let finite = left[0].is_finite()
        & left[1].is_finite()
        & left[2].is_finite()
        & right[0].is_finite()
        & right[1].is_finite()
        & right[2].is_finite();
    let pick = |a: f32, b: f32| if finite { a } else { b };
    (
        [pick(left[0], p.0), pick(left[1], p.1), pick(left[2], p.2)],
        [
            pick(right[0], p.0),
            pick(right[1], p.1),
            pick(right[2], p.2),
        ],
    )
}

/// The strip of one run; inlined into each target-feature variant.
#[inline(always)]
fn emit_run_portable(
    run: &mut Run,
    start: usize,
    m: usize,
    closed: bool,
    camera: &StrokeCamera,
    params: &StrokeParams,
    out: &mut StrokeVertices,
) {
    let end = start + m;
    let Run {
        x,
        y,
        z,
        sx,
        sy,
        w,
        alpha,
        dx,
        dy,
        length,
        depth,
        left,
        right,
    } = run;
    let (x, y, z, w, alpha) = (
        &x[start..end],
        &y[start..end],
        &z[start..end],
        &w[start..end],
        &alpha[start..end],
    );
    let (sx, sy) = (&sx[start..end], &sy[start..end]);
    let (dx, dy, length) = (
        &mut dx[start..end],
        &mut dy[start..end],
        &mut length[start..end],
    );
    // Segment directions and lengths; the last point's segment closes the loop (unused when
    // open).
    let segment = |i: usize, j: usize| {
        let (ex, ey) = (sx[j] - sx[i], sy[j] - sy[i]);
        let l = (ex * ex + ey * ey).sqrt();
        let inv = l.recip();
        if l > 0.0 {
            (ex * inv, ey * inv, l)
        } else {
            (1.0, 0.0, l)
        }
    };
    for i in 0..m - 1 {
        (dx[i], dy[i], length[i]) = segment(i, i + 1);
    }
    (dx[m - 1], dy[m - 1], length[m - 1]) = segment(m - 1, 0);
    let (dx, dy) = (&*dx, &*dy);
    let depth = &mut depth[start..end];
    if params.depth_scale == 0.0 {
        depth.fill(1.0);
    } else {
        for (d, &w) in depth.iter_mut().zip(w) {
            *d = w.recip().powf(params.depth_scale);
        }
    }
    let depth = &*depth;
    let o = OffsetParams {
        half_width: 0.5 * params.width_px * params.stroke_scale,
        half_limit: (0.5 * params.stroke_limit_px).max(0.0),
        angle_scale: params.angle_scale,
        affine: camera.unproject_x.w == 0.0 && camera.unproject_y.w == 0.0,
        unproject_x: camera.unproject_x,
        unproject_y: camera.unproject_y,
    };
    let [lx, ly, lz] = left;
    let [rx, ry, rz] = right;
    let (lx, ly, lz) = (
        &mut lx[start..end],
        &mut ly[start..end],
        &mut lz[start..end],
    );
    let (rx, ry, rz) = (
        &mut rx[start..end],
        &mut ry[start..end],
        &mut rz[start..end],
    );
    let dir = |i: usize| (dx[i], dy[i]);
    let at = |i: usize| (x[i], y[i], z[i]);
    // Open ends use their one segment twice: a plain perpendicular, no miter.
    let last = m - 1;
    let first_in = if closed { dir(last) } else { dir(0) };
    let last_out = if closed { dir(last) } else { dir(last - 1) };
    let ends = [
        offset_point(&o, first_in, dir(0), at(0), w[0], depth[0]),
        offset_point(&o, dir(last - 1), last_out, at(last), w[last], depth[last]),
    ];
    // The inner points: one straight loop over equally long slices, which vectorises.
    let k = last - 1;
    let (ix, iy, ox, oy) = (&dx[..k], &dy[..k], &dx[1..=k], &dy[1..=k]);
    let (px, py, pz) = (&x[1..=k], &y[1..=k], &z[1..=k]);
    let (pw, pd) = (&w[1..=k], &depth[1..=k]);
    {
        let (lx, ly, lz) = (&mut lx[1..=k], &mut ly[1..=k], &mut lz[1..=k]);
        let (rx, ry, rz) = (&mut rx[1..=k], &mut ry[1..=k], &mut rz[1..=k]);
        for j in 0..k {
            let (l, r) = offset_point(
                &o,
                (ix[j], iy[j]),
                (ox[j], oy[j]),
                (px[j], py[j], pz[j]),
                pw[j],
                pd[j],
            );
            [lx[j], ly[j], lz[j]] = l;
            [rx[j], ry[j], rz[j]] = r;
        }
    }
    for (i, (l, r)) in [(0, ends[0]), (last, ends[1])] {
        [lx[i], ly[i], lz[i]] = l;
        [rx[i], ry[i], rz[i]] = r;
    }
    // Sized first, then written by index: no capacity check per element.
    let base = out.positions.len();
    let pairs = m + usize::from(closed);
    let vertices = base..base + 2 * pairs;
    out.positions.resize(vertices.end, [0.0; 3]);
    out.colors.resize(vertices.end, [0.0; 4]);
    out.uvs.resize(vertices.end, [0.0; 2]);
    let positions = &mut out.positions[vertices.clone()];
    let colors = &mut out.colors[vertices.clone()];
    let [red, green, blue, opacity] = params.color;
    let uvs = &mut out.uvs[vertices];
    let (lx, ly, lz, rx, ry, rz) = (&lx[..m], &ly[..m], &lz[..m], &rx[..m], &ry[..m], &rz[..m]);
    let alpha = &alpha[..m];
    for (i, (pair, colour)) in positions
        .chunks_exact_mut(2)
        .zip(colors.chunks_exact_mut(2))
        .enumerate()
        .take(m)
    {
        pair.copy_from_slice(&[[lx[i], ly[i], lz[i]], [rx[i], ry[i], rz[i]]]);
        let c = [red, green, blue, opacity * alpha[i]];
        colour.copy_from_slice(&[c, c]);
    }
    let inv_texture = if params.texture_length_px > 0.0 {
        params.texture_length_px.recip()
    } else {
        0.0
    };
    let mut arc = 0.0;
    for (pair, &l) in uvs.chunks_exact_mut(2).zip(&length[..m]) {
        let u = arc * inv_texture;
        pair.copy_from_slice(&[[u, 0.0], [u, 1.0]]);
        arc += l;
    }
    if closed {
        let u = arc * inv_texture;
        positions.copy_within(0..2, 2 * m);
        colors.copy_within(0..2, 2 * m);
        uvs[2 * m..].copy_from_slice(&[[u, 0.0], [u, 1.0]]);
    }
    let base = base as u32;
    let first_index = out.indices.len();
    out.indices.resize(first_index + 6 * (pairs - 1), 0);
    for (i, quad) in (0..).zip(out.indices[first_index..].chunks_exact_mut(6)) {
        let l0 = base + 2 * i;
        let (r0, l1, r1) = (l0 + 1, l0 + 2, l0 + 3);
        quad.copy_from_slice(&[r0, r1, l1, r0, l1, l0]);
    }
}
