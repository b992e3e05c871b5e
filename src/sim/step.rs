//! The per-frame systems: gather colliders, step every hair's batches, write particles back.

use std::sync::atomic::{AtomicU32, Ordering};

use bevy::ecs::batching::BatchingStrategy;
use bevy::ecs::entity::EntityHashMap;
use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use crate::math::usable_frame;
use crate::parallel;

use super::attach::{ComputedHair, Hair, HairStrands, Strand, StrandOf, StrandParticles};
use super::chain_lanes::ParticleBox;
use super::chain_pose::{ChainJoint, ChainPose, PoseFrame, pose_chain_hair};
use super::collider::{HairCollider, HairCollidesOnly};
use super::physics::WorldColliders;
use super::scratch::ShapeView;
use super::settings::HairSimSettings;
use super::solver::Batch;
use super::step_input::{FrameShared, Prepared, prepare_hair};
use super::wind::{HairForceField, HairWind, HairWindOverride};
use super::write_out::{
    ChangedEarlyJoints, EarlyJointNodes, EarlyJoints, EarlyStrands, NotEarlyJoint,
    OtherChangedJoints,
};
use super::{HairSimControl, HairTime};

/// [`HairCollider`]s' and [`HairForceField`]s' poses last frame, so moving ones are
/// interpolated per substep; and this frame's shapes and fields, in buffers reused every frame.
#[derive(Resource, Default)]
pub(crate) struct ColliderHistory {
    /// Per collider entity: its pose and its shapes' bounds (as in [`ColliderReach`]) last
    /// frame, and this frame's being gathered.
    poses: EntityHashMap<(Affine3A, (Vec3A, Vec3A))>,
    poses_now: EntityHashMap<(Affine3A, (Vec3A, Vec3A))>,
    fields: EntityHashMap<Affine3A>,
    /// Every `HairCollider` shape this frame (pose last frame, now, shape, keep inside) and the
    /// entity it is on.
    pub(super) shapes: Vec<(ShapeView, Entity)>,
    /// Every force field that blows: pose last frame, now, field.
    pub(super) field_views: Vec<(Affine3A, Affine3A, HairForceField)>,
    /// Per collider entity: its run of `shapes` and where they were and are, so a hair skips a
    /// far collider with one box test (a crowd's hair meets its own character's body).
    pub(super) colliders: Vec<ColliderReach>,
    /// `colliders` sorted along X, so a hair in a crowd finds the few near it without testing
    /// every one.
    pub(super) index: super::collider_index::ColliderIndex,
    /// This frame's hairs that step or finish after the rest (reused every frame).
    later: std::sync::Mutex<Vec<Later>>,
}

/// A [`HairCollider`]'s shapes over one frame, for the per-hair broad phase.
#[derive(Clone, Copy, Debug)]
pub(super) struct ColliderReach {
    /// Its shapes: `shapes[first..end]`.
    pub(super) first: usize,
    pub(super) end: usize,
    /// Its pose now is usable (its shapes are skipped until it is).
    pub(super) usable: bool,
    /// How far its origin moved since last frame (infinite when last frame's pose is unusable).
    pub(super) travel: f32,
    /// Its shapes' bounds last frame and now; infinite for planes and keep-inside shapes,
    /// which every hair tests.
    prev: (Vec3A, Vec3A),
    now: (Vec3A, Vec3A),
}

impl ColliderReach {
    /// Whether a hair within `reach` (grown by `margin`) can meet the collider this frame,
    /// given that the collider `jumped` (then only its pose now counts).
    pub(super) fn meets(&self, reach: (Vec3A, Vec3A), margin: f32, jumped: bool) -> bool {
        let (mut lo, mut hi) = self.now;
        if !jumped {
            lo = lo.min(self.prev.0);
            hi = hi.max(self.prev.1);
        }
        (lo - margin).cmple(reach.1).all() && (hi + margin).cmpge(reach.0).all()
    }
}

/// Hairs with at least this many batches share their batches out over the threads; smaller
/// hairs are stepped whole, several hairs at once.
const SHARED_HAIR_BATCHES: usize = 32;

/// A hair, its simulation settings and its strands' radius (for its volume pass).
type HairOf<'a> = (
    Entity,
    &'a HairSimSettings,
    Option<&'a super::HairStrandRadius>,
);

/// Hairs made ready and stepped by one task (most hairs are small: a character's few dozen
/// to a few hundred strands).
const HAIRS_PER_TASK: usize = 4;

/// A hair whose step or finish waits until every small hair has stepped: a big hair (or one
/// alone), whose batches are then shared out over the threads, or a hair whose volume pass
/// shares its work out.
#[derive(Clone, Copy, Debug)]
struct Later {
    entity: Entity,
    prepared: Prepared,
    /// Its free particles' bounds and reset strands, when it has stepped.
    stepped: Option<(super::volume::Bounds, u32)>,
}

/// Interpolates two affine transforms (translation and scale linearly, rotation by slerp).
pub(crate) fn interpolate(a: &Affine3A, b: &Affine3A, t: f32) -> Affine3A {
    if t <= 0.0 {
        return *a;
    }
    if t >= 1.0 {
        return *b;
    }
    Between::new(a, b).at(t)
}

/// Two affine transforms taken apart (scale, rotation, translation) once, to be interpolated
/// at several times: [`interpolate`] without taking both apart at each one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Between {
    a: Affine3A,
    b: Affine3A,
    from: (Vec3, Quat, Vec3),
    to: (Vec3, Quat, Vec3),
}

impl Between {
    pub(crate) fn new(a: &Affine3A, b: &Affine3A) -> Self {
        Self {
            a: *a,
            b: *b,
            from: a.to_scale_rotation_translation(),
            to: b.to_scale_rotation_translation(),
        }
    }

    /// The same as `interpolate(a, b, t)`, bit for bit.
    pub(crate) fn at(&self, t: f32) -> Affine3A {
        if t <= 0.0 {
            return self.a;
        }
        if t >= 1.0 {
            return self.b;
        }
        let ((sa, ra, ta), (sb, rb, tb)) = (self.from, self.to);
        Affine3A::from_scale_rotation_translation(sa.lerp(sb, t), ra.slerp(rb, t), ta.lerp(tb, t))
    }
}

/// Advances every hair by the frame's time: fixed substeps, bone interpolated per substep,
/// teleports carried, unusable bones skipped, non-finite strands reset. Each small hair is made
/// ready ([`prepare_hair`]), stepped and finished on one thread, several hairs at once, and a
/// bone-chain hair is then posed on that thread while its batches are in its cache and its
/// joints written ([`EarlyJoints`]), and its strands' particles written ([`EarlyStrands`]); big
/// hairs follow, each shared out over the threads, and are posed and written by the systems
/// after this one.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn step_hair_strands(
    (time, mut history, mut world): (
        Res<Time<HairTime>>,
        ResMut<ColliderHistory>,
        ResMut<WorldColliders>,
    ),
    mut hairs: Query<(
        Entity,
        &Hair,
        &GlobalTransform,
        &HairSimSettings,
        &mut ComputedHair,
        Option<&super::HairStrandRadius>,
        Option<(&super::HairCulling, &super::HairInView)>,
        Option<&super::HairInertiaFrame>,
        Has<super::BoneChainHair>,
        Option<(Ref<super::BoneChainHair>, &mut ChainPose)>,
        Option<&HairStrands>,
    )>,
    (own, only_colliders, frames): (
        Query<(Entity, Ref<HairCollider>, &GlobalTransform)>,
        Query<&HairCollidesOnly>,
        Query<&GlobalTransform, NotEarlyJoint>,
    ),
    (animations, global_wind, own_wind, fields): (
        Res<Assets<crate::asset::HairAnimation>>,
        Option<Res<HairWind>>,
        Query<&HairWindOverride>,
        Query<(Entity, &HairForceField, &GlobalTransform)>,
    ),
    (bind, (owners, mut joint_sets, other_changed), mut posing): (
        Query<&Transform, NotEarlyJoint>,
        (
            Query<&'static ChainJoint>,
            ParamSet<(EarlyJointNodes, ChangedEarlyJoints)>,
            OtherChangedJoints,
        ),
        Local<PoseFrame>,
    ),
    // The strands' particles, written by the thread that stepped their hair.
    (control, strand_info, strand_particles): (
        Res<HairSimControl>,
        Query<(&'static StrandOf, &'static Strand)>,
        Query<&'static mut StrandParticles>,
    ),
) {
    // The hair's clock: zero while paused, one step when stepped.
    let dt = time.delta_secs();
    // Every HairCollider shape: its pose last frame and now (into last frame's buffers), and
    // where its shapes are now for posing (the same posed shapes give the broad phase's box).
    let history = &mut *history;
    history.shapes.clear();
    history.colliders.clear();
    history.index.clear();
    let shapes_now = posing.shapes_mut();
    shapes_now.clear();
    let nowhere = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for (e, collider, g) in &own {
        let now = g.affine();
        let inside = collider.inside();
        let usable = usable_frame(&now);
        let posed = shapes_now.add(e, inside, collider.shapes().map(|s| s.at(&now)));
        let at_now = if usable { posed } else { nowhere };
        // Where its shapes were last frame: kept from then, unless the collider changed since.
        let (prev, at_prev) = match history.poses.get(&e) {
            Some(&(prev, at_prev)) if !collider.is_changed() => (prev, at_prev),
            Some(&(prev, _)) if usable_frame(&prev) => (prev, collider.bounds_at(&prev)),
            Some(&(prev, _)) => (prev, nowhere),
            None => (now, at_now),
        };
        let prev_usable = usable_frame(&prev);
        let first = history.shapes.len();
        history.shapes.extend(
            collider
                .shapes()
                .map(|shape| ((prev, now, shape, inside), e)),
        );
        history.colliders.push(ColliderReach {
            first,
            end: history.shapes.len(),
            usable,
            travel: if prev_usable {
                prev.translation.distance(now.translation)
            } else {
                f32::INFINITY
            },
            prev: at_prev,
            now: at_now,
        });
        history.index.add([at_prev, at_now]);
        history.poses_now.insert(e, (now, at_now));
    }
    history.index.sort();
    std::mem::swap(&mut history.poses, &mut history.poses_now);
    history.poses_now.clear();
    // Every force field that blows: its pose last frame and now.
    history.field_views.clear();
    for (e, field, g) in &fields {
        let now = g.affine();
        if field.is_calm() || !usable_frame(&now) {
            continue;
        }
        let prev = history.fields.get(&e).copied().unwrap_or(now);
        history.field_views.push((prev, now, *field));
    }
    history.fields.clear();
    history
        .fields
        .extend(fields.iter().map(|(e, _, g)| (e, g.affine())));
    // Posing needs the hairs whose joints changed, and the joints the step reads.
    if hairs.iter().any(|h| h.9.is_some()) {
        let changed = joint_sets.p1();
        let changed = changed
            .iter()
            .filter_map(|joint| owners.get(joint).ok().map(|j| j.hair));
        posing.gather_stale(changed.chain(other_changed.iter().map(|j| j.hair)));
    }
    let joint_nodes = joint_sets.p0();
    posing.gather_read_elsewhere(
        hairs
            .iter()
            .filter_map(|h| h.7.map(|frame| frame.0))
            .filter(|&frame| joint_nodes.contains(frame)),
    );
    let joints = EarlyJoints {
        owners: &owners,
        nodes: &joint_nodes,
        read_elsewhere: &posing.read_elsewhere,
    };
    let pool = parallel::compute_pool();
    let shared = FrameShared {
        dt,
        history,
        world: &world,
        only_colliders: &|e| only_colliders.get(e).ok(),
        frames: &|e| joints.world(e, &frames),
        animations: &animations,
        global_wind: global_wind.as_deref(),
        own_wind: &|e| own_wind.get(e).ok().map(|o| &o.0),
    };
    // A hair alone shares its batches out over the threads, as a big hair does.
    let alone = hairs.iter().nth(1).is_none();
    let later = &history.later;
    let posing = &*posing;
    let early = EarlyStrands {
        info: &strand_info,
        particles: &strand_particles,
        structural: control.write_structural,
    };
    // Each hair made ready and stepped whole on one thread, several hairs at once; a chain hair
    // then posed while its batches are in that thread's cache.
    hairs
        .par_iter_mut()
        .batching_strategy(BatchingStrategy::fixed(HAIRS_PER_TASK))
        .for_each(
            |(
                entity,
                hair,
                global,
                settings,
                mut computed,
                mesh_settings,
                culling,
                inertia,
                chains,
                chain,
                strands,
            )| {
                let computed = &mut *computed;
                let done = match prepare_hair(
                    &shared,
                    (entity, hair, global, settings),
                    computed,
                    (culling, inertia, chains),
                ) {
                    // No substep this frame: posed where its particles are.
                    None => true,
                    Some(prepared) => step_small_hair(
                        (entity, settings, mesh_settings),
                        computed,
                        prepared,
                        alone,
                        later,
                    ),
                };
                if let Some((driven, mut pose)) = chain {
                    // A hair left for later is posed by posing's own system.
                    pose.posed_early = done;
                    if done {
                        pose_chain_hair(
                            (entity, &driven, driven.is_changed()),
                            global,
                            Some(&mut *computed),
                            &mut pose,
                            (settings, only_colliders.get(entity).ok()),
                            posing,
                            &|e| joints.local(entity, e, &bind),
                        );
                    }
                    // Its joints written while its poses are in this thread's cache.
                    pose.joints_written = done && joints.write(entity, pose.posed());
                }
                // Its particles written out while its batches are in this thread's cache (after
                // posing, which moves them); a hair left for later is written after the step.
                computed.strands_written =
                    done && strands.is_some_and(|list| early.write(entity, computed, list));
            },
        );
    let mut later = std::mem::take(
        history
            .later
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    );
    later.sort_unstable_by_key(|l| l.entity);
    for Later {
        entity,
        prepared,
        stepped,
    } in later.drain(..)
    {
        let Ok((_, _, _, settings, mut computed, mesh_settings, ..)) = hairs.get_mut(entity) else {
            continue;
        };
        let computed = &mut *computed;
        let (bounds, resets) = stepped.unwrap_or_else(|| {
            let ComputedHair {
                batches, scratch, ..
            } = computed;
            let (bounds, particle_box, resets) = step_shared(
                pool,
                batches,
                (&scratch.input, &scratch.factors, &prepared.last),
                (prepared.measure, prepared.boxed),
            );
            computed.particle_box = prepared.boxed.then_some(particle_box);
            (bounds, resets)
        });
        finish_hair(
            (entity, settings, mesh_settings),
            computed,
            &prepared,
            (bounds, resets),
        );
    }
    *history
        .later
        .get_mut()
        .unwrap_or_else(std::sync::PoisonError::into_inner) = later;
    // The engines' colliders read: their gathering finds the buffers empty next frame.
    world.next_frame();
}

/// Steps and finishes a small hair made ready by [`prepare_hair`], on this thread; returns
/// `false` when it is left for `later`: a big hair (or one `alone`), whose batches are shared
/// out over the threads, or a hair whose volume pass shares its work out (finished then).
fn step_small_hair(
    hair: HairOf,
    computed: &mut ComputedHair,
    prepared: Prepared,
    alone: bool,
    later: &std::sync::Mutex<Vec<Later>>,
) -> bool {
    let (entity, settings, _) = hair;
    let later = |stepped| {
        later
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .push(Later {
                entity,
                prepared,
                stepped,
            });
    };
    if alone || computed.batches.len() >= SHARED_HAIR_BATCHES {
        later(None);
        return false;
    }
    let ComputedHair {
        batches, scratch, ..
    } = computed;
    let (resets, particle_box) = step_batches(
        batches,
        &scratch.input,
        &scratch.factors,
        &prepared.last,
        prepared.boxed,
    );
    let bounds = if prepared.measure {
        super::volume::bounds_of(batches)
    } else {
        super::volume::NO_BOUNDS
    };
    computed.particle_box = prepared.boxed.then_some(particle_box);
    if settings.volume.is_some() {
        later(Some((bounds, resets)));
        return false;
    }
    finish_hair(hair, computed, &prepared, (bounds, resets));
    true
}

/// Steps `batches` with `input`, up to three of one chain length at a time, and resets each
/// strand whose state stopped being finite onto its anchors at `last`; returns how many strands
/// were reset, and (when `boxed`) the particles' box, each batch measured right after its step.
fn step_batches(
    batches: &mut [Batch],
    input: &super::solver::StepInput,
    factors: &[(usize, Vec<f32>)],
    last: &Affine3A,
    boxed: bool,
) -> (u32, ParticleBox) {
    let factors_of = |b: &Batch| {
        factors
            .iter()
            .find(|(n, _)| *n == b.nodes.len())
            .map(|(_, f)| f.as_slice())
            .unwrap_or(&[])
    };
    let mut resets = 0;
    let mut particle_box = ParticleBox::EMPTY;
    let mut rest = batches;
    while let Some((first, after)) = rest.split_first_mut() {
        // Up to three batches of one chain length step side by side (see `Batch::step_together`).
        let len = first.nodes.len();
        let anchors = factors_of(first);
        let same = after
            .iter()
            .take(2)
            .take_while(|b| b.nodes.len() == len)
            .count();
        let stepped = match (same, after) {
            (2, [second, third, tail @ ..]) => {
                Batch::step_together([first, second, third], input, anchors);
                rest = tail;
                [Some(first), Some(second), Some(third)]
            }
            (1, [second, tail @ ..]) => {
                Batch::step_together([first, second], input, anchors);
                rest = tail;
                [Some(first), Some(second), None]
            }
            (_, others) => {
                first.step_with(input, anchors);
                rest = others;
                [Some(first), None, None]
            }
        };
        for b in stepped.into_iter().flatten() {
            // A strand whose state stopped being finite starts again on its anchors.
            let bad = b.non_finite_lanes();
            if bad != 0 {
                for l in 0..super::solver::LANES {
                    if bad & (1 << l) != 0 {
                        b.reset_lane(l, last);
                        if l < b.count {
                            resets += 1;
                        }
                    }
                }
            }
            if boxed {
                particle_box = particle_box.merge(ParticleBox::of(std::slice::from_ref(b)));
            }
        }
    }
    (resets, particle_box)
}

/// [`step_batches`] with the batches shared out over `pool`'s threads, and (when `measure`)
/// the free particles' bounds measured part by part.
fn step_shared(
    pool: &bevy::tasks::TaskPool,
    batches: &mut [Batch],
    (input, factors, last): (&super::solver::StepInput, &[(usize, Vec<f32>)], &Affine3A),
    (measure, boxed): (bool, bool),
) -> (super::volume::Bounds, ParticleBox, u32) {
    // A multiple of three a part, so its batches step three at a time.
    let chunk = batches
        .len()
        .div_ceil(parallel::workers(pool) * 4)
        .max(1)
        .next_multiple_of(3);
    let resets = AtomicU32::new(0);
    let measured = std::sync::Mutex::new((super::volume::NO_BOUNDS, ParticleBox::EMPTY));
    parallel::run_parts(pool, batches.chunks_mut(chunk), &|part: &mut [Batch]| {
        let (reset, particle_box) = step_batches(part, input, factors, last, boxed);
        resets.fetch_add(reset, Ordering::Relaxed);
        let bounds = measure.then(|| super::volume::bounds_of(part));
        if measure || boxed {
            let mut all = measured
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if let Some(bounds) = bounds {
                all.0 = super::volume::merge_bounds(all.0, bounds);
            }
            all.1 = all.1.merge(particle_box);
        }
    });
    let (bounds, particle_box) = measured
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    (bounds, particle_box, resets.into_inner())
}

/// After a hair's substeps: counts its `resets`, keeps its strands apart (hair–hair volume,
/// once a frame after the last substep), given the `bounds` its step measured (when `prepared`
/// says it measured them).
fn finish_hair(
    (hair_entity, settings, mesh_settings): HairOf,
    computed: &mut ComputedHair,
    prepared: &Prepared,
    (bounds, resets): (super::volume::Bounds, u32),
) {
    let last = &prepared.last;
    if prepared.measure {
        computed.volume.measure(bounds);
    }
    computed.stats.strand_resets += resets;
    computed.stats.volume_pairs = 0;
    computed.stats.volume_spread = 0;
    let Some(volume) = settings.volume else {
        return;
    };
    let radius = volume
        .radius
        .or(mesh_settings.map(|r| r.0))
        .unwrap_or(super::DEFAULT_STRAND_RADIUS)
        * computed.size;
    let ComputedHair {
        batches,
        volume: scratch,
        ..
    } = computed;
    let was_dense = scratch.dense;
    let pairs = super::keep_apart(batches, radius, volume.stiffness, last, scratch);
    if scratch.dense != was_dense {
        debug!(
            "hair {hair_entity}: volume {} ({} particles crowded at radius {radius} m)",
            if scratch.dense {
                "spreads the hair by its density"
            } else {
                "back to pairs"
            },
            scratch.crowded_count
        );
    }
    computed.stats.volume_pairs = u32::try_from(pairs).unwrap_or(u32::MAX);
    computed.stats.volume_spread = computed.volume.spread;
}

/// Debug builds: particle state must be finite after the simulation wrote it.
#[cfg(debug_assertions)]
pub(crate) fn assert_particles_finite(strands: Query<(Entity, &Strand, &StrandParticles)>) {
    for (entity, strand, particles) in &strands {
        if let Some(i) = particles.positions.iter().position(|p| !p.is_finite()) {
            panic!(
                "strand {} ({entity}) particle {i} is {:?}: last written by \
                 write_hair_state in HairSystems::Simulate",
                strand.index, particles.positions[i]
            );
        }
    }
}
