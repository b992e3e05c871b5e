//! Posing the chains of one solver batch side by side: joint `k` of every chain in the batch at
//! once, each number a [`Lane`] with the chain innermost, as the solver lays them out. The chains
//! of a hair are independent, so the arithmetic of eight chains overlaps instead of waiting down
//! one chain's dependent products, and the particles are read straight from the solver's lanes.
//!
//! The joints' local translations and scales, bind rotations and child offsets are read from
//! the world once, into the same lane order ([`LaneJoints`]), and read again only when a joint's
//! transform changes: a frame reads them in the order it uses them, not joint by joint from
//! the world.
//!
//! The lanes do the arithmetic every joint needs (the joint's world origin, its bind direction,
//! the shortest turn onto its next particle, its world matrix) and the first round of keeping
//! the posed child off colliders (most children are certainly clear). What only some joints need
//! is done lane by lane between the two halves: the rest of keeping a child off a collider, and
//! keeping it inside an angle limit. A chain that needs more than a rotation times a uniform
//! scale (a mirrored or stretched joint), its tail joint, or a turn the lanes cannot take (a
//! bone with no direction, a half turn) is handed, from that joint on, to the one-chain posing
//! in `chain_pose`, which gives the same poses one joint at a time.
//!
//! Where the CPU has AVX2 the lane code runs compiled for it (a lane of eight numbers in one
//! register); it gives the same bits as the portable build. The box a hair's nearby colliders
//! are gathered by ([`ParticleBox`]) is measured here too, by the step right after each batch.
#![cfg_attr(
    target_arch = "x86_64",
    expect(
        unsafe_code,
        reason = "the AVX2 variant of the lane posing, chosen after runtime feature detection"
    )
)]
// Lane loops index several arrays with the same counter on purpose: that is the shape the
// compiler vectorises across chains.
#![expect(
    clippy::needless_range_loop,
    reason = "lane loops index several arrays at once, which the compiler vectorises"
)]

use bevy::math::{Affine3A, Mat3A, Vec3A};
use bevy::prelude::*;

use super::attach::ComputedHair;
use super::chain_pose::{
    ChainCursor, NearShape, Pose, UNPOSED, chain_particles, keep_off, pose_chain, solver_holds,
    uniform_scale,
};
use super::chains::BoneChainHair;
use super::contact::ContactShape;
use super::limits::{limit_frame, limit_offset};
use super::solver::{Batch, LANES, Lane, get3, set3};

/// Three numbers per lane.
type Lane3 = [Lane; 3];
/// A quaternion per lane: `x, y, z, w`.
type Lane4 = [Lane; 4];

/// The joint each lane's chain was last posed at: its world matrix (columns `x`, `y`, `z`), its
/// origin, its world rotation and its world scale.
#[derive(Clone, Copy)]
struct Parents {
    matrix: [Lane3; 3],
    origin: Lane3,
    rotation: Lane4,
    scale: Lane,
}

impl Parents {
    /// Every lane at `cursor`.
    fn splat(cursor: &ChainCursor) -> Self {
        let m = cursor.parent.matrix3;
        let column = |c: Vec3A| [[c.x; LANES], [c.y; LANES], [c.z; LANES]];
        let (t, q) = (cursor.parent.translation, cursor.parent_rotation);
        Self {
            matrix: [column(m.x_axis), column(m.y_axis), column(m.z_axis)],
            origin: [[t.x; LANES], [t.y; LANES], [t.z; LANES]],
            rotation: [[q.x; LANES], [q.y; LANES], [q.z; LANES], [q.w; LANES]],
            scale: [cursor.scale; LANES],
        }
    }

    /// Lane `l`'s world transform.
    fn affine(&self, l: usize) -> Affine3A {
        Affine3A {
            matrix3: Mat3A::from_cols(
                lane3a(&self.matrix[0], l),
                lane3a(&self.matrix[1], l),
                lane3a(&self.matrix[2], l),
            ),
            translation: lane3a(&self.origin, l),
        }
    }

    /// Lane `l` of chain `strand` as the one-chain posing's cursor.
    fn cursor(&self, l: usize, strand: usize) -> ChainCursor {
        ChainCursor {
            strand,
            parent: self.affine(l),
            parent_rotation: lane4(&self.rotation, l),
            simulated: true,
            uniform: true,
            scale: self.scale[l],
        }
    }
}

/// A hair's joints in the solver's lane order, read from their entities once and kept between
/// frames: posing reads them in the order it uses them, not joint by joint from the world. Read
/// again when the hair's batches change or [`forget`](Self::forget) is called (a joint's
/// transform changed, or a joint lost it).
#[derive(Clone, Debug, Default)]
pub(super) struct LaneJoints {
    /// Per batch, as when read: its lanes' strands, its live lanes, its nodes.
    batches: Vec<([u32; LANES], usize, usize)>,
    /// Per batch: its first row in `rows`, and one past its last.
    rows_of: Vec<(usize, usize)>,
    /// Per batch, joint `k` of every lane.
    rows: Vec<LaneJoint>,
    /// Read since the last [`forget`](Self::forget).
    fresh: bool,
}

impl LaneJoints {
    /// Read again before the next posing.
    pub(super) fn forget(&mut self) {
        self.fresh = false;
    }

    /// Reads the joints again unless they were read for these batches since the last
    /// [`forget`](Self::forget).
    pub(super) fn refresh(
        &mut self,
        driven: &BoneChainHair,
        computed: &ComputedHair,
        bind: &impl Fn(Entity) -> Option<Transform>,
    ) {
        if !self.reads(computed) {
            self.read(driven, computed, bind);
        }
    }

    /// Whether this was read for these batches.
    fn reads(&self, computed: &ComputedHair) -> bool {
        self.fresh
            && self.batches.len() == computed.batches.len()
            && self
                .batches
                .iter()
                .zip(&computed.batches)
                .all(|(&(strands, count, nodes), b)| {
                    strands == b.strands && count == b.count && nodes == b.nodes.len()
                })
    }

    /// Reads the joints of every batch's lanes.
    fn read(
        &mut self,
        driven: &BoneChainHair,
        computed: &ComputedHair,
        bind: &impl Fn(Entity) -> Option<Transform>,
    ) {
        self.batches.clear();
        self.rows_of.clear();
        self.rows.clear();
        for batch in &computed.batches {
            let (count, strands) = (batch.count.min(LANES), batch.strands);
            let particle_count = batch.nodes.len() / 2;
            self.batches
                .push((batch.strands, batch.count, batch.nodes.len()));
            let first = self.rows.len();
            let chain = |l: usize| driven.joints.get(strands[l] as usize);
            let longest = (0..count)
                .filter_map(chain)
                .map(Vec::len)
                .max()
                .unwrap_or(0);
            for k in 0..longest {
                let mut row = LaneJoint::default();
                for l in 0..count {
                    let s = strands[l] as usize;
                    let Some(chain) = chain(l) else {
                        continue;
                    };
                    let Some(&joint) = chain.get(k) else {
                        continue;
                    };
                    if k > 0 && self.rows[self.rows.len() - 1].step[l] != Step::Lanes {
                        // The lane was left at an earlier joint.
                        continue;
                    }
                    let tail_joint = driven.tail_joint.get(s).copied().unwrap_or(false);
                    let usable = solver_holds(driven, s, particle_count);
                    let Some(local) = bind(joint) else {
                        row.step[l] = Step::Missing;
                        continue;
                    };
                    if !usable
                        || (tail_joint && k + 1 == chain.len())
                        || !uniform_scale(local.scale)
                    {
                        row.step[l] = Step::Alone;
                        continue;
                    }
                    let rest = &driven.rest[s];
                    row.step[l] = Step::Lanes;
                    row.entity[l] = joint;
                    set3(&mut row.translation, l, local.translation);
                    row.scale[l] = local.scale.x;
                    set4(&mut row.rest, l, rest[k].rotation);
                    let child = rest.get(k + 1).map_or(driven.tail[s], |t| t.translation);
                    set3(&mut row.child, l, child);
                }
                self.rows.push(row);
            }
            self.rows_of.push((first, self.rows.len()));
        }
        self.fresh = true;
    }
}

/// What posing one joint in a lane takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// Posed in the lanes.
    Lanes,
    /// Posed alone from here on (a tail joint, a stretched or mirrored joint, a chain the solver
    /// does not hold as it is).
    Alone,
    /// The joint has no transform: its chain is not posed from here on.
    Missing,
    /// No joint (the chain ended, or left the lanes at an earlier joint).
    End,
}

/// Joint `k` of each lane's chain: its entity, what posing it takes, its local translation and
/// (uniform) scale, its bind rotation and its child's bind offset.
#[derive(Clone, Debug)]
struct LaneJoint {
    entity: [Entity; LANES],
    step: [Step; LANES],
    translation: Lane3,
    scale: Lane,
    rest: Lane4,
    child: Lane3,
}

impl Default for LaneJoint {
    fn default() -> Self {
        Self {
            entity: [Entity::PLACEHOLDER; LANES],
            step: [Step::End; LANES],
            translation: [[0.0; LANES]; 3],
            scale: [1.0; LANES],
            rest: [[0.0; LANES], [0.0; LANES], [0.0; LANES], [1.0; LANES]],
            child: [[0.0; LANES], [1.0; LANES], [0.0; LANES]],
        }
    }
}

/// The first half of posing a joint: its world origin, its bind rotation under its posed parent,
/// its bone's bind offset in the world (`from`), that bone's length, and the offset to its next
/// particle (`to`).
struct Reach {
    origin: Lane3,
    at_rest: Lane4,
    from: Lane3,
    length: Lane,
    to: Lane3,
}

impl Default for Reach {
    fn default() -> Self {
        Self {
            origin: [[0.0; LANES]; 3],
            at_rest: [[0.0; LANES]; 4],
            from: [[0.0; LANES]; 3],
            length: [0.0; LANES],
            to: [[0.0; LANES]; 3],
        }
    }
}

fn lane3a(a: &Lane3, l: usize) -> Vec3A {
    Vec3A::new(a[0][l], a[1][l], a[2][l])
}

fn lane4(a: &Lane4, l: usize) -> Quat {
    Quat::from_xyzw(a[0][l], a[1][l], a[2][l], a[3][l])
}

fn set4(a: &mut Lane4, l: usize, q: Quat) {
    a[0][l] = q.x;
    a[1][l] = q.y;
    a[2][l] = q.z;
    a[3][l] = q.w;
}

/// `a * b` (quaternions `x, y, z, w`), as glam writes it.
#[inline(always)]
fn mul(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `v` turned by the unit quaternion `q`.
#[inline(always)]
fn rotate(q: [f32; 4], v: [f32; 3]) -> [f32; 3] {
    let [x, y, z, w] = q;
    let [vx, vy, vz] = v;
    let b2 = x * x + y * y + z * z;
    let along = (vx * x + vy * y + vz * z) * 2.0;
    let (k, w2) = (w * w - b2, w * 2.0);
    // v (w^2 - b.b) + b (2 v.b) + (b x v) 2w
    [
        vx * k + x * along + (y * vz - z * vy) * w2,
        vy * k + y * along + (z * vx - x * vz) * w2,
        vz * k + z * along + (x * vy - y * vx) * w2,
    ]
}

/// The first half of posing joint `j` of every lane, its next particles at `particle` (see
/// [`Reach`]).
#[inline(always)]
fn reach(p: &Parents, j: &LaneJoint, particle: &Lane3, r: &mut Reach) {
    for l in 0..LANES {
        let m = |c: usize, i: usize| p.matrix[c][i][l];
        let apply = |v: [f32; 3], i: usize| m(0, i) * v[0] + m(1, i) * v[1] + m(2, i) * v[2];
        let t = [
            j.translation[0][l],
            j.translation[1][l],
            j.translation[2][l],
        ];
        let q = [
            p.rotation[0][l],
            p.rotation[1][l],
            p.rotation[2][l],
            p.rotation[3][l],
        ];
        let rest = [j.rest[0][l], j.rest[1][l], j.rest[2][l], j.rest[3][l]];
        let s = j.scale[l];
        let bone = rotate(
            rest,
            [j.child[0][l] * s, j.child[1][l] * s, j.child[2][l] * s],
        );
        let at_rest = mul(q, rest);
        let mut length = 0.0;
        for i in 0..3 {
            let origin = apply(t, i) + p.origin[i][l];
            let from = apply(bone, i);
            r.origin[i][l] = origin;
            r.from[i][l] = from;
            r.to[i][l] = particle[i][l] - origin;
            length += from * from;
        }
        r.length[l] = length.sqrt();
        for i in 0..4 {
            r.at_rest[i][l] = at_rest[i];
        }
    }
}

/// The lanes whose posed child, at its bone's length toward its next particle, is certainly
/// clear of every shape in `near` (outside its box, or farther than `margin` outside a sphere or
/// capsule by squared distances): the first round of [`keep_off`], which the other lanes go
/// through whole.
#[inline(always)]
fn clear_of_all(near: &[NearShape], r: &Reach, margin: f32) -> [bool; LANES] {
    // The child's offset from the joint: toward the particle, at the bone's length.
    let mut offset = [[0.0; LANES]; 3];
    let mut clear = [true; LANES];
    for l in 0..LANES {
        let t = [r.to[0][l], r.to[1][l], r.to[2][l]];
        let rcp = 1.0 / (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        // No direction: `keep_off` decides.
        clear[l] = rcp.is_finite() && rcp > 0.0;
        for i in 0..3 {
            offset[i][l] = t[i] * rcp * r.length[l];
        }
    }
    for (shape, inside, lo, hi) in near {
        let (lo, hi) = (lo.to_array(), hi.to_array());
        // Where the shape's points lie from each lane's joint.
        let (centre, b, reach) = match *shape {
            ContactShape::Sphere { centre, radius } if !inside => (centre, None, radius + margin),
            ContactShape::Capsule { a, b, radius } if !inside => (a, Some(b), radius + margin),
            // Clear only outside the box.
            _ => (Vec3A::ZERO, None, f32::NAN),
        };
        for l in 0..LANES {
            let o = [offset[0][l], offset[1][l], offset[2][l]];
            let mut outside = false;
            for i in 0..3 {
                let q = r.origin[i][l] + o[i];
                outside |= q < lo[i] || q > hi[i];
            }
            let a = [
                centre.x - r.origin[0][l],
                centre.y - r.origin[1][l],
                centre.z - r.origin[2][l],
            ];
            let nearest = match b {
                None => a,
                Some(b) => {
                    let ab = [b.x - centre.x, b.y - centre.y, b.z - centre.z];
                    let along =
                        (o[0] - a[0]) * ab[0] + (o[1] - a[1]) * ab[1] + (o[2] - a[2]) * ab[2];
                    let t = (along / (ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2]).max(1e-20))
                        .clamp(0.0, 1.0);
                    [a[0] + ab[0] * t, a[1] + ab[1] * t, a[2] + ab[2] * t]
                }
            };
            let d = [o[0] - nearest[0], o[1] - nearest[1], o[2] - nearest[2]];
            // NaN for a shape tested by its box alone: never clear by distance.
            let far = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] >= reach * reach;
            clear[l] &= outside || far;
        }
    }
    clear
}

/// The second half: each lane's joint turned by the shortest arc from `from` to `to`, into its
/// world pose as the next joint's parent (`next`) and its local rotation (`local`); `ok` says
/// whether the lane could take the turn (both offsets have a direction, and they are not
/// opposite).
#[inline(always)]
fn turn(
    p: &Parents,
    r: &Reach,
    scale: &Lane,
    (next, local, ok): (&mut Parents, &mut Lane4, &mut [bool; LANES]),
) {
    next.origin = r.origin;
    for l in 0..LANES {
        let f = [r.from[0][l], r.from[1][l], r.from[2][l]];
        let t = [r.to[0][l], r.to[1][l], r.to[2][l]];
        let norms = ((f[0] * f[0] + f[1] * f[1] + f[2] * f[2])
            * (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]))
            .sqrt();
        let w = norms + (f[0] * t[0] + f[1] * t[1] + f[2] * t[2]);
        ok[l] = norms > 0.0 && norms < f32::INFINITY && w > 1e-6 * norms;
        let c = [
            f[1] * t[2] - f[2] * t[1],
            f[2] * t[0] - f[0] * t[2],
            f[0] * t[1] - f[1] * t[0],
        ];
        let inv = 1.0 / (c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + w * w).sqrt();
        let arc = [c[0] * inv, c[1] * inv, c[2] * inv, w * inv];
        let at_rest = [
            r.at_rest[0][l],
            r.at_rest[1][l],
            r.at_rest[2][l],
            r.at_rest[3][l],
        ];
        let world = mul(arc, at_rest);
        let q = [
            -p.rotation[0][l],
            -p.rotation[1][l],
            -p.rotation[2][l],
            p.rotation[3][l],
        ];
        let own = mul(q, world);
        let s = p.scale[l] * scale[l];
        // The world matrix: the rotation's, times the scale (as `Mat3A::from_quat` writes it).
        let [x, y, z, w] = world;
        let (x2, y2, z2) = (x + x, y + y, z + z);
        let (xx, xy, xz) = (x * x2, x * y2, x * z2);
        let (yy, yz, zz) = (y * y2, y * z2, z * z2);
        let (wx, wy, wz) = (w * x2, w * y2, w * z2);
        let columns = [
            [1.0 - (yy + zz), xy + wz, xz - wy],
            [xy - wz, 1.0 - (xx + zz), yz + wx],
            [xz + wy, yz - wx, 1.0 - (xx + yy)],
        ];
        for c in 0..3 {
            for i in 0..3 {
                next.matrix[c][i][l] = columns[c][i] * s;
            }
        }
        for i in 0..4 {
            next.rotation[i][l] = world[i];
            local[i][l] = own[i];
        }
        next.scale[l] = s;
    }
}

/// Poses the chains in the lanes of batch `b` (see the module docs) into `posed`, the hair's
/// cursor `start` before each chain's first joint, chain `s`'s slots from `first[s]`; `joints`
/// are the hair's joints, read for these batches ([`LaneJoints::refresh`]). The hair's scale is
/// uniform. Returns how many joints were posed in the lanes.
///
/// Runs the AVX2 variant where the CPU has AVX2 (8 lanes a register instead of 4); both give
/// bit-identical poses.
pub(super) fn pose_batch(
    driven: &BoneChainHair,
    (b, start): (usize, &ChainCursor),
    computed: &mut ComputedHair,
    joints: &LaneJoints,
    near: (&[NearShape], f32),
    out: (&mut [Pose], &[usize], &mut Vec<Vec3>),
    bind: &impl Fn(Entity) -> Option<Transform>,
) -> usize {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        return unsafe { pose_batch_avx2(driven, (b, start), computed, joints, near, out, bind) };
    }
    pose_batch_lanes(driven, (b, start), computed, joints, near, out, bind)
}

/// [`pose_batch`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn pose_batch_avx2(
    driven: &BoneChainHair,
    at: (usize, &ChainCursor),
    computed: &mut ComputedHair,
    joints: &LaneJoints,
    near: (&[NearShape], f32),
    out: (&mut [Pose], &[usize], &mut Vec<Vec3>),
    bind: &impl Fn(Entity) -> Option<Transform>,
) -> usize {
    pose_batch_lanes(driven, at, computed, joints, near, out, bind)
}

/// The lane posing; inlined into each target-feature variant of [`pose_batch`].
#[inline(always)]
fn pose_batch_lanes(
    driven: &BoneChainHair,
    (b, start): (usize, &ChainCursor),
    computed: &mut ComputedHair,
    joints: &LaneJoints,
    (near, margin): (&[NearShape], f32),
    (posed, first, particles): (&mut [Pose], &[usize], &mut Vec<Vec3>),
    bind: &impl Fn(Entity) -> Option<Transform>,
) -> usize {
    // A lane's chain posed alone from joint `k`, its cursor at the joint before.
    let alone = |(mut cursor, k): (ChainCursor, usize),
                 computed: &mut ComputedHair,
                 (posed, particles): (&mut [Pose], &mut Vec<Vec3>)| {
        let s = cursor.strand;
        cursor.simulated &= chain_particles(driven, s, Some(computed), particles);
        pose_chain(
            driven,
            &mut cursor,
            (first[s], k),
            Some(computed),
            (near, margin, particles),
            posed,
            bind,
        );
    };
    let batch = &computed.batches[b];
    let (count, strands) = (batch.count.min(LANES), batch.strands);
    // A lane is posed here while its chain's particles are finite.
    let mut live = [true; LANES];
    for node in batch.nodes.iter().skip(1).step_by(2) {
        let x = &node.x;
        for l in 0..LANES {
            // `&`, not `&&`: no branch per number, so the lanes are tested side by side.
            live[l] &= x[0][l].is_finite() & x[1][l].is_finite() & x[2][l].is_finite();
        }
    }
    for l in 0..LANES {
        let s = strands[l] as usize;
        if l >= count || driven.joints.get(s).is_none() {
            live[l] = false;
        } else if !live[l] {
            let cursor = ChainCursor {
                strand: s,
                ..*start
            };
            alone((cursor, 0), computed, (posed, particles));
        }
    }
    let (from, to) = joints.rows_of[b];
    let rows = &joints.rows[from..to];
    // Each lane's chain's angle limits, looked up once for all its rows.
    let limits: [&[Option<_>]; LANES] = std::array::from_fn(|l| {
        driven
            .limits
            .get(strands[l] as usize)
            .map_or(&[][..], Vec::as_slice)
    });
    // Two rows' parents taking turns: each row's posed joints are the next row's parents, with
    // no copy between rows (a copy of every lane a row, its loads waiting on its stores).
    let mut even = Parents::splat(start);
    let mut odd = even;
    let mut r = Reach::default();
    let (mut local, mut ok) = ([[0.0; LANES]; 4], [false; LANES]);
    let mut in_lanes = 0;
    let mut k = 0;
    // Row `k`, posed under `$parents` into `$next`; past the last row or the last live lane,
    // out of the loop `$done`.
    macro_rules! pose_row {
        ($parents:ident, $next:ident, $done:lifetime) => {
            let Some(row) = rows.get(k) else {
                break $done;
            };
            // A chain that ends, loses a joint or needs more than the lanes give leaves them.
            for l in 0..LANES {
                if !live[l] || row.step[l] == Step::Lanes {
                    continue;
                }
                live[l] = false;
                let s = strands[l] as usize;
                match row.step[l] {
                    Step::Alone => alone(($parents.cursor(l, s), k), computed, (posed, particles)),
                    Step::Missing => {
                        posed[first[s] + k..first[s] + driven.joints[s].len()].fill(UNPOSED);
                    }
                    Step::Lanes | Step::End => {}
                }
            }
            if !live.contains(&true) {
                break $done;
            }
            reach(
                &$parents,
                row,
                &computed.batches[b].nodes[2 * (k + 1) + 1].x,
                &mut r,
            );
            // The posed child at its bone's length, kept off the colliders the particle was
            // kept off, and inside the joint's angle limit (the particle follows: the simulation
            // goes on from where the joint is, as VRM's step does).
            let clear = if near.is_empty() {
                [true; LANES]
            } else {
                clear_of_all(near, &r, margin)
            };
            for l in 0..LANES {
                let limit = limits[l].get(k).and_then(Option::as_ref);
                if !live[l] || (clear[l] && limit.is_none()) {
                    continue;
                }
                let origin = get3(&r.origin, l);
                let mut to = get3(&r.to, l);
                if !clear[l]
                    && let Some(kept) = keep_off(near, origin, to, r.length[l], margin)
                {
                    computed.batches[b].set_particle(l, k + 1, origin + kept);
                    to = kept;
                }
                if let Some(limit) = limit {
                    let frame = limit_frame(lane4(&r.at_rest, l), get3(&row.child, l), limit);
                    let limited = limit_offset(frame, limit, to);
                    if limited != to {
                        computed.batches[b].move_particle(l, k + 1, origin + limited);
                        to = limited;
                    }
                }
                set3(&mut r.to, l, to);
            }
            turn(&$parents, &r, &row.scale, (&mut $next, &mut local, &mut ok));
            for l in 0..LANES {
                if !live[l] {
                    continue;
                }
                let s = strands[l] as usize;
                let rotation = lane4(&local, l);
                if !ok[l] || !rotation.is_finite() {
                    // A bone without a direction, a half turn or a non-finite turn: posed
                    // alone.
                    live[l] = false;
                    alone(($parents.cursor(l, s), k), computed, (posed, particles));
                    continue;
                }
                posed[first[s] + k] = (row.entity[l], rotation, $next.affine(l));
                in_lanes += 1;
            }
            k += 1;
        };
    }
    'rows: loop {
        pose_row!(even, odd, 'rows);
        pose_row!(odd, even, 'rows);
    }
    in_lanes
}

/// The box of a hair's finite particles (the live lanes of each batch) and the square of the
/// longest segment between two finite particles one after the other; `min` infinite when no
/// particle is finite. Measured right after the step while the batches are in cache (see
/// [`ComputedHair::particle_box`]), or by posing when the step did not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ParticleBox {
    pub(crate) min: Vec3A,
    pub(crate) max: Vec3A,
    pub(crate) longest_sq: f32,
}

impl Default for ParticleBox {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl ParticleBox {
    /// No particle.
    pub(crate) const EMPTY: Self = Self {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
        longest_sq: 0.0,
    };

    /// Both boxes in one, the longer segment.
    pub(crate) fn merge(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            longest_sq: self.longest_sq.max(other.longest_sq),
        }
    }

    /// The box of `batches`' particles as they are. Runs the AVX2 variant where the CPU has
    /// AVX2; both give the same numbers.
    pub(crate) fn of(batches: &[Batch]) -> Self {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx2() {
            // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
            return unsafe { particle_box_avx2(batches) };
        }
        particle_box_lanes(batches)
    }
}

/// [`ParticleBox::of`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn particle_box_avx2(batches: &[Batch]) -> ParticleBox {
    particle_box_lanes(batches)
}

/// The box over the lanes as they lie in memory, with masks instead of a branch per particle
/// (so the compiler vectorises it); inlined into each variant of [`ParticleBox::of`].
#[inline(always)]
fn particle_box_lanes(batches: &[Batch]) -> ParticleBox {
    let mut lo = [[f32::INFINITY; LANES]; 3];
    let mut hi = [[f32::NEG_INFINITY; LANES]; 3];
    let mut longest = [0.0f32; LANES];
    let (up, down) = (f32::INFINITY.to_bits(), f32::NEG_INFINITY.to_bits());
    for batch in batches {
        let live = batch.count.min(LANES);
        let mut before = [[0.0f32; LANES]; 3];
        let mut had = [0u32; LANES];
        for node in batch.nodes.iter().skip(1).step_by(2) {
            let x = &node.x;
            // All bits set for a live lane whose coordinates are finite.
            let keep = super::volume::placed(x, live);
            // Lane loops innermost, one quantity at a time: the shape that vectorises.
            let mut d2 = [0.0f32; LANES];
            for i in 0..3 {
                for l in 0..LANES {
                    let d = x[i][l] - before[i][l];
                    d2[l] += d * d;
                    let bits = x[i][l].to_bits() & keep[l];
                    lo[i][l] = lo[i][l].min(f32::from_bits(bits | (up & !keep[l])));
                    hi[i][l] = hi[i][l].max(f32::from_bits(bits | (down & !keep[l])));
                }
            }
            for l in 0..LANES {
                // Zero (no longer than any segment) unless both ends are finite.
                longest[l] = longest[l].max(f32::from_bits(d2[l].to_bits() & keep[l] & had[l]));
                had[l] = keep[l];
            }
            before = *x;
        }
    }
    let across = |v: &[Lane; 3], f: fn(f32, f32) -> f32, start: f32| {
        Vec3A::from_array(v.map(|c| c.into_iter().fold(start, f)))
    };
    ParticleBox {
        min: across(&lo, f32::min, f32::INFINITY),
        max: across(&hi, f32::max, f32::NEG_INFINITY),
        longest_sq: longest.into_iter().fold(0.0, f32::max),
    }
}
