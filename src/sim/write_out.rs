//! Writing the frame's simulation out, in one system after the step and posing: every posed
//! joint's local and global transforms (the skinned mesh is drawn from these this frame) and
//! the global transforms of what hangs below them, then the particles of the strands the step
//! did not write itself ([`EarlyStrands`]: most are written by the thread that stepped them).
//!
//! One system for both, rather than one each: every system the hair's stages run costs the
//! scheduler a hand-over besides its own work, which a crowd of small hairs feels.

use bevy::ecs::batching::BatchingStrategy;
use bevy::math::Affine3A;
use bevy::prelude::*;
use bevy::transform::components::TransformTreeChanged;
use bevy::utils::Parallel;

use super::HairSimControl;
use super::attach::{ComputedHair, HairStrands, Strand, StrandOf, StrandParticles};
use super::chain_pose::{ChainJoint, ChainPose, Pose};
use super::chains::BoneChainHair;

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

/// Writes every bone-chain hair's posed joints ([`write_joints`]), then every strand's
/// particles ([`write_strand_particles`]).
pub(crate) fn write_hair_state(
    control: Res<HairSimControl>,
    (poses, computed): (Query<&ChainPose>, Query<&ComputedHair>),
    mut strands: Query<(&StrandOf, &Strand, &mut StrandParticles)>,
    mut joints: JointNodes,
    mut below: Local<Below>,
) {
    // Made with defaults when no app made it (tests, benches).
    crate::parallel::compute_pool();
    if !poses.is_empty() {
        write_joints(&poses, &mut joints, &mut below);
    }
    // Hairs whose strands the step wrote (most) are left alone.
    if computed.iter().any(|c| !c.strands_written) {
        write_strand_particles(control.write_structural, &computed, &mut strands);
    }
}

/// Writes each posed joint's local rotation and world transform, joint by joint on every core,
/// then the world transforms of what hangs below them. The world transform is written here, so
/// the local rotation is stored without flagging the joint changed: Bevy's propagation would
/// otherwise walk every joint's ancestors next frame to recompute what is already there.
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
                        *last = Some((of.hair, pose.posed()));
                        pose.posed()
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
