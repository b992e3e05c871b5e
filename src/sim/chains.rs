//! Bone chains as strands: the hair bones of a modelled hair mesh (VRM spring bones, Blender or
//! MMD hair bones) simulated by the hair solver, with each joint's rotation written back so
//! Bevy's skinning bends the user's own mesh.
//!
//! A [`HairBoneChains`] names the chains. Once the character's bones exist, the plugin groups the
//! chains by the bone they hang from (usually the head) and spawns one [`Hair`] per group as that
//! bone's child, its groom made from the joints' bind pose: particle `k` of a strand is joint `k`
//! of its chain, and one more particle, the tail, lies past the last joint (as VRM's spring bones
//! do). A [`HairCollidesOnly`] or [`HairInertiaFrame`] on the [`HairBoneChains`] entity is
//! copied to its hairs.
//! Everything the solver does for groomed hair applies: [`HairSimSettings`] (copied from the
//! [`HairBoneChains`] entity), colliders, wind and force fields, volume, style limits, teleports,
//! any rig scale. The solver moves a chain's particles alone, with edge and bending springs and
//! the anchors, and no torsion (see [`StepInput::particles_only`](super::solver::StepInput::particles_only)).
//! After each step the joints are turned, root to tip, so each points at the next particle; the
//! bind pose is the style the chains return to.

use bevy::prelude::*;
use bevy::transform::components::TransformTreeChanged;
use bevy::transform::helper::TransformHelper;
use bevy::world_serialization::WorldAssetRoot;

use super::attach::Hair;
use super::attach_work::AttachWork;
use super::bone::{
    BonePredicate, CharacterSpawned, names_under, report_scene_failure, scene_failure,
};
use super::chain_pose::{ChainJoint, ChainPose};
use super::collider::{HairCollider, HairCollidesOnly};
use super::events::BoneNotFound;
use super::limits::ChainJointLimits;
use super::settings::{HairInertiaFrame, HairSimSettings};
use crate::asset::{HairGroom, JointLimit};

/// Shortest tail, in metres at the character's size, whatever [`HairBoneChains::tail`] says.
pub const MIN_TAIL: f32 = 0.005;

/// Which bones start a chain. A chain runs from its first bone down through the first child of
/// each joint (name other branches as chains of their own) to a bone without children.
#[derive(Clone, Debug, Reflect)]
#[reflect(Clone, Debug)]
#[non_exhaustive]
pub enum ChainSelect {
    /// The character's descendants with these [`Name`]s.
    Named(Vec<String>),
    /// Every descendant whose name passes the test and whose parent's name does not: e.g.
    /// `|n| n.starts_with("J_Sec_Hair")` for a VRoid character's hair.
    Matching(#[reflect(ignore)] BonePredicate),
    /// These bone entities.
    Entities(Vec<Entity>),
    /// These chains, each its joints root first, each the parent of the next (a VRM spring's
    /// joint list). The last joint is the tail: it moves with the chain but is not turned (VRM
    /// 1.0's rule; add an empty child to turn a leaf bone), so a chain needs two joints. No child
    /// is followed past them. A chain hangs from its first joint's parent.
    Joints(Vec<Vec<Entity>>),
}

/// Simulates chains of a character's own bones as hair strands. Put it, with the
/// [`HairSimSettings`] the chains should have, on an entity of its own; the plugin spawns the
/// [`Hair`]s (see the module docs) and lists them in [`BoneChainHairs`].
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::sim::{ChainSelect, HairBoneChains, HairSimSettings};
/// # fn setup(mut commands: Commands, character: Entity) {
/// commands.spawn((
///     HairBoneChains::matching(character, |name| name.starts_with("J_Sec_Hair")),
///     HairSimSettings { bend_stiffness: 0.6, ..default() },
/// ));
/// # }
/// ```
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component, Debug)]
#[require(HairSimSettings)]
pub struct HairBoneChains {
    /// The character whose descendants are searched (a glTF scene root).
    pub root: Entity,
    /// Which bones start chains.
    pub select: ChainSelect,
    /// Length of the tail past each chain's last joint, as a fraction of the chain's last bone
    /// (or, for a chain of one joint, of the joint's distance from its parent). At least
    /// [`MIN_TAIL`]. Default: `1.0`.
    pub tail: f32,
}

impl HairBoneChains {
    /// Chains starting at the descendants of `root` with these names.
    pub fn named(root: Entity, names: impl IntoIterator<Item = impl Into<String>>) -> Self {
        Self {
            root,
            select: ChainSelect::Named(names.into_iter().map(Into::into).collect()),
            tail: 1.0,
        }
    }

    /// Chains starting at every descendant whose name passes `test` and whose parent's does
    /// not.
    pub fn matching(root: Entity, test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self {
            root,
            select: ChainSelect::Matching(BonePredicate::new(test)),
            tail: 1.0,
        }
    }
}

/// The hairs built for a [`HairBoneChains`] (one per bone the chains hang from), set once they
/// are built. Remove it to build them again (after despawning them).
#[derive(Component, Clone, Debug, Default, Reflect)]
#[reflect(Component, Debug)]
pub struct BoneChainHairs(pub Vec<Entity>);

/// On a [`Hair`] built from bone chains: the joints its strands drive. Its strands are not meshed
/// (the character's own mesh is what they move).
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component, Debug)]
pub struct BoneChainHair {
    /// The [`HairBoneChains`] entity.
    pub chains: Entity,
    /// Per strand: its joints, root first (the tail particle has none).
    pub joints: Vec<Vec<Entity>>,
    /// Per strand: each joint's local transform in the bind pose.
    pub(super) rest: Vec<Vec<Transform>>,
    /// Per strand: the tail's offset in the last turned joint's local frame.
    pub(super) tail: Vec<Vec3>,
    /// Per strand: its last joint is the tail (moved, not turned).
    pub(super) tail_joint: Vec<bool>,
    /// Per strand: each joint's angle limit ([`ChainJointLimits`]), if any; empty for a chain
    /// without limits (posing it reads nothing here).
    pub(super) limits: Vec<Vec<Option<JointLimit>>>,
    /// The joints whose world transforms posing alone writes (Bevy's propagation skips them):
    /// given back to Bevy when this component goes.
    pub(super) taken: Vec<Entity>,
}

/// A chain found under the character: the bone it hangs from and its joints, root first.
struct FoundChain {
    parent: Entity,
    joints: Vec<Entity>,
    /// The last joint is the tail (not turned); otherwise a tail particle is added past it.
    tail_joint: bool,
}

/// Descendants of `root` that start chains, in depth-first order.
fn chain_starts(
    root: Entity,
    select: &ChainSelect,
    children: &Query<&Children>,
    names: &Query<&Name>,
) -> Vec<Entity> {
    match select {
        ChainSelect::Entities(list) => return list.clone(),
        ChainSelect::Joints(chains) => {
            return chains.iter().filter_map(|c| c.first().copied()).collect();
        }
        _ => {}
    }
    let name_of = |e: Entity| names.get(e).map(Name::as_str).ok();
    let mut out = Vec::new();
    let mut stack = vec![(root, false)];
    while let Some((e, parent_matched)) = stack.pop() {
        let matched = match (select, name_of(e)) {
            (ChainSelect::Named(list), Some(n)) => list.iter().any(|m| m == n),
            (ChainSelect::Matching(test), Some(n)) => test.matches(n),
            _ => false,
        };
        let starts = match select {
            ChainSelect::Matching(_) => matched && !parent_matched,
            _ => matched,
        };
        if starts {
            out.push(e);
        }
        if let Ok(kids) = children.get(e) {
            for k in kids.iter().rev() {
                stack.push((k, matched));
            }
        }
    }
    out
}

/// The joints of the chain starting at `start`: it and the first child of each joint.
fn walk_chain(
    start: Entity,
    children: &Query<&Children>,
    bones: &Query<&Transform>,
) -> Vec<Entity> {
    let mut joints = vec![start];
    let mut at = start;
    while let Some(next) = children
        .get(at)
        .ok()
        .and_then(|c| c.iter().find(|k| bones.contains(*k)))
    {
        if joints.len() >= crate::asset::MAX_PARTICLES_PER_STRAND - 1 || joints.contains(&next) {
            break;
        }
        joints.push(next);
        at = next;
    }
    joints
}

/// Builds the hairs of every [`HairBoneChains`] whose character's bones exist.
#[expect(
    clippy::too_many_arguments,
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn build_bone_chains(
    mut commands: Commands,
    sets: Query<
        (
            Entity,
            &HairBoneChains,
            &HairSimSettings,
            Option<&HairCollidesOnly>,
            (Option<&ChainJointLimits>, Option<&HairInertiaFrame>),
        ),
        Without<BoneChainHairs>,
    >,
    children: Query<&Children>,
    names: Query<&Name>,
    parents: Query<&ChildOf>,
    locals: Query<&Transform>,
    roots: Query<(Option<&WorldAssetRoot>, Has<CharacterSpawned>)>,
    plain: Query<(), PlainLeaf>,
    helper: TransformHelper,
    (mut grooms, mut work, ticks, server): (
        ResMut<Assets<HairGroom>>,
        ResMut<AttachWork>,
        bevy::ecs::system::SystemChangeTick,
        Option<Res<AssetServer>>,
    ),
    (owners, chain_hairs): (Query<&ChainJoint>, Query<(), With<BoneChainHair>>),
) {
    // The joints the hairs built here take: a joint another hair takes too (built before, or
    // here) is shared, and written only after the step (see `ChainJoint::shared`).
    let mut claimed = bevy::ecs::entity::EntityHashSet::default();
    for (set, chains, settings, only, (limits, inertia)) in &sets {
        let starts = chain_starts(chains.root, &chains.select, &children, &names);
        if starts.is_empty() {
            // A glTF character whose scene has not spawned yet: wait for it, as a bone search
            // does, unless it failed to load.
            if let Ok((Some(scene), false)) = roots.get(chains.root) {
                if let Some((file, reason)) = scene_failure(server.as_deref(), scene) {
                    report_scene_failure(
                        &mut commands,
                        (set, "hair bone chains", "no chain is simulated"),
                        chains.root,
                        file,
                        reason,
                    );
                    commands.entity(set).insert(BoneChainHairs::default());
                }
                continue;
            }
            let available = names_under(chains.root, &names, &children);
            error!(
                "hair bone chains {set}: no bone of character {} starts a chain ({:?}); it has {} \
                 named entities: {:?}. Fix HairBoneChains::select; no chain is simulated",
                chains.root,
                chains.select,
                available.len(),
                &available[..available.len().min(40)]
            );
            commands.trigger(BoneNotFound {
                entity: set,
                root: chains.root,
                bone: format!("{:?}", chains.select),
                available,
            });
            commands.entity(set).insert(BoneChainHairs::default());
            continue;
        }
        // The hairs spawned here are built by the strand build in this same frame.
        work.bones = ticks.this_run();
        // Group the chains by the bone they hang from.
        let mut groups: Vec<(Entity, Vec<FoundChain>)> = Vec::new();
        for start in starts {
            let Ok(parent) = parents.get(start).map(ChildOf::parent) else {
                warn!("hair bone chains {set}: bone {start} has no parent to hang from; skipped");
                continue;
            };
            let (joints, tail_joint) = match &chains.select {
                ChainSelect::Joints(listed) => {
                    let joints = listed
                        .iter()
                        .find(|c| c.first() == Some(&start))
                        .map(|c| c[..c.len().min(crate::asset::MAX_PARTICLES_PER_STRAND)].to_vec())
                        .unwrap_or_default();
                    let linked = joints
                        .windows(2)
                        .all(|w| parents.get(w[1]).is_ok_and(|p| p.parent() == w[0]));
                    if joints.len() < 2 || !linked {
                        warn!(
                            "hair bone chains {set}: the chain from bone {start} needs two or more \
                             joints, each the parent of the next; skipped"
                        );
                        continue;
                    }
                    (joints, true)
                }
                _ => (walk_chain(start, &children, &locals), false),
            };
            let chain = FoundChain {
                parent,
                joints,
                tail_joint,
            };
            match groups.iter_mut().find(|(p, _)| *p == parent) {
                Some((_, list)) => list.push(chain),
                None => groups.push((parent, vec![chain])),
            }
        }
        let mut hairs = Vec::new();
        for (parent, found) in groups {
            let Ok(parent_world) = helper.compute_global_transform(parent) else {
                continue;
            };
            let to_parent = parent_world.affine().inverse();
            let mut strands = Vec::new();
            let mut driven = BoneChainHair {
                chains: set,
                joints: Vec::new(),
                rest: Vec::new(),
                tail: Vec::new(),
                tail_joint: Vec::new(),
                limits: Vec::new(),
                taken: Vec::new(),
            };
            for chain in found {
                let Some(built) = chain_strand(&chain, chains.tail, &helper, &locals) else {
                    warn!(
                        "hair bone chains {set}: the chain from bone {} has joints in one place; \
                         skipped",
                        chain.joints[0]
                    );
                    continue;
                };
                let (world, rest, tail) = built;
                strands.push(
                    world
                        .iter()
                        .map(|p| to_parent.transform_point3(*p))
                        .collect(),
                );
                driven.tail_joint.push(chain.tail_joint);
                let chain_limits: Vec<_> = chain
                    .joints
                    .iter()
                    .map(|j| limits.and_then(|l| l.of(*j)))
                    .collect();
                driven
                    .limits
                    .push(if chain_limits.iter().any(Option::is_some) {
                        chain_limits
                    } else {
                        Vec::new()
                    });
                let own = owned_from(&chain.joints, &children, &plain);
                driven.taken.extend_from_slice(&chain.joints[own..]);
                driven.joints.push(chain.joints);
                driven.rest.push(rest);
                driven.tail.push(tail);
            }
            let groom = match HairGroom::from_strands("", strands) {
                Ok(g) => g,
                Err(e) => {
                    warn!("hair bone chains {set}: chains under bone {parent}: {e}; skipped");
                    continue;
                }
            };
            let taken = driven.taken.clone();
            let joints: Vec<Entity> = driven.joints.iter().flatten().copied().collect();
            let name = names
                .get(parent)
                .map_or(String::new(), |n| n.as_str().to_owned());
            let mut hair = commands.spawn((
                Name::new(format!("hair bone chains on {name}")),
                // Where propagation will put it (on the bone, identity transform): the
                // strands are built this frame, at the bone's scale.
                Transform::IDENTITY,
                parent_world,
                Hair {
                    groom: grooms.add(groom),
                    ..default()
                },
                settings.clone(),
                driven,
                ChainPose::default(),
                ChildOf(parent),
            ));
            if let Some(only) = only {
                hair.insert(only.clone());
            }
            if let Some(inertia) = inertia {
                hair.insert(*inertia);
            }
            let hair = hair.id();
            hairs.push(hair);
            for (slot, &joint) in joints.iter().enumerate() {
                let taken_before = owners
                    .get(joint)
                    .is_ok_and(|j| j.hair != hair && chain_hairs.contains(j.hair));
                let shared = taken_before || claimed.contains(&joint);
                commands
                    .entity(joint)
                    .insert(ChainJoint::new(hair, slot as u32, shared));
            }
            claimed.extend(joints.iter().copied());
            for &joint in &taken {
                commands.entity(joint).remove::<TransformTreeChanged>();
            }
        }
        commands.entity(set).insert(BoneChainHairs(hairs));
    }
}

/// An entity below a joint that posing may propagate: no children, not a hair, not a collider.
type PlainLeaf = (Without<Children>, Without<Hair>, Without<HairCollider>);

/// Where the joints of a chain that its hair takes from Bevy's transform propagation begin:
/// the longest run at its tip whose joints have nothing below them but the next joint and
/// plain leaves (an end bone, an accessory: no children, not a hair, not a collider), which
/// posing propagates. A joint with more below it (a branch chain, a hair, a collider) stays
/// with Bevy, and so do the joints above it.
fn owned_from(
    joints: &[Entity],
    children: &Query<&Children>,
    plain: &Query<(), PlainLeaf>,
) -> usize {
    let mut from = joints.len();
    while from > 0 {
        let next = joints.get(from);
        let below_is_ours = children.get(joints[from - 1]).map_or(true, |c| {
            c.iter().all(|e| Some(&e) == next || plain.contains(e))
        });
        if !below_is_ours {
            break;
        }
        from -= 1;
    }
    from
}

/// Gives the joints of a bone-chain hair that goes back to Bevy's transform propagation.
pub(crate) fn release_joints(
    remove: On<Remove<BoneChainHair>>,
    hairs: Query<&BoneChainHair>,
    mut commands: Commands,
) {
    let Ok(driven) = hairs.get(remove.entity) else {
        return;
    };
    let (hair, taken) = (remove.entity, driven.taken.clone());
    for &joint in driven.joints.iter().flatten() {
        // Unless another hair has posed it since.
        commands
            .entity(joint)
            .queue_silenced(move |mut entity: EntityWorldMut| {
                if entity.get::<ChainJoint>().is_some_and(|j| j.hair == hair) {
                    entity.remove::<ChainJoint>();
                }
            });
    }
    commands.queue(move |world: &mut World| {
        for joint in taken {
            let Ok(mut entity) = world.get_entity_mut(joint) else {
                continue;
            };
            if let Some(mut local) = entity.get_mut::<Transform>() {
                // Changed, so propagation reaches it from its root.
                local.set_changed();
                entity.insert(TransformTreeChanged);
            }
        }
    });
}

/// A chain's particles in world space (its joints and the tail), its joints' local bind
/// transforms, and the tail in the last joint's frame; `None` when two joints coincide.
fn chain_strand(
    chain: &FoundChain,
    tail: f32,
    helper: &TransformHelper,
    locals: &Query<&Transform>,
) -> Option<(Vec<Vec3>, Vec<Transform>, Vec3)> {
    let mut world = Vec::with_capacity(chain.joints.len() + 1);
    let mut rest = Vec::with_capacity(chain.joints.len());
    let mut last = None;
    for &j in &chain.joints {
        let g = helper.compute_global_transform(j).ok()?;
        world.push(g.translation());
        // Posing multiplies these into unit rotations without normalising each product; a
        // file's rotations are as long as it wrote them.
        let local = *locals.get(j).ok()?;
        rest.push(local.with_rotation(local.rotation.normalize()));
        last = Some(g);
    }
    let last = last?;
    if chain.tail_joint {
        // The last joint is the tail: no particle past it; its offset in the joint before.
        let n = rest.len();
        if n < 2 || world[n - 1].distance(world[n - 2]) <= f32::EPSILON {
            return None;
        }
        let tail_local = rest[n - 1].translation;
        return Some((world, rest, tail_local));
    }
    let before = if world.len() >= 2 {
        world[world.len() - 2]
    } else {
        helper
            .compute_global_transform(chain.parent)
            .ok()?
            .translation()
    };
    let end = *world.last()?;
    let bone = end - before;
    let direction = bone.try_normalize()?;
    let length = (bone.length() * tail.max(0.0)).max(MIN_TAIL);
    let tip = end + direction * length;
    world.push(tip);
    let tail_local = last.affine().inverse().transform_point3(tip);
    Some((world, rest, tail_local))
}
