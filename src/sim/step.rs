//! The per-frame systems: gather colliders, step every hair's batches, write particles back.

use std::sync::atomic::{AtomicU32, Ordering};

use bevy::ecs::entity::EntityHashMap;
use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use crate::math::usable_frame;
use crate::parallel;

use super::attach::{
    ComputedHair, Hair, Strand, StrandOf, StrandParticles, draw_margin, margin_key,
};
use super::chain_lanes::ParticleBox;
use super::collider::{HairCollider, HairCollidesOnly};
use super::contact::LocalShape;
use super::physics::{WorldColliders, WorldShape};
use super::scratch::{ShapeView, StepScratch};
use super::settings::{HairDampingFrame, HairSimSettings, compliance_factor};
use super::solver::{Batch, Contact, ContactShape, PINNED, along};
use super::wind::{FieldStep, HairForceField, HairWind, HairWindOverride};
use super::{HairSimControl, HairTime};

/// [`HairCollider`]s' and [`HairForceField`]s' poses last frame, so moving ones are
/// interpolated per substep; and this frame's shapes and fields, in buffers reused every frame.
#[derive(Resource, Default)]
pub(crate) struct ColliderHistory {
    poses: EntityHashMap<Affine3A>,
    fields: EntityHashMap<Affine3A>,
    /// Every `HairCollider` shape this frame (pose last frame, now, shape, keep inside) and the
    /// entity it is on.
    shapes: Vec<(ShapeView, Entity)>,
    /// Every force field that blows: pose last frame, now, field.
    field_views: Vec<(Affine3A, Affine3A, HairForceField)>,
    /// Per collider entity: its run of `shapes` and where they were and are, so a hair skips a
    /// far collider with one box test (a crowd's hair meets its own character's body).
    colliders: Vec<ColliderReach>,
    /// This frame's small hairs, each stepped whole on one thread (reused every frame).
    jobs: Vec<HairJob>,
}

/// A [`HairCollider`]'s shapes over one frame, for the per-hair broad phase.
#[derive(Clone, Copy, Debug)]
struct ColliderReach {
    /// Its shapes: `shapes[first..end]`.
    first: usize,
    end: usize,
    /// Its pose now is usable (its shapes are skipped until it is).
    usable: bool,
    /// How far its origin moved since last frame (infinite when last frame's pose is unusable).
    travel: f32,
    /// Its shapes' bounds last frame and now; infinite for planes and keep-inside shapes,
    /// which every hair tests.
    prev: (Vec3A, Vec3A),
    now: (Vec3A, Vec3A),
}

impl ColliderReach {
    /// Whether a hair within `reach` (grown by `margin`) can meet the collider this frame,
    /// given that the collider `jumped` (then only its pose now counts).
    fn meets(&self, reach: (Vec3A, Vec3A), margin: f32, jumped: bool) -> bool {
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

/// A small hair's step, run on one thread beside other hairs': its batches and step buffers,
/// taken from its [`ComputedHair`] for the frame and given back after.
#[derive(Default)]
struct HairJob {
    entity: Option<Entity>,
    batches: Vec<Batch>,
    scratch: StepScratch,
    /// The bone's pose at the last substep (where a reset strand starts again).
    last: Affine3A,
    /// Measure the free particles' bounds (the hair spreads by its density).
    measure: bool,
    bounds: super::volume::Bounds,
    /// Measure the particles' box for posing (a bone-chain hair).
    boxed: bool,
    particle_box: ParticleBox,
    resets: u32,
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
/// teleports carried, unusable bones skipped, non-finite strands reset.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn step_hair_strands(
    time: Res<Time<HairTime>>,
    mut history: ResMut<ColliderHistory>,
    world: Res<WorldColliders>,
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
    )>,
    (own, only_colliders, frames): (
        Query<(Entity, &HairCollider, &GlobalTransform)>,
        Query<&HairCollidesOnly>,
        Query<&GlobalTransform>,
    ),
    animations: Res<Assets<crate::asset::HairAnimation>>,
    (global_wind, own_wind, fields): (
        Option<Res<HairWind>>,
        Query<&HairWindOverride>,
        Query<(Entity, &HairForceField, &GlobalTransform)>,
    ),
) {
    // The hair's clock: zero while paused, one step when stepped.
    let dt = time.delta_secs();
    // Every HairCollider shape: its pose last frame and now (into last frame's buffers).
    let history = &mut *history;
    history.shapes.clear();
    history.colliders.clear();
    for (e, collider, g) in &own {
        let now = g.affine();
        let prev = history.poses.get(&e).copied().unwrap_or(now);
        let inside = collider.inside();
        let first = history.shapes.len();
        history.shapes.extend(
            collider
                .shapes()
                .map(|shape| ((prev, now, shape, inside), e)),
        );
        let (usable, prev_usable) = (usable_frame(&now), usable_frame(&prev));
        let everywhere = (Vec3A::NEG_INFINITY, Vec3A::INFINITY);
        let nowhere = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let (mut at_prev, mut at_now) = (nowhere, nowhere);
        for ((_, _, shape, _), _) in &history.shapes[first..] {
            let grow = |pose: &Affine3A, into: &mut (Vec3A, Vec3A)| {
                let (lo, hi) = if inside {
                    everywhere
                } else {
                    shape.at(pose).bounds()
                };
                *into = (into.0.min(lo), into.1.max(hi));
            };
            if usable {
                grow(&now, &mut at_now);
            }
            if prev_usable {
                grow(&prev, &mut at_prev);
            }
        }
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
    }
    history.poses.clear();
    history
        .poses
        .extend(own.iter().map(|(e, _, g)| (e, g.affine())));
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
    let pool = parallel::compute_pool();
    for (
        hair_entity,
        hair,
        global,
        settings,
        mut computed,
        mesh_settings,
        culling,
        inertia,
        chains,
    ) in &mut hairs
    {
        let computed = &mut *computed;
        computed.particle_box = None;
        let full = global.affine();
        if !usable_frame(&full) {
            computed.stats.invalid_bone_frames += 1;
            computed.stats.substeps = 0;
            continue;
        }
        // The groom was scaled when it was built (a new scale rebuilds it first, in
        // `HairSystems::Attach`): the solver moves it by the rigid part only.
        let (bone, _) = super::attach::split_bone(&full);
        // Margins follow the settings (Alter margins = a new seed).
        let key = margin_key(settings);
        if key != computed.margin_key {
            let (lo, hi) = settings.margins();
            let (lo, hi) = (lo * computed.size, hi * computed.size);
            for b in &mut computed.batches {
                for l in 0..b.count {
                    b.margin[l] = draw_margin(settings.margin_seed, b.strands[l], lo, hi);
                }
            }
            computed.margin_key = key;
        }
        let last = computed.last_bone.unwrap_or(bone);
        // A teleporting bone carries the hair rigidly instead of dragging it through space.
        let (_, last_rot, last_pos) = last.to_scale_rotation_translation();
        let (_, rot, pos) = bone.to_scale_rotation_translation();
        let moved = last_pos.distance(pos);
        let turned = last_rot.angle_between(rot);
        let from = if computed.last_bone.is_none()
            || moved > settings.teleport_distance.max(0.0) * computed.size
            || turned > settings.teleport_angle.max(0.0)
        {
            if computed.last_bone.is_some() {
                computed.stats.teleports += 1;
                let delta = bone * last.inverse();
                for b in &mut computed.batches {
                    b.carry(&delta);
                }
            }
            bone
        } else {
            last
        };
        let teleported = computed.last_bone.is_some() && from == bone && last != bone;
        computed.last_bone = Some(bone);
        // The inertia frame's pose last frame and now (none after a teleport: the carry did it).
        let frame_now = inertia
            .and_then(|f| frames.get(f.0).ok())
            .map(GlobalTransform::affine)
            .filter(usable_frame)
            .map(|a| super::attach::split_bone(&a).0);
        let frame_from = match (computed.last_frame, frame_now) {
            (Some(prev), Some(_)) if !teleported => Some(prev),
            (_, now) => now,
        };
        computed.last_frame = frame_now;

        // Hair no camera saw last frame simulates coarser (see `HairCulling`).
        let h = match culling {
            Some((c, in_view)) if c.enabled && !in_view.0 && c.culled_substep_rate.is_finite() => {
                settings
                    .substep()
                    .max(1.0 / c.culled_substep_rate.clamp(30.0, 2000.0))
            }
            _ => settings.substep(),
        };
        let dt = dt.clamp(0.0, settings.frame_clamp());
        let start = -computed.accumulator;
        computed.accumulator += dt;
        // The tolerance keeps f32 rounding (1/60 over 1/240 is 3.9999...) from dropping a
        // substep and shifting the hair a substep behind the bone.
        let substeps = (computed.accumulator / h + 1e-3).floor().max(0.0) as u32;
        computed.accumulator = (computed.accumulator - substeps as f32 * h).max(0.0);
        computed.stats.substeps = substeps;
        computed.animation_time += dt;
        if substeps == 0 {
            continue;
        }

        let mut scratch = std::mem::take(&mut computed.scratch);
        let StepScratch {
            input,
            templates,
            paths,
            fields: field_templates,
            origins,
            factors,
        } = &mut scratch;
        let mut wind_times = input.wind.take().map(|w| w.times).unwrap_or_default();
        input.h = h;
        input.gravity_h2 = settings.gravity() * computed.size * h * h;
        input.damping = settings.damping_factor();
        input.alpha = [
            settings.edge_stiffness,
            settings.bend_stiffness,
            settings.torsion_stiffness,
        ]
        .map(|s| alpha_tilde(s, h));
        input.style_limit = settings.style_limit() * computed.size;
        // A bone chain's joints are far apart: its segments collide too.
        input.segments = chains;
        // Loose edges (stiffness 0) ask for stretchy hair: no limit then.
        input.max_stretch = if compliance_factor(settings.edge_stiffness, h, 1.0) > 0.0 {
            settings.max_stretch()
        } else {
            f32::INFINITY
        };
        input.bones.clear();
        input.bone_motion.clear();
        input.carry.clear();
        input.spheres.clear();
        input.sphere_shift.clear();
        input.contacts.clear();
        input.shapes.clear();
        input.fields.clear();
        input.anchor_factor.clear();
        let substep_t = |j: u32| {
            if dt > 0.0 {
                (start + (j + 1) as f32 * h) / dt
            } else {
                1.0
            }
        };
        let bone_path = Between::new(&from, &bone);
        for j in 0..substeps {
            input.bones.push(bone_path.at(substep_t(j)));
        }
        // Wind: the hair's own, else the world's; sampled at each substep's time.
        let wind = own_wind
            .get(hair_entity)
            .map(|o| &o.0)
            .ok()
            .or(global_wind.as_deref())
            .filter(|w| !w.is_calm());
        if let Some(wind) = wind {
            let first = computed.time_done;
            wind_times.clear();
            wind_times
                .extend((0..substeps).map(|j| (first + f64::from(j + 1) * f64::from(h)) as f32));
            input.wind = Some(super::solver::WindInput {
                wind: wind.clone(),
                pull: 1.0 - (-wind.drag() * h).exp(),
                times: wind_times,
            });
        }
        input.first_substep = computed.substeps_done;
        computed.substeps_done += u64::from(substeps);
        computed.time_done += f64::from(substeps) * f64::from(h);
        let start_t = if dt > 0.0 {
            (start / dt).clamp(0.0, 1.0)
        } else {
            1.0
        };
        if let (Some(a), Some(b)) = (frame_from, frame_now)
            && a != b
        {
            let path = Between::new(&a, &b);
            let mut prev = path.at(start_t);
            for j in 0..substeps {
                let now = path.at(substep_t(j));
                input.carry.push(now * prev.inverse());
                prev = now;
            }
        }
        if settings.damping_frame == HairDampingFrame::Bone {
            let mut prev = bone_path.at(start_t);
            for now in &input.bones {
                input.bone_motion.push(*now * prev.inverse());
                prev = *now;
            }
        }
        // Colliders this hair sees, after the broad phase: analytic shapes followed per
        // substep, other engine shapes at the frame's final pose.
        let max_margin = settings.margins().1 * computed.size;
        let reach = hair_reach(computed, &from, &bone, input.max_stretch);
        let meets = |shape: &LocalShape, prev: &Affine3A, now: &Affine3A, inside: bool| {
            let Some((min, max)) = reach else {
                return true;
            };
            let (a, b) = (shape.at(prev), shape.at(now));
            if inside || matches!(a, ContactShape::Plane { .. }) {
                return inside || a.meets(min, max, max_margin) || b.meets(min, max, max_margin);
            }
            // Everything the shape swept through this frame.
            let ((lo_a, hi_a), (lo_b, hi_b)) = (a.bounds(), b.bounds());
            let (lo, hi) = (lo_a.min(lo_b) - max_margin, hi_a.max(hi_b) + max_margin);
            lo.cmple(max).all() && hi.cmpge(min).all()
        };
        // A collider that jumped farther than the teleport distance this frame (with the
        // character, or on its own) is where it is now: no path through the hair in between.
        let jump = settings.teleport_distance.max(0.0) * computed.size;
        let jumped = |prev: &Affine3A, now: &Affine3A| -> bool {
            !usable_frame(prev) || prev.translation.distance(now.translation) > jump
        };
        templates.clear();
        // A collider whose pose is not usable (NaN, zero scale) is skipped until it is; one
        // that cannot reach the hair this frame is skipped whole.
        let only = only_colliders.get(hair_entity).ok();
        for c in &history.colliders {
            let Some(&(_, on)) = history.shapes.get(c.first) else {
                continue;
            };
            if !c.usable || only.is_some_and(|o| !o.0.contains(&on)) {
                continue;
            }
            if reach.is_some_and(|r| !c.meets(r, max_margin, c.travel > jump)) {
                continue;
            }
            for &((prev, now, shape, inside), _) in &history.shapes[c.first..c.end] {
                let prev = if jumped(&prev, &now) { now } else { prev };
                if meets(&shape, &prev, &now, inside) {
                    templates.push((prev, now, shape, inside));
                }
            }
        }
        let seen = world
            .seen_by
            .get(&hair_entity)
            .map_or(&[][..], Vec::as_slice);
        for collider in seen
            .iter()
            .map(|&i| &world.colliders[i])
            .filter(|c| usable_frame(&c.now))
        {
            let prev = if jumped(&collider.prev, &collider.now) {
                collider.now
            } else {
                collider.prev
            };
            match &collider.shape {
                WorldShape::Local(shapes) => templates.extend(
                    shapes
                        .iter()
                        .filter(|shape| meets(shape, &prev, &collider.now, false))
                        .map(|&shape| (prev, collider.now, shape, false)),
                ),
                #[cfg(any(feature = "rapier", feature = "avian"))]
                WorldShape::Other(kind) => {
                    let shape = kind.collider(&collider.now, max_margin);
                    let far = reach.is_some_and(|(min, max)| {
                        Vec3A::from(shape.aabb_min).cmpgt(max).any()
                            || Vec3A::from(shape.aabb_max).cmplt(min).any()
                    });
                    if !far {
                        input.shapes.push(shape);
                    }
                }
            }
        }
        computed.stats.colliders =
            u32::try_from(templates.len() + input.shapes.len()).unwrap_or(u32::MAX);
        // Outside spheres that move little take the solver's fast path (first); everything
        // else is a contact, tested along each particle's path.
        let mut spheres = 0;
        for i in 0..templates.len() {
            let (prev, now, shape, inside) = &templates[i];
            if fast_path(shape, *inside, prev, now, substeps) {
                // Stable: spheres keep their order, so do the rest.
                templates[spheres..=i].rotate_right(1);
                spheres += 1;
            }
        }
        input.sphere_count = spheres;
        input.contact_count = templates.len() - spheres;
        input.friction = settings.friction();
        // Each template's path over the frame, taken apart once (a collider's shapes share
        // one pose: taken apart once for all of them).
        paths.clear();
        for (i, (prev, now, _, _)) in templates.iter().enumerate() {
            let same = i > 0 && templates[i - 1].0 == *prev && templates[i - 1].1 == *now;
            let path = if same {
                paths[i - 1]
            } else {
                Between::new(prev, now)
            };
            paths.push(path);
        }
        origins.clear();
        origins.extend(
            templates
                .iter()
                .zip(paths.iter())
                .map(|((_, _, shape, _), path)| path.at(start_t).transform_point3a(shape.origin())),
        );
        // Substep-major: `spheres[s * sphere_count + i]`, `contacts[s * contact_count + i]`.
        for j in 0..substeps {
            let t = substep_t(j);
            for (i, &(_, _, shape, inside)) in templates.iter().enumerate() {
                let pose = paths[i].at(t);
                let origin = pose.transform_point3a(shape.origin());
                let shift = origin - origins[i];
                origins[i] = origin;
                let contact = Contact::new(shape.at(&pose), inside, shift, max_margin);
                match contact.shape {
                    ContactShape::Sphere { centre, radius } if i < spheres => {
                        input.spheres.push((centre, radius));
                        input.sphere_shift.push(shift);
                    }
                    _ => input.contacts.push(contact),
                }
            }
        }
        // Force fields whose sphere meets the hair's reach this frame, per substep.
        field_templates.clear();
        for &(prev, now, field) in &history.field_views {
            let prev = if jumped(&prev, &now) { now } else { prev };
            // Everything the field's sphere swept through this frame.
            let near = reach.is_none_or(|(min, max)| {
                let r = field.radius()
                    * crate::math::largest_scale(&prev).max(crate::math::largest_scale(&now));
                let (a, b) = (prev.translation, now.translation);
                (a.min(b) - r).cmple(max).all() && (a.max(b) + r).cmpge(min).all()
            });
            if near {
                field_templates.push((prev, now, field));
            }
        }
        input.field_count = field_templates.len();
        for j in 0..substeps {
            let t = substep_t(j);
            for (prev, now, field) in field_templates.iter() {
                let pose = interpolate(prev, now, t);
                input.fields.push(FieldStep {
                    centre: pose.translation.into(),
                    direction: match field.kind {
                        super::HairForceFieldKind::Point => None,
                        super::HairForceFieldKind::Directional => {
                            Some(Vec3::from(-pose.matrix3.z_axis).normalize_or(Vec3::NEG_Z))
                        }
                    },
                    speed_h: field.speed() * h,
                    radius: field.radius() * crate::math::largest_scale(&pose),
                    pull: 1.0 - (-field.drag() * h).exp(),
                });
            }
        }
        // Keyframe anchors for this frame.
        if let Some(anim) = hair
            .animation
            .as_ref()
            .and_then(|h| animations.get(h))
            .filter(|_| computed.animation.is_some())
        {
            let mut w = [(0, 0.0); 4];
            let n = anim.weights(computed.animation_time, &mut w);
            for b in &mut computed.batches {
                b.blend_anchors(&w[..n]);
            }
        }
        // Each group of equal chain length shares anchor factors.
        anchor_factors(
            settings,
            h,
            computed.batches.iter().map(|b| b.nodes.len()),
            factors,
        );
        let last = input.bones.last().copied().unwrap_or(bone);
        // Hair spread by its density needs its bounds: measured while stepping, while the
        // batches are in the stepping thread's cache.
        let measure = settings.volume.is_some() && computed.volume.wants_bounds();
        // A chain hair's posing needs its particles' box: measured the same way (the volume
        // pass moves particles after the step, so then posing measures it).
        let boxed = chains && settings.volume.is_none();
        computed.scratch = scratch;
        if computed.batches.len() >= SHARED_HAIR_BATCHES {
            // A big hair: its batches shared out over the threads now.
            let ComputedHair {
                batches, scratch, ..
            } = computed;
            let (bounds, particle_box, resets) = step_shared(
                pool,
                batches,
                (&scratch.input, &scratch.factors, &last),
                (measure, boxed),
            );
            computed.particle_box = boxed.then_some(particle_box);
            finish_hair(
                hair_entity,
                settings,
                mesh_settings,
                computed,
                &last,
                (measure, bounds),
                resets,
            );
        } else {
            history.jobs.push(HairJob {
                entity: Some(hair_entity),
                batches: std::mem::take(&mut computed.batches),
                scratch: std::mem::take(&mut computed.scratch),
                last,
                measure,
                bounds: super::volume::NO_BOUNDS,
                boxed,
                particle_box: ParticleBox::EMPTY,
                resets: 0,
            });
        }
    }
    // The small hairs, several at once, each whole on one thread (one hair alone shares its
    // batches out).
    let mut jobs = std::mem::take(&mut history.jobs);
    if let [job] = jobs.as_mut_slice() {
        (job.bounds, job.particle_box, job.resets) = step_shared(
            pool,
            &mut job.batches,
            (&job.scratch.input, &job.scratch.factors, &job.last),
            (job.measure, job.boxed),
        );
    } else if !jobs.is_empty() {
        let per_part = jobs.len().div_ceil(parallel::workers(pool) * 2).max(1);
        parallel::run_parts(
            pool,
            jobs.chunks_mut(per_part),
            &|part: &mut [HairJob]| {
                for job in part {
                    let (input, factors) = (&job.scratch.input, &job.scratch.factors);
                    (job.resets, job.particle_box) =
                        step_batches(&mut job.batches, input, factors, &job.last, job.boxed);
                    if job.measure {
                        job.bounds = super::volume::bounds_of(&job.batches);
                    }
                }
            },
        );
    }
    for job in &mut jobs {
        let Some(entity) = job.entity.take() else {
            continue;
        };
        let Ok((_, _, _, settings, mut computed, mesh_settings, _, _, _)) = hairs.get_mut(entity)
        else {
            continue;
        };
        computed.batches = std::mem::take(&mut job.batches);
        computed.scratch = std::mem::take(&mut job.scratch);
        computed.particle_box = job.boxed.then_some(job.particle_box);
        finish_hair(
            entity,
            settings,
            mesh_settings,
            &mut computed,
            &job.last,
            (job.measure, job.bounds),
            job.resets,
        );
    }
    jobs.clear();
    history.jobs = jobs;
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

/// After a hair's substeps: counts its resets, keeps its strands apart (hair–hair volume,
/// once a frame after the last substep), given `measured` bounds when it measured them.
fn finish_hair(
    hair_entity: Entity,
    settings: &HairSimSettings,
    mesh_settings: Option<&super::HairStrandRadius>,
    computed: &mut ComputedHair,
    last: &Affine3A,
    (measured, bounds): (bool, super::volume::Bounds),
    resets: u32,
) {
    if measured {
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

/// Whether a shape goes to the solver's sphere fast path: an outside sphere that moves less
/// than a quarter of its radius per substep (the fast path tests where particles are, not the
/// path they took).
fn fast_path(
    shape: &LocalShape,
    inside: bool,
    prev: &Affine3A,
    now: &Affine3A,
    substeps: u32,
) -> bool {
    let LocalShape::Sphere(centre, radius) = *shape else {
        return false;
    };
    let travel = prev
        .transform_point3a(centre)
        .distance(now.transform_point3a(centre));
    !inside && travel <= 0.25 * radius * substeps.max(1) as f32
}

/// Where the hair's particles can be this frame: its rest shape's bounds at the frame's first
/// and last bone pose, grown by twice the longest strand at the strain limit (a particle is
/// within a stretched strand's length of its root, which is inside the rest bounds; twice that
/// leaves room for a substep's overshoot before the limit applies). `None` (test every collider) without a strain limit or bounds.
fn hair_reach(
    computed: &ComputedHair,
    from: &Affine3A,
    to: &Affine3A,
    max_stretch: f32,
) -> Option<(Vec3A, Vec3A)> {
    let (lo, hi) = computed.rest_bounds?;
    if !max_stretch.is_finite() {
        return None;
    }
    let grow = 2.0 * computed.longest * max_stretch.max(1.0);
    let mut min = Vec3A::INFINITY;
    let mut max = Vec3A::NEG_INFINITY;
    for pose in [from, to] {
        for corner in 0..8 {
            let c = Vec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            let w = pose.transform_point3a(c.into());
            min = min.min(w);
            max = max.max(w);
        }
    }
    Some((min - grow, max + grow))
}

/// XPBD `alpha~` for a stiffness: `inf` when loose.
fn alpha_tilde(stiffness: f32, h: f32) -> f32 {
    let f = compliance_factor(stiffness, h, 1.0);
    if f <= 0.0 {
        f32::INFINITY
    } else {
        // f = w / (w + alpha~) with w = 1.
        (1.0 / f - 1.0).max(0.0)
    }
}

/// Anchor correction factors per node, for every distinct chain length, into `out` (its
/// buffers reused).
fn anchor_factors(
    settings: &HairSimSettings,
    h: f32,
    lengths: impl Iterator<Item = usize>,
    out: &mut Vec<(usize, Vec<f32>)>,
) {
    let mut used = 0;
    for n in lengths {
        if out[..used].iter().any(|(m, _)| *m == n) {
            continue;
        }
        if used == out.len() {
            out.push((n, Vec::new()));
        }
        let (m, f) = &mut out[used];
        *m = n;
        f.clear();
        f.extend((0..n).map(|k| {
            if k < PINNED {
                0.0
            } else {
                let s = settings.anchor_stiffness.eval_unit(along(k, n));
                compliance_factor(s, h, 1.0)
            }
        }));
        used += 1;
    }
    out.truncate(used);
}

/// Copies solver state into each strand entity's [`StrandParticles`], in parallel over strands.
pub(crate) fn write_strand_particles(
    control: Res<HairSimControl>,
    hairs: Query<&ComputedHair>,
    mut strands: Query<(&StrandOf, &Strand, &mut StrandParticles)>,
) {
    let structural = control.write_structural;
    strands
        .par_iter_mut()
        .for_each(|(of, strand, mut particles)| {
            let Ok(computed) = hairs.get(of.0) else {
                return;
            };
            let s = strand.index as usize;
            let Some(&(b, l)) = computed.lane_of.get(s) else {
                return;
            };
            let batch = &computed.batches[b as usize];
            let l = l as usize;
            let particles = &mut *particles;
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
        });
}

/// Debug builds: particle state must be finite after the simulation wrote it.
#[cfg(debug_assertions)]
pub(crate) fn assert_particles_finite(strands: Query<(Entity, &Strand, &StrandParticles)>) {
    for (entity, strand, particles) in &strands {
        if let Some(i) = particles.positions.iter().position(|p| !p.is_finite()) {
            panic!(
                "strand {} ({entity}) particle {i} is {:?}: last written by \
                 write_strand_particles in HairSystems::Simulate",
                strand.index, particles.positions[i]
            );
        }
    }
}
