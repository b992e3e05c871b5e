//! Posing bone chains from their solved particles: each joint turned, root to tip, to point at
//! its next particle (kept at the bone's length, off the hair's colliders and inside the
//! joint's angle limit), and its local and global transforms written so Bevy's skinning draws
//! this frame's pose.
//!
//! The poses are worked out hair by hair, on every core (each hair reads its own solver state
//! and its joints' bind transforms; the chains of each solver batch are posed side by side in
//! the solver's lanes, see `chain_lanes`, and a chain that needs more is posed alone here, one
//! joint at a time), then written (`write_out`). Most hairs are posed by the step, on the
//! thread that stepped them, right after their substeps ([`pose_chain_hair`]), and their joints
//! written by that thread too; [`pose_bone_chains`] poses the rest (a hair whose batches the
//! step shared out over the threads, or whose volume pass ran after the step, or one not built
//! yet), and runs only in frames that have such a hair; their joints are written joint by joint
//! after.
//!
//! Bevy's transform propagation does not visit most of the joints a hair poses (those its
//! hair's build took over: see `chains::owned_from`), since every frame it would compute world
//! transforms that posing replaces. So every joint is written each frame (a chain posing cannot
//! turn follows its bind pose), and whatever hangs below a joint that is not a joint is
//! propagated from it.

use bevy::ecs::batching::BatchingStrategy;
use bevy::math::{Affine3A, Mat3A, Vec3A};
use bevy::prelude::*;

use super::attach::ComputedHair;
use super::chain_lanes::{LaneJoints, ParticleBox};
use super::chains::BoneChainHair;
use super::collider::{HairCollider, HairCollidesOnly, bounds_of};
use super::contact::ContactShape;
use super::limits::{limit_frame, limit_offset};
use super::settings::HairSimSettings;

/// A bone-chain hair's posing buffers, kept between frames.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ChainPose {
    /// This frame's poses and the buffers they are worked out in.
    buffers: PoseBuffers,
    /// The collider shapes near the hair this frame.
    near: Vec<NearShape>,
    /// Posed this frame by the step, right after its substeps (set by the step every frame).
    pub(super) posed_early: bool,
    /// Every joint posed this frame was also written by the thread that posed it
    /// ([`EarlyJoints::write`](super::write_out::EarlyJoints::write)): the write after the step
    /// leaves the hair alone.
    pub(super) joints_written: bool,
}

impl ChainPose {
    /// This frame's pose of each joint.
    pub(super) fn posed(&self) -> &[Pose] {
        &self.buffers.posed
    }
}

/// A joint's pose: its entity, its local rotation, its world transform.
pub(super) type Pose = (Entity, Quat, Affine3A);

/// One hair's poses and what working them out needs, kept between frames.
#[derive(Clone, Debug, Default)]
pub(super) struct PoseBuffers {
    /// This frame's pose of each joint: its entity, its local rotation, its world transform.
    pub(super) posed: Vec<Pose>,
    /// The slot of each chain's first joint in `posed`.
    pub(super) first: Vec<usize>,
    /// The particles of a chain posed one joint at a time.
    pub(super) particles: Vec<Vec3>,
    /// The joints in the solver's lane order.
    pub(super) lanes: LaneJoints,
}

/// How a hair's chains are posed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PosePath {
    /// The chains of each solver batch side by side, one joint of each at a time, in the
    /// solver's lanes (under a uniform scale; a chain that needs more is posed alone).
    Lanes,
    /// Each chain alone, one joint at a time.
    #[cfg(test)]
    Alone,
}

/// On a joint a bone-chain hair poses: the hair, and the joint's slot in its poses.
#[derive(Component, Clone, Copy, Debug)]
pub(crate) struct ChainJoint {
    pub(crate) hair: Entity,
    pub(crate) slot: u32,
    /// The joint's next slot's entity when its children were last looked at, and whether one
    /// of them is not that entity (so is propagated from the joint): looked at again only when
    /// its children or that entity change, since reading every joint's children each frame
    /// costs a visit to memory far from the rest. `None`: not looked at yet.
    pub(crate) others: Option<(Option<Entity>, bool)>,
    /// Another hair was built on this joint too (its chains take it as well), and may read its
    /// transform while the step runs: the joint is written after the step, never by the
    /// thread that posed it.
    pub(crate) shared: bool,
}

impl ChainJoint {
    /// The joint in `slot` of `hair`'s poses; `shared`: another hair takes it too.
    pub(crate) fn new(hair: Entity, slot: u32, shared: bool) -> Self {
        Self {
            hair,
            slot,
            others: None,
            shared,
        }
    }
}

/// A collider shape near a hair: the shape, whether it keeps particles inside, and where a
/// point can touch it (its bounds grown by the hair's margin; everywhere for keep-inside).
pub(super) type NearShape = (ContactShape, bool, Vec3A, Vec3A);

/// Every [`HairCollider`]'s shapes where they are this frame, gathered once for all hairs.
#[derive(Default)]
pub(crate) struct FrameShapes {
    /// Per collider: its entity, its run of `shapes`, its shapes' bounds (infinite for keep
    /// inside colliders and planes).
    colliders: Vec<(Entity, usize, usize, Vec3A, Vec3A)>,
    shapes: Vec<(ContactShape, bool)>,
}

impl FrameShapes {
    /// Every collider's shapes where they are now, and their bounds.
    pub(super) fn gather<'a>(
        &mut self,
        colliders: impl IntoIterator<Item = (Entity, &'a HairCollider, &'a GlobalTransform)>,
    ) {
        self.clear();
        for (e, collider, g) in colliders {
            let pose = g.affine();
            self.add(e, collider.inside(), collider.shapes().map(|s| s.at(&pose)));
        }
    }

    /// No collider.
    pub(super) fn clear(&mut self) {
        self.colliders.clear();
        self.shapes.clear();
    }

    /// Adds collider `e`'s shapes, `posed` where they are now; returns their bounds (infinite
    /// for a keep-inside collider; empty, min above max, for a collider without shapes).
    pub(super) fn add(
        &mut self,
        e: Entity,
        inside: bool,
        posed: impl IntoIterator<Item = ContactShape>,
    ) -> (Vec3A, Vec3A) {
        let first = self.shapes.len();
        self.shapes.extend(posed.into_iter().map(|s| (s, inside)));
        let (lo, hi) = bounds_of(inside, self.shapes[first..].iter().map(|&(s, _)| s));
        self.colliders.push((e, first, self.shapes.len(), lo, hi));
        (lo, hi)
    }
}

/// What posing needs from the frame, gathered once for every hair.
#[derive(Default)]
pub(crate) struct PoseFrame {
    /// The colliders where they are now.
    shapes: FrameShapes,
    /// Hairs whose joints' transforms changed (an animation, the game) or went since last
    /// frame, sorted: their joints are read again. Posing itself stores rotations without
    /// flagging them.
    stale: Vec<Entity>,
    /// Joints some hair's step reads the world transform of (an inertia frame on a joint),
    /// sorted: written after the step, never by the thread that posed them.
    pub(super) read_elsewhere: Vec<Entity>,
}

impl PoseFrame {
    /// The colliders' shapes, to be filled with [`FrameShapes::add`].
    pub(super) fn shapes_mut(&mut self) -> &mut FrameShapes {
        &mut self.shapes
    }

    /// The `colliders` where they are now.
    pub(super) fn gather_colliders<'a>(
        &mut self,
        colliders: impl IntoIterator<Item = (Entity, &'a HairCollider, &'a GlobalTransform)>,
    ) {
        self.shapes.gather(colliders);
    }

    /// The joints some hair's step reads the world transform of.
    pub(super) fn gather_read_elsewhere(&mut self, joints: impl IntoIterator<Item = Entity>) {
        self.read_elsewhere.clear();
        self.read_elsewhere.extend(joints);
        self.read_elsewhere.sort_unstable();
        self.read_elsewhere.dedup();
    }

    /// The hairs whose joints changed: `hairs`, one for each changed joint.
    pub(super) fn gather_stale(&mut self, hairs: impl IntoIterator<Item = Entity>) {
        self.stale.clear();
        self.stale.extend(hairs);
        self.stale.sort_unstable();
        self.stale.dedup();
    }
}

/// Poses one bone-chain hair (see [`pose_hair`]) into its [`ChainPose`]: its joints' bind
/// transforms read again when `rebuilt` (its [`BoneChainHair`] changed) or its joints changed
/// this frame, the colliders near its particles gathered.
pub(super) fn pose_chain_hair(
    (hair, driven, rebuilt): (Entity, &BoneChainHair, bool),
    hair_world: &GlobalTransform,
    computed: Option<&mut ComputedHair>,
    pose: &mut ChainPose,
    (settings, only): (&HairSimSettings, Option<&HairCollidesOnly>),
    frame: &PoseFrame,
    bind: &impl Fn(Entity) -> Option<Transform>,
) {
    if rebuilt || frame.stale.binary_search(&hair).is_ok() {
        pose.buffers.lanes.forget();
    }
    let margin = computed
        .as_deref()
        .map_or(0.0, |c| settings.margins().0 * c.size);
    match computed.as_deref() {
        Some(c) => gather_near(&frame.shapes, c, only, margin, &mut pose.near),
        None => pose.near.clear(),
    }
    pose_hair(
        driven,
        hair_world,
        computed,
        (&pose.near, margin),
        &mut pose.buffers,
        bind,
        PosePath::Lanes,
    );
}

/// Hairs posed by one task (a chain hair is small: a few dozen to a few hundred joints).
const HAIRS_PER_TASK: usize = 4;

/// Turns each chain's joints of the hairs the step did not pose ([`pose_chain_hair`]), root to
/// tip, so each points at its next particle (its child, at the bone's length, kept off the
/// hair's colliders and inside the joint's angle limit, if it has one:
/// [`ChainJointLimits`](super::ChainJointLimits); the particle follows). The joints are written
/// after, with those of every hair whose joints the step did not write (`write_out`).
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn pose_bone_chains(
    mut hairs: Query<(
        (Entity, Ref<BoneChainHair>),
        &GlobalTransform,
        Option<&mut ComputedHair>,
        &mut ChainPose,
        (&HairSimSettings, Option<&HairCollidesOnly>),
    )>,
    (colliders, bind, changed): (
        Query<(Entity, &HairCollider, &GlobalTransform), Without<BoneChainHair>>,
        Query<&Transform, Without<BoneChainHair>>,
        Query<&ChainJoint, Or<(Changed<Transform>, Without<Transform>)>>,
    ),
    mut frame: Local<PoseFrame>,
) {
    // Made with defaults when no app made it (tests, benches).
    crate::parallel::compute_pool();
    // The colliders where they are now and the hairs whose joints changed, once for every hair
    // left to pose (the step poses most).
    frame.gather_colliders(colliders.iter());
    frame.gather_stale(changed.iter().map(|j| j.hair));
    let frame = &*frame;
    hairs
        .par_iter_mut()
        .batching_strategy(BatchingStrategy::fixed(HAIRS_PER_TASK))
        .for_each(
            |((hair, driven), hair_world, computed, mut pose, settings)| {
                if pose.posed_early && computed.is_some() {
                    return;
                }
                pose.joints_written = false;
                pose_chain_hair(
                    (hair, &driven, driven.is_changed()),
                    hair_world,
                    computed.map(Mut::into_inner),
                    &mut pose,
                    settings,
                    frame,
                    &|e| bind.get(e).ok().copied(),
                );
            },
        );
}

/// Run condition of [`pose_bone_chains`]: some bone-chain hair was not posed by the step (one
/// not built yet, a hair alone, or one whose batches the step shared out over the threads).
pub(crate) fn hairs_left_to_pose(hairs: Query<(&ChainPose, Has<ComputedHair>)>) -> bool {
    hairs
        .iter()
        .any(|(pose, built)| !pose.posed_early || !built)
}

/// The shapes of `frame` the hair of `computed` can meet: those near its particles' box grown
/// by twice its longest segment (the posed joints lie within a bone of the particles), and
/// keep-inside ones; a crowd's hair meets its own character's body, not every body.
fn gather_near(
    frame: &FrameShapes,
    computed: &ComputedHair,
    only: Option<&HairCollidesOnly>,
    margin: f32,
    near: &mut Vec<NearShape>,
) {
    near.clear();
    // Measured by the step this frame, else now.
    let particles = computed
        .particle_box
        .unwrap_or_else(|| ParticleBox::of(&computed.batches));
    let reach = Vec3A::splat(2.0 * particles.longest_sq.sqrt());
    let (lo, hi) = (particles.min - reach, particles.max + reach);
    for &(e, first, end, c_lo, c_hi) in &frame.colliders {
        if only.is_some_and(|o| !o.0.contains(&e)) {
            continue;
        }
        if !((c_lo - margin).cmple(hi).all() && (c_hi + margin).cmpge(lo).all()) {
            continue;
        }
        near.extend(
            frame.shapes[first..end]
                .iter()
                .filter(|(s, inside)| *inside || s.meets(lo, hi, margin))
                .map(|&(s, inside)| {
                    let (a, b) = if inside {
                        (Vec3A::NEG_INFINITY, Vec3A::INFINITY)
                    } else {
                        s.bounds()
                    };
                    (s, inside, a - margin, b + margin)
                }),
        );
    }
}

/// A slot of a hair's poses whose joint is not posed this frame.
pub(super) const UNPOSED: Pose = (Entity::PLACEHOLDER, Quat::IDENTITY, Affine3A::IDENTITY);

/// A chain being posed: where it is along its joints.
#[derive(Clone, Copy, Debug)]
pub(super) struct ChainCursor {
    /// The chain (strand) index.
    pub(super) strand: usize,
    /// The last joint posed: its world transform and world rotation.
    pub(super) parent: Affine3A,
    pub(super) parent_rotation: Quat,
    /// Posed from its particles (else it follows its bind pose).
    pub(super) simulated: bool,
    /// The last joint's world transform is a rotation times a uniform positive scale, `scale`.
    pub(super) uniform: bool,
    pub(super) scale: f32,
}

/// One hair's joint poses into `buffers.posed`, one slot per joint, chain by chain (a joint not
/// posed keeps [`Entity::PLACEHOLDER`]); particles the pose moves (off a collider, into a limit)
/// are moved in `computed` too. `bind` gives a joint's local transform now (its rotation is
/// replaced; translation and scale are kept). A chain without usable particles (not built yet,
/// non-finite) follows its parent in its bind pose from the joint where posing stops: every
/// joint is posed, since Bevy's propagation does not visit them. Returns how many joints were
/// posed in the solver's lanes.
pub(super) fn pose_hair(
    driven: &BoneChainHair,
    hair_world: &GlobalTransform,
    mut computed: Option<&mut ComputedHair>,
    (near, margin): (&[NearShape], f32),
    buffers: &mut PoseBuffers,
    bind: &impl Fn(Entity) -> Option<Transform>,
    path: PosePath,
) -> usize {
    let hair = hair_world.affine();
    // Under a uniform, unmirrored scale a joint's world rotation is its parent's times its
    // own; otherwise it is read back from each parent's matrix.
    let (scale, hair_rotation, _) = hair.to_scale_rotation_translation();
    let uniform = scale.min_element() > 0.0
        && (scale.max_element() - scale.min_element()) <= 1e-4 * scale.max_element();
    let PoseBuffers {
        posed,
        first,
        particles,
        lanes,
    } = buffers;
    first.clear();
    let mut total = 0;
    for chain in &driven.joints {
        first.push(total);
        total += chain.len();
    }
    // Every slot is written below (a joint not posed with a placeholder).
    posed.resize(total, UNPOSED);
    let start = ChainCursor {
        strand: 0,
        // The hair hangs on the chains' parent bone with an identity transform.
        parent: hair,
        parent_rotation: hair_rotation,
        simulated: false,
        uniform,
        scale: scale.x,
    };
    if let Some(c) = computed.as_deref_mut()
        && path == PosePath::Lanes
        && uniform
        && c.lane_of.len() == driven.joints.len()
    {
        lanes.refresh(driven, c, bind);
        // Every strand is in one lane of one batch.
        return (0..c.batches.len())
            .map(|b| {
                super::chain_lanes::pose_batch(
                    driven,
                    (b, &start),
                    c,
                    lanes,
                    (near, margin),
                    (posed, first, particles),
                    bind,
                )
            })
            .sum();
    }
    for (s, &slot) in first.iter().enumerate() {
        let mut cursor = ChainCursor {
            strand: s,
            simulated: chain_particles(driven, s, computed.as_deref(), particles),
            ..start
        };
        pose_chain(
            driven,
            &mut cursor,
            (slot, 0),
            computed.as_deref_mut(),
            (near, margin, particles),
            posed,
            bind,
        );
    }
    0
}

/// Whether the solver holds chain `s` as it is, in strands of `particle_count` particles: as
/// many as it has joints and a tail, with its bind pose and tail.
pub(super) fn solver_holds(driven: &BoneChainHair, s: usize, particle_count: usize) -> bool {
    let Some(chain) = driven.joints.get(s) else {
        return false;
    };
    let tail_joint = driven.tail_joint.get(s).copied().unwrap_or(false);
    chain.len() + usize::from(!tail_joint) == particle_count
        && driven.rest.get(s).is_some_and(|r| r.len() == chain.len())
        && driven.tail.get(s).is_some()
}

/// Chain `s`'s particles into `particles`, read once (the solver's lanes are strided in memory):
/// whether the chain can be posed from them (the solver holds it as it is, see
/// [`solver_holds`], and they are all finite).
pub(super) fn chain_particles(
    driven: &BoneChainHair,
    s: usize,
    computed: Option<&ComputedHair>,
    particles: &mut Vec<Vec3>,
) -> bool {
    particles.clear();
    match computed {
        Some(c) if solver_holds(driven, s, c.particle_count(s)) => {
            particles.extend((0..c.particle_count(s)).map(|i| c.particle(s, i)));
            particles.iter().all(|p| p.is_finite())
        }
        _ => false,
    }
}

/// Poses the chain at `cursor` (its strand) from joint `from` on into `posed`, its first joint's
/// slot `slot`, the cursor at the joint before `from`; `particles` are the chain's (see
/// [`chain_particles`]).
pub(super) fn pose_chain(
    driven: &BoneChainHair,
    cursor: &mut ChainCursor,
    (slot, from): (usize, usize),
    mut computed: Option<&mut ComputedHair>,
    (near, margin, particles): (&[NearShape], f32, &[Vec3]),
    posed: &mut [Pose],
    bind: &impl Fn(Entity) -> Option<Transform>,
) {
    let s = cursor.strand;
    let chain = &driven.joints[s];
    let tail_joint = driven.tail_joint.get(s).copied().unwrap_or(false);
    for (k, &joint) in chain.iter().enumerate().skip(from) {
        let Some(local) = bind(joint) else {
            posed[slot + k..slot + chain.len()].fill(UNPOSED);
            return;
        };
        // The tail joint follows the turned chain, unturned.
        cursor.simulated &= !(tail_joint && k + 1 == chain.len());
        let (rotation, world) = pose_joint(
            driven,
            cursor,
            (k, &local),
            computed.as_deref_mut(),
            (near, margin, particles),
        );
        posed[slot + k] = (joint, rotation, world);
    }
}

/// Joint `k` of the chain at `cursor`, whose local transform now is `local`: its local
/// rotation and world transform, turned to point at its next particle (see [`pose_hair`]), or
/// in its bind pose when the chain is not simulated (from there on, or at its tail joint).
/// Moves the cursor on.
fn pose_joint(
    driven: &BoneChainHair,
    cursor: &mut ChainCursor,
    (k, local): (usize, &Transform),
    computed: Option<&mut ComputedHair>,
    (near, margin, particles): (&[NearShape], f32, &[Vec3]),
) -> (Quat, Affine3A) {
    let s = cursor.strand;
    let (Some(rest), Some(tail), Some(computed), true) = (
        driven.rest.get(s),
        driven.tail.get(s),
        computed,
        cursor.simulated,
    ) else {
        cursor.parent *= local.compute_affine();
        cursor.uniform &= uniform_scale(local.scale);
        cursor.scale *= local.scale.x;
        cursor.parent_rotation = if cursor.uniform {
            (cursor.parent_rotation * local.rotation).normalize()
        } else {
            cursor.parent.to_scale_rotation_translation().1
        };
        return (local.rotation, cursor.parent);
    };
    let parent = cursor.parent;
    let parent_rotation = if cursor.uniform {
        cursor.parent_rotation
    } else {
        parent.to_scale_rotation_translation().1
    };
    let rest_rotation = rest[k].rotation;
    let origin = parent.transform_point3(local.translation);
    let at_rest_rotation = parent_rotation * rest_rotation;
    let child = rest.get(k + 1).map_or(*tail, |t| t.translation);
    let from = parent
        .matrix3
        .mul_vec3(rest_rotation * (local.scale * child));
    let mut to = particles[k + 1] - origin;
    // The posed child sits at its bone's length: keep it off the colliders the particle was
    // kept off (a collider can hold a particle nearer than a bone).
    if let Some(kept) = keep_off(near, origin, to, from.length(), margin) {
        computed.set_particle(s, k + 1, origin + kept);
        to = kept;
    }
    let limits = driven.limits.get(s).map_or(&[][..], Vec::as_slice);
    if let Some(Some(limit)) = limits.get(k) {
        let frame = limit_frame(at_rest_rotation, child, limit);
        let limited = limit_offset(frame, limit, to);
        if limited != to {
            // The simulation goes on from the limited joint, as VRM's step does, with the
            // particle's velocity: a limit makes none (a kick back out of the limit would swing
            // a loose chain over, to flip it across a hinge).
            computed.move_particle(s, k + 1, origin + limited);
            to = limited;
        }
    }
    // Products of unit quaternions: unit to rounding, which a chain's few joints do not
    // accumulate (each frame starts from the bind pose).
    let (mut rotation, mut world_rotation) = match shortest_arc(from, to) {
        Some(arc) => {
            let world = arc * at_rest_rotation;
            (parent_rotation.inverse() * world, world)
        }
        None => (rest_rotation, at_rest_rotation),
    };
    if !rotation.is_finite() {
        // From here the chain keeps its bind pose.
        cursor.simulated = false;
        (rotation, world_rotation) = (local.rotation, parent_rotation * local.rotation);
    }
    let scale = local.scale;
    cursor.parent = if cursor.uniform && uniform_scale(scale) {
        // A rotation times a uniform scale: the world rotation is at hand.
        cursor.scale *= scale.x;
        Affine3A {
            matrix3: Mat3A::from_quat(world_rotation) * cursor.scale,
            translation: origin.into(),
        }
    } else {
        cursor.uniform = false;
        parent * Affine3A::from_scale_rotation_translation(scale, rotation, local.translation)
    };
    cursor.parent_rotation = world_rotation;
    (rotation, cursor.parent)
}

/// Whether a local scale keeps a rotation times a uniform scale one (a mirror does not).
#[inline]
pub(super) fn uniform_scale(scale: Vec3) -> bool {
    scale.x > 0.0 && scale.x == scale.y && scale.x == scale.z
}

/// The shortest turn taking the direction of `from` to that of `to` (neither need be of unit
/// length); `None` when either has no direction.
#[inline]
fn shortest_arc(from: Vec3, to: Vec3) -> Option<Quat> {
    let norms = (from.length_squared() * to.length_squared()).sqrt();
    if !(norms > 0.0 && norms.is_finite()) {
        return None;
    }
    let w = norms + from.dot(to);
    if w <= 1e-6 * norms {
        // Opposite directions: any half turn about an axis across them.
        return Some(Quat::from_rotation_arc(
            from / from.length(),
            to / to.length(),
        ));
    }
    let c = from.cross(to);
    Some(Quat::from_xyzw(c.x, c.y, c.z, w).normalize())
}

/// Rounds of [`keep_off`]: each turns the child onto the margin of a collider it is within
/// (exactly for a sphere; for a capsule onto the sphere about the nearest point of its axis,
/// which the next round corrects; for a box or plane pushed out and back to the bone's length,
/// nearer the margin each time).
const KEEP_OFF_ROUNDS: usize = 8;

/// How far past a sphere's or capsule's margin [`keep_off`] puts the child, as a fraction of the
/// margin's radius: enough for the next round to find it clear despite rounding.
const SHELL_CLEARANCE: f32 = 1e-5;

/// Where the posed child of a joint at `joint` goes instead of `joint + to` when, at its bone's
/// length `length`, it would lie within `margin` of a collider in `shapes`: turned about the
/// joint onto the collider's margin. `None` when it is clear.
pub(super) fn keep_off(
    shapes: &[NearShape],
    joint: Vec3,
    to: Vec3,
    length: f32,
    margin: f32,
) -> Option<Vec3> {
    // Clear of every shape that cannot reach the bone's sphere about the joint.
    let (reach_lo, reach_hi) = (Vec3A::from(joint) - length, Vec3A::from(joint) + length);
    if !shapes
        .iter()
        .any(|(_, _, lo, hi)| reach_hi.cmpge(*lo).all() && reach_lo.cmple(*hi).all())
    {
        return None;
    }
    let mut dir = to.try_normalize()?;
    let mut moved = false;
    // Measured from the joint: a character far from the world's origin rounds its world
    // coordinates more coarsely than the clearance the shell step leaves.
    let joint = Vec3A::from(joint);
    for _ in 0..KEEP_OFF_ROUNDS {
        let mut clear = true;
        for (shape, inside, lo, hi) in shapes {
            let offset = Vec3A::from(dir * length);
            let q = joint + offset;
            if q.cmplt(*lo).any()
                || q.cmpgt(*hi).any()
                || (!inside && clear_of(shape, joint, offset, margin))
            {
                continue;
            }
            let turned = match (*inside, *shape) {
                (false, ContactShape::Sphere { centre, radius }) => {
                    onto_shell(centre - joint, dir.into(), length, radius + margin)
                }
                (false, ContactShape::Capsule { a, b, radius }) => onto_shell(
                    nearest_on_axis(a - joint, b - joint, offset),
                    dir.into(),
                    length,
                    radius + margin,
                ),
                _ => None,
            };
            let turned = turned.or_else(|| {
                shape
                    .resolve(q, margin, *inside)
                    .and_then(|out| Vec3::from(out - joint).try_normalize())
            });
            if let Some(d) = turned {
                dir = d;
                clear = false;
                moved = true;
            }
        }
        if clear {
            break;
        }
    }
    // At the bone's length: the particle goes where the posed joint is.
    let kept = dir * length;
    (moved && kept.is_finite()).then_some(kept)
}

/// The direction nearest `dir` from a joint whose point at `length` lies on the sphere of radius
/// `reach` about `centre` (measured from the joint), a little outside it: the circle where that
/// sphere meets the sphere of the bone's reach about the joint, at its point nearest `dir`.
/// `None` when the two spheres do not meet (the bone cannot reach the surface, or cannot leave
/// it).
fn onto_shell(centre: Vec3A, dir: Vec3A, length: f32, reach: f32) -> Option<Vec3> {
    let reach = reach * (1.0 + SHELL_CLEARANCE);
    let d = centre.length();
    if d <= f32::EPSILON * reach.max(length) {
        return None;
    }
    let u = centre / d;
    // The circle's plane lies `along` from the joint toward the centre; its radius is `across`.
    let along = (length * length - reach * reach + d * d) / (2.0 * d);
    let across_sq = length * length - along * along;
    if across_sq.is_nan() || across_sq < 0.0 {
        return None;
    }
    let side = (dir - u * dir.dot(u))
        .try_normalize()
        .unwrap_or_else(|| u.any_orthonormal_vector());
    let turned = (u * along + side * across_sq.sqrt()) / length;
    Some(Vec3::from(turned).normalize_or(Vec3::from(dir)))
}

/// Whether the point `offset` from `joint` is certainly farther than `margin` outside `shape`,
/// by squared distances measured from the joint (most joints near a head are clear of it: no
/// square root, no call).
#[inline(always)]
fn clear_of(shape: &ContactShape, joint: Vec3A, offset: Vec3A, margin: f32) -> bool {
    match *shape {
        ContactShape::Sphere { centre, radius } => {
            let reach = radius + margin;
            offset.distance_squared(centre - joint) >= reach * reach
        }
        ContactShape::Capsule { a, b, radius } => {
            let reach = radius + margin;
            offset.distance_squared(nearest_on_axis(a - joint, b - joint, offset)) >= reach * reach
        }
        ContactShape::Plane { .. } | ContactShape::Box { .. } => false,
    }
}

/// The point of the segment `a`-`b` nearest `q`.
#[inline(always)]
fn nearest_on_axis(a: Vec3A, b: Vec3A, q: Vec3A) -> Vec3A {
    let ab = b - a;
    a + ab * ((q - a).dot(ab) / ab.length_squared().max(1e-20)).clamp(0.0, 1.0)
}

/// One way's poses, every particle after posing, and how many joints were posed in lanes.
#[cfg(test)]
pub(super) type PosedBothWays = (Vec<Pose>, Vec<Vec3>, usize);

/// Hair `hair`'s poses this frame worked out both ways, [`PosePath::Lanes`] then
/// [`PosePath::Alone`], each on its own copy of the solver's state (with `tamper` applied first):
/// the poses, every particle after posing, and how many joints were posed in lanes.
#[cfg(test)]
pub(super) fn poses_both_ways(
    world: &mut World,
    hair: Entity,
    tamper: impl Fn(&mut ComputedHair),
) -> [PosedBothWays; 2] {
    let mut frame = FrameShapes::default();
    let mut colliders =
        world.query_filtered::<(Entity, &HairCollider, &GlobalTransform), Without<BoneChainHair>>();
    frame.gather(colliders.iter(world));
    let e = world.entity(hair);
    let (driven, hair_world) = (
        e.get::<BoneChainHair>().unwrap(),
        e.get::<GlobalTransform>().unwrap(),
    );
    let computed = e.get::<ComputedHair>().unwrap();
    let margin = e.get::<HairSimSettings>().unwrap().margins().0 * computed.size;
    let mut near = Vec::new();
    gather_near(
        &frame,
        computed,
        e.get::<HairCollidesOnly>(),
        margin,
        &mut near,
    );
    [PosePath::Lanes, PosePath::Alone].map(|path| {
        let mut copy = ComputedHair {
            batches: computed.batches.clone(),
            lane_of: computed.lane_of.clone(),
            ..default()
        };
        tamper(&mut copy);
        let mut buffers = PoseBuffers::default();
        let lanes = pose_hair(
            driven,
            hair_world,
            Some(&mut copy),
            (&near, margin),
            &mut buffers,
            &|j| world.get::<Transform>(j).copied(),
            path,
        );
        let particles = (0..copy.lane_of.len())
            .flat_map(|s| (0..copy.particle_count(s)).map(move |i| (s, i)))
            .map(|(s, i)| copy.particle(s, i))
            .collect();
        (buffers.posed, particles, lanes)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere shape as posing sees it near a hair: bounds grown by the margin.
    fn near_sphere(centre: Vec3A, radius: f32, margin: f32) -> NearShape {
        let shape = ContactShape::Sphere { centre, radius };
        let (lo, hi) = shape.bounds();
        (shape, false, lo - margin, hi + margin)
    }

    #[test]
    fn onto_shell_lands_on_the_margin_nearest_the_wanted_direction() {
        let (length, reach) = (0.03, 0.1);
        let centre = Vec3A::new(0.02, -0.09, 0.01);
        let dir = Vec3A::new(0.1, -1.0, 0.2).normalize();
        let turned = Vec3A::from(onto_shell(centre, dir, length, reach).unwrap());
        assert!((turned.length() - 1.0).abs() < 1e-5, "{turned}");
        let from_centre = (turned * length).distance(centre);
        assert!(
            from_centre >= reach && from_centre <= reach * (1.0 + 1e-4),
            "{from_centre} from the centre, margin at {reach}"
        );
        // No direction on the circle where the two spheres meet is nearer the wanted one.
        let u = centre.normalize();
        let (e1, e2) = u.any_orthonormal_pair();
        let along = (turned * length).dot(u);
        let across = (length * length - along * along).sqrt();
        for i in 0..3600 {
            let a = i as f32 / 3600.0 * std::f32::consts::TAU;
            let other = (u * along + (e1 * a.cos() + e2 * a.sin()) * across) / length;
            assert!(
                other.dot(dir) <= turned.dot(dir) + 1e-5,
                "{other} nearer than {turned}"
            );
        }
    }

    #[test]
    fn onto_shell_declines_a_surface_the_bone_cannot_reach() {
        // The joint 0.5 from a sphere of reach 0.1, a bone of 0.03: the spheres do not meet.
        assert!(onto_shell(Vec3A::new(0.0, -0.5, 0.0), Vec3A::NEG_Y, 0.03, 0.1).is_none());
    }

    #[test]
    fn a_joint_far_from_the_origin_is_kept_off_in_a_couple_of_rounds() {
        // A character a kilometre out: world coordinates round to about 0.1 mm there, coarser
        // than the clearance; measured from the joint, the child still lands on the margin.
        let (radius, margin, length) = (0.09, 0.01, 0.03);
        for far in [0.0, 1000.0] {
            let joint = Vec3::new(far, 1.6, -far);
            let centre = Vec3A::from(joint) + Vec3A::new(0.01, -0.09, 0.0);
            let shapes = [near_sphere(centre, radius, margin)];
            let kept = keep_off(&shapes, joint, Vec3::new(0.0, -length, 0.0), length, margin)
                .expect("the straight-down child lies inside the head");
            assert!((kept.length() - length).abs() < 1e-6, "{kept}");
            let from_centre = Vec3A::from(kept).distance(centre - Vec3A::from(joint));
            assert!(
                (from_centre - (radius + margin)).abs() < 1e-5,
                "{far} m out: the child {from_centre} from the centre, margin at {}",
                radius + margin
            );
        }
    }
}
