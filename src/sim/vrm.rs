//! VRM spring bones as hair: once a VRM (or any glTF with `VRMC_springBone` or VRM 0.x
//! `secondaryAnimation`) scene spawns, each spring becomes a [`HairBoneChains`] simulated by the
//! hair solver and each collider a [`HairCollider`] on its node, with collider groups applying
//! only to the springs that name them ([`HairCollidesOnly`]).
//!
//! ## The parameter mapping
//!
//! VRM's reference step is per frame; the hair solver is per second with fixed substeps, so the
//! same numbers behave the same at 30, 60 or 144 fps. [`vrm_sim_settings`] maps a spring (VRM
//! 1.0: its joints but the last, which is only a tail; VRM 0.x: its group) as follows, reading
//! VRM's per-frame quantities at 60 frames a second, the rate authors tune at:
//!
//! | VRM | hair | mapping |
//! |---|---|---|
//! | `dragForce` `d` (share of velocity lost per frame) | [`HairSimSettings::damping`] | `-60 ln(1 - d)` per second (`d` capped at 0.95) |
//! | `gravityPower` `g`, `gravityDir` | [`HairSimSettings::gravity`] | `gravityDir * g * k`, `k = -60 ln(1 - d) / d` (`60` when `d` is 0): the fall speed VRM settles at, `g / d` per frame, is the one the damped solver settles at |
//! | `stiffness` `s` (per joint) | [`HairSimSettings::anchor_stiffness`] | VRM moves a tail back toward its bind direction at `s` metres a second; a bone of length `L` so returns at a rate `s / L` a second, and each joint gets the anchor whose pull removes that rate ([`anchor_for_rate`]), root `x = 0` to last `x = 1`, fitted by a least-squares quadratic. `L` is the spring's mean bone length at the character's size |
//! | `stiffness` | [`HairSimSettings::bend_stiffness`] | the mean anchor: a joint's stiffness turns it back toward its rest direction from its parent, as the chain's bending springs do (`torsion_stiffness`, which bone chains do not use, gets half) |
//! | `hitRadius` | [`HairSimSettings::margin_min`], `margin_max` | the spring's largest, capped at [`MAX_MARGIN`](super::MAX_MARGIN) |
//! | `center` | [`HairInertiaFrame`] | the spring's particles are carried by the center node's motion each substep: moving that node gives them no inertia, as in VRM's step |
//!
//! Averages are over the spring's joints. Stiffness has no exact counterpart (VRM pushes the
//! tail back at a constant speed, the solver pulls it with a spring): the mapping matches the
//! rate at which a displaced joint returns. Edit the spawned
//! [`HairBoneChains`]' [`HairSimSettings`] to tune further.
//!
//! ## Angle limits
//!
//! A VRM 1.0 joint's `VRMC_springBone_limit` (cone, hinge or spherical, 1.0 draft) becomes an
//! entry of the spring's [`ChainJointLimits`]; the chains keep each limited bone inside its limit
//! as they are posed (see `sim::limits`).
//!
//! ## Colliders
//!
//! Each collider becomes a child entity of its node with one [`HairCollider`] shape, so it
//! moves, turns **and scales** with the node: a collider's radius follows its node's scale (as
//! UniVRM does; three-vrm does not scale radii). VRM 0.x offsets are converted from Unity's
//! space (`z` negated). Inside spheres and capsules keep joints inside; planes keep them on the
//! normal's side. The hair's own colliders and any other [`HairCollider`] in the scene do not
//! affect VRM springs unless the user adds them to the springs' [`HairCollidesOnly`].
//!
//! ## Chains
//!
//! A VRM 1.0 spring is one chain; its last joint is a tail that moves but is not turned (the
//! specification's rule). A VRM 0.x group's root bones swing with every descendant: a chain runs
//! through each joint's first child, every other child starts a chain of its own, and each leaf
//! gets a tail node 7 cm (in its own units) along its bone, as UniVRM adds.

use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;
use bevy::world_serialization::WorldAssetRoot;

use crate::asset::{
    CollisionCapsule, CollisionPlane, CollisionSphere, MAX_PARTICLES_PER_STRAND, VrmNode, VrmShape,
    VrmSpring, VrmSpringBones, VrmVersion,
};
use crate::curve::QuadraticCurve;

use super::chains::{ChainSelect, HairBoneChains};
use super::collider::{HairCollider, HairColliderMode, HairCollidesOnly};
use super::events::VrmSpringsFailed;
use super::limits::ChainJointLimits;
use super::settings::{HairInertiaFrame, HairSimSettings, MAX_MARGIN};

/// VRM 0.x's tail past a leaf bone, in the leaf's units.
pub const VRM0_TAIL: f32 = 0.07;

/// Frame rate at which VRM's per-frame quantities are read.
const VRM_RATE: f32 = 60.0;

/// On a scene root with [`VrmSpringBones`] once they are built: one [`HairBoneChains`] entity per
/// spring (in the file's order; springs with nothing to simulate are left out) and one
/// [`HairCollider`] entity per collider. All are descendants of the scene root, so despawning
/// the character despawns them and their hairs. Remove it (after despawning those) to build again.
#[derive(Component, Clone, Debug, Default, Reflect)]
#[reflect(Component, Debug)]
pub struct VrmSpringChains {
    /// The [`HairBoneChains`] entities.
    pub springs: Vec<Entity>,
    /// The collider entities, in the file's order.
    pub colliders: Vec<Entity>,
}

/// The hair settings a VRM spring maps to (see the module docs); `bone_length` is the spring's
/// mean bone length in metres (world), which turns VRM's stiffness (a speed) into a rate.
pub fn vrm_sim_settings(
    spring: &VrmSpring,
    version: VrmVersion,
    bone_length: f32,
) -> HairSimSettings {
    // A VRM 1.0 spring's last joint is only a tail: its parameters are unused.
    let joints = match version {
        VrmVersion::V1 if spring.joints.len() > 1 => &spring.joints[..spring.joints.len() - 1],
        _ => &spring.joints[..],
    };
    let mut settings = HairSimSettings::default();
    if joints.is_empty() {
        return settings;
    }
    let n = joints.len() as f32;
    let drag = (joints.iter().map(|j| j.drag_force).sum::<f32>() / n).clamp(0.0, 0.95);
    let damping = -VRM_RATE * (1.0 - drag).ln();
    let fall = if drag > 1e-4 {
        damping / drag
    } else {
        VRM_RATE
    };
    let gravity = joints
        .iter()
        .map(|j| j.gravity_dir * j.gravity_power)
        .sum::<Vec3>()
        / n;
    let hit = joints.iter().map(|j| j.hit_radius).fold(0.0, f32::max);
    let h = settings.substep();
    let length = if bone_length.is_finite() && bone_length > 1e-6 {
        bone_length
    } else {
        VRM0_TAIL
    };
    let anchor = |s: f32| anchor_for_rate(s / length, h);
    settings.damping = damping;
    settings.gravity = gravity * fall;
    settings.anchor_stiffness = fit_quadratic(
        joints
            .iter()
            .enumerate()
            .map(|(k, j)| {
                let x = if joints.len() > 1 {
                    k as f32 / (n - 1.0)
                } else {
                    0.0
                };
                (x, anchor(j.stiffness))
            })
            .collect::<Vec<_>>()
            .as_slice(),
    );
    // A joint's stiffness turns it back toward its rest direction from its parent: the anchors
    // pull toward the styled pose, and the bending springs (between every other particle of a
    // bone chain) toward the styled angle at each joint, with the joints' mean anchor, so a
    // soft spring is soft all along. Bone chains have no torsion springs; a groom given these
    // settings gets half of it.
    let mean_anchor = joints.iter().map(|j| anchor(j.stiffness)).sum::<f32>() / n;
    settings.bend_stiffness = mean_anchor;
    settings.torsion_stiffness = 0.5 * mean_anchor;
    settings.margin_min = hit.min(MAX_MARGIN);
    settings.margin_max = settings.margin_min;
    settings
}

/// The anchor stiffness whose pull removes `rate` of a particle's offset per second (for a
/// small offset, substeps of `h`): the inverse of
/// [`compliance_factor`](super::compliance_factor) for one particle.
pub fn anchor_for_rate(rate: f32, h: f32) -> f32 {
    if rate.is_nan() || rate <= 0.0 || !rate.is_finite() {
        return 0.0;
    }
    let f = (rate * h).clamp(1e-7, 0.999);
    let compliance = h * h * (1.0 - f) / f;
    (-compliance.log10() / 9.0).clamp(0.0, 1.0)
}

/// The least-squares quadratic through `points` (a constant for one, a line for two).
fn fit_quadratic(points: &[(f32, f32)]) -> QuadraticCurve {
    match points {
        [] => QuadraticCurve::new(0.0, 0.0, 0.0),
        [(_, y)] => QuadraticCurve::new(0.0, 0.0, *y),
        [(x0, y0), (x1, y1)] => {
            let b = if (x1 - x0).abs() > 1e-6 {
                (y1 - y0) / (x1 - x0)
            } else {
                0.0
            };
            QuadraticCurve::new(0.0, b, y0 - b * x0)
        }
        _ => {
            // Normal equations of y = a x^2 + b x + c.
            let mut m = Mat3::ZERO;
            let mut r = Vec3::ZERO;
            for &(x, y) in points {
                let v = Vec3::new(x * x, x, 1.0);
                m += Mat3::from_cols(v * v.x, v * v.y, v * v.z);
                r += v * y;
            }
            if m.determinant().abs() < 1e-9 {
                let mean = points.iter().map(|p| p.1).sum::<f32>() / points.len() as f32;
                return QuadraticCurve::new(0.0, 0.0, mean);
            }
            let s = m.inverse() * r;
            QuadraticCurve::new(s.x, s.y, s.z)
        }
    }
}

/// A `.vrm` file that fails to load (a broken file, or textures in a format the game's Bevy
/// features cannot decode, such as WebP without Bevy's `webp` feature) is reported like a hair
/// file: an error in the log naming the file and the loader's reason, and [`VrmSpringsFailed`]
/// on every scene root that waits for it; when no scene root names the file (another crate,
/// such as bevy_vrm1, loads it, or its scene is not spawned yet), on [`Entity::PLACEHOLDER`],
/// so global observers still hear of it.
pub(crate) fn report_failed_vrm_loads(
    mut commands: Commands,
    mut failed: MessageReader<bevy::asset::UntypedAssetLoadFailedEvent>,
    roots: Query<(Entity, &WorldAssetRoot, Has<VrmSpringChains>)>,
) {
    for event in failed.read() {
        let is_vrm = event
            .path
            .path()
            .extension()
            .is_some_and(|x| x.eq_ignore_ascii_case("vrm"));
        if !is_vrm {
            continue;
        }
        let file = event.path.without_label().to_string();
        // The loader's reason, without the backtrace Bevy attaches (never resolved for a glTF
        // error: resolving one reads the program's debug information).
        let gltf_error = match &event.error {
            bevy::asset::AssetLoadError::AssetLoaderError(e) => {
                e.error().downcast_ref::<bevy::gltf::GltfError>()
            }
            _ => None,
        };
        let reason = gltf_error
            .map(ToString::to_string)
            .unwrap_or_else(|| super::attach::load_failure(&event.error));
        let reason = reason.lines().next().unwrap_or_default();
        // A texture Bevy cannot decode fails the whole file: say which features decode what.
        let hint = if matches!(
            gltf_error,
            Some(
                bevy::gltf::GltfError::ImageError(_)
                    | bevy::gltf::GltfError::InvalidImageMimeType(_)
            )
        ) {
            " (this crate turns on Bevy's `png`, `jpeg` and `ktx2` image features; add the \
             feature of the texture's format to the game's `bevy` dependency)"
        } else {
            ""
        };
        let error = format!(
            "{file}: the VRM file did not load, so its character and springs are missing: \
             {reason}{hint}"
        );
        error!("{error}");
        // Every scene root of the file is told once; a file no scene root names, once on the
        // placeholder.
        let mut named = false;
        for (entity, root, told) in &roots {
            let of_file = root
                .0
                .path()
                .is_some_and(|p| p.without_label() == event.path.without_label());
            named |= of_file;
            if of_file && !told {
                commands.trigger(VrmSpringsFailed {
                    entity,
                    file: file.clone(),
                    error: error.clone(),
                });
                commands.entity(entity).insert(VrmSpringChains::default());
            }
        }
        if !named {
            commands.trigger(VrmSpringsFailed {
                entity: Entity::PLACEHOLDER,
                file,
                error,
            });
        }
    }
}

/// Builds the chains and colliders of every spawned scene root with [`VrmSpringBones`].
pub(crate) fn build_vrm_springs(
    mut commands: Commands,
    roots: Query<(Entity, &VrmSpringBones), Without<VrmSpringChains>>,
    nodes: Query<&VrmNode>,
    children: Query<&Children>,
    locals: Query<&Transform>,
    helper: TransformHelper,
) {
    for (root, bones) in &roots {
        if let Some(error) = &bones.error {
            commands.trigger(VrmSpringsFailed {
                entity: root,
                file: bones.file.clone(),
                error: error.clone(),
            });
            commands.entity(root).insert(VrmSpringChains::default());
            continue;
        }
        // Node index -> entity, over the scene's descendants.
        let mut by_index: Vec<Option<Entity>> = Vec::new();
        let mut stack = vec![root];
        while let Some(e) = stack.pop() {
            if let Ok(VrmNode(i)) = nodes.get(e) {
                let i = *i as usize;
                if by_index.len() <= i {
                    by_index.resize(i + 1, None);
                }
                by_index[i] = Some(e);
            }
            if let Ok(kids) = children.get(e) {
                stack.extend(kids.iter());
            }
        }
        let entity_of = |i: u32| by_index.get(i as usize).copied().flatten();
        let file = &bones.file;
        let springs = &bones.springs;
        let mut built = VrmSpringChains::default();
        let mut collider_entities = Vec::with_capacity(springs.colliders.len());
        for (i, c) in springs.colliders.iter().enumerate() {
            let Some(node) = entity_of(c.node) else {
                warn!(
                    "{file}: collider {i}: node {} is not in the spawned scene; left out",
                    c.node
                );
                collider_entities.push(None);
                continue;
            };
            let global = helper.compute_global_transform(node).unwrap_or_default();
            let e = commands
                .spawn((
                    Name::new(format!("VRM collider {i}")),
                    Transform::IDENTITY,
                    global,
                    collider(&c.shape),
                    ChildOf(node),
                ))
                .id();
            collider_entities.push(Some(e));
            built.colliders.push(e);
        }
        for (s, spring) in springs.springs.iter().enumerate() {
            let chains = match springs.version {
                VrmVersion::V1 => {
                    let joints: Option<Vec<Entity>> =
                        spring.nodes.iter().map(|&n| entity_of(n)).collect();
                    match joints {
                        Some(j) if j.len() >= 2 => vec![j],
                        Some(_) => {
                            warn!(
                                "{file}: spring {s} ({:?}) has fewer than two joints: nothing \
                                 turns; give it a tail joint",
                                spring.name
                            );
                            continue;
                        }
                        None => {
                            warn!(
                                "{file}: spring {s}: a joint is not in the spawned scene; skipped"
                            );
                            continue;
                        }
                    }
                }
                VrmVersion::V0 => {
                    let mut out = Vec::new();
                    for &n in &spring.nodes {
                        let Some(start) = entity_of(n) else {
                            warn!("{file}: bone group {s}: node {n} is not in the spawned scene");
                            continue;
                        };
                        vrm0_chains(start, &children, &locals, &mut commands, &mut out);
                    }
                    out
                }
            };
            if chains.is_empty() {
                continue;
            }
            let mut only: Vec<Entity> = Vec::new();
            for &g in &spring.groups {
                for &c in springs
                    .groups
                    .get(g as usize)
                    .map_or(&[][..], Vec::as_slice)
                {
                    if let Some(Some(e)) = collider_entities.get(c as usize)
                        && !only.contains(e)
                    {
                        only.push(*e);
                    }
                }
            }
            // Angle limits (VRM 1.0 joints), by joint entity.
            let limits: Vec<(Entity, crate::asset::JointLimit)> = match springs.version {
                VrmVersion::V1 => spring
                    .nodes
                    .iter()
                    .zip(&spring.joints)
                    .filter_map(|(&n, j)| Some((entity_of(n)?, j.limit?)))
                    .collect(),
                VrmVersion::V0 => Vec::new(),
            };
            let bone_length = mean_bone_length(&chains, &helper);
            let name = if spring.name.is_empty() {
                format!("VRM spring {s}")
            } else {
                format!("VRM spring {s} {}", spring.name)
            };
            let e = commands
                .spawn((
                    Name::new(name),
                    HairBoneChains {
                        root,
                        select: ChainSelect::Joints(chains),
                        tail: 1.0,
                    },
                    vrm_sim_settings(spring, springs.version, bone_length),
                    HairCollidesOnly(only),
                    ChainJointLimits(limits),
                    // Under the scene root: despawning the character despawns its springs.
                    Transform::IDENTITY,
                    ChildOf(root),
                ))
                .id();
            // VRM's `center`: the spring moves in that node's frame.
            if let Some(center) = spring.center.and_then(entity_of) {
                commands.entity(e).insert(HairInertiaFrame(center));
            }
            built.springs.push(e);
        }
        if built.springs.is_empty() {
            // A file with the extension but nothing to simulate: the game should hear of it.
            let error = format!(
                "{file}: no usable spring bones ({} springs or bone groups in the file, none with \
                 joints in the spawned scene): its hair will not move; check the file's \
                 VRMC_springBone springs or secondaryAnimation boneGroups",
                springs.springs.len()
            );
            warn!("{error}");
            commands.trigger(VrmSpringsFailed {
                entity: root,
                file: file.clone(),
                error,
            });
        } else {
            info!(
                "{file}: {} VRM springs and {} colliders simulated as hair",
                built.springs.len(),
                built.colliders.len()
            );
        }
        commands.entity(root).insert(built);
    }
}

/// The mean distance between consecutive joints that exist now (a VRM 0.x tail is spawned
/// this frame and not counted), in world units; `NaN` when there is none.
fn mean_bone_length(chains: &[Vec<Entity>], helper: &TransformHelper) -> f32 {
    let (mut sum, mut count) = (0.0, 0.0);
    for chain in chains {
        let points: Vec<Vec3> = chain
            .iter()
            .map_while(|j| helper.compute_global_transform(*j).ok())
            .map(|g| g.translation())
            .collect();
        for w in points.windows(2) {
            sum += w[0].distance(w[1]);
            count += 1.0;
        }
    }
    sum / count
}

/// The hair collider of a VRM collider shape.
fn collider(shape: &VrmShape) -> HairCollider {
    match *shape {
        VrmShape::Sphere {
            offset,
            radius,
            inside,
        } => HairCollider {
            spheres: vec![CollisionSphere {
                center: offset,
                radius,
            }],
            mode: mode(inside),
            ..default()
        },
        VrmShape::Capsule {
            offset,
            tail,
            radius,
            inside,
        } => HairCollider {
            capsules: vec![CollisionCapsule {
                a: offset,
                b: tail,
                radius,
            }],
            mode: mode(inside),
            ..default()
        },
        VrmShape::Plane { offset, normal } => HairCollider {
            planes: vec![CollisionPlane {
                point: offset,
                normal,
            }],
            ..default()
        },
    }
}

fn mode(inside: bool) -> HairColliderMode {
    if inside {
        HairColliderMode::Inside
    } else {
        HairColliderMode::Outside
    }
}

/// VRM 0.x: the chains of the tree under `start` (through first children; other children start
/// their own), each ending in a tail node spawned past its leaf.
fn vrm0_chains(
    start: Entity,
    children: &Query<&Children>,
    locals: &Query<&Transform>,
    commands: &mut Commands,
    out: &mut Vec<Vec<Entity>>,
) {
    let mut starts = vec![start];
    while let Some(first) = starts.pop() {
        if out.len() >= crate::asset::MAX_VRM_JOINTS {
            return;
        }
        let mut chain = vec![first];
        let mut at = first;
        loop {
            let kids: Vec<Entity> = children
                .get(at)
                .map(|c| c.iter().filter(|k| locals.contains(*k)).collect())
                .unwrap_or_default();
            let Some((&next, rest)) = kids.split_first() else {
                break;
            };
            starts.extend(rest.iter().rev());
            if chain.len() >= MAX_PARTICLES_PER_STRAND - 2 || chain.contains(&next) {
                break;
            }
            chain.push(next);
            at = next;
        }
        // The tail: 7 cm along the leaf's own bone, in its space.
        let leaf = at;
        let along = locals
            .get(leaf)
            .ok()
            .and_then(|t| t.translation.try_normalize())
            .unwrap_or(Vec3::Y);
        let tail = commands
            .spawn((
                Name::new("VRM 0.x tail"),
                Transform::from_translation(along * VRM0_TAIL),
                ChildOf(leaf),
            ))
            .id();
        chain.push(tail);
        out.push(chain);
    }
}
