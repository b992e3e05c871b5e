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

use bevy::math::{Affine3A, DVec3, Vec3A};
use bevy::prelude::*;

use super::solver::{Batch, LANES, PINNED};

/// Keeps a hair's strands apart ([`HairSimSettings::volume`](super::HairSimSettings::volume)).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct HairVolume {
    /// Share of each overlap removed per frame, 0 (none) to 1 (all at once), where a particle
    /// overlaps one or two others; a particle crowded by more moves by the average of its
    /// pushes times two. Default: `0.5`.
    pub stiffness: f32,
    /// Particles of different strands closer than twice this (metres, at the character's
    /// built size) are pushed apart. `None`: the hair's tube radius
    /// (`HairMeshSettings::radius`, or its default without one). Default: `None`.
    pub radius: Option<f32>,
}

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
    /// `reach + skin` when it was built, as indices into `pos`.
    pairs: Vec<(u32, u32)>,
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
    /// Summed push per particle.
    delta: Vec<Vec3A>,
    /// Pairs pushing each particle.
    count: Vec<u32>,
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

/// The grid has at most this many cells per particle (plus a few); where the hair's bounds
/// would need more, its cells grow (they hold more particles, which only costs candidates).
const CELLS_PER_PARTICLE: usize = 4;

/// Pushes apart the particles of different strands in `batches` closer than `2 * radius` (see
/// the module docs). `bone` is the hair's bone pose now: the pair list is kept while the hair
/// only moved with it. Returns the number of pairs pushed.
pub fn keep_apart(
    batches: &mut [Batch],
    radius: f32,
    stiffness: f32,
    bone: &Affine3A,
    scratch: &mut VolumeScratch,
) -> usize {
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
    gather(batches, s);
    let n = s.pos.len();
    if n < 2 {
        return 0;
    }
    if !list_holds(s, bone, reach) {
        build_pairs(s, reach * (1.0 + SKIN));
        s.built.clone_from(&s.pos);
        s.built_from = bone.inverse();
        s.built_reach = reach;
        s.reused = 0;
    } else {
        s.reused += 1;
    }
    s.delta.clear();
    s.delta.resize(n, Vec3A::ZERO);
    s.count.clear();
    s.count.resize(n, 0);
    let mut pushed = 0;
    let reach2 = reach * reach;
    for &(i, j) in &s.pairs {
        let (i, j) = (i as usize, j as usize);
        let d = s.pos[i] - s.pos[j];
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
    for ((&d, &count), &(b, l, k)) in s.delta.iter().zip(&s.count).zip(&s.slot) {
        if d == Vec3A::ZERO || !d.is_finite() {
            continue;
        }
        // Constraint averaging with over-relaxation (see the module docs).
        let d = d * (RELAXATION / count.max(1) as f32).min(1.0);
        let node = &mut batches[b as usize].nodes[k as usize];
        let l = l as usize;
        for (c, v) in d.to_array().into_iter().enumerate() {
            node.x[c][l] += v;
            node.p[c][l] += v;
        }
    }
    pushed
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
            for k in (PINNED..batch.nodes.len()).filter(|k| k % 2 == 1) {
                for l in 0..lanes {
                    s.owner.push((b * LANES + l) as u32);
                    s.slot.push((b as u32, l as u8, k as u16));
                }
            }
        }
        // A new layout: the pair list's indices mean other particles now.
        s.built.clear();
    }
    s.pos.resize(s.slot.len(), Vec3A::ZERO);
    let mut to = s.pos.iter_mut();
    for batch in batches {
        let lanes = batch.count.min(LANES);
        for k in (PINNED..batch.nodes.len()).filter(|k| k % 2 == 1) {
            let [xs, ys, zs] = &batch.nodes[k].x;
            for ((&x, &y), &z) in xs.iter().zip(ys).zip(zs).take(lanes) {
                if let Some(p) = to.next() {
                    *p = Vec3A::new(x, y, z);
                }
            }
        }
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

/// Builds the pair list: the pairs of particles of different strands closer than `range`,
/// found in a grid of cells at least `range` wide.
fn build_pairs(s: &mut VolumeScratch, range: f32) {
    s.pairs.clear();
    // Particles that are not finite are left out of the grid.
    let (mut min, mut max) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let mut n = 0;
    for &p in s.pos.iter().filter(|p| p.is_finite()) {
        min = min.min(p);
        max = max.max(p);
        n += 1;
    }
    if n < 2 {
        return;
    }
    // A dense grid over the particles' bounds, so a particle's neighbours are in the 27 cells
    // around its own. In f64: the bounds of hostile positions can be wider than f32 holds.
    let extent = max.as_dvec3() - min.as_dvec3();
    let limit = (CELLS_PER_PARTICLE * n + 64) as f64;
    let dims_for = |size: f64| (extent / size).floor() + 1.0;
    let fits = |dims: DVec3| dims.x * dims.y * dims.z <= limit;
    let mut size = f64::from(range);
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
    let [dx, dy, dz] = [dims.x as usize, dims.y as usize, dims.z as usize];
    let cells = dx * dy * dz;
    let inv = (1.0 / size) as f32;
    let index = |[x, y, z]: [u32; 3]| x as usize + dx * (y as usize + dy * z as usize);
    let cell_of = |p: Vec3A| {
        let c = ((p - min) * inv).floor();
        [
            (c.x.max(0.0) as usize).min(dx - 1) as u32,
            (c.y.max(0.0) as usize).min(dy - 1) as u32,
            (c.z.max(0.0) as usize).min(dz - 1) as u32,
        ]
    };
    // Counting sort by cell: counts, then running totals (`start[c]` is where cell `c` ends),
    // then each particle, last first, taken off its cell's end (so `start[c]` becomes where
    // the cell begins and a cell keeps its particles in gathered order).
    s.start.clear();
    s.start.resize(cells + 1, 0);
    s.cell.clear();
    s.cell_xyz.clear();
    for &p in &s.pos {
        if !p.is_finite() {
            s.cell.push(u32::MAX);
            s.cell_xyz.push([0; 3]);
            continue;
        }
        let xyz = cell_of(p);
        let c = index(xyz);
        s.cell.push(c as u32);
        s.cell_xyz.push(xyz);
        s.start[c] += 1;
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
                s.pairs.push((from, to));
                mine += 1;
                if mine == MAX_PAIRS {
                    break 'cells;
                }
            }
        }
    }
}
