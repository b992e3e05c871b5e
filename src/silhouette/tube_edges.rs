//! Silhouette edges of strand tubes from per-ring facing bit masks.
//!
//! [`silhouette_edges`](super::adjacency::silhouette_edges) works on any closed mesh: it tests every
//! triangle through the index list, then walks the whole edge table. A strand tube (the layout of
//! [`TubeTopology`]) is a grid, so [`TubeEdges`] does the same job with its structure:
//!
//! 1. the ring vertices are transposed into coordinate rows with the seam column repeated, so
//!    that the two wall triangles of every quad are tested by one straight, vectorised loop with
//!    no index lookups;
//! 2. the results become two bit masks per ring band (first and second triangle of each quad) and
//!    one per cap;
//! 3. each class of edge (diagonals, long edges, ring edges, cap spokes) is the exclusive or of
//!    the masks of its two triangles, and only the set bits are visited.
//!
//! The facing test is the same arithmetic, in the same order, as the general path, so both give
//! the same edges, oriented the same way (tested on random tubes and viewers).
#![cfg_attr(
    target_arch = "x86_64",
    expect(
        unsafe_code,
        reason = "AVX2 kernels, chosen after runtime feature detection"
    )
)]

use bevy::math::Vec3A;

use super::adjacency::Viewer;
use crate::mesh::tube::TubeTopology;

/// The silhouette-edge finder of one [`TubeTopology`]; cheap to build (it only keeps the sizes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TubeEdges {
    rings: usize,
    sides: usize,
}

/// Reusable buffers of [`TubeEdges::silhouette_edges`]; keep one per thread.
#[derive(Clone, Debug, Default)]
pub struct TubeEdgeScratch {
    /// Ring vertex coordinates, `rings` rows of `sides + 1` (seam repeated), plus one padding.
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    /// Facing values of each quad's first and second triangle, laid out like the rows.
    first: Vec<f32>,
    second: Vec<f32>,
    /// Facing values of the root cap's triangles, then the tip cap's.
    caps: Vec<f32>,
    /// Per band: facing bits of the first and second triangles.
    masks: Vec<[u64; 2]>,
}

impl TubeEdges {
    /// The finder for tubes with `topology`'s layout.
    pub fn new(topology: &TubeTopology) -> Self {
        Self {
            rings: topology.rings(),
            sides: topology.sides(),
        }
    }

    /// The number of vertices a strand's tube has.
    pub fn vertex_count(&self) -> usize {
        self.rings * self.sides + 2
    }

    /// Writes the silhouette edges of one strand's tube (`positions`, laid out as
    /// [`TubeTopology`] says) seen by `viewer` into `out` (cleared first). The edges and their
    /// orientation are those of [`silhouette_edges`](super::adjacency::silhouette_edges) on
    /// [`TubeTopology::indices`]; only their order differs.
    ///
    /// # Panics
    ///
    /// If `positions` is shorter than [`TubeEdges::vertex_count`].
    pub fn silhouette_edges(
        &self,
        positions: &[[f32; 3]],
        viewer: impl Into<Viewer>,
        scratch: &mut TubeEdgeScratch,
        out: &mut Vec<[u32; 2]>,
    ) {
        let (rings, sides) = (self.rings, self.sides);
        assert!(
            positions.len() >= self.vertex_count(),
            "{} positions for a tube of {} vertices",
            positions.len(),
            self.vertex_count()
        );
        let viewer = viewer.into();
        let row = sides + 1;
        let root = (rings * sides) as u32;
        let tip = root + 1;
        let TubeEdgeScratch {
            x,
            y,
            z,
            first,
            second,
            caps,
            masks,
        } = scratch;
        // Sized once; every entry is overwritten below.
        let len = rings * row + 1;
        for c in [&mut *x, &mut *y, &mut *z] {
            c.resize(len, 0.0);
        }
        let n = (rings - 1) * row;
        first.resize(n, 0.0);
        second.resize(n, 0.0);
        caps.resize(2 * sides, 0.0);
        let centres = [root, tip].map(|v| positions[v as usize]);
        facing_values(
            &positions[..rings * sides],
            centres,
            sides,
            viewer,
            [x, y, z],
            [first, second, caps],
        );

        let full = if sides == 64 {
            u64::MAX
        } else {
            (1u64 << sides) - 1
        };
        masks.clear();
        masks.extend((0..rings - 1).map(|r| {
            let band = r * row..r * row + sides;
            [bits(&first[band.clone()]), bits(&second[band])]
        }));
        // `side` is at most `sides` here: wrap without a division.
        let at =
            |ring: usize, side: usize| (ring * sides + if side == sides { 0 } else { side }) as u32;
        let (root_cap, tip_cap) = (bits(&caps[..sides]), bits(&caps[sides..]));
        // Bit k of `rotate_down(m)` is bit k + 1 of `m`; of `rotate_up(m)`, bit k - 1 (cyclic).
        let rotate_down = |m: u64| (m >> 1) | ((m & 1) << (sides - 1));
        let rotate_up = |m: u64| ((m << 1) & full) | (m >> (sides - 1));

        out.clear();
        // Cap spokes: root fan triangle k runs (0, k) -> root, triangle k - 1 the other way.
        emit(out, root_cap ^ rotate_up(root_cap), root_cap, |k| {
            (at(0, k), root)
        });
        // Ring 0: quad (0, k)'s first triangle runs (0, k) -> (0, k + 1); root triangle k back.
        emit(out, masks[0][0] ^ root_cap, masks[0][0], |k| {
            (at(0, k), at(0, k + 1))
        });
        for (r, &[a, b]) in masks.iter().enumerate() {
            // Diagonal (r, k) - (r + 1, k + 1): the first triangle runs it downward.
            emit(out, a ^ b, a, |k| (at(r + 1, k + 1), at(r, k)));
            // Long edge (r, k + 1) - (r + 1, k + 1): the first triangle of quad k runs it upward,
            // the second triangle of quad k + 1 downward.
            emit(out, a ^ rotate_down(b), a, |k| {
                (at(r, k + 1), at(r + 1, k + 1))
            });
            // Ring r + 1 between this band's second triangles and the next band's first ones
            // (or the tip cap): the second triangle runs (r + 1, k + 1) -> (r + 1, k).
            let next = masks.get(r + 1).map_or(tip_cap, |m| m[0]);
            emit(out, b ^ next, b, |k| (at(r + 1, k + 1), at(r + 1, k)));
        }
        // Tip spokes: tip fan triangle k runs tip -> (rings - 1, k), triangle k - 1 back.
        emit(out, tip_cap ^ rotate_up(tip_cap), tip_cap, |k| {
            (tip, at(rings - 1, k))
        });
    }
}

/// Appends edge `[p, q]` for each set bit `k` of `edges`, where `(p, q) = ends(k)`, when bit `k`
/// of `front` is set (the edge's first triangle, which runs `p -> q`, faces the viewer), and
/// `[q, p]` otherwise.
#[inline(always)]
fn emit(out: &mut Vec<[u32; 2]>, edges: u64, front: u64, ends: impl Fn(usize) -> (u32, u32)) {
    let mut m = edges;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        let (p, q) = ends(k);
        out.push(if front >> k & 1 == 1 { [p, q] } else { [q, p] });
    }
}

/// Bit `k` set where `values[k] > 0` (at most 64 values).
#[inline(always)]
fn bits(values: &[f32]) -> u64 {
    let mut mask = 0u64;
    let mut blocks = values.chunks_exact(4);
    let mut shift = 0;
    for block in &mut blocks {
        #[cfg(target_arch = "x86_64")]
        let nibble = {
            use std::arch::x86_64::{_mm_cmpgt_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_setzero_ps};
            // SAFETY: SSE is part of x86_64; the block holds four floats.
            unsafe {
                _mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(block.as_ptr()), _mm_setzero_ps())) as u64
            }
        };
        #[cfg(not(target_arch = "x86_64"))]
        let nibble = (0..4).fold(0u64, |m, j| m | (u64::from(block[j] > 0.0) << j));
        mask |= nibble << shift;
        shift += 4;
    }
    for (j, &d) in blocks.remainder().iter().enumerate() {
        mask |= u64::from(d > 0.0) << (shift + j);
    }
    mask
}

/// The arithmetic of [`Viewer::faces`] on triangle `(a, b, c)`, with the viewer given as
/// `(point, v)`: an eye point `v` when `point`, else a direction `v`. Positive: front-facing.
#[inline(always)]
fn facing(
    (ax, ay, az): (f32, f32, f32),
    (bx, by, bz): (f32, f32, f32),
    (cx, cy, cz): (f32, f32, f32),
    point: bool,
    v: Vec3A,
) -> f32 {
    let (ux, uy, uz) = (bx - ax, by - ay, bz - az);
    let (dx, dy, dz) = (cx - ax, cy - ay, cz - az);
    let (vx, vy, vz) = if point {
        (v.x - ax, v.y - ay, v.z - az)
    } else {
        (v.x, v.y, v.z)
    };
    let (nx, ny, nz) = (uy * dz - uz * dy, uz * dx - ux * dz, ux * dy - uy * dx);
    (nx * vx + ny * vy) + nz * vz
}

/// Transposes the ring vertices (`sides` per ring) into coordinate rows of `sides + 1` (the seam
/// vertex repeated), then computes the facing values (positive: front-facing) of the two wall
/// triangles of every quad (`first[i]`, `second[i]` for the quad whose first vertex is row entry
/// `i`) and of the root and tip cap triangles (`caps`, around the cap `centres`).
fn facing_values(
    ring_vertices: &[[f32; 3]],
    centres: [[f32; 3]; 2],
    sides: usize,
    viewer: Viewer,
    rows: [&mut Vec<f32>; 3],
    values: [&mut Vec<f32>; 3],
) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        unsafe { facing_values_avx2(ring_vertices, centres, sides, viewer, rows, values) };
        return;
    }
    facing_values_body(ring_vertices, centres, sides, viewer, rows, values, false);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn facing_values_avx2(
    ring_vertices: &[[f32; 3]],
    centres: [[f32; 3]; 2],
    sides: usize,
    viewer: Viewer,
    rows: [&mut Vec<f32>; 3],
    values: [&mut Vec<f32>; 3],
) {
    let [x, y, z] = rows;
    // SAFETY: AVX2 is enabled in this function.
    unsafe { transpose_rings_avx2(ring_vertices, sides, [&mut *x, &mut *y, &mut *z]) };
    facing_values_body(
        ring_vertices,
        centres,
        sides,
        viewer,
        [x, y, z],
        values,
        true,
    );
}

/// The ring transposition of [`facing_values_body`], eight vertices at a time with AVX2
/// shuffles (the rest one by one); [`facing_values_body`] then finds it done.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn transpose_rings_avx2(
    ring_vertices: &[[f32; 3]],
    sides: usize,
    [x, y, z]: [&mut Vec<f32>; 3],
) {
    use std::arch::x86_64::{
        _mm_loadu_ps, _mm256_castps128_ps256, _mm256_insertf128_ps, _mm256_shuffle_ps,
        _mm256_storeu_ps,
    };
    let row = sides + 1;
    for (r, ring) in ring_vertices.chunks_exact(sides).enumerate() {
        let (xr, yr, zr) = (
            &mut x[r * row..(r + 1) * row],
            &mut y[r * row..(r + 1) * row],
            &mut z[r * row..(r + 1) * row],
        );
        let mut k = 0;
        while k + 8 <= sides {
            let block = ring[k..k + 8].as_flattened();
            let p = block.as_ptr();
            // SAFETY: `block` holds 24 floats; each row holds at least `k + 8` entries.
            unsafe {
                let load = |i: usize| _mm_loadu_ps(p.add(i));
                let m03 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(load(0)), load(12));
                let m14 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(load(4)), load(16));
                let m25 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(load(8)), load(20));
                // Per 128-bit lane (vertices 0-3, then 4-7): x2 y2 x3 y3 and y0 z0 y1 z1.
                let xy = _mm256_shuffle_ps::<0b10_01_11_10>(m14, m25);
                let yz = _mm256_shuffle_ps::<0b01_00_10_01>(m03, m14);
                _mm256_storeu_ps(
                    xr.as_mut_ptr().add(k),
                    _mm256_shuffle_ps::<0b10_00_11_00>(m03, xy),
                );
                _mm256_storeu_ps(
                    yr.as_mut_ptr().add(k),
                    _mm256_shuffle_ps::<0b11_01_10_00>(yz, xy),
                );
                _mm256_storeu_ps(
                    zr.as_mut_ptr().add(k),
                    _mm256_shuffle_ps::<0b11_00_11_01>(yz, m25),
                );
            }
            k += 8;
        }
        for k in k..sides {
            [xr[k], yr[k], zr[k]] = ring[k];
        }
        [xr[sides], yr[sides], zr[sides]] = ring[0];
    }
}

/// The shared body; inlined so that each caller vectorises it for its own target features.
#[inline(always)]
fn facing_values_body(
    ring_vertices: &[[f32; 3]],
    centres: [[f32; 3]; 2],
    sides: usize,
    viewer: Viewer,
    [x, y, z]: [&mut Vec<f32>; 3],
    [first, second, caps]: [&mut Vec<f32>; 3],
    transposed: bool,
) {
    let row = sides + 1;
    let rings = ring_vertices.len() / sides;
    for r in (0..rings).filter(|_| !transposed) {
        let ring = &ring_vertices[r * sides..(r + 1) * sides];
        let (xr, yr, zr) = (
            &mut x[r * row..(r + 1) * row],
            &mut y[r * row..(r + 1) * row],
            &mut z[r * row..(r + 1) * row],
        );
        for k in 0..sides {
            [xr[k], yr[k], zr[k]] = ring[k];
        }
        [xr[sides], yr[sides], zr[sides]] = ring[0];
    }
    let (point, v) = match viewer {
        Viewer::Point(e) => (true, Vec3A::from(e)),
        Viewer::Direction(d) => (false, Vec3A::from(d)),
    };
    let n = first.len().min(second.len());
    // Quad i: a0 = i, a1 = i + 1, b0 = i + row, b1 = i + row + 1. Equal-length slices let the
    // compiler drop the bounds checks and vectorise.
    fn c(v: &[f32], start: usize, n: usize) -> &[f32] {
        &v[start..start + n]
    }
    let (xa0, xa1, xb0, xb1) = (c(x, 0, n), c(x, 1, n), c(x, row, n), c(x, row + 1, n));
    let (ya0, ya1, yb0, yb1) = (c(y, 0, n), c(y, 1, n), c(y, row, n), c(y, row + 1, n));
    let (za0, za1, zb0, zb1) = (c(z, 0, n), c(z, 1, n), c(z, row, n), c(z, row + 1, n));
    let (first, second) = (&mut first[..n], &mut second[..n]);
    for i in 0..n {
        let a0 = (xa0[i], ya0[i], za0[i]);
        let a1 = (xa1[i], ya1[i], za1[i]);
        let b0 = (xb0[i], yb0[i], zb0[i]);
        let b1 = (xb1[i], yb1[i], zb1[i]);
        // The triangles (a0, a1, b1) and (a0, b1, b0) of `TubeTopology::indices`.
        first[i] = facing(a0, a1, b1, point, v);
        second[i] = facing(a0, b1, b0, point, v);
    }
    // Cap fans: root triangle k is (root, ring 0 vertex k + 1, vertex k); tip triangle k is
    // (tip, last ring vertex k, vertex k + 1).
    let (root_caps, tip_caps) = caps.split_at_mut(sides);
    let last = (rings - 1) * row;
    let [root, tip] = centres.map(|[x, y, z]| (x, y, z));
    for k in 0..sides {
        let ring0 = |k: usize| (x[k], y[k], z[k]);
        let ring1 = |k: usize| (x[last + k], y[last + k], z[last + k]);
        root_caps[k] = facing(root, ring0(k + 1), ring0(k), point, v);
        tip_caps[k] = facing(tip, ring1(k), ring1(k + 1), point, v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::silhouette::adjacency::{EdgeAdjacency, SilhouetteScratch, silhouette_edges};
    use crate::test_support::Rng;
    use bevy::math::Vec3;

    #[test]
    fn tube_edges_equal_the_general_path() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut general = Vec::new();
        let mut fast = Vec::new();
        let mut scratch = SilhouetteScratch::default();
        let mut tube_scratch = TubeEdgeScratch::default();
        let mut compared = 0;
        for (rings, sides) in [(2, 3), (3, 4), (16, 8), (4, 17), (7, 63), (5, 64), (40, 5)] {
            let topology = TubeTopology::new(rings, sides);
            let adjacency = EdgeAdjacency::from_triangles(&topology.indices).unwrap();
            let tube = TubeEdges::new(&topology);
            for trial in 0..40 {
                // Random bumpy tubes (self-intersecting ones too) and random viewers, including
                // degenerate rings (every vertex of a ring in one point).
                let centre = rng.vec3(0.3);
                let mut positions: Vec<[f32; 3]> = (0..topology.vertex_count())
                    .map(|_| (centre + rng.vec3(0.05)).to_array())
                    .collect();
                if trial % 7 == 3 {
                    let p = positions[0];
                    positions[..sides].fill(p);
                }
                let viewer = if trial % 2 == 0 {
                    Viewer::Point(rng.vec3(2.0))
                } else {
                    Viewer::Direction(rng.vec3(1.0))
                };
                silhouette_edges(
                    &adjacency,
                    &topology.indices,
                    &positions,
                    viewer,
                    &mut scratch,
                    &mut general,
                );
                tube.silhouette_edges(&positions, viewer, &mut tube_scratch, &mut fast);
                general.sort_unstable();
                fast.sort_unstable();
                assert_eq!(general, fast, "{rings}x{sides} trial {trial}");
                compared += general.len();
            }
        }
        assert!(compared > 10_000, "only {compared} edges compared");
    }

    #[test]
    fn portable_and_dispatched_facing_agree() {
        let mut rng = Rng(7);
        for sides in [3, 8, 12, 17] {
            let rings = 5;
            let ring_vertices: Vec<[f32; 3]> = (0..rings * sides)
                .map(|_| rng.vec3(1.0).to_array())
                .collect();
            let centres = [rng.vec3(1.0).to_array(), rng.vec3(1.0).to_array()];
            let viewer = Viewer::Point(rng.vec3(3.0));
            let run = |portable: bool| {
                let len = rings * (sides + 1) + 1;
                let mut rows = [vec![0.0; len], vec![0.0; len], vec![0.0; len]];
                let n = (rings - 1) * (sides + 1);
                let mut values = [vec![0.0; n], vec![0.0; n], vec![0.0; 2 * sides]];
                let [x, y, z] = &mut rows;
                let [a, b, c] = &mut values;
                if portable {
                    facing_values_body(
                        &ring_vertices,
                        centres,
                        sides,
                        viewer,
                        [x, y, z],
                        [a, b, c],
                        false,
                    );
                } else {
                    facing_values(&ring_vertices, centres, sides, viewer, [x, y, z], [a, b, c]);
                }
                (rows, values)
            };
            assert_eq!(run(true), run(false), "{sides} sides");
        }
    }

    #[test]
    #[should_panic(expected = "positions for a tube")]
    fn short_positions_are_refused() {
        let tube = TubeEdges::new(&TubeTopology::new(4, 4));
        tube.silhouette_edges(
            &[[0.0; 3]; 10],
            Vec3::ZERO,
            &mut TubeEdgeScratch::default(),
            &mut Vec::new(),
        );
    }
}
