//! Hair–hair volume: strands of one hair keep apart instead of passing through each other.
//!
//! Once a frame, after the last substep (like the strain and style limits), each pair of free
//! particles of different strands closer than `2 r` is pushed apart along the line between
//! them by [`HairVolume::stiffness`] times half the overlap each. The push moves the previous
//! position too, so it adds no velocity: strands settle side by side instead of bouncing. Only
//! particles move; their structural neighbours follow through the springs in the next frame.
//!
//! **Pushes are averaged** (Jacobi with constraint averaging and over-relaxation, as in Macklin
//! et al. 2014, "Unified particle physics for real-time applications"): a particle pushed by `n`
//! pairs moves by the sum of their pushes times `min(1, RELAXATION / n)`. Two strands touching
//! are pushed as much as they overlap; a particle crowded on all sides is not thrown by the sum
//! of dozens of pushes. Summed pushes in hair much denser than its radius (1,000 strands
//! 8 mm apart with 16 mm tubes) moved particles up to 0.3 m a frame and never settled.
//!
//! **Pairs come from a list kept across frames** (a Verlet list, as in molecular dynamics).
//! It holds the pairs closer than `2 r (1 + SKIN)`, found in a dense grid of cells that wide
//! over the particles' bounds (a counting sort; each pair looked at from one side). It is kept
//! while no particle moved more than `r SKIN` from where the bone would have carried it since
//! the list was built: then no pair outside the list can have come closer than `2 r`. Hair at
//! rest on a moving head keeps its list; hair swinging against the head rebuilds it as often as
//! that takes. A build looks at no more than [`MAX_CANDIDATES`] particles around each particle
//! and each particle starts at most [`MAX_PAIRS`] pairs, so a build costs a bounded amount per
//! particle however dense the hair (the grid grows its cells rather than its memory for
//! hair spread far apart).
//!
//! **Crowded hair is spread by its density instead** (a density grid, as in Petrovic et al.
//! 2005, "Volumetric methods for simulation and rendering of hair"). Hair packed far denser
//! than its radius can keep apart (1,000 strands 8 mm apart with 16 mm tubes) has dozens of
//! pairs per particle that can never all be met: pushing them costs 4 times the frame and
//! leaves the hair restless. Where the pair list holds half the pairs its particles may start
//! ([`MAX_PAIRS`]` / 2` a particle), the density is read: each particle is splatted (trilinear weights) into
//! a grid of nodes `2 r` apart as the share of a strand it stands for, so that strands `2 r`
//! apart everywhere read 1 strand per node. A particle is crowded where the density read back
//! there is over [`CROWDING`]. A hair with at least [`CROWDED_FROM`] crowded particles leaves
//! the pair list: each frame every particle where the density is over `CROWDING` moves down
//! its slope by `DIFFUSION * stiffness * h^2 * (rho - CROWDING) / rho^2 * slope` (`h` the
//! node spacing), at most `stiffness * r`, the previous position with it. This spreads
//! crowded hair out until no node holds more than `CROWDING` strands' worth, cell by cell: it
//! does not separate strands inside one cell, which is what the pairs are for. A hair whose
//! crowded particles fall under half `CROWDED_FROM` goes back to the pair list. Hair with
//! fewer crowded particles than that (a few dozen strands meeting at their tips) keeps every
//! particle in the pair list, whose caps bound its cost.
#![expect(
    unsafe_code,
    reason = "the density pass: its AVX2 variant, chosen after runtime feature detection, and \
              a float-to-index conversion that vectorises"
)]

use bevy::math::{Affine3A, DVec3, Vec3A};
use bevy::prelude::*;

use super::solver::{Batch, LANES, Lane, PINNED};

/// Keeps a hair's strands apart ([`HairSimSettings::volume`](super::HairSimSettings::volume)).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct HairVolume {
    /// Share of each overlap removed per frame, 0 (none) to 1 (all at once), where a particle
    /// overlaps one or two others; a particle crowded by more moves by the average of its
    /// pushes times two. Hair far denser than its radius (more than 1,024 particles where over
    /// twice the strands that fit a `2 * radius` apart pass) is spread by its density instead,
    /// at a rate this scales (see the `volume` module docs). Default: `0.5`.
    pub stiffness: f32,
    /// Particles of different strands closer than twice this (metres, at the character's
    /// built size) are pushed apart. `None`: the hair's [`HairStrandRadius`] (the drawn tube's
    /// radius, which the mesh stage hands over), or [`DEFAULT_STRAND_RADIUS`] without one.
    /// Default: `None`.
    pub radius: Option<f32>,
}

/// The radius of a hair's strands as drawn, metres at the built size, for the volume
/// ([`HairVolume::radius`] `None`). The mesh stage sets it on the hair entity from
/// `HairMeshSettings::radius`; a game without it may set it itself.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug, PartialEq)]
pub struct HairStrandRadius(pub f32);

/// The strand radius without a [`HairStrandRadius`] (and `HairMeshSettings`' default).
pub const DEFAULT_STRAND_RADIUS: f32 = 0.016;

impl Default for HairVolume {
    fn default() -> Self {
        Self {
            stiffness: 0.5,
            radius: None,
        }
    }
}

/// Reused buffers of [`keep_apart`] and its pair list; one per hair.
#[derive(Clone, Debug, Default)]
pub struct VolumeScratch {
    /// Positions of the free particles, their strands (batch * LANES + lane), and where each
    /// lives (batch, lane, node).
    pos: Vec<Vec3A>,
    owner: Vec<u32>,
    slot: Vec<(u32, u8, u16)>,
    /// The batches' layout `slot` and `owner` were made for: lanes and nodes per batch.
    layout: Vec<(usize, usize)>,
    /// The pair list: every pair of particles of different strands that was closer than
    /// `reach + skin` when it was built, as indices into `members`: the particles (indices
    /// into `pos`) in any pair. `local` maps `pos` indices to `members` ones during a build.
    pairs: Vec<(u32, u32)>,
    members: Vec<u32>,
    local: Vec<u32>,
    /// The list's build: particle positions, the inverse bone pose, and the reach.
    built: Vec<Vec3A>,
    built_from: Affine3A,
    built_reach: f32,
    /// Frames the list has been used since it was built (for tests).
    pub(crate) reused: u32,
    /// Grid scratch of a build: each particle's cell; where each cell's particles start in
    /// the sorted arrays (`cells + 1`); the particles sorted by cell (position, cell, index).
    cell: Vec<u32>,
    cell_xyz: Vec<[u32; 3]>,
    start: Vec<u32>,
    sorted: Vec<Vec3A>,
    sorted_cell: Vec<[u32; 3]>,
    sorted_from: Vec<u32>,
    /// Summed push per member of a pair.
    delta: Vec<Vec3A>,
    /// Pairs pushing each member.
    count: Vec<u32>,
    /// Mean distance between neighbouring particles of a strand, measured when the layout
    /// changed (for the crowding measure).
    spacing: f32,
    /// Whether the hair is spread by its density instead of pairs (see the module docs), and
    /// how many particles were over [`CROWDING`] when the density was last read.
    pub(crate) dense: bool,
    pub(crate) crowded_count: u32,
    /// The density grids (strands per node, see [`spread`]), and each cell's 8 nodes.
    density: Vec<f32>,
    cells: Vec<[f32; 8]>,
    /// Particles the density spread last frame.
    pub(crate) spread: u32,
    /// The free particles' bounds, measured by the solver's pass this frame while its batches
    /// were in cache (see [`VolumeScratch::measure`]).
    measured: Option<Bounds>,
}

/// The smallest and largest finite free particle positions, and how many there are.
pub(crate) type Bounds = (Vec3A, Vec3A, usize);

/// [`Bounds`] of nothing.
pub(crate) const NO_BOUNDS: Bounds = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, 0);

impl VolumeScratch {
    /// Whether the solver's pass should measure the free particles' bounds for
    /// [`VolumeScratch::measure`]: the hair is spread by its density, which needs them.
    pub(crate) fn wants_bounds(&self) -> bool {
        self.dense
    }

    /// The free particles' bounds after this frame's steps ([`bounds_of`] the batches), for
    /// the next [`keep_apart`]: a pass over the hair less.
    pub(crate) fn measure(&mut self, bounds: Bounds) {
        self.measured = Some(bounds);
    }
}

/// The most pairs a particle starts in the pair list (see the module docs).
pub const MAX_PAIRS: usize = 16;

/// Over-relaxation of the averaged pushes: a particle pushed by `n` pairs moves by their sum
/// times `min(1, RELAXATION / n)` (see the module docs).
pub const RELAXATION: f32 = 2.0;

/// The most other particles a particle looks at when the pair list is built, near or not (see
/// the module docs): the bound on a build's cost, `O(particles * MAX_CANDIDATES)`. Each pair is
/// looked at from one side only, so this covers about twice as many neighbours.
pub const MAX_CANDIDATES: usize = 64;

/// The pair list holds pairs up to `reach * (1 + SKIN)` apart, and stays valid while no particle
/// moved more than half that margin relative to the bone.
pub const SKIN: f32 = 0.5;

/// A particle is crowded where the density there is over this many strands per node: more
/// than this many times as many strands as fit a reach apart (see the module docs).
pub const CROWDING: f32 = 2.0;

/// How far the density moves a crowded particle a frame: at most `DIFFUSION * stiffness` node
/// spacings times the density's slope over a node spacing, relative to the density (see the
/// module docs).
pub const DIFFUSION: f32 = 0.5;

/// Density grids each thread splats a hair's particles into, in turn (see [`spread`]).
const SPLATS: usize = 4;

/// Hair with at least this many particles per thread spreads them in parallel.
const PARALLEL_FROM: usize = 2048;

/// A hair with at least this many crowded particles is spread by its density instead of the
/// pair list; with fewer than half as many it goes back (see the module docs).
pub const CROWDED_FROM: usize = 1024;

/// The grid has at most this many cells per particle (plus a few); where the hair's bounds
/// would need more, its cells grow (they hold more particles, which only costs candidates).
const CELLS_PER_PARTICLE: usize = 4;

/// Pushes apart the particles of different strands in `batches` closer than `2 * radius`, or
/// spreads crowded hair by its density (see the module docs). `bone` is the hair's bone pose
/// now: the pair list is kept while the hair only moved with it. Returns the number of pairs
/// pushed (0 while the hair is spread by density: [`HairStepStats::volume_spread`](super::HairStepStats::volume_spread)
/// counts those moves).
pub fn keep_apart(
    batches: &mut [Batch],
    radius: f32,
    stiffness: f32,
    bone: &Affine3A,
    scratch: &mut VolumeScratch,
) -> usize {
    // This frame's measure, if any, is used now or never.
    let measured = scratch.measured.take();
    let stiffness = if stiffness.is_finite() {
        stiffness.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if !(radius.is_finite() && radius > 0.0) || stiffness == 0.0 {
        return 0;
    }
    let reach = 2.0 * radius;
    let s = scratch;
    s.spread = 0;
    gather(batches, s);
    if s.slot.len() < 2 {
        return 0;
    }
    if s.dense {
        s.spread = spread(batches, s, reach, stiffness, measured);
        // Back to pairs where the hair thinned out (the list is built next frame).
        if (s.crowded_count as usize) < CROWDED_FROM / 2 {
            s.dense = false;
            s.built.clear();
        }
        return 0;
    }
    if !list_holds(s, bone, reach) {
        s.pairs.clear();
        s.members.clear();
        if let Some(cells) = sort_cells(s, reach * (1.0 + SKIN)) {
            find_pairs(s, &cells, reach * (1.0 + SKIN));
            // Hair that fills the list (half the most pairs a particle may start, on average)
            // may be crowded: read its density (stiffness 0 moves nothing). With enough
            // crowded particles, the hair is spread by its density from now on.
            if s.pairs.len() >= cells.sorted * MAX_PAIRS / 2 {
                spread(batches, s, reach, 0.0, None);
                if s.crowded_count as usize >= CROWDED_FROM {
                    s.dense = true;
                    s.pairs.clear();
                    s.members.clear();
                    s.spread = spread(batches, s, reach, stiffness, None);
                    return 0;
                }
            }
        }
        s.built.clone_from(&s.pos);
        s.built_from = bone.inverse();
        s.built_reach = reach;
        s.reused = 0;
    } else {
        s.reused += 1;
    }
    let m = s.members.len();
    s.delta.clear();
    s.delta.resize(m, Vec3A::ZERO);
    s.count.clear();
    s.count.resize(m, 0);
    let mut pushed = 0;
    let reach2 = reach * reach;
    for &(i, j) in &s.pairs {
        let (i, j) = (i as usize, j as usize);
        let d = s.pos[s.members[i] as usize] - s.pos[s.members[j] as usize];
        let d2 = d.length_squared();
        // (Not finite: not pushed.)
        if !(d2 < reach2 && d2 > 1e-18) {
            continue;
        }
        let dist = d2.sqrt();
        let push = d * ((reach - dist) * 0.5 * stiffness / dist);
        s.delta[i] += push;
        s.delta[j] -= push;
        s.count[i] += 1;
        s.count[j] += 1;
        pushed += 1;
    }
    for ((&d, &count), &member) in s.delta.iter().zip(&s.count).zip(&s.members) {
        if count == 0 {
            continue;
        }
        // Constraint averaging with over-relaxation (see the module docs).
        let d = d * (RELAXATION / count as f32).min(1.0);
        if !d.is_finite() {
            continue;
        }
        let (b, l, k) = s.slot[member as usize];
        let node = &mut batches[b as usize].nodes[k as usize];
        let l = l as usize;
        for (c, v) in d.to_array().into_iter().enumerate() {
            node.x[c][l] += v;
            node.p[c][l] += v;
        }
    }
    pushed
}

/// The bounds of the finite points and how many there are.
fn bounds(points: impl Iterator<Item = Vec3A>) -> Bounds {
    let (mut min, mut max, mut n) = NO_BOUNDS;
    for p in points.filter(|p| p.is_finite()) {
        min = min.min(p);
        max = max.max(p);
        n += 1;
    }
    (min, max, n)
}

/// [`bounds`] of the free particles of `batches`; lane by lane without branches (which the
/// compiler vectorises), then across the lanes.
pub(crate) fn bounds_of(batches: &[Batch]) -> Bounds {
    let mut lo = [[f32::INFINITY; LANES]; 3];
    let mut hi = [[f32::NEG_INFINITY; LANES]; 3];
    let mut n = [0u32; LANES];
    let (up, down) = (f32::INFINITY.to_bits(), f32::NEG_INFINITY.to_bits());
    for b in batches {
        let live = b.count.min(LANES);
        for k in free_rows(b.nodes.len()) {
            let x = &b.nodes[k].x;
            let keep = placed(x, live);
            for l in 0..LANES {
                n[l] += keep[l] & 1;
            }
            for c in 0..3 {
                for l in 0..LANES {
                    let bits = x[c][l].to_bits() & keep[l];
                    lo[c][l] = lo[c][l].min(f32::from_bits(bits | (up & !keep[l])));
                    hi[c][l] = hi[c][l].max(f32::from_bits(bits | (down & !keep[l])));
                }
            }
        }
    }
    let fold = |v: &[Lane; 3], f: fn(f32, f32) -> f32, start: f32| {
        Vec3A::from_array(v.map(|c| c.into_iter().fold(start, f)))
    };
    (
        fold(&lo, f32::min, f32::INFINITY),
        fold(&hi, f32::max, f32::NEG_INFINITY),
        n.iter().map(|&n| n as usize).sum(),
    )
}

/// Which lanes of a node row count: all bits set for the first `live` lanes with a finite
/// position, else 0 (a mask for branch-free selects, which the compiler vectorises).
#[inline(always)]
pub(super) fn placed(x: &[Lane; 3], live: usize) -> [u32; LANES] {
    let mut keep = [0u32; LANES];
    for (l, keep) in keep.iter_mut().enumerate() {
        // `&`, not `&&`: no branch per lane (NaN is not below infinity either).
        let finite = (x[0][l].abs() < f32::INFINITY)
            & (x[1][l].abs() < f32::INFINITY)
            & (x[2][l].abs() < f32::INFINITY);
        *keep = u32::from(finite & (l < live)).wrapping_neg();
    }
    keep
}

/// Both bounds together.
pub(crate) fn merge_bounds(a: Bounds, b: Bounds) -> Bounds {
    (a.0.min(b.0), a.1.max(b.1), a.2 + b.2)
}

/// A grid over the finite particles' bounds with cells `size` wide, grown until it has at most
/// `CELLS_PER_PARTICLE` cells per particle: its corner, cell size and cells along each axis.
/// `None` without two finite particles.
fn grid_over((min, max, n): Bounds, size: f32, extra: usize) -> Option<(Vec3A, f64, [usize; 3])> {
    if n < 2 {
        return None;
    }
    // In f64: the bounds of hostile positions can be wider than f32 holds.
    let extent = max.as_dvec3() - min.as_dvec3();
    let limit = (CELLS_PER_PARTICLE * n + 64) as f64;
    let dims_for = |size: f64| (extent / size).floor() + 1.0 + extra as f64;
    let fits = |dims: DVec3| dims.x * dims.y * dims.z <= limit;
    let mut size = f64::from(size);
    let mut dims = dims_for(size);
    if !fits(dims) {
        // Grow the cells until the grid fits (each round doubles them; the extent is finite,
        // so this ends).
        size = size.max(extent.max_element() / limit.cbrt());
        dims = dims_for(size);
        while !fits(dims) {
            size *= 2.0;
            dims = dims_for(size);
        }
    }
    Some((
        min,
        size,
        [dims.x as usize, dims.y as usize, dims.z as usize],
    ))
}

/// How the density moves crowded particles: `DIFFUSION * stiffness * h^2` (the step) and the
/// most a particle moves in a frame.
#[derive(Clone, Copy)]
struct Spreading {
    step: f32,
    most: f32,
}

/// A frame's density grid: nodes `h` apart from `low`, `dims` along each axis (`sy` and `sz`
/// apart in memory), with room for a cell past each particle's.
struct Grid {
    low: [f32; 3],
    inv: f32,
    top: [f32; 3],
    strides: [usize; 3],
    corners: [usize; 8],
    span: usize,
    /// Strands per node one particle adds.
    weight: f32,
    /// Particles along a strand splatted: every first, or every second where they are closer
    /// than half a cell (the trilinear weights, two cells wide, then blur them alike).
    stride: usize,
}

impl Grid {
    /// Where each lane of a node row sits: its cell's first node and its place in the cell (0
    /// to 1 along each axis); 1 for a live lane with a finite position, else 0 (such a lane
    /// is placed at the grid's corner). Written as plain lane loops without branches, which
    /// the compiler vectorises.
    #[inline(always)]
    fn locate(&self, x: &[Lane; 3], live: usize) -> ([usize; LANES], [Lane; 3], Lane) {
        // Lanes to place (all bits set) and their weight (1.0), else 0.
        let keep = placed(x, live);
        let mut ok = [0f32; LANES];
        for (ok, &k) in ok.iter_mut().zip(&keep) {
            *ok = f32::from(u8::from(k != 0));
        }
        let mut at = [0i32; LANES];
        let mut f = [[0f32; LANES]; 3];
        for c in 0..3 {
            let low = self.low[c].to_bits();
            for l in 0..LANES {
                // The lane's position, or the grid's corner: a bitwise select, as a select of
                // loads compiles to scalar code.
                let p = f32::from_bits((x[c][l].to_bits() & keep[l]) | (low & !keep[l]));
                let u = ((p - self.low[c]) * self.inv).max(0.0);
                // SAFETY: `u.min(top)` is a number from 0 to `top` (`max` and `min` return the
                // number where the other side is NaN; `top` is a node count less 2), which
                // i32 holds. (Not a saturating `as`, which does not vectorise.)
                let i = unsafe { u.min(self.top[c]).to_int_unchecked::<i32>() };
                f[c][l] = (u - i as f32).min(1.0);
                at[l] += i * self.strides[c] as i32;
            }
        }
        (at.map(|a| a as usize), f, ok)
    }
}

/// Reads the hair's density (see the module docs) at each free particle of `batches`, and
/// moves the particles where it is over [`CROWDING`] down its slope. Each particle is splatted into a grid of nodes `reach` apart (trilinear
/// weights) as strands per node, so that strands a reach apart everywhere read 1; then the
/// grid is read back at the particle. `measured`: the particles' bounds, where the solver's
/// pass measured them. Returns how many particles moved (with stiffness 0
/// it only reads the density); `s.crowded_count` is how many are over [`CROWDING`].
fn spread(
    batches: &mut [Batch],
    s: &mut VolumeScratch,
    reach: f32,
    stiffness: f32,
    measured: Option<Bounds>,
) -> u32 {
    s.crowded_count = 0;
    // (Tests run with debug assertions: every frame there checks the solver's measure.)
    debug_assert!(measured.is_none_or(|m| m == bounds_of(batches)));
    let box_ = measured.unwrap_or_else(|| bounds_of(batches));
    let n = box_.2;
    let Some((min, size, [dx, dy, dz])) = grid_over(box_, reach, 1) else {
        return 0;
    };
    let h = size as f32;
    // Each particle stands for `spacing` of its strand: `spacing / h` strands through a cell
    // `h` wide; per node of a grid coarser than the reach, as a share of the strands that fit.
    let spacing = if s.spacing.is_finite() && s.spacing > 0.0 {
        s.spacing
    } else {
        reach
    };
    let weight = (f64::from(spacing) * f64::from(reach).powi(2) / size.powi(3)) as f32;
    let inv = 1.0 / h;
    if !(weight.is_finite() && weight > 0.0 && inv.is_finite() && inv > 0.0) {
        return 0;
    }
    let nodes = dx * dy * dz;
    let (sy, sz) = (dx, dx * dy);
    let grid = Grid {
        low: min.to_array(),
        inv,
        top: [(dx - 2) as f32, (dy - 2) as f32, (dz - 2) as f32],
        strides: [1, sy, sz],
        corners: [0, 1, sy, sy + 1, sz, sz + 1, sz + sy, sz + sy + 1],
        span: sz + sy + 2,
        weight,
        stride: if 2.0 * spacing < h { 2 } else { 1 },
    };
    let how = Spreading {
        step: DIFFUSION * stiffness * h * h,
        most: 0.5 * stiffness * reach,
    };
    // Parts of the batches, one per thread for large hair. Each part splats into SPLATS grids
    // of its own, lane l into grid l % SPLATS (neighbouring particles add to the same nodes,
    // and one grid would make each add wait for the last); then the grids are summed.
    let pool = crate::parallel::compute_pool();
    let parts = crate::parallel::workers(pool).min(n / PARALLEL_FROM).max(1);
    let per_part = batches.len().div_ceil(parts).max(1);
    s.density.clear();
    s.density.resize(SPLATS * nodes, 0.0);
    let grid = &grid;
    splat(batches, grid, &mut s.density);
    let (sum, others) = s.density.split_at_mut(nodes);
    for other in others.chunks(nodes) {
        for (a, b) in sum.iter_mut().zip(other) {
            *a += b;
        }
    }
    // Each cell's 8 nodes side by side, so a read takes one slice.
    s.cells.clear();
    s.cells.resize(nodes, [0.0; 8]);
    let last = nodes.saturating_sub(grid.span);
    for (at, cell) in s.cells.iter_mut().enumerate().take(last + 1) {
        *cell = grid.corners.map(|c| sum[at + c]);
    }
    let sum = &s.cells[..];
    // Read back and move.
    let moved = std::sync::atomic::AtomicU32::new(0);
    let crowded = std::sync::atomic::AtomicU32::new(0);
    let read = |b: &mut [Batch]| {
        let (m, c) = read_back(b, grid, sum, how);
        moved.fetch_add(m, std::sync::atomic::Ordering::Relaxed);
        crowded.fetch_add(c, std::sync::atomic::Ordering::Relaxed);
    };
    if parts == 1 {
        batches.chunks_mut(per_part).for_each(read);
    } else {
        crate::parallel::run_parts(pool, batches.chunks_mut(per_part), &read);
    }
    s.crowded_count = crowded.into_inner();
    moved.into_inner()
}

/// The free particles' node rows of a batch of `nodes` nodes: every other node past the
/// pinned root.
fn free_rows(nodes: usize) -> impl Iterator<Item = usize> {
    (PINNED..nodes).filter(|k| k % 2 == 1)
}

/// Splats the particles of `batches` into `grids` ([`SPLATS`] grids, one after another).
fn splat(batches: &[Batch], grid: &Grid, grids: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        return unsafe { splat_avx2(batches, grid, grids) };
    }
    splat_portable(batches, grid, grids);
}

/// [`splat_portable`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn splat_avx2(batches: &[Batch], grid: &Grid, grids: &mut [f32]) {
    splat_portable(batches, grid, grids);
}

/// [`splat`]; inlined into each target-feature variant.
#[inline(always)]
fn splat_portable(batches: &[Batch], grid: &Grid, grids: &mut [f32]) {
    let Grid { corners, span, .. } = *grid;
    let nodes = grids.len() / SPLATS;
    for b in batches {
        let live = b.count.min(LANES);
        // Every `stride`-th row stands for the rows it skips (their share of the strand's
        // particles, so a strand adds the same in all).
        let rows = free_rows(b.nodes.len()).count();
        let taken = rows.div_ceil(grid.stride);
        let weight = grid.weight * rows as f32 / taken.max(1) as f32;
        for k in free_rows(b.nodes.len()).step_by(grid.stride) {
            let (at, [fx, fy, fz], ok) = grid.locate(&b.nodes[k].x, live);
            let mut w = [[0f32; LANES]; 8];
            for l in 0..LANES {
                let (gx, gy, gz) = (1.0 - fx[l], 1.0 - fy[l], 1.0 - fz[l]);
                let (a, c) = (gx * weight * ok[l], fx[l] * weight * ok[l]);
                let (y0z0, y1z0) = (gy * gz, fy[l] * gz);
                let (y0z1, y1z1) = (gy * fz[l], fy[l] * fz[l]);
                w[0][l] = a * y0z0;
                w[1][l] = c * y0z0;
                w[2][l] = a * y1z0;
                w[3][l] = c * y1z0;
                w[4][l] = a * y0z1;
                w[5][l] = c * y0z1;
                w[6][l] = a * y1z1;
                w[7][l] = c * y1z1;
            }
            for l in 0..live {
                let first = (l % SPLATS) * nodes + at[l];
                let cell = &mut grids[first..first + span];
                for (&c, w) in corners.iter().zip(&w) {
                    cell[c] += w[l];
                }
            }
        }
    }
}

/// Reads the grid (each cell's 8 nodes) back at the particles of `batches` and moves the
/// crowded ones. Returns how many moved and how many are crowded (over [`CROWDING`]).
fn read_back(batches: &mut [Batch], grid: &Grid, sum: &[[f32; 8]], how: Spreading) -> (u32, u32) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        return unsafe { read_back_avx2(batches, grid, sum, how) };
    }
    read_back_portable(batches, grid, sum, how, corners_portable)
}

/// [`read_back_portable`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn read_back_avx2(
    batches: &mut [Batch],
    grid: &Grid,
    sum: &[[f32; 8]],
    how: Spreading,
) -> (u32, u32) {
    read_back_portable(batches, grid, sum, how, |sum, at, live| {
        // SAFETY: this function is only called where AVX2 was found (see `read_back`).
        unsafe { corners_avx2(sum, at, live) }
    })
}

/// Each corner's values for the lanes of a row, taking lane `l` from cell `at[l]` (0 past
/// `live`): an 8 x 8 transpose.
#[inline(always)]
fn corners_portable(sum: &[[f32; 8]], at: &[usize; LANES], live: usize) -> [Lane; 8] {
    let mut r = [[0f32; LANES]; 8];
    for l in 0..live {
        let cell = sum[at[l]];
        for (c, r) in r.iter_mut().enumerate() {
            r[l] = cell[c];
        }
    }
    r
}

/// [`corners_portable`] as an AVX2 8 x 8 transpose (eight loads and 24 shuffles instead of 64
/// inserts); the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn corners_avx2(sum: &[[f32; 8]], at: &[usize; LANES], live: usize) -> [Lane; 8] {
    use std::arch::x86_64::{
        __m256, _mm256_loadu_ps, _mm256_permute2f128_ps, _mm256_shuffle_ps, _mm256_storeu_ps,
        _mm256_unpackhi_ps, _mm256_unpacklo_ps,
    };
    const { assert!(LANES == 8) };
    let zero = [0f32; 8];
    let rows: [&[f32; 8]; LANES] =
        std::array::from_fn(|l| if l < live { &sum[at[l]] } else { &zero });
    // SAFETY: each row is 8 floats, read unaligned.
    let r: [__m256; 8] = rows.map(|row| unsafe { _mm256_loadu_ps(row.as_ptr()) });
    // Rows a..h: pairs interleaved (a0 b0 a1 b1 | a4 b4 a5 b5), then quads, then halves.
    let t = [
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
        _mm256_unpacklo_ps(r[4], r[5]),
        _mm256_unpackhi_ps(r[4], r[5]),
        _mm256_unpacklo_ps(r[6], r[7]),
        _mm256_unpackhi_ps(r[6], r[7]),
    ];
    let u = [
        _mm256_shuffle_ps::<0x44>(t[0], t[2]),
        _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
        _mm256_shuffle_ps::<0x44>(t[1], t[3]),
        _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
        _mm256_shuffle_ps::<0x44>(t[4], t[6]),
        _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
        _mm256_shuffle_ps::<0x44>(t[5], t[7]),
        _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
    ];
    let out = [
        _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
        _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
        _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
        _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
        _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
        _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
        _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
        _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
    ];
    let mut corners = [[0f32; LANES]; 8];
    for (to, v) in corners.iter_mut().zip(out) {
        // SAFETY: each corner row is 8 floats, written unaligned.
        unsafe { _mm256_storeu_ps(to.as_mut_ptr(), v) };
    }
    corners
}

/// [`read_back`]; inlined into each target-feature variant.
#[inline(always)]
#[expect(
    clippy::needless_range_loop,
    reason = "lane loops index several arrays at once, which the compiler vectorises"
)]
fn read_back_portable(
    batches: &mut [Batch],
    grid: &Grid,
    sum: &[[f32; 8]],
    how: Spreading,
    corners: impl Fn(&[[f32; 8]], &[usize; LANES], usize) -> [Lane; 8],
) -> (u32, u32) {
    let (mut moved, mut crowded) = (0, 0);
    for b in batches.iter_mut() {
        let live = b.count.min(LANES);
        for k in free_rows(b.nodes.len()) {
            let node = &mut b.nodes[k];
            let (at, [fx, fy, fz], ok) = grid.locate(&node.x, live);
            let r = corners(sum, &at, live);
            // The density and its slope (trilinear): along x on the cell's four x edges (y, z
            // = 00, 10, 01, 11), then across; then the move down the slope where crowded,
            // `step * (1 - CROWDING / rho) / rho * slope`, at most `most` long.
            let mut push = [[0f32; LANES]; 3];
            let (mut count, mut over) = (0, 0);
            for l in 0..LANES {
                let (gx, gy, gz) = (1.0 - fx[l], 1.0 - fy[l], 1.0 - fz[l]);
                let e00 = r[0][l] * gx + r[1][l] * fx[l];
                let e10 = r[2][l] * gx + r[3][l] * fx[l];
                let e01 = r[4][l] * gx + r[5][l] * fx[l];
                let e11 = r[6][l] * gx + r[7][l] * fx[l];
                let (a00, a10) = (r[1][l] - r[0][l], r[3][l] - r[2][l]);
                let (a01, a11) = (r[5][l] - r[4][l], r[7][l] - r[6][l]);
                let rho = (e00 * gy + e10 * fy[l]) * gz + (e01 * gy + e11 * fy[l]) * fz[l];
                let sx = (a00 * gy + a10 * fy[l]) * gz + (a01 * gy + a11 * fy[l]) * fz[l];
                let sy = (e10 - e00) * gz + (e11 - e01) * fz[l];
                let sz = (e01 - e00) * gy + (e11 - e10) * fy[l];
                over += u32::from(rho * ok[l] > CROWDING);
                // (rho - CROWDING) / rho^2 where crowded, else 0.
                let gate = (rho - CROWDING).max(0.0) / (rho * rho).max(CROWDING * CROWDING);
                let scale = -how.step * grid.inv * gate * ok[l];
                let (px, py, pz) = (sx * scale, sy * scale, sz * scale);
                let len2 = px * px + py * py + pz * pz;
                let shrink = (how.most / len2.sqrt()).min(1.0);
                let good = len2 < f32::INFINITY && len2 > 0.0;
                let keep = if good { shrink } else { 0.0 };
                push[0][l] = px * keep;
                push[1][l] = py * keep;
                push[2][l] = pz * keep;
                count += u32::from(good);
            }
            if count > 0 {
                for c in 0..3 {
                    for l in 0..LANES {
                        node.x[c][l] += push[c][l];
                        node.p[c][l] += push[c][l];
                    }
                }
                moved += count;
            }
            crowded += over;
        }
    }
    (moved, crowded)
}

/// Copies the free particles' positions (nodes 2i + 1 past the pinned root) into `s.pos`, in
/// batch, node, lane order. Which strand and slot each one is are only worked out again when
/// the batches' layout changed. Positions that are not finite are kept (so indices stay put)
/// and left out of pairs.
fn gather(batches: &[Batch], s: &mut VolumeScratch) {
    let layout_holds = s.layout.len() == batches.len()
        && batches
            .iter()
            .zip(&s.layout)
            .all(|(b, &(count, nodes))| b.count.min(LANES) == count && b.nodes.len() == nodes);
    if !layout_holds {
        s.layout.clear();
        s.owner.clear();
        s.slot.clear();
        for (b, batch) in batches.iter().enumerate() {
            let lanes = batch.count.min(LANES);
            s.layout.push((lanes, batch.nodes.len()));
            for k in free_rows(batch.nodes.len()) {
                for l in 0..lanes {
                    s.owner.push((b * LANES + l) as u32);
                    s.slot.push((b as u32, l as u8, k as u16));
                }
            }
        }
        // A new layout: the pair list's indices mean other particles now.
        s.built.clear();
        s.dense = false;
        s.spacing = mean_spacing(batches);
    }
    if s.dense {
        // Spread by density, which reads the batches: no positions needed.
        return;
    }
    s.pos.resize(s.slot.len(), Vec3A::ZERO);
    let mut to = s.pos.iter_mut();
    for batch in batches {
        let lanes = batch.count.min(LANES);
        for k in free_rows(batch.nodes.len()) {
            let [xs, ys, zs] = &batch.nodes[k].x;
            for ((&x, &y), &z) in xs.iter().zip(ys).zip(zs).take(lanes) {
                if let Some(p) = to.next() {
                    *p = Vec3A::new(x, y, z);
                }
            }
        }
    }
}

/// The mean distance between neighbouring free particles of a strand in `batches`, over the
/// finite ones; NaN without any.
fn mean_spacing(batches: &[Batch]) -> f32 {
    let (mut sum, mut count) = (0.0f64, 0u32);
    for b in batches {
        let rows: Vec<usize> = free_rows(b.nodes.len()).collect();
        for pair in rows.windows(2) {
            let ([x0, y0, z0], [x1, y1, z1]) = (&b.nodes[pair[0]].x, &b.nodes[pair[1]].x);
            for l in 0..b.count.min(LANES) {
                let d = Vec3A::new(x1[l] - x0[l], y1[l] - y0[l], z1[l] - z0[l]).length();
                if d.is_finite() {
                    sum += f64::from(d);
                    count += 1;
                }
            }
        }
    }
    if count == 0 {
        f32::NAN
    } else {
        (sum / f64::from(count)) as f32
    }
}

/// Whether the pair list built earlier still holds every pair now closer than `reach`: same
/// particles and reach, and none moved more than half the skin from where the bone would have
/// carried it since the build (two particles then closed in by less than the skin).
fn list_holds(s: &VolumeScratch, bone: &Affine3A, reach: f32) -> bool {
    if s.built.len() != s.pos.len() || s.built_reach != reach || !bone.is_finite() {
        return false;
    }
    let carry = *bone * s.built_from;
    if !carry.is_finite() {
        return false;
    }
    let limit = (0.5 * SKIN * reach).powi(2);
    s.built
        .iter()
        .zip(&s.pos)
        .all(|(&then, &now)| carry.transform_point3a(then).distance_squared(now) <= limit)
}

/// The grid [`sort_cells`] sorted the particles into: cells along each axis, and how many
/// particles it holds.
struct Cells {
    dims: [usize; 3],
    sorted: usize,
}

/// Sorts the finite particles by cell, in a dense grid of cells at least
/// `range` wide over their bounds: a counting sort (counts, then running totals, so that
/// `start[c]` is where cell `c` ends; then each particle, last first, taken off its cell's end,
/// so `start[c]` becomes where the cell begins and a cell keeps its particles in gathered
/// order). `None` without two such particles.
fn sort_cells(s: &mut VolumeScratch, range: f32) -> Option<Cells> {
    let (min, size, [dx, dy, dz]) = grid_over(bounds(s.pos.iter().copied()), range, 0)?;
    let cells = dx * dy * dz;
    let inv = (1.0 / size) as f32;
    let index = |[x, y, z]: [u32; 3]| x as usize + dx * (y as usize + dy * z as usize);
    // (Truncating a float cast to an unsigned integer floors it, and clamps it at 0.)
    let cell_of = |p: Vec3A| {
        let c = (p - min) * inv;
        [
            (c.x as usize).min(dx - 1) as u32,
            (c.y as usize).min(dy - 1) as u32,
            (c.z as usize).min(dz - 1) as u32,
        ]
    };
    s.start.clear();
    s.start.resize(cells + 1, 0);
    s.cell.clear();
    s.cell_xyz.clear();
    let mut n = 0;
    for p in &s.pos {
        if !p.is_finite() {
            s.cell.push(u32::MAX);
            s.cell_xyz.push([0; 3]);
            continue;
        }
        let xyz = cell_of(*p);
        let c = index(xyz);
        s.cell.push(c as u32);
        s.cell_xyz.push(xyz);
        s.start[c] += 1;
        n += 1;
    }
    let mut total = 0;
    for count in &mut s.start[..cells] {
        total += *count;
        *count = total;
    }
    s.start[cells] = n as u32;
    s.sorted.resize(n, Vec3A::ZERO);
    s.sorted_cell.resize(n, [0; 3]);
    s.sorted_from.resize(n, 0);
    for i in (0..s.pos.len()).rev() {
        let c = s.cell[i] as usize;
        if c == u32::MAX as usize {
            continue;
        }
        s.start[c] -= 1;
        let to = s.start[c] as usize;
        s.sorted[to] = s.pos[i];
        s.sorted_cell[to] = s.cell_xyz[i];
        s.sorted_from[to] = i as u32;
    }
    Some(Cells {
        dims: [dx, dy, dz],
        sorted: n,
    })
}

/// Builds the pair list: the pairs of particles of different strands closer than `range`,
/// from the particles sorted into `cells` (at least `range` wide) by [`sort_cells`].
fn find_pairs(s: &mut VolumeScratch, cells: &Cells, range: f32) {
    s.local.clear();
    s.local.resize(s.pos.len(), u32::MAX);
    let Cells {
        dims: [dx, dy, dz],
        sorted: n,
    } = *cells;
    let index = |[x, y, z]: [u32; 3]| x as usize + dx * (y as usize + dy * z as usize);
    let range2 = range * range;
    let (last_x, last_y, last_z) = (dx as u32 - 1, dy as u32 - 1, dz as u32 - 1);
    for i in 0..n {
        let (p, [x, y, z]) = (s.sorted[i], s.sorted_cell[i]);
        let from = s.sorted_from[i];
        let own = s.owner[from as usize];
        // Half the 26 cells around, so each pair is looked at once: the rest of this cell and
        // the next along x; then the rows of 3 cells (contiguous in the sorted arrays) at
        // y + 1, and at z + 1 for y - 1 to y + 1.
        let row = |ry: u32, rz: u32| {
            s.start[index([x.saturating_sub(1), ry, rz])] as usize
                ..s.start[index([(x + 1).min(last_x), ry, rz]) + 1] as usize
        };
        let mut ranges = [0..0, 0..0, 0..0, 0..0, 0..0];
        ranges[0] = i + 1..s.start[index([(x + 1).min(last_x), y, z]) + 1] as usize;
        if y < last_y {
            ranges[1] = row(y + 1, z);
        }
        if z < last_z {
            for (r, ry) in (y.saturating_sub(1)..=(y + 1).min(last_y)).enumerate() {
                ranges[2 + r] = row(ry, z + 1);
            }
        }
        let (mut mine, mut looked) = (0, 0);
        'cells: for range in ranges {
            for j in range {
                looked += 1;
                if looked > MAX_CANDIDATES {
                    break 'cells;
                }
                if p.distance_squared(s.sorted[j]) >= range2 {
                    continue;
                }
                let to = s.sorted_from[j];
                // Strands other than its own.
                if s.owner[to as usize] == own {
                    continue;
                }
                let mut member = |i: u32| {
                    let slot = &mut s.local[i as usize];
                    if *slot == u32::MAX {
                        *slot = s.members.len() as u32;
                        s.members.push(i);
                    }
                    *slot
                };
                let pair = (member(from), member(to));
                s.pairs.push(pair);
                mine += 1;
                if mine == MAX_PAIRS {
                    break 'cells;
                }
            }
        }
    }
}
