//! The strand solver: plain data, no ECS, no GPU.
//!
//! # Model
//! Each guide strand of `N` particles becomes a chain of `2N` nodes
//! `[g, p0, s0, p1, s1, ..., s(N-2), p(N-1)]`: the particles `p` interleaved with extra
//! structural particles `s` (Selle et al. 2008) set beside each segment, each a quarter turn around
//! the strand from the last, plus one ghost `g` before the root. Any four consecutive nodes form a
//! tetrahedron, so distance springs between nodes one apart (**edge**), two apart (**bending**;
//! but particle to particle, the strand's own segment, is an **edge**) and three apart
//! (**torsion**) hold the strand's styled shape in 3D, bends and twist included, without angle
//! terms. Distances alone also admit the style's mirror image (every tetrahedron inside out), a
//! second rest state a fast motion can knock a strand into, so each tetrahedron's **signed
//! volume** is held too: the styled shape is the only rest state. Rest lengths come from the styled
//! (already bent) groom, so hair keeps its style rather than straightening. `g`, `p0` and `s0` are
//! pinned to the bone: three non-collinear points fix the root's position and orientation.
//!
//! Collisions act on the particles, not on the structural nodes: those are left to their springs,
//! so a strand lying on a surface rests on its particles and torsion never fights a contact.
//!
//! Every node also has an anchor (thesis 4.2.3): a zero-length "blending" spring toward the
//! keyframe pose, with a stiffness shaped along the strand by the S curve.
//!
//! # Solver
//! XPBD with small steps (Macklin et al. 2019): fixed-length substeps with one Gauss-Seidel pass
//! each; stiffness becomes a compliance, so results do not depend on the frame rate.
//!
//! # Layout
//! Strands are solved [`LANES`] at a time, side by side: every number is a `[f32; LANES]` with the
//! strand innermost, so the compiler vectorises across strands and the sqrt/divide chains of
//! different strands overlap (a one-strand-at-a-time solver is latency-bound; see
//! `PERF_NOTES.md`). A batch runs all of a frame's substeps before the next batch starts, so its
//! nodes stay in L1.
//!
//! One batch's pass down its chains is still a chain of dependent square roots and divisions
//! (each spring moves the node the next spring reads). Batches of one chain length can step
//! together ([`Batch::step_together`]): each spring of each batch
//! runs beside the same spring of the others, so the processor works on one batch while another
//! waits. Every batch ends bit for bit where it would alone; the simulation steps a hair's
//! batches three at a time where their lengths allow.
#![cfg_attr(
    target_arch = "x86_64",
    expect(
        unsafe_code,
        reason = "the AVX2 variant of the solver, chosen after runtime feature detection"
    )
)]
// Lane loops index several arrays with the same counter on purpose: that is the shape the
// compiler vectorises across strands.
#![expect(
    clippy::needless_range_loop,
    reason = "lane loops index several arrays at once, which the compiler vectorises"
)]

use std::f32::consts::FRAC_PI_2;

use bevy::math::{Affine3A, BVec4A, Vec3, Vec3A, Vec4};

use crate::math::orthonormalise;

pub use super::contact::{Contact, ContactShape};
pub use super::physics::ShapeCollider;

/// Strands solved side by side in one batch.
pub const LANES: usize = 8;
/// One number per lane.
pub type Lane = [f32; LANES];
/// Nodes pinned to the bone at the start of every chain (`g`, `p0`, `s0`).
pub const PINNED: usize = 3;

/// Builds the chain `[g, p0, s0, p1, ..., p(N-1)]` of a strand. The structural particles sit
/// `offset * segment length` away from each segment's midpoint, along a normal carried down the
/// strand by parallel transport. `reference` is the base pose's `(root tangent, root normal)`:
/// keyframe poses pass it so their structural particles sit on the same side as the base's.
/// Returns the root `(tangent, normal)` used.
pub fn build_chain(
    points: &[Vec3],
    offset: f32,
    reference: Option<(Vec3, Vec3)>,
    out: &mut Vec<Vec3>,
) -> (Vec3, Vec3) {
    out.clear();
    let n = points.len();
    debug_assert!(n >= 2);
    let t0 = (points[1] - points[0]).normalize_or(Vec3::Y);
    let n0 = match reference {
        Some((rt, rn)) => {
            let carried = bevy::math::Quat::from_rotation_arc(rt, t0) * rn;
            orthonormalise(carried, t0)
        }
        None => {
            // The world axis least aligned with the root direction gives a stable first normal.
            // Near-ties go to the earlier axis: a strand straight down (0, -1, 0) is a tie of X
            // and Z, and rounding (a rig of another scale) must not flip its structural side.
            const TIE: f32 = 1e-4;
            let a = t0.abs();
            let axis = if a.x <= a.y + TIE && a.x <= a.z + TIE {
                Vec3::X
            } else if a.y <= a.z + TIE {
                Vec3::Y
            } else {
                Vec3::Z
            };
            orthonormalise(axis, t0)
        }
    };
    let mut normal = n0;
    let mut prev_t = t0;
    for i in 0..n - 1 {
        let seg = points[i + 1] - points[i];
        let len = seg.length();
        let t = seg.normalize_or(prev_t);
        normal = orthonormalise(bevy::math::Quat::from_rotation_arc(prev_t, t) * normal, t);
        prev_t = t;
        // Each structural particle sits a quarter turn around the strand from the previous one,
        // so even a straight strand's tetrahedra have volume (a flat chain could twist freely).
        let side = bevy::math::Quat::from_axis_angle(t, i as f32 * FRAC_PI_2) * normal;
        let mid = (points[i] + points[i + 1]) * 0.5;
        if i == 0 {
            // The ghost before the root: behind p0, a quarter turn the other way.
            let back = bevy::math::Quat::from_axis_angle(t, -FRAC_PI_2) * normal;
            out.push(points[0] - t * (0.5 * len) + back * (offset * len));
        }
        out.push(points[i]);
        out.push(mid + side * (offset * len));
    }
    out.push(points[n - 1]);
    (t0, n0)
}

/// Where along the strand node `k` of a chain of `nodes` sits, root `0` to tip `1`.
pub fn along(k: usize, nodes: usize) -> f32 {
    ((k as f32 - 1.0) / (nodes as f32 - 2.0).max(1.0)).clamp(0.0, 1.0)
}

/// One chain node for every lane of a batch.
#[derive(Clone, Debug, Default)]
pub struct Node {
    /// Position, world space.
    pub x: [Lane; 3],
    /// Position at the previous substep (velocity is `(x - p) / h`).
    pub p: [Lane; 3],
    /// Rest distance to the node 1, 2 and 3 places before this one (edge, bend, torsion).
    pub rest: [Lane; 3],
    /// Six times the signed rest volume of the tetrahedron this node closes with the three
    /// before it, `(b - a) x (c - a) . (d - a)`; 0 for the first three nodes.
    pub volume: Lane,
    /// Anchor position for this frame, bone space.
    pub anchor: [Lane; 3],
}

/// [`LANES`] strands with the same number of particles, solved together.
#[derive(Clone, Debug)]
pub struct Batch {
    /// Strand index (in the groom) of each lane; lanes past `count` repeat lane 0 and are ignored.
    pub strands: [u32; LANES],
    /// Live lanes.
    pub count: usize,
    /// The chain nodes, root first.
    pub nodes: Vec<Node>,
    /// Base (styled) pose, bone space, per node.
    pub local: Vec<[Lane; 3]>,
    /// Keyframe poses (with structural particles), bone space; empty without animation.
    pub keys: Vec<Vec<[Lane; 3]>>,
    /// Collision margin per lane.
    pub margin: Lane,
    /// Per node: for a particle, the rest distance to the particle two before it (the bending
    /// springs of [`StepInput::particles_only`]); 0 for the others and the first two particles.
    pub bend: Vec<Lane>,
}

/// Wind for one frame of one hair.
#[derive(Clone, Debug)]
pub struct WindInput {
    /// The wind (velocity, gusts, seed).
    pub wind: super::HairWind,
    /// The share of the gap between a particle's velocity and the wind's closed per substep:
    /// `1 - exp(-drag h)`.
    pub pull: f32,
    /// Each substep's time (seconds of simulated time), for the gusts.
    pub times: Vec<f32>,
}

/// Per-substep world state the batches are stepped against.
#[derive(Clone, Debug, Default)]
pub struct StepInput {
    /// Substep length, seconds.
    pub h: f32,
    /// Bone pose at the end of each substep.
    pub bones: Vec<Affine3A>,
    /// Collision spheres at each substep: `spheres[s * sphere_count + i]` = (centre, radius).
    pub spheres: Vec<(Vec3A, f32)>,
    /// Spheres per substep.
    pub sphere_count: usize,
    /// How far each entry of `spheres` moved over its substep (for friction).
    pub sphere_shift: Vec<Vec3A>,
    /// Capsules, planes, boxes and keep-inside shapes at each substep:
    /// `contacts[s * contact_count + i]`.
    pub contacts: Vec<Contact>,
    /// Contacts per substep.
    pub contact_count: usize,
    /// Coulomb friction coefficient at every contact (`0` = none).
    pub friction: f32,
    /// Other collider shapes (from rapier or avian colliders), at the frame's final pose.
    pub shapes: Vec<ShapeCollider>,
    /// `gravity * h^2`.
    pub gravity_h2: Vec3,
    /// Velocity kept per substep (`exp(-damping h)`).
    pub damping: f32,
    /// XPBD `alpha~ = compliance / h^2` for edge, bend and torsion springs (`inf` = loose).
    pub alpha: [f32; 3],
    /// Anchor correction factor per node (`0` = free, `1` = held on the anchor).
    pub anchor_factor: Vec<f32>,
    /// With damping in the bone's frame: the bone's rigid motion over each substep (its pose
    /// at the substep's end times the inverse of its pose at the start), one per entry of
    /// `bones`; empty = damping in the world frame.
    pub bone_motion: Vec<Affine3A>,
    /// With an inertia frame ([`HairInertiaFrame`](super::HairInertiaFrame)): that frame's
    /// rigid motion over each substep, which carries every node and its previous position;
    /// empty = none.
    pub carry: Vec<Affine3A>,
    /// Wind, when there is any.
    pub wind: Option<WindInput>,
    /// Local force fields at each substep: `fields[s * field_count + i]`.
    pub fields: Vec<super::FieldStep>,
    /// Force fields per substep.
    pub field_count: usize,
    /// The number of substeps the hair had simulated before this frame (the signed-volume
    /// constraint runs on every other one).
    pub first_substep: u64,
    /// Style limit applied after the last substep: no free node farther than this (metres)
    /// from its anchor; `inf` = none.
    pub style_limit: f32,
    /// Keep the segments between particles off spheres and capsules too, not only the
    /// particles (bone chains, whose joints are far apart; see `sim::segments`).
    pub segments: bool,
    /// Strain limit applied after the last substep: no chain edge (and no particle segment)
    /// longer than this times its rest length; `inf` or below 1 = none.
    pub max_stretch: f32,
    /// Bone chains: only the particles are simulated. Each hangs on the particle before it (an
    /// edge spring) and on the one two before (a bending spring, `alpha[1]`); the first free
    /// particle on the three pinned nodes (its edge, and bending springs to the two pinned
    /// structural points, which hold its angle to the bone). No torsion springs or volumes: a
    /// chain's joints are turned by the shortest arc onto the next particle, so the twist the
    /// structural nodes carry never shows. The structural nodes are placed from the particles
    /// once a frame, at their styled offsets.
    pub particles_only: bool,
}

/// Lane `l` of three lanes, as a vector.
pub(crate) fn get3(a: &[Lane; 3], l: usize) -> Vec3 {
    Vec3::new(a[0][l], a[1][l], a[2][l])
}

/// Sets lane `l` of three lanes to `v`.
pub(crate) fn set3(a: &mut [Lane; 3], l: usize, v: Vec3) {
    a[0][l] = v.x;
    a[1][l] = v.y;
    a[2][l] = v.z;
}

/// The lanes (bit `l` for lane `l`) whose span from `a` to `b` is not outside the box
/// `lo`..`hi` on any axis: per axis, the smaller end above `hi` or the larger below `lo` is
/// outside, with the ends ordered by glam's `min` and `max` as the per-particle tests order
/// them, so the mask is those tests to the bit, NaN included. Four lanes a vector, without a
/// branch per lane; the per-lane code that follows runs only for the lanes set. Pass the same
/// rows twice for points.
#[inline(always)]
pub(crate) fn lanes_near(a: &[Lane; 3], b: &[Lane; 3], lo: Vec3A, hi: Vec3A) -> u32 {
    let four = |row: &Lane, h: usize| Vec4::from_slice(&row[4 * h..4 * h + 4]);
    let mut near = 0;
    for h in 0..LANES / 4 {
        let mut outside = BVec4A::splat(false);
        for c in 0..3 {
            let (p, q) = (four(&a[c], h), four(&b[c], h));
            outside |= p.min(q).cmpgt(Vec4::splat(hi[c])) | p.max(q).cmplt(Vec4::splat(lo[c]));
        }
        near |= (!outside).bitmask() << (4 * h);
    }
    near
}

/// Where a batch's particles are, every lane's (the root's too): a box that skips a shape for
/// the whole batch where [`lanes_near`] would find no lane near it at any particle. Grown as
/// particles move; with a NaN coordinate (which [`lanes_near`] counts as near) it skips nothing.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ParticleSpan {
    lo: Vec3A,
    hi: Vec3A,
    nan: bool,
}

impl ParticleSpan {
    /// Whether every particle is outside the box `lo`..`hi` on one axis (then so is every
    /// particle and every segment between two of them, as [`lanes_near`] tests them).
    #[inline(always)]
    pub(crate) fn apart(&self, lo: Vec3A, hi: Vec3A) -> bool {
        !self.nan && (self.lo.cmpgt(hi).any() || self.hi.cmplt(lo).any())
    }

    /// Grows the box to hold `p`, a particle just moved.
    #[inline(always)]
    pub(crate) fn take(&mut self, p: Vec3A) {
        self.nan |= p.is_nan();
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
}

/// The lanes set in `mask`, lowest first.
#[inline(always)]
pub(crate) fn set_lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            l
        })
    })
}

/// `m * v` for every lane.
#[inline(always)]
pub(super) fn transform(m: &Affine3A, v: &[Lane; 3]) -> [Lane; 3] {
    let (c0, c1, c2, t) = (
        m.matrix3.x_axis,
        m.matrix3.y_axis,
        m.matrix3.z_axis,
        m.translation,
    );
    let mut o = [[0.0; LANES]; 3];
    for l in 0..LANES {
        let (x, y, z) = (v[0][l], v[1][l], v[2][l]);
        o[0][l] = c0.x * x + c1.x * y + c2.x * z + t.x;
        o[1][l] = c0.y * x + c1.y * y + c2.y * z + t.y;
        o[2][l] = c0.z * x + c1.z * y + c2.z * z + t.z;
    }
    o
}

impl Batch {
    /// A batch from chains (bone space, all of the same length; 1 to [`LANES`] of them).
    pub fn new(
        strands: &[u32],
        chains: &[&[Vec3]],
        keys: &[Vec<&[Vec3]>],
        margins: &[f32],
    ) -> Self {
        let count = chains.len().clamp(1, LANES);
        let nodes = chains[0].len();
        let lane = |l: usize| if l < count { l } else { 0 };
        let mut local = vec![[[0.0; LANES]; 3]; nodes];
        let mut bend = vec![[0.0; LANES]; nodes];
        let mut out = Vec::with_capacity(nodes);
        for k in 0..nodes {
            let mut node = Node::default();
            for l in 0..LANES {
                let c = chains[lane(l)];
                set3(&mut local[k], l, c[k]);
                set3(&mut node.anchor, l, c[k]);
                for s in 0..3 {
                    node.rest[s][l] = if k > s {
                        c[k].distance(c[k - s - 1])
                    } else {
                        0.0
                    };
                }
                if k >= 3 {
                    node.volume[l] = signed_volume(c[k - 3], c[k - 2], c[k - 1], c[k]);
                }
                if k >= 5 && k % 2 == 1 {
                    bend[k][l] = c[k].distance(c[k - 4]);
                }
            }
            out.push(node);
        }
        let keys = keys
            .iter()
            .map(|key_chains| {
                let mut pose = vec![[[0.0; LANES]; 3]; nodes];
                for (k, p) in pose.iter_mut().enumerate() {
                    for l in 0..LANES {
                        set3(p, l, key_chains[lane(l)][k]);
                    }
                }
                pose
            })
            .collect();
        let mut ids = [strands[0]; LANES];
        let mut margin = [margins[0]; LANES];
        ids[..count].copy_from_slice(&strands[..count]);
        margin[..count].copy_from_slice(&margins[..count]);
        Self {
            strands: ids,
            count,
            nodes: out,
            local,
            keys,
            margin,
            bend,
        }
    }

    /// Puts every node on its base pose under `bone`, at rest.
    pub fn reset(&mut self, bone: &Affine3A) {
        for (node, local) in self.nodes.iter_mut().zip(&self.local) {
            node.x = transform(bone, local);
            node.p = node.x;
        }
    }

    /// Resets only lane `l` (after a non-finite value appeared in it).
    pub fn reset_lane(&mut self, l: usize, bone: &Affine3A) {
        for (node, local) in self.nodes.iter_mut().zip(&self.local) {
            let v = bone.transform_point3(get3(local, l));
            set3(&mut node.x, l, v);
            set3(&mut node.p, l, v);
        }
    }

    /// Moves every node (and its previous position) by `delta`: the hair rides along with a
    /// teleporting bone without gaining velocity.
    pub fn carry(&mut self, delta: &Affine3A) {
        for node in &mut self.nodes {
            node.x = transform(delta, &node.x);
            node.p = transform(delta, &node.p);
        }
    }

    /// Blends the keyframe poses into this frame's anchors: `sum(weight * key)`.
    pub fn blend_anchors(&mut self, weights: &[(usize, f32)]) {
        if self.keys.is_empty() {
            return;
        }
        for (k, node) in self.nodes.iter_mut().enumerate() {
            let mut a = [[0.0; LANES]; 3];
            for &(key, w) in weights {
                let pose = &self.keys[key.min(self.keys.len() - 1)][k];
                for c in 0..3 {
                    for l in 0..LANES {
                        a[c][l] += w * pose[c][l];
                    }
                }
            }
            node.anchor = a;
        }
    }

    /// Lanes whose state is not finite (bit `l` set for lane `l`). Checking positions suffices:
    /// a non-finite previous position makes the position non-finite at the next substep.
    pub fn non_finite_lanes(&self) -> u32 {
        // `x * 0` is 0 for finite x and NaN for NaN or infinity; the sum keeps any NaN.
        let mut acc = [0.0f32; LANES];
        for node in &self.nodes {
            for c in 0..3 {
                for l in 0..LANES {
                    acc[l] += node.x[c][l] * 0.0;
                }
            }
        }
        let mut bad = 0u32;
        for (l, a) in acc.iter().enumerate() {
            if a.is_nan() {
                bad |= 1 << l;
            }
        }
        bad
    }

    /// Position of particle `i` (not structural) of lane `l`.
    pub fn particle(&self, l: usize, i: usize) -> Vec3 {
        get3(&self.nodes[2 * i + 1].x, l)
    }

    /// Moves particle `i` of lane `l` to `p` (its previous position stays: the move is motion
    /// the solver sees, as a limit that cuts a step short).
    pub fn set_particle(&mut self, l: usize, i: usize, p: Vec3) {
        set3(&mut self.nodes[2 * i + 1].x, l, p);
    }

    /// Moves particle `i` of lane `l` to `p` and its previous position with it: its velocity
    /// kept, none made by the move (as the style and stretch limits move particles).
    pub fn move_particle(&mut self, l: usize, i: usize, p: Vec3) {
        let node = &mut self.nodes[2 * i + 1];
        let d = p - get3(&node.x, l);
        set3(&mut node.x, l, p);
        let q = get3(&node.p, l) + d;
        set3(&mut node.p, l, q);
    }

    /// Anchor (keyframe target) of chain node `k` of lane `l`, bone space.
    pub fn anchor(&self, l: usize, k: usize) -> Vec3 {
        get3(&self.nodes[k].anchor, l)
    }

    /// Rest position (the styled pose in the bone's rigid space) of chain node `k` of lane `l`.
    pub fn rest(&self, l: usize, k: usize) -> Vec3 {
        get3(&self.local[k], l)
    }

    /// Position of any chain node of lane `l`.
    pub fn node(&self, l: usize, k: usize) -> Vec3 {
        get3(&self.nodes[k].x, l)
    }

    /// Advances the batch through every substep of `input`.
    ///
    /// On x86-64 CPUs with AVX2 the same code runs compiled for 8-wide vectors (the portable
    /// baseline is 4-wide SSE2). Rust never fuses `a * b + c` on its own, so both paths give
    /// bit-identical results.
    pub fn step(&mut self, input: &StepInput) {
        self.step_with(input, &input.anchor_factor);
    }

    /// [`Batch::step`] with the anchor factors per node given apart from `input` (whose own
    /// `anchor_factor` is then not read), so batches of different chain lengths share one input.
    pub fn step_with(&mut self, input: &StepInput, anchors: &[f32]) {
        step_interleaved([self], input, anchors);
    }

    /// Steps `N` batches of one chain length with the same `input` and anchor factors, their
    /// chains' dependent arithmetic interleaved (each spring of one batch beside the same spring
    /// of the others), so the processor overlaps what one batch alone waits for. Each batch ends
    /// bit for bit where [`Batch::step_with`] would take it. The simulation steps three at a
    /// time.
    ///
    /// # Panics
    /// If the batches' chains are not all the same length.
    pub fn step_together<const N: usize>(
        batches: [&mut Batch; N],
        input: &StepInput,
        anchors: &[f32],
    ) {
        let n = batches.first().map_or(0, |b| b.nodes.len());
        assert!(
            batches.iter().all(|b| b.nodes.len() == n),
            "batches stepped together step chains of one length"
        );
        step_interleaved(batches, input, anchors);
    }

    /// The box of every lane's particles, root included ([`ParticleSpan`]).
    #[inline(always)]
    pub(crate) fn particle_span(&self) -> ParticleSpan {
        let mut lo = [[f32::INFINITY; LANES]; 3];
        let mut hi = [[f32::NEG_INFINITY; LANES]; 3];
        let mut nan = [0u32; LANES];
        // Lane by lane, so the compiler keeps eight lanes a register; `if` rather than
        // `f32::min`, which would test for NaN in every step; a NaN kept as a bit, not a
        // `bool` (bytes the compiler would pack from the lanes' masks every row).
        for node in self.nodes.iter().skip(1).step_by(2) {
            for c in 0..3 {
                for l in 0..LANES {
                    let v = node.x[c][l];
                    nan[l] |= u32::from(v.is_nan());
                    lo[c][l] = if v < lo[c][l] { v } else { lo[c][l] };
                    hi[c][l] = if v > hi[c][l] { v } else { hi[c][l] };
                }
            }
        }
        let fold = |rows: &[Lane; 3], pick: fn(f32, f32) -> f32| {
            Vec3A::from_array(rows.map(|row| row.into_iter().reduce(pick).unwrap_or(0.0)))
        };
        ParticleSpan {
            lo: fold(&lo, f32::min),
            hi: fold(&hi, f32::max),
            nan: nan.iter().fold(0, |a, &m| a | m) != 0,
        }
    }

    /// Every collider of substep `s`; `swept`: along each particle's path this substep.
    #[inline(always)]
    fn collide(&mut self, input: &StepInput, s: usize, swept: bool) {
        let c = input.sphere_count;
        let range = s * c..(s + 1) * c;
        self.collide_spheres(
            &input.spheres[range.clone()],
            input.sphere_shift.get(range).unwrap_or(&[]),
            input.friction,
        );
        // The box of the particles, measured once: the contacts grow it with the particles
        // they move, and the segments' pass starts from it.
        let mut span = None;
        let c = input.contact_count;
        if c > 0 {
            let contacts = &input.contacts[s * c..(s + 1) * c];
            let span = span.insert(self.particle_span());
            self.collide_contacts(contacts, input.friction, swept, span);
        }
        if !input.shapes.is_empty() {
            self.collide_shapes(&input.shapes, input.friction);
            // Moved without growing the box.
            span = None;
        }
        if input.segments {
            let mut span = span.unwrap_or_else(|| self.particle_span());
            self.collide_segments(input, s, &mut span);
        }
    }

    /// The free nodes the solver moves: every node past the pinned ones, or with
    /// `particles_only` ([`StepInput::particles_only`]) the particles alone (the structural
    /// nodes are placed from them once a frame).
    #[inline(always)]
    pub(super) fn free_nodes_mut(
        &mut self,
        particles_only: bool,
    ) -> impl Iterator<Item = &mut Node> {
        let step = if particles_only { 2 } else { 1 };
        self.nodes.iter_mut().skip(PINNED).step_by(step)
    }

    /// Damping in the bone's frame, before a substep whose bone motion is `m`: only the velocity
    /// relative to the point the bone carries along should be damped, so hair riding a moving
    /// bone (a character in a vehicle) keeps its velocity. The prediction damps all of `x - p`
    /// by `d`; moving `p` by `vb (1 - 1/d)` (`vb = m x - x`) leaves it damping only `x - p - vb`.
    #[inline(always)]
    fn damp_in_bone_frame(&mut self, m: &Affine3A, d: f32, particles_only: bool) {
        let k = 1.0 - 1.0 / d.max(1e-6);
        for node in self.free_nodes_mut(particles_only) {
            let carried = transform(m, &node.x);
            for c in 0..3 {
                for l in 0..LANES {
                    node.p[c][l] += (carried[c][l] - node.x[c][l]) * k;
                }
            }
        }
    }

    /// Force fields before a substep: each free node's velocity is pulled toward each field's
    /// air (see [`FieldStep::blow`](super::FieldStep::blow)), written into its previous position
    /// like the wind's.
    fn blow_fields(&mut self, fields: &[super::FieldStep], damping: f32, particles_only: bool) {
        let d = damping.max(1e-6);
        for node in self.free_nodes_mut(particles_only) {
            for l in 0..LANES {
                let x = get3(&node.x, l);
                let v = (x - get3(&node.p, l)) * d;
                let blown = fields.iter().fold(v, |v, field| field.blow(x, v));
                // Nodes no field reaches keep their state bit for bit.
                if blown != v {
                    set3(&mut node.p, l, x - blown / d);
                }
            }
        }
    }

    /// Wind drag before substep `s`: each free node's velocity `v` becomes
    /// `v + (w h - v) pull` (`w` the wind's velocity with this strand's gust), written into its
    /// previous position so the prediction that follows integrates it.
    #[inline(always)]
    fn blow(&mut self, w: &WindInput, s: usize, phases: &[f32; LANES], input: &StepInput) {
        let t = w.times.get(s).copied().unwrap_or(0.0);
        let d = input.damping.max(1e-6);
        let base = w.wind.velocity * input.h;
        let mut target = [[0.0; LANES]; 3];
        for (l, phase) in phases.iter().enumerate() {
            let g = w.wind.gust_factor(t, *phase);
            target[0][l] = base.x * g;
            target[1][l] = base.y * g;
            target[2][l] = base.z * g;
        }
        for node in self.free_nodes_mut(input.particles_only) {
            for c in 0..3 {
                for l in 0..LANES {
                    let x = node.x[c][l];
                    let v = (x - node.p[c][l]) * d;
                    let blown = v + (target[c][l] - v) * w.pull;
                    node.p[c][l] = x - blown / d;
                }
            }
        }
    }

    /// Pulls node `k` toward its anchor (the last change to it in a substep before collisions).
    #[inline(always)]
    pub(super) fn solve_anchor(&mut self, k: usize, anchors: &[f32], bone: &Affine3A) {
        let f = anchors.get(k).copied().unwrap_or(0.0);
        if f <= 0.0 {
            return;
        }
        let node = &mut self.nodes[k];
        let a = transform(bone, &node.anchor);
        for c in 0..3 {
            for l in 0..LANES {
                node.x[c][l] += (a[c][l] - node.x[c][l]) * f;
            }
        }
    }

    /// Pushes free particles out of spheres grown by each lane's margin; with `friction`, the
    /// push also slows their motion along the sphere (relative to its `shifts`).
    #[inline(always)]
    fn collide_spheres(&mut self, spheres: &[(Vec3A, f32)], shifts: &[Vec3A], friction: f32) {
        for (i, &(centre, radius)) in spheres.iter().enumerate() {
            if friction > 0.0 {
                let shift = shifts.get(i).copied().unwrap_or(Vec3A::ZERO);
                let mut span = self.particle_span();
                self.collide_contacts(
                    &[Contact::new(
                        ContactShape::Sphere { centre, radius },
                        false,
                        shift,
                        f32::INFINITY,
                    )],
                    friction,
                    false,
                    &mut span,
                );
                continue;
            }
            let mut reach = [0.0; LANES];
            for l in 0..LANES {
                reach[l] = radius + self.margin[l];
            }
            for node in self.nodes.iter_mut().skip(PINNED).step_by(2) {
                // Every lane's push worked out and kept only where it is inside, by a bit mask
                // (no branch or select per lane, which the compiler would make scalar again), so
                // the lanes go side by side; the lanes outside keep their bits. A row with no
                // lane inside (most rows of a strand hanging off the head) is left as it is.
                let x = &mut node.x;
                let mut d = [[0.0f32; LANES]; 3];
                let (mut d2, mut inside) = ([0.0f32; LANES], [0u32; LANES]);
                for l in 0..LANES {
                    d[0][l] = x[0][l] - centre.x;
                    d[1][l] = x[1][l] - centre.y;
                    d[2][l] = x[2][l] - centre.z;
                    d2[l] = d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l];
                    inside[l] = u32::from(d2[l] < reach[l] * reach[l]).wrapping_neg();
                }
                if inside.iter().fold(0, |a, &m| a | m) == 0 {
                    continue;
                }
                let (mut f, mut keep, mut top) = ([0.0f32; LANES], [0u32; LANES], [0u32; LANES]);
                for l in 0..LANES {
                    let len = d2[l].sqrt();
                    f[l] = reach[l] / len;
                    // At the centre itself: straight up.
                    keep[l] = inside[l] & u32::from(len > 1e-9).wrapping_neg();
                    top[l] = inside[l] & !keep[l];
                }
                let c = [centre.x, centre.y, centre.z];
                for a in 0..3 {
                    for l in 0..LANES {
                        let pushed = (c[a] + d[a][l] * f[l]).to_bits();
                        let old = x[a][l].to_bits();
                        x[a][l] = f32::from_bits((pushed & keep[l]) | (old & !keep[l]));
                    }
                }
                for l in 0..LANES {
                    let up = (centre.y + reach[l]).to_bits();
                    x[1][l] = f32::from_bits((up & top[l]) | (x[1][l].to_bits() & !top[l]));
                }
            }
        }
    }

    /// Keeps free particles the margin outside (or inside) analytic shapes, along their path
    /// relative to the shape this substep (so a fast shape pushes them ahead instead of passing
    /// them), with friction. `span` holds every particle ([`Batch::particle_span`]), and grows
    /// with those moved.
    fn collide_contacts(
        &mut self,
        contacts: &[Contact],
        friction: f32,
        swept: bool,
        span: &mut ParticleSpan,
    ) {
        for contact in contacts {
            let (lo, hi) = contact.reach;
            // No particle of any lane within its reach: the per-particle tests below would each
            // find none.
            if span.apart(lo, hi) {
                continue;
            }
            for node in self.nodes.iter_mut().skip(PINNED).step_by(2) {
                // Particles outside the shape's reach are left as they are.
                for l in set_lanes(lanes_near(&node.x, &node.x, lo, hi)) {
                    let x = get3(&node.x, l);
                    let p = get3(&node.p, l);
                    // Where the particle was this substep's start, relative to where the shape
                    // is now.
                    let from = if swept {
                        Vec3A::from(p) + contact.shift
                    } else {
                        Vec3A::from(x)
                    };
                    let Some(to) =
                        contact
                            .shape
                            .resolve_swept(from, x.into(), self.margin[l], contact.inside)
                    else {
                        continue;
                    };
                    let to = Vec3::from(to);
                    let to = if friction > 0.0 {
                        super::contact::rub(x, to, p, contact.shift.into(), friction)
                    } else {
                        to
                    };
                    set3(&mut node.x, l, to);
                    span.take(to.into());
                }
            }
        }
    }

    /// Pushes free particles out of arbitrary shapes (the engine's point projection), keeping
    /// the margin.
    fn collide_shapes(&mut self, shapes: &[ShapeCollider], friction: f32) {
        for node in self.nodes.iter_mut().skip(PINNED).step_by(2) {
            // Every shape tests where the particle was before any of them moved it.
            let before = node.x;
            for sc in shapes {
                let (lo, hi) = (sc.aabb_min.into(), sc.aabb_max.into());
                for l in set_lanes(lanes_near(&before, &before, lo, hi)) {
                    let x = get3(&before, l);
                    let m = self.margin[l];
                    let (point, inside) = sc.shape.project(x);
                    let to_surface = point - x;
                    let dist = to_surface.length();
                    let moved = if inside {
                        // Inside: out through the nearest surface point, then the margin.
                        let out = if dist > 1e-9 {
                            to_surface / dist
                        } else {
                            Vec3::Y
                        };
                        Some(point + out * m)
                    } else if dist < m && dist > 1e-9 {
                        Some(point - to_surface / dist * m)
                    } else {
                        None
                    };
                    if let Some(v) = moved {
                        let v = if friction > 0.0 {
                            super::contact::rub(x, v, get3(&node.p, l), Vec3::ZERO, friction)
                        } else {
                            v
                        };
                        set3(&mut node.x, l, v);
                    }
                }
            }
        }
    }
}

/// Steps every batch of `batches` (chains of one length) through every substep of `input`,
/// choosing the AVX2 build where the CPU has it.
fn step_interleaved<const N: usize>(batches: [&mut Batch; N], input: &StepInput, anchors: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    if crate::simd::avx2() {
        // SAFETY: `simd::avx2` found AVX2 on this CPU at run time, just above.
        unsafe { step_avx2(batches, input, anchors) };
        return;
    }
    step_portable(batches, input, anchors);
}

/// [`step_portable`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn step_avx2<const N: usize>(batches: [&mut Batch; N], input: &StepInput, anchors: &[f32]) {
    step_portable(batches, input, anchors);
}

/// The solver loop; inlined into each target-feature variant. The batches take each substep's
/// stages one after another, except the pass down the chains, which interleaves them.
#[inline(always)]
fn step_portable<const N: usize>(mut batches: [&mut Batch; N], input: &StepInput, anchors: &[f32]) {
    let phases = input.wind.as_ref().map(|w| {
        batches
            .each_ref()
            .map(|b| b.strands.map(|strand| w.wind.phase(strand)))
    });
    for (s, bone) in input.bones.iter().enumerate() {
        for (i, batch) in batches.iter_mut().enumerate() {
            let n = batch.nodes.len();
            if let Some(m) = input.carry.get(s) {
                batch.carry(m);
            }
            // Pinned nodes follow the bone.
            for k in 0..PINNED.min(n) {
                let x = transform(bone, &batch.local[k]);
                batch.nodes[k].x = x;
                batch.nodes[k].p = x;
            }
            if let (Some(w), Some(phases)) = (&input.wind, &phases) {
                batch.blow(w, s, &phases[i], input);
            }
            let f = input.field_count;
            if f > 0 {
                let fields = &input.fields[s * f..(s + 1) * f];
                batch.blow_fields(fields, input.damping, input.particles_only);
            }
            if let Some(m) = input.bone_motion.get(s) {
                batch.damp_in_bone_frame(m, input.damping, input.particles_only);
            }
        }
        // Volumes every other substep (counted from the hair's first): enough to keep the
        // style the only rest state, at half the cost.
        // Loose torsion (stiffness 0) asks for a free strand: no volumes then.
        let volumes =
            (input.first_substep + s as u64).is_multiple_of(2) && input.alpha[2].is_finite();
        if input.particles_only {
            Batch::integrate_particles(&mut batches, input, anchors, bone);
        } else {
            integrate_and_solve(&mut batches, input, anchors, bone, volumes);
        }
        for batch in &mut batches {
            batch.collide(input, s, true);
        }
    }
    // Once a frame, after the last substep; then the last substep's collisions again, so
    // nothing the limit pulled in stays inside a collider.
    let last = input.bones.len();
    let stretch = input.max_stretch.is_finite() && input.max_stretch >= 1.0;
    let style = input.style_limit.is_finite() && input.style_limit >= 0.0;
    if last > 0 && (stretch || style) {
        for batch in &mut batches {
            let pulled = stretch && batch.limit_stretch(input.max_stretch, input.particles_only);
            if style {
                let bone = &input.bones[last - 1];
                batch.limit_to_style(input.style_limit, bone, input.particles_only);
            }
            // Where the limits left them: no path to follow. A batch the limits left alone is
            // where the last substep's collisions put it.
            if pulled || style {
                batch.collide(input, last - 1, false);
            }
        }
    }
    if input.particles_only
        && let Some(bone) = input.bones.last()
    {
        for batch in &mut batches {
            batch.place_structure(bone);
        }
    }
}

/// One pass down the chains: each free node is predicted (Verlet, damping, gravity), then its
/// edge, bending and torsion springs to the three nodes before it are solved (Gauss-Seidel),
/// then the anchor spring of the node three back, which no later spring touches this
/// substep. Fusing them walks each node once per substep. With several batches, each stage of
/// node `k` runs for every batch before the next stage: the batches' chains are independent,
/// so one batch's arithmetic fills the time another waits on its square roots and divisions.
#[inline(always)]
fn integrate_and_solve<const N: usize>(
    batches: &mut [&mut Batch; N],
    input: &StepInput,
    anchors: &[f32],
    bone: &Affine3A,
    volumes: bool,
) {
    let g = input.gravity_h2.to_array();
    let d = input.damping;
    let n = batches[0].nodes.len();
    for k in PINNED..n {
        // Node k stays in registers through its prediction and its three springs.
        let mut xk = [[[0.0; LANES]; 3]; N];
        for b in 0..N {
            xk[b] = predict(&mut batches[b].nodes[k], g, d);
        }
        for s in 0..3 {
            // Two nodes apart, particle to particle (odd k), is the strand's own segment:
            // an edge spring. Structural to structural (even k) is a bending spring.
            let alpha = if s == 1 && k % 2 == 1 {
                input.alpha[0]
            } else {
                input.alpha[s]
            };
            if k < s + 1 || alpha.is_infinite() {
                continue;
            }
            let j = k - s - 1;
            let wj = if j < PINNED { 0.0 } else { 1.0 };
            for b in 0..N {
                let (head, tail) = batches[b].nodes.split_at_mut(k);
                solve_distance(&mut head[j].x, &mut xk[b], &tail[0].rest[s], wj, alpha);
            }
        }
        // Distances alone also hold the mirror image of the style: hold the tetrahedron's
        // signed volume too, so the style is the only rest state.
        if volumes && k >= 3 {
            let w = |j: usize| if j < PINNED { 0.0 } else { 1.0 };
            for b in 0..N {
                let (head, tail) = batches[b].nodes.split_at_mut(k);
                let [p, q, r] = &mut head[k - 3..k] else {
                    unreachable!()
                };
                solve_volume(
                    [&mut p.x, &mut q.x, &mut r.x, &mut xk[b]],
                    [w(k - 3), w(k - 2), w(k - 1), 1.0],
                    &tail[0].volume,
                );
            }
        }
        for b in 0..N {
            batches[b].nodes[k].x = xk[b];
            // Node k-3 is touched by no later spring this substep: its anchor can go now.
            if k >= PINNED + 3 {
                batches[b].solve_anchor(k - 3, anchors, bone);
            }
        }
    }
    for batch in batches.iter_mut() {
        for k in n.saturating_sub(3).max(PINNED)..n {
            batch.solve_anchor(k, anchors, bone);
        }
    }
}

/// Node `node` predicted for the substep (Verlet with damping `d`, then gravity `g`): returns
/// where it goes and keeps where it was as its previous position.
#[inline(always)]
pub(super) fn predict(node: &mut Node, g: [f32; 3], d: f32) -> [Lane; 3] {
    let mut xk = node.x;
    for c in 0..3 {
        for l in 0..LANES {
            let x = xk[c][l];
            let v = (x - node.p[c][l]) * d;
            node.p[c][l] = x;
            xk[c][l] = x + v + g[c];
        }
    }
    xk
}

/// Six times the signed volume of the tetrahedron `(a, b, c, d)`: `(b - a) x (c - a) . (d - a)`.
/// Its sign is the tetrahedron's orientation, which a mirror image flips.
pub(crate) fn signed_volume(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> f32 {
    (b - a).cross(c - a).dot(d - a)
}

/// Restores each lane's signed tetrahedron volume `(x0, x1, x2, x3)` toward `rest` (six times
/// the rest volume), moving every node whose inverse mass `w` is 1 along its gradient (PBD, full
/// correction). Distance springs alone keep only `|volume|`, so without this a strand can settle
/// in the mirror image of its style and stay there.
#[inline(always)]
fn solve_volume(x: [&mut [Lane; 3]; 4], w: [f32; 4], rest: &Lane) {
    let [r0, r1, r2, r3] = x;
    // Local copies: the compiler then knows the four never alias, and vectorises across lanes.
    let (mut x0, mut x1, mut x2, mut x3) = (*r0, *r1, *r2, *r3);
    for l in 0..LANES {
        let p0 = [x0[0][l], x0[1][l], x0[2][l]];
        let e1 = [x1[0][l] - p0[0], x1[1][l] - p0[1], x1[2][l] - p0[2]];
        let e2 = [x2[0][l] - p0[0], x2[1][l] - p0[1], x2[2][l] - p0[2]];
        let e3 = [x3[0][l] - p0[0], x3[1][l] - p0[1], x3[2][l] - p0[2]];
        let g1 = cross(e2, e3);
        let g2 = cross(e3, e1);
        let g3 = cross(e1, e2);
        let g0 = [
            -(g1[0] + g2[0] + g3[0]),
            -(g1[1] + g2[1] + g3[1]),
            -(g1[2] + g2[2] + g3[2]),
        ];
        let volume = dot(g3, e3);
        let denom =
            w[0] * dot(g0, g0) + w[1] * dot(g1, g1) + w[2] * dot(g2, g2) + w[3] * dot(g3, g3);
        // Where every gradient is zero (a flat, degenerate tetrahedron) the correction is zero
        // whatever lambda is.
        let lambda = (rest[l] - volume) / denom.max(1e-30);
        for c in 0..3 {
            x0[c][l] += lambda * (g0[c] * w[0]);
            x1[c][l] += lambda * (g1[c] * w[1]);
            x2[c][l] += lambda * (g2[c] * w[2]);
            x3[c][l] += lambda * (g3[c] * w[3]);
        }
    }
    (*r0, *r1, *r2, *r3) = (x0, x1, x2, x3);
}

#[inline(always)]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
pub(super) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// XPBD distance constraint between positions `xj` (inverse mass `wj`) and `xk` (inverse mass 1)
/// with rest lengths `rest`.
#[inline(always)]
pub(super) fn solve_distance(
    xj: &mut [Lane; 3],
    xk: &mut [Lane; 3],
    rest: &Lane,
    wj: f32,
    alpha: f32,
) {
    let inv_denom = 1.0 / (wj + 1.0 + alpha);
    for l in 0..LANES {
        let dx = xk[0][l] - xj[0][l];
        let dy = xk[1][l] - xj[1][l];
        let dz = xk[2][l] - xj[2][l];
        let len = (dx * dx + dy * dy + dz * dz).sqrt();
        let f = (len - rest[l]) * inv_denom / len.max(1e-9);
        xk[0][l] -= f * dx;
        xk[1][l] -= f * dy;
        xk[2][l] -= f * dz;
        xj[0][l] += wj * f * dx;
        xj[1][l] += wj * f * dy;
        xj[2][l] += wj * f * dz;
    }
}

#[cfg(test)]
#[path = "solver_tests.rs"]
mod tests;
