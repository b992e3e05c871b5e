//! Writing the frame's simulation out: every posed joint's local and global transforms (the
//! skinned mesh is drawn from these this frame) and the global transforms of what hangs below
//! them, and the strands' particles. Most of both are written by the thread that stepped and
//! posed their hair, while the step runs ([`EarlyJoints`], [`EarlyStrands`]); one system after
//! the step and posing writes the rest, and runs only in frames that leave some
//! ([`anything_left_to_write`]).
//!
//! One system for both, rather than one each: every system the hair's stages run costs the
//! scheduler a hand-over besides its own work, which a crowd of small hairs feels.

use bevy::ecs::batching::BatchingStrategy;
use bevy::math::Affine3A;
use bevy::prelude::*;
use bevy::transform::components::TransformTreeChanged;
use bevy::utils::Parallel;

use super::HairSimControl;
use super::attach::{ComputedHair, Hair, HairStrands, Strand, StrandOf, StrandParticles};
use super::chain_pose::{ChainJoint, ChainPose, Pose};
use super::chains::BoneChainHair;
use super::collider::HairCollider;
use super::wind::HairForceField;

/// Entities below posed joints that are not joints themselves, with their parent's world
/// transform this frame: found on every core, then propagated from one list (kept between
/// frames).
#[derive(Default)]
pub(crate) struct Below(Parallel<Vec<(Affine3A, Entity)>>, Vec<(Affine3A, Entity)>);

/// The joints' queries: written joint by joint, then what hangs below them.
type JointNodes<'w, 's> = ParamSet<
    'w,
    's,
    (
        Query<
            'static,
            'static,
            (
                Entity,
                &'static mut ChainJoint,
                &'static mut Transform,
                &'static mut GlobalTransform,
                Option<Ref<'static, Children>>,
            ),
            Without<BoneChainHair>,
        >,
        Query<
            'static,
            'static,
            (
                &'static mut Transform,
                &'static mut GlobalTransform,
                Option<&'static Children>,
                Has<TransformTreeChanged>,
            ),
            Without<BoneChainHair>,
        >,
    ),
>;

/// Run condition of [`write_hair_state`]: some chain hair's joints or some strands' particles
/// were not written by the step.
pub(crate) fn anything_left_to_write(
    poses: Query<&ChainPose>,
    computed: Query<&ComputedHair>,
    strands: Query<(), With<StrandOf>>,
) -> bool {
    poses.iter().any(|p| !p.joints_written)
        || (!strands.is_empty() && computed.iter().any(|c| !c.strands_written))
}

/// Writes the posed joints of every bone-chain hair whose joints the step did not write all of
/// ([`write_joints`]), then the particles of the strands it did not write
/// ([`write_strand_particles`]).
pub(crate) fn write_hair_state(
    control: Res<HairSimControl>,
    (poses, computed): (Query<&ChainPose>, Query<&ComputedHair>),
    mut strands: Query<(&StrandOf, &Strand, &mut StrandParticles)>,
    mut joints: JointNodes,
    mut below: Local<Below>,
) {
    // Made with defaults when no app made it (tests, benches).
    crate::parallel::compute_pool();
    if poses.iter().any(|p| !p.joints_written) {
        write_joints(&poses, &mut joints, &mut below);
    }
    // Hairs whose strands the step wrote (most) are left alone.
    if computed.iter().any(|c| !c.strands_written) {
        write_strand_particles(control.write_structural, &computed, &mut strands);
    }
}

/// Writes each posed joint's local rotation and world transform, joint by joint on every core,
/// then the world transforms of what hangs below them, for every hair whose joints the step did
/// not write all of. The world transform is written here, so the local rotation is stored
/// without flagging the joint changed: Bevy's propagation would otherwise walk every joint's
/// ancestors next frame to recompute what is already there.
fn write_joints(poses: &Query<&ChainPose>, nodes: &mut JointNodes, below: &mut Below) {
    nodes
        .p0()
        .par_iter_mut()
        .batching_strategy(BatchingStrategy::new().batches_per_thread(4))
        .for_each_init(
            || (below.0.borrow_local_mut(), None),
            |(below, last), (joint, mut of, mut local, mut global, children)| {
                // A hair's joints mostly come one after another: its poses are looked up once.
                let posed: &[Pose] = match *last {
                    Some((hair, posed)) if hair == of.hair => posed,
                    _ => {
                        let Ok(pose) = poses.get(of.hair) else {
                            return;
                        };
                        // A hair the step wrote: no pose to write (looked up once).
                        let posed = if pose.joints_written {
                            &[]
                        } else {
                            pose.posed()
                        };
                        *last = Some((of.hair, posed));
                        posed
                    }
                };
                let slot = of.slot as usize;
                let Some(&(posed_joint, rotation, world)) = posed.get(slot) else {
                    return;
                };
                if posed_joint != joint {
                    return;
                }
                local.bypass_change_detection().rotation = rotation;
                *global = GlobalTransform::from(world);
                // A chain's next joint is posed with it; anything else below is propagated.
                let next = posed.get(slot + 1).map(|p| p.0);
                let Some(children) = children else {
                    return;
                };
                let others = match of.others {
                    Some((seen, others)) if seen == next && !children.is_changed() => others,
                    _ => {
                        let others = children.iter().any(|c| Some(c) != next);
                        of.bypass_change_detection().others = Some((next, others));
                        others
                    }
                };
                if others {
                    for c in children.iter() {
                        if Some(c) != next {
                            below.push((world, c));
                        }
                    }
                }
            },
        );
    let mut nodes = nodes.p1();
    let Below(found, below) = below;
    below.clear();
    below.extend(found.drain());
    // What hangs below the joints (an end bone, an accessory), depth first. A posed joint of
    // another chain (one Bevy's propagation skips) is its own hair's; a hair entity is left to
    // Bevy's propagation next frame.
    while let Some((parent, entity)) = below.pop() {
        let Ok((local, mut global, children, propagated)) = nodes.get_mut(entity) else {
            continue;
        };
        if !propagated {
            continue;
        }
        let world = parent * local.compute_affine();
        *global = GlobalTransform::from(world);
        for &c in children.map_or(&[][..], |c| &c[..]) {
            below.push((world, c));
        }
    }
}

/// Copies solver state into each strand entity's [`StrandParticles`] whose hair's strands the
/// step did not write ([`EarlyStrands`]), in parallel over strands (with the `structural` nodes
/// too when asked).
fn write_strand_particles(
    structural: bool,
    hairs: &Query<&ComputedHair>,
    strands: &mut Query<(&StrandOf, &Strand, &mut StrandParticles)>,
) {
    strands
        .par_iter_mut()
        .batching_strategy(BatchingStrategy::new().batches_per_thread(4))
        .for_each_init(
            || None,
            |last, (of, strand, mut particles)| {
                // A hair's strands mostly come one after another: its state is looked up once.
                let computed: &ComputedHair = match *last {
                    Some((hair, computed)) if hair == of.0 => computed,
                    _ => {
                        let Ok(computed) = hairs.get(of.0) else {
                            return;
                        };
                        *last = Some((of.0, computed));
                        computed
                    }
                };
                if computed.strands_written {
                    return;
                }
                copy_particles(computed, strand.index as usize, &mut particles, structural);
            },
        );
}

/// Copies strand `s`'s particles (and its `structural` nodes when asked) out of `computed`.
fn copy_particles(
    computed: &ComputedHair,
    s: usize,
    particles: &mut StrandParticles,
    structural: bool,
) {
    let Some(&(b, l)) = computed.lane_of.get(s) else {
        return;
    };
    let batch = &computed.batches[b as usize];
    let l = l as usize;
    let count = batch.nodes.len() / 2;
    particles.positions.resize(count, Vec3::ZERO);
    for (i, p) in particles.positions.iter_mut().enumerate() {
        *p = batch.particle(l, i);
    }
    if structural {
        // Structural nodes: the ghost before the root, then one per segment.
        particles.structural.resize(count, Vec3::ZERO);
        for (i, p) in particles.structural.iter_mut().enumerate() {
            *p = batch.node(l, if i == 0 { 0 } else { 2 * i });
        }
    } else {
        particles.structural.clear();
    }
}

/// The step's way to write a hair's strands from the thread that stepped it, while its batches
/// are in that thread's cache, instead of in a pass over every strand after.
pub(crate) struct EarlyStrands<'a, 'w, 's> {
    /// Each strand entity's hair and index.
    pub(crate) info: &'a Query<'w, 's, (&'static StrandOf, &'static Strand)>,
    /// Where the particles go. No other parameter of the step reads or writes them.
    pub(crate) particles: &'a Query<'w, 's, &'static mut StrandParticles>,
    /// Also write the structural nodes.
    pub(crate) structural: bool,
}

impl EarlyStrands<'_, '_, '_> {
    /// Writes the particles of `hair`'s strands, `list`, out of `computed`; `false` when the
    /// list is not the hair's strands in the order they were built (entity `i` is strand `i`
    /// of this hair), and then the pass after the step writes them all.
    #[expect(
        unsafe_code,
        reason = "several threads write strands of different hairs through one query"
    )]
    pub(crate) fn write(&self, hair: Entity, computed: &ComputedHair, list: &HairStrands) -> bool {
        if list.len() != computed.lane_of.len() {
            return false;
        }
        for (i, e) in list.iter().enumerate() {
            match self.info.get(e) {
                Ok((of, strand)) if of.0 == hair && strand.index as usize == i => {}
                _ => return false,
            }
            // SAFETY: a strand entity has one `StrandOf` and one `Strand`, so it passes the
            // check above for one hair and one place in that hair's list only: of all the
            // threads writing their own hairs' strands at once, one takes this entity's
            // particles, once. No other query of the calling system touches
            // `StrandParticles`, and the scheduler keeps other systems off them meanwhile.
            let Ok(mut particles) = (unsafe { self.particles.get_unchecked(e) }) else {
                return false;
            };
            copy_particles(computed, i, &mut particles, self.structural);
        }
        true
    }
}

/// What a joint may also be whose transforms the step reads while it runs: a hair, a collider,
/// a force field. Such a joint is written after the step.
type ReadByStep = Or<(With<Hair>, With<HairCollider>, With<HairForceField>)>;

/// Everything but the joints [`EarlyJoints`] writes: what the step's other queries of
/// transforms may read.
pub(crate) type NotEarlyJoint = Or<(
    Without<ChainJoint>,
    With<Hair>,
    With<HairCollider>,
    With<HairForceField>,
)>;

/// A joint the thread that posed it may write while the step runs: not also something the step
/// reads ([`ReadByStep`]).
type EarlyJoint = (
    With<ChainJoint>,
    Without<Hair>,
    Without<HairCollider>,
    Without<HairForceField>,
);

/// The joints the thread that posed them may write while the step runs: every joint that is not
/// also something the step reads ([`ReadByStep`]).
pub(crate) type EarlyJointNodes<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static mut Transform,
        &'static mut GlobalTransform,
        Option<Ref<'static, Children>>,
    ),
    EarlyJoint,
>;

/// The joints of [`EarlyJointNodes`] whose transform changed since the step last ran: the same
/// joints as its items' `is_changed`, found by the change ticks alone (a crowd's tens of
/// thousands of joints are looked at on one thread before the step's threads start).
pub(crate) type ChangedEarlyJoints<'w, 's> =
    Query<'w, 's, Entity, (EarlyJoint, Changed<Transform>)>;

/// The joints without a transform, and those whose transform changed since the step last ran
/// among the joints [`EarlyJointNodes`] leaves out (the step finds the others through it).
pub(crate) type OtherChangedJoints<'w, 's> =
    Query<'w, 's, &'static ChainJoint, Or<(Without<Transform>, (Changed<Transform>, ReadByStep))>>;

/// The step's way to write a chain hair's posed joints from the thread that posed it, while its
/// poses are in that thread's cache, instead of in a pass over every joint after; and its way
/// to read joints' transforms meanwhile without meeting those writes.
pub(crate) struct EarlyJoints<'a, 'w, 's> {
    /// Each joint's hair and slot. No query of the step writes it.
    pub(crate) owners: &'a Query<'w, 's, &'static ChainJoint>,
    /// The joints written here.
    pub(crate) nodes: &'a EarlyJointNodes<'w, 's>,
    /// Joints whose world transform some hair's step reads (sorted): left for the pass after.
    pub(crate) read_elsewhere: &'a [Entity],
}

impl EarlyJoints<'_, '_, '_> {
    /// Writes the joints of `hair` posed this frame, `posed` (see [`ChainPose`]): each one whose
    /// [`ChainJoint`] names this hair and this slot, not shared with another hair, not read by
    /// another hair's step, and with nothing below it but its chain's next joint as last seen
    /// (what hangs below a joint is propagated by the pass after the step). Returns whether
    /// every posed joint was written; if not, the pass after the step writes the hair's joints.
    #[expect(
        unsafe_code,
        reason = "several threads write joints of different hairs through one query"
    )]
    pub(crate) fn write(&self, hair: Entity, posed: &[Pose]) -> bool {
        let mut all = true;
        for (slot, &(joint, rotation, world)) in posed.iter().enumerate() {
            let Ok(of) = self.owners.get(joint) else {
                // Unposed, or not a joint any more: the pass after writes no pose to it either.
                continue;
            };
            if of.hair != hair || of.slot as usize != slot {
                // Another hair's, or this hair's at another slot: written from that pose.
                continue;
            }
            if of.shared
                || (!self.read_elsewhere.is_empty()
                    && self.read_elsewhere.binary_search(&joint).is_ok())
            {
                all = false;
                continue;
            }
            // SAFETY: a joint has one `ChainJoint`, so it passes the check above for one hair
            // and one slot only: of all the threads writing their own hairs' joints at once,
            // one takes this joint's transforms, once. No other thread reads them meanwhile:
            // a hair's step reads another's joint only through `local` and `world` below,
            // which leave these joints alone (a joint two hairs take is `shared`, a joint an
            // inertia frame is on is in `read_elsewhere`, and the step's other queries of
            // transforms leave out what `EarlyJointNodes` matches), and the scheduler keeps
            // other systems off them.
            let Ok((_, mut local, mut global, children)) =
                (unsafe { self.nodes.get_unchecked(joint) })
            else {
                all = false;
                continue;
            };
            // What hangs below the joint, other than the next joint, is the pass after's.
            if let Some(children) = children {
                let next = posed.get(slot + 1).map(|p| p.0);
                match of.others {
                    Some((seen, false)) if seen == next && !children.is_changed() => {}
                    _ => {
                        all = false;
                        continue;
                    }
                }
            }
            local.bypass_change_detection().rotation = rotation;
            *global = GlobalTransform::from(world);
        }
        all
    }

    /// Joint `joint`'s local transform, read for posing `hair` while the step runs, or `None`
    /// for a joint another hair's thread may be writing (never, while joints two hairs take are
    /// `shared`); `others` reads every entity that is not a joint written here.
    pub(crate) fn local(
        &self,
        hair: Entity,
        joint: Entity,
        others: &Query<&Transform, NotEarlyJoint>,
    ) -> Option<Transform> {
        if let Ok(of) = self.owners.get(joint)
            && of.hair != hair
            && !of.shared
            && self.nodes.contains(joint)
        {
            debug_assert!(
                false,
                "joint {joint} of hair {} read by hair {hair}",
                of.hair
            );
            return None;
        }
        match self.nodes.get(joint) {
            Ok((_, local, ..)) => Some(*local),
            Err(_) => others.get(joint).ok().copied(),
        }
    }

    /// Entity `e`'s world transform, read while the step runs: a joint written here only when
    /// it is in `read_elsewhere` (so not written while the step runs); `others` reads every
    /// other entity.
    pub(crate) fn world<'a>(
        &'a self,
        e: Entity,
        others: &'a Query<&GlobalTransform, NotEarlyJoint>,
    ) -> Option<&'a GlobalTransform> {
        if let Ok(g) = others.get(e) {
            return Some(g);
        }
        if self.read_elsewhere.binary_search(&e).is_err() {
            return None;
        }
        self.nodes.get(e).ok().map(|(_, _, g, _)| g)
    }
}
