//! A hair's step input for one frame: its substeps, the bone's path, the colliders and force
//! fields it can meet (the broad phase), wind and anchor factors. Worked out for each hair on
//! the thread that then steps it.

use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use crate::math::usable_frame;

use super::attach::{ComputedHair, Hair, draw_margin, margin_key};
use super::collider::HairCollidesOnly;
use super::contact::LocalShape;
use super::physics::{WorldColliders, WorldShape};
use super::scratch::StepScratch;
use super::settings::{HairDampingFrame, HairInertiaFrame, HairSimSettings, compliance_factor};
use super::solver::{Contact, ContactShape, PINNED, along};
use super::step::{Between, ColliderHistory, interpolate};
use super::wind::{FieldStep, HairWind};
use super::{HairCulling, HairInView};

/// What every hair's step input is made from this frame, shared by the threads that make them.
pub(super) struct FrameShared<'a> {
    /// The hair's clock's time this frame.
    pub(super) dt: f32,
    /// Every hair collider's and force field's poses last frame and now.
    pub(super) history: &'a ColliderHistory,
    /// The physics engine's colliders each hair sees.
    pub(super) world: &'a WorldColliders,
    /// A hair's [`HairCollidesOnly`], if it has one.
    pub(super) only_colliders: &'a (dyn Fn(Entity) -> Option<&'a HairCollidesOnly> + Sync),
    /// An inertia frame's pose.
    pub(super) frames: &'a (dyn Fn(Entity) -> Option<&'a GlobalTransform> + Sync),
    /// Keyframe animations of the hairs' anchors.
    pub(super) animations: &'a Assets<crate::asset::HairAnimation>,
    /// The world's wind.
    pub(super) global_wind: Option<&'a HairWind>,
    /// A hair's own wind ([`HairWindOverride`](super::wind::HairWindOverride)), if it has one.
    pub(super) own_wind: &'a (dyn Fn(Entity) -> Option<&'a HairWind> + Sync),
}

/// A hair ready to step: its input is in its [`ComputedHair::scratch`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Prepared {
    /// The bone's pose at the last substep (where a reset strand starts again).
    pub(super) last: Affine3A,
    /// Measure the free particles' bounds while stepping (the hair spreads by its density).
    pub(super) measure: bool,
    /// Measure the particles' box while stepping (a bone-chain hair's posing needs it).
    pub(super) boxed: bool,
}

/// Advances a hair's clock by the frame and fills its step input: `None` when it takes no
/// substep this frame (its bone's pose is unusable, or the clock did not reach a substep).
/// Teleports are carried here, margins redrawn when the settings changed, keyframe anchors
/// blended.
pub(super) fn prepare_hair(
    shared: &FrameShared,
    (hair_entity, hair, global, settings): (Entity, &Hair, &GlobalTransform, &HairSimSettings),
    computed: &mut ComputedHair,
    (culling, inertia, chains): (
        Option<(&HairCulling, &HairInView)>,
        Option<&HairInertiaFrame>,
        bool,
    ),
) -> Option<Prepared> {
    let FrameShared {
        dt,
        history,
        world,
        only_colliders,
        frames,
        animations,
        global_wind,
        own_wind,
    } = *shared;
    computed.particle_box = None;
    let full = global.affine();
    if !usable_frame(&full) {
        computed.stats.invalid_bone_frames += 1;
        computed.stats.substeps = 0;
        return None;
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
        .and_then(|f| frames(f.0))
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
        return None;
    }

    let mut scratch = std::mem::take(&mut computed.scratch);
    let StepScratch {
        input,
        templates,
        paths,
        fields: field_templates,
        origins,
        factors,
        near,
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
    input.particles_only = chains;
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
    let wind = own_wind(hair_entity)
        .or(global_wind)
        .filter(|w| !w.is_calm());
    if let Some(wind) = wind {
        let first = computed.time_done;
        wind_times.clear();
        wind_times.extend((0..substeps).map(|j| (first + f64::from(j + 1) * f64::from(h)) as f32));
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
    let only = only_colliders(hair_entity);
    // The colliders whose box can reach the hair's along X, in their order (every one without
    // a reach); each then tested whole.
    let everywhere = (Vec3A::NEG_INFINITY, Vec3A::INFINITY);
    history
        .index
        .near(reach.unwrap_or(everywhere), max_margin, near);
    for c in near
        .iter()
        .filter_map(|&i| history.colliders.get(i as usize))
    {
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
        let mut pose = Affine3A::IDENTITY;
        for (i, &(prev, now, shape, inside)) in templates.iter().enumerate() {
            // A collider's shapes share its pose: interpolated once for all of them.
            if i == 0 || templates[i - 1].0 != prev || templates[i - 1].1 != now {
                pose = paths[i].at(t);
            }
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
    Some(Prepared {
        last,
        measure,
        boxed,
    })
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
