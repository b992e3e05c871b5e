//! Hair–hair volume: strands of one hair keep apart instead of passing through each other.
//!
//! Once a frame, after the last substep (like the strain and style limits), every free particle
//! of the hair is put in a spatial hash of cells `2 r` wide (Teschner et al. 2003: counting
//! sort into a table twice the particle count, no allocation once warm). Each pair of particles
//! of different strands closer than `2 r` is pushed apart along the line between them by
//! [`HairVolume::stiffness`] times half the overlap each (Jacobi: all pushes are summed first,
//! then applied), and the push moves the previous position too, so it adds no velocity: strands
//! settle side by side instead of bouncing. Only particles move; their structural neighbours
//! follow through the springs in the next frame.
//!
//! The cost grows with how many particles lie within `2 r` of each other. Guide strands a
//! radius or two apart have a few neighbours each; hair much denser than its radius (1,000
//! strands 3.5 mm apart with 16 mm tubes) has dozens. So each particle starts at most
//! [`MAX_PUSHES`] pairs a frame, the first it finds, and looks at no more than
//! [`MAX_CANDIDATES`] particles in the cells around it: in such hair the volume builds up over
//! a few frames instead of in one, and the pass costs a bounded amount per particle.

use bevy::math::Vec3A;
use bevy::prelude::*;

use super::solver::{Batch, LANES, PINNED};

/// Keeps a hair's strands apart ([`HairSimSettings::volume`](super::HairSimSettings::volume)).
#[derive(Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct HairVolume {
    /// Share of each overlap removed per frame, 0 (none) to 1 (all at once). Default: `0.5`.
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

/// Reused buffers of [`keep_apart`]; one per hair.
#[derive(Clone, Debug, Default)]
pub struct VolumeScratch {
    /// Positions of the free particles.
    pos: Vec<Vec3A>,
    /// Per particle: its strand (batch * LANES + lane), and where it lives (batch, lane, node).
    owner: Vec<u32>,
    slot: Vec<(u32, u8, u16)>,
    /// Hash table: bucket starts (`len + 1`), particles sorted by bucket, and each particle's
    /// bucket.
    start: Vec<u32>,
    sorted: Vec<u32>,
    bucket: Vec<u32>,
    /// Each particle's cell.
    cells: Vec<[i32; 3]>,
    /// Where the next particle of each bucket goes while filling `sorted`.
    fill: Vec<u32>,
    /// Summed push per particle.
    delta: Vec<Vec3A>,
}

/// The most pairs a particle starts in one frame (see the module docs).
pub const MAX_PUSHES: usize = 16;

/// The most other particles a particle looks at in one frame, near or not (see the module
/// docs): the bound on the pass's cost, `O(particles * MAX_CANDIDATES)`.
pub const MAX_CANDIDATES: usize = 96;

fn cell_of(p: Vec3A, inv: f32) -> [i32; 3] {
    let c = (p * inv).floor();
    [c.x as i32, c.y as i32, c.z as i32]
}

fn hash([x, y, z]: [i32; 3], mask: u32) -> u32 {
    ((x as u32).wrapping_mul(73_856_093)
        ^ (y as u32).wrapping_mul(19_349_663)
        ^ (z as u32).wrapping_mul(83_492_791))
        & mask
}

/// Pushes apart the particles of different strands in `batches` closer than `2 * radius` (see
/// the module docs). Returns the number of pairs pushed.
pub fn keep_apart(
    batches: &mut [Batch],
    radius: f32,
    stiffness: f32,
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
    let inv = reach.recip();
    let s = scratch;
    s.pos.clear();
    s.owner.clear();
    s.slot.clear();
    // Free particles only: nodes 2i + 1 past the pinned root.
    for (b, batch) in batches.iter().enumerate() {
        for l in 0..batch.count.min(LANES) {
            for k in (PINNED..batch.nodes.len()).filter(|k| k % 2 == 1) {
                let x = &batch.nodes[k].x;
                let p = Vec3A::new(x[0][l], x[1][l], x[2][l]);
                if !p.is_finite() {
                    continue;
                }
                s.pos.push(p);
                s.owner.push((b * LANES + l) as u32);
                s.slot.push((b as u32, l as u8, k as u16));
            }
        }
    }
    let n = s.pos.len();
    if n < 2 {
        return 0;
    }
    let size = (2 * n).next_power_of_two().max(16);
    let mask = (size - 1) as u32;
    s.start.clear();
    s.start.resize(size + 1, 0);
    s.cells.clear();
    s.cells.extend(s.pos.iter().map(|&p| cell_of(p, inv)));
    s.bucket.clear();
    s.bucket.extend(s.cells.iter().map(|&c| hash(c, mask)));
    for &h in &s.bucket {
        s.start[h as usize + 1] += 1;
    }
    for i in 0..size {
        s.start[i + 1] += s.start[i];
    }
    s.sorted.clear();
    s.sorted.resize(n, 0);
    s.fill.clear();
    s.fill.extend_from_slice(&s.start);
    for (i, &h) in s.bucket.iter().enumerate() {
        s.sorted[s.fill[h as usize] as usize] = i as u32;
        s.fill[h as usize] += 1;
    }
    s.delta.clear();
    s.delta.resize(n, Vec3A::ZERO);
    let mut pairs = 0;
    let reach2 = reach * reach;
    'particles: for i in 0..n {
        let (mut mine, mut looked) = (0, 0);
        let p = s.pos[i];
        let c = s.cells[i];
        // The 27 cells around. Distinct cells may share a bucket: a particle counts only under
        // its own cell, so none is seen twice.
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let cell = [c[0] + dx, c[1] + dy, c[2] + dz];
                    let h = hash(cell, mask);
                    let range = s.start[h as usize] as usize..s.start[h as usize + 1] as usize;
                    for &j in &s.sorted[range] {
                        let j = j as usize;
                        looked += 1;
                        if looked > MAX_CANDIDATES {
                            continue 'particles;
                        }
                        // Each pair once, strands other than its own.
                        if j <= i || s.owner[j] == s.owner[i] || s.cells[j] != cell {
                            continue;
                        }
                        let d = p - s.pos[j];
                        let d2 = d.length_squared();
                        if d2 >= reach2 || d2 <= 1e-18 {
                            continue;
                        }
                        let dist = d2.sqrt();
                        let push = d * ((reach - dist) * 0.5 * stiffness / dist);
                        s.delta[i] += push;
                        s.delta[j] -= push;
                        pairs += 1;
                        mine += 1;
                        if mine == MAX_PUSHES {
                            continue 'particles;
                        }
                    }
                }
            }
        }
    }
    for (i, &(b, l, k)) in s.slot.iter().enumerate() {
        let d = s.delta[i];
        if d == Vec3A::ZERO || !d.is_finite() {
            continue;
        }
        let node = &mut batches[b as usize].nodes[k as usize];
        let l = l as usize;
        for (c, v) in d.to_array().into_iter().enumerate() {
            node.x[c][l] += v;
            node.p[c][l] += v;
        }
    }
    pairs
}
