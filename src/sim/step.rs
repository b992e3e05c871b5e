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
use super::collider::HairCollider;
use super::contact::LocalShape;
use super::physics::{WorldColliders, WorldShape};
use super::settings::{HairDampingFrame, HairSimSettings, compliance_factor};
use super::solver::{Batch, Contact, ContactShape, PINNED, StepInput, along};
use super::wind::{FieldStep, HairForceField, HairWind, HairWindOverride};
use super::{HairSimControl, HairTime};

/// [`HairCollider`]s' and [`HairForceField`]s' poses last frame, so moving ones are
/// interpolated per substep.
#[derive(Resource, Default)]
pub(crate) struct ColliderHistory {
    poses: EntityHashMap<Affine3A>,
    fields: EntityHashMap<Affine3A>,
}

/// Interpolates two affine transforms (translation and scale linearly, rotation by slerp).
pub(crate) fn interpolate(a: &Affine3A, b: &Affine3A, t: f32) -> Affine3A {
    if t <= 0.0 {
        return *a;
    }
    if t >= 1.0 {
        return *b;
    }
    let (sa, ra, ta) = a.to_scale_rotation_translation();
    let (sb, rb, tb) = b.to_scale_rotation_translation();
    Affine3A::from_scale_rotation_translation(sa.lerp(sb, t), ra.slerp(rb, t), ta.lerp(tb, t))
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
        Option<&crate::mesh::HairMeshSettings>,
    )>,
    own: Query<(Entity, &HairCollider, &GlobalTransform)>,
    animations: Res<Assets<crate::asset::HairAnimation>>,
    (global_wind, own_wind, fields): (
        Option<Res<HairWind>>,
        Query<&HairWindOverride>,
        Query<(Entity, &HairForceField, &GlobalTransform)>,
    ),
) {
    // The hair's clock: zero while paused, one step when stepped.
    let dt = time.delta_secs();
    // Every HairCollider: its pose last frame and now, and its spheres (in its space).
    let own_views: Vec<(Affine3A, Affine3A, &HairCollider)> = own
        .iter()
        .map(|(e, collider, g)| {
            let now = g.affine();
            (history.poses.get(&e).copied().unwrap_or(now), now, collider)
        })
        .collect();
    history.poses.clear();
    history
        .poses
        .extend(own.iter().map(|(e, _, g)| (e, g.affine())));
    // Every force field that blows: its pose last frame and now.
    let field_views: Vec<(Affine3A, Affine3A, &HairForceField)> = fields
        .iter()
        .filter(|(_, f, g)| !f.is_calm() && usable_frame(&g.affine()))
        .map(|(e, field, g)| {
            let now = g.affine();
            let prev = history.fields.get(&e).copied().unwrap_or(now);
            (prev, now, field)
        })
        .collect();
    history.fields.clear();
    history
        .fields
        .extend(fields.iter().map(|(e, _, g)| (e, g.affine())));
    let pool = parallel::compute_pool();
    for (hair_entity, hair, global, settings, mut computed, mesh_settings) in &mut hairs {
        let computed = &mut *computed;
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
        computed.last_bone = Some(bone);

        let h = settings.substep();
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

        let mut input = StepInput {
            h,
            gravity_h2: settings.gravity() * computed.size * h * h,
            damping: settings.damping_factor(),
            alpha: [
                settings.edge_stiffness,
                settings.bend_stiffness,
                settings.torsion_stiffness,
            ]
            .map(|s| alpha_tilde(s, h)),
            style_limit: settings.style_limit() * computed.size,
            // Loose edges (stiffness 0) ask for stretchy hair: no limit then.
            max_stretch: if compliance_factor(settings.edge_stiffness, h, 1.0) > 0.0 {
                settings.max_stretch()
            } else {
                f32::INFINITY
            },
            ..default()
        };
        for j in 0..substeps {
            let t = if dt > 0.0 {
                (start + (j + 1) as f32 * h) / dt
            } else {
                1.0
            };
            input.bones.push(interpolate(&from, &bone, t));
        }
        // Wind: the hair's own, else the world's; sampled at each substep's time.
        let wind = own_wind
            .get(hair_entity)
            .map(|o| &o.0)
            .ok()
            .or(global_wind.as_deref())
            .filter(|w| !w.is_calm());
        if let Some(wind) = wind {
            let first = computed.substeps_done;
            input.wind = Some(super::solver::WindInput {
                wind: wind.clone(),
                pull: 1.0 - (-wind.drag() * h).exp(),
                times: (0..substeps)
                    .map(|j| (first + u64::from(j) + 1) as f32 * h)
                    .collect(),
            });
        }
        input.first_substep = computed.substeps_done;
        computed.substeps_done += u64::from(substeps);
        if settings.damping_frame == HairDampingFrame::Bone {
            let mut prev = interpolate(
                &from,
                &bone,
                if dt > 0.0 {
                    (start / dt).clamp(0.0, 1.0)
                } else {
                    1.0
                },
            );
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
        let mut templates: Vec<(&Affine3A, &Affine3A, LocalShape, bool)> = Vec::new();
        // A collider whose pose is not usable (NaN, zero scale) is skipped until it is.
        for (prev, now, collider) in own_views.iter().filter(|(_, now, _)| usable_frame(now)) {
            let prev = if jumped(prev, now) { now } else { prev };
            let inside = collider.inside();
            templates.extend(
                collider
                    .shapes()
                    .filter(|shape| meets(shape, prev, now, inside))
                    .map(|shape| (prev, now, shape, inside)),
            );
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
                &collider.now
            } else {
                &collider.prev
            };
            match &collider.shape {
                WorldShape::Local(shapes) => templates.extend(
                    shapes
                        .iter()
                        .filter(|shape| meets(shape, prev, &collider.now, false))
                        .map(|&shape| (prev, &collider.now, shape, false)),
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
        // Outside spheres that move little take the solver's fast path; everything else is a
        // contact, tested along each particle's path.
        let spheres = templates
            .iter()
            .filter(|&&(prev, now, shape, inside)| fast_path(&shape, inside, prev, now, substeps))
            .count();
        input.sphere_count = spheres;
        input.contact_count = templates.len() - spheres;
        input.friction = settings.friction();
        let start_t = if dt > 0.0 {
            (start / dt).clamp(0.0, 1.0)
        } else {
            1.0
        };
        for &(prev, now, shape, inside) in &templates {
            let mut before = interpolate(prev, now, start_t).transform_point3a(shape.origin());
            let is_sphere = fast_path(&shape, inside, prev, now, substeps);
            for j in 0..substeps {
                let t = if dt > 0.0 {
                    (start + (j + 1) as f32 * h) / dt
                } else {
                    1.0
                };
                let pose = interpolate(prev, now, t);
                let origin = pose.transform_point3a(shape.origin());
                let shift = origin - before;
                before = origin;
                let contact = Contact::new(shape.at(&pose), inside, shift, max_margin);
                if is_sphere {
                    if let ContactShape::Sphere { centre, radius } = contact.shape {
                        input.spheres.push((centre, radius));
                        input.sphere_shift.push(shift);
                    }
                } else {
                    input.contacts.push(contact);
                }
            }
        }
        // Per substep, not per shape: `spheres[s * count + i]`.
        transpose(&mut input.spheres, spheres, substeps as usize);
        transpose(&mut input.sphere_shift, spheres, substeps as usize);
        transpose(&mut input.contacts, input.contact_count, substeps as usize);
        // Force fields whose sphere meets the hair's reach this frame, per substep.
        let mut field_templates: Vec<(&Affine3A, &Affine3A, &HairForceField)> = Vec::new();
        for (prev, now, field) in &field_views {
            let prev = if jumped(prev, now) { now } else { prev };
            let near = reach.is_none_or(|(min, max)| {
                [prev, now].iter().any(|pose| {
                    let r = field.radius() * crate::math::largest_scale(pose);
                    let c = pose.translation;
                    (c - r).cmple(max).all() && (c + r).cmpge(min).all()
                })
            });
            if near {
                field_templates.push((prev, now, field));
            }
        }
        input.field_count = field_templates.len();
        for j in 0..substeps {
            let t = if dt > 0.0 {
                (start + (j + 1) as f32 * h) / dt
            } else {
                1.0
            };
            for &(prev, now, field) in &field_templates {
                let pose = interpolate(prev, now, t);
                input.fields.push(FieldStep {
                    centre: pose.translation.into(),
                    direction: match field.kind {
                        super::HairForceFieldKind::Point => None,
                        super::HairForceFieldKind::Directional => {
                            Some(Vec3::from(-pose.matrix3.z_axis).normalize_or(Vec3::NEG_Z))
                        }
                    },
                    speed_h: field.speed * h,
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
        // Step batches in parallel; each group of equal chain length shares anchor factors.
        let batches = &mut computed.batches;
        let chunk = batches.len().div_ceil(parallel::workers(pool) * 4).max(1);
        let factors = anchor_factors(settings, h, batches.iter().map(|b| b.nodes.len()));
        let last = &input.bones.last().copied().unwrap_or(bone);
        let resets = AtomicU32::new(0);
        parallel::run_parts(pool, batches.chunks_mut(chunk), &|part: &mut [Batch]| {
            let mut local = StepInput {
                anchor_factor: Vec::new(),
                ..input.clone()
            };
            for b in part {
                let f = factors
                    .iter()
                    .find(|(n, _)| *n == b.nodes.len())
                    .map(|(_, f)| f.as_slice())
                    .unwrap_or(&[]);
                local.anchor_factor.clear();
                local.anchor_factor.extend_from_slice(f);
                b.step(&local);
                // A strand whose state stopped being finite starts again on its anchors.
                let bad = b.non_finite_lanes();
                if bad != 0 {
                    for l in 0..super::solver::LANES {
                        if bad & (1 << l) != 0 {
                            b.reset_lane(l, last);
                            if l < b.count {
                                resets.fetch_add(1, Ordering::Relaxed);
                            }
                        }
                    }
                }
            }
        });
        computed.stats.strand_resets += resets.load(Ordering::Relaxed);
        // Hair–hair volume, once a frame after the last substep.
        computed.stats.volume_pairs = 0;
        if let (Some(volume), false) = (settings.volume, input.bones.is_empty()) {
            let radius = volume
                .radius
                .or(mesh_settings.map(|m| m.radius))
                .unwrap_or_else(|| crate::mesh::HairMeshSettings::default().radius)
                * computed.size;
            let ComputedHair {
                batches,
                volume: scratch,
                ..
            } = computed;
            let pairs = super::keep_apart(batches, radius, volume.stiffness, scratch);
            computed.stats.volume_pairs = u32::try_from(pairs).unwrap_or(u32::MAX);
        }
    }
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

/// Reorders `items` from shape-major (`[shape][substep]`) to substep-major
/// (`[substep][shape]`).
fn transpose<T: Copy>(items: &mut [T], shapes: usize, substeps: usize) {
    if shapes <= 1 || substeps <= 1 {
        return;
    }
    let by_shape = items.to_vec();
    for (i, item) in items.iter_mut().enumerate() {
        let (s, shape) = (i / shapes, i % shapes);
        *item = by_shape[shape * substeps + s];
    }
}

/// Where the hair's particles can be this frame: its rest shape's bounds at the frame's first
/// and last bone pose, grown by the longest strand at the strain limit (no particle strays
/// farther from its rest place). `None` (test every collider) without a strain limit or bounds.
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

/// Anchor correction factors per node, for every distinct chain length.
fn anchor_factors(
    settings: &HairSimSettings,
    h: f32,
    lengths: impl Iterator<Item = usize>,
) -> Vec<(usize, Vec<f32>)> {
    let mut out: Vec<(usize, Vec<f32>)> = Vec::new();
    for n in lengths {
        if out.iter().any(|(m, _)| *m == n) {
            continue;
        }
        let f = (0..n)
            .map(|k| {
                if k < PINNED {
                    0.0
                } else {
                    let s = settings.anchor_stiffness.eval_unit(along(k, n));
                    compliance_factor(s, h, 1.0)
                }
            })
            .collect();
        out.push((n, f));
    }
    out
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
