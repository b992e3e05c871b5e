//! Colliders from physics engines: the world's colliders a hair opted in to, gathered once a
//! frame for the solver, and the head collider made visible to the engine's other users.
//!
//! - `rapier` (default feature): [`HairCollisionGroups`] opts a hair in; rapier's `Collider`s
//!   count when the groups match. The head collider gets a compound rapier collider.
//! - `avian`: [`HairCollisionLayers`] opts a hair in; avian's `Collider`s count when the layers
//!   interact. The head collider gets a compound avian collider of zero density, so it never
//!   changes the mass of a body it ends up part of.
//!
//! Sensors and other [`HairCollider`](super::HairCollider) entities are never gathered. Balls,
//! capsules, cuboids and half spaces (alone or in a compound of them) are followed per substep
//! like the crate's own colliders; any other shape is projected onto at the frame's final pose. No type of either engine's
//! `parry` is part of this crate's API.
#![cfg_attr(
    not(any(feature = "rapier", feature = "avian")),
    expect(dead_code, reason = "without an engine feature nothing is gathered")
)]

use bevy::ecs::entity::EntityHashMap;
use bevy::math::Affine3A;
use bevy::prelude::*;

pub(crate) use super::contact::LocalShape;

#[cfg(feature = "avian")]
mod avian;
#[cfg(feature = "rapier")]
mod rapier;

#[cfg(feature = "avian")]
pub use avian::HairCollisionLayers;
#[cfg(feature = "rapier")]
pub use rapier::HairCollisionGroups;

/// `fn local_shapes(&SharedShape) -> Option<Vec<LocalShape>>` for one engine's `parry` (rapier
/// and avian depend on different `parry3d` releases, whose types differ but read the same): a
/// ball, capsule, cuboid or half space, or a compound of only those, as analytic shapes in the
/// collider's space; `None` for any other shape.
#[cfg(any(feature = "rapier", feature = "avian"))]
macro_rules! local_shapes_for {
    ($($parry:ident)::+) => {
        fn local_shapes(
            shape: &$($parry)::+::shape::SharedShape,
        ) -> Option<Vec<LocalShape>> {
            use bevy::math::{Quat, Vec3A};
            use $($parry)::+::shape::Shape;
            fn one(shape: &dyn Shape, at: Vec3A, rotation: Quat) -> Option<LocalShape> {
                let v = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
                if let Some(ball) = shape.as_ball() {
                    Some(LocalShape::Sphere(at, ball.radius))
                } else if let Some(c) = shape.as_capsule() {
                    let (a, b) = (c.segment.a, c.segment.b);
                    Some(LocalShape::Capsule(
                        at + rotation * v(a.x, a.y, a.z),
                        at + rotation * v(b.x, b.y, b.z),
                        c.radius,
                    ))
                } else if let Some(c) = shape.as_cuboid() {
                    let h = c.half_extents;
                    Some(LocalShape::Box(at, rotation, v(h.x, h.y, h.z)))
                } else {
                    shape.as_halfspace().map(|h| {
                        let n = rotation * v(h.normal.x, h.normal.y, h.normal.z);
                        LocalShape::Plane(at, n.normalize_or(Vec3A::Y))
                    })
                }
            }
            match shape.as_compound() {
                Some(compound) => compound
                    .shapes()
                    .iter()
                    .map(|(pose, s)| {
                        let (r, t) = (pose.rotation, pose.translation);
                        one(
                            &**s,
                            Vec3A::new(t.x, t.y, t.z),
                            Quat::from_xyzw(r.x, r.y, r.z, r.w),
                        )
                    })
                    .collect(),
                None => one(&**shape, Vec3A::ZERO, Quat::IDENTITY).map(|s| vec![s]),
            }
        }
    };
}
#[cfg(any(feature = "rapier", feature = "avian"))]
use local_shapes_for;

/// The engines' gathering systems run in this set, before the hairs are stepped (the step
/// leaves [`WorldColliders`] empty for them: [`WorldColliders::next_frame`]).
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct GatherColliders;

/// Adds the enabled engines' gathering systems and head-collider observers.
pub(crate) fn build(app: &mut App) {
    app.init_resource::<WorldColliders>();
    #[cfg(feature = "rapier")]
    rapier::build(app);
    #[cfg(feature = "avian")]
    avian::build(app);
}

/// What a gathered engine collider is, for the solver.
pub(crate) enum WorldShape {
    /// Spheres, capsules, boxes and half spaces in the collider's space: followed per substep.
    Local(Vec<LocalShape>),
    /// Any other shape, projected onto at the frame's final pose.
    #[cfg(any(feature = "rapier", feature = "avian"))]
    Other(ShapeKind),
}

/// A collider of the world, at the previous and the current frame.
pub(crate) struct WorldCollider {
    pub prev: Affine3A,
    pub now: Affine3A,
    pub shape: WorldShape,
}

/// The world's engine colliders this frame, and which hairs see which of them.
#[derive(Resource, Default)]
pub(crate) struct WorldColliders {
    pub colliders: Vec<WorldCollider>,
    /// Hair entity -> indices into `colliders` it collides with.
    pub seen_by: EntityHashMap<Vec<usize>>,
    /// Each gathered collider's pose last frame.
    poses: EntityHashMap<Affine3A>,
    /// Poses written this frame (swapped into `poses` after the step: [`Self::next_frame`]).
    next_poses: EntityHashMap<Affine3A>,
}

impl WorldColliders {
    /// Once the step has read them, this frame's colliders go and their poses become the
    /// history next frame's moving ones are interpolated from: the gathering systems find it
    /// empty. (Done by the step rather than by a system of its own before the gathering: a
    /// system costs a hand-over between threads every frame.)
    pub(crate) fn next_frame(&mut self) {
        self.colliders.clear();
        self.seen_by.clear();
        std::mem::swap(&mut self.poses, &mut self.next_poses);
        self.next_poses.clear();
    }

    /// Adds a collider that `hairs` see (nothing when none does).
    /// The engines scale their shapes themselves, so the pose keeps only the collider's
    /// rotation and translation.
    pub(crate) fn push(
        &mut self,
        entity: Entity,
        global: &GlobalTransform,
        shape: WorldShape,
        hairs: impl IntoIterator<Item = Entity>,
    ) {
        let index = self.colliders.len();
        let mut seen = false;
        for hair in hairs {
            self.seen_by.entry(hair).or_default().push(index);
            seen = true;
        }
        if !seen {
            return;
        }
        let (_, rotation, translation) = global.to_scale_rotation_translation();
        let now = Affine3A::from_rotation_translation(rotation, translation);
        let prev = self.poses.get(&entity).copied().unwrap_or(now);
        self.next_poses.insert(entity, now);
        self.colliders.push(WorldCollider { prev, now, shape });
    }
}

/// An engine's shape at a pose: what the solver projects particles onto. (Without an engine
/// feature it has no variant, and no value of it exists.)
#[derive(Clone)]
pub(crate) enum ShapeKind {
    /// A rapier shape at its pose.
    #[cfg(feature = "rapier")]
    Rapier(
        bevy_rapier3d::parry::shape::SharedShape,
        bevy_rapier3d::parry::math::Pose,
    ),
    /// An avian collider (its scaled shape) at a translation and rotation.
    #[cfg(feature = "avian")]
    Avian(avian3d::prelude::Collider, Vec3, Quat),
}

impl ShapeKind {
    /// The shape at `pose` (translation and rotation; scale is the engine's own), its bounds
    /// grown by `margin`: what the solver tests particles against.
    #[cfg(any(feature = "rapier", feature = "avian"))]
    pub(crate) fn collider(&self, pose: &Affine3A, margin: f32) -> ShapeCollider {
        let (_, rotation, translation) = pose.to_scale_rotation_translation();
        let shape = match *self {
            #[cfg(feature = "rapier")]
            Self::Rapier(ref shape, _) => Self::Rapier(
                shape.clone(),
                bevy_rapier3d::parry::math::Pose::from_parts(translation, rotation),
            ),
            #[cfg(feature = "avian")]
            Self::Avian(ref collider, _, _) => Self::Avian(collider.clone(), translation, rotation),
        };
        let (min, max) = shape.aabb();
        ShapeCollider {
            shape,
            aabb_min: min - Vec3::splat(margin),
            aabb_max: max + Vec3::splat(margin),
        }
    }

    /// World bounds (min, max).
    #[cfg(any(feature = "rapier", feature = "avian"))]
    fn aabb(&self) -> (Vec3, Vec3) {
        match *self {
            #[cfg(feature = "rapier")]
            Self::Rapier(ref shape, ref pose) => {
                let aabb = shape.compute_aabb(pose);
                (aabb.mins, aabb.maxs)
            }
            #[cfg(feature = "avian")]
            Self::Avian(ref collider, translation, rotation) => {
                use avian3d::prelude::SimpleCollider;
                let aabb = collider.aabb(translation, rotation, 0.0);
                (aabb.min, aabb.max)
            }
        }
    }

    #[cfg_attr(
        not(any(feature = "rapier", feature = "avian")),
        expect(unused_variables, reason = "without an engine there is no shape")
    )]
    /// The nearest point on the surface to `x` and whether `x` is inside. (The shape is
    /// treated as hollow: a solid projection of an inside point is the point itself, which
    /// gives no way out.)
    pub(crate) fn project(&self, x: Vec3) -> (Vec3, bool) {
        match *self {
            #[cfg(feature = "rapier")]
            Self::Rapier(ref shape, ref pose) => {
                let p = shape.project_point(pose, x, false);
                (p.point, p.is_inside)
            }
            #[cfg(feature = "avian")]
            Self::Avian(ref collider, translation, rotation) => {
                collider.project_point(translation, rotation, x, false)
            }
        }
    }

    /// The engine's name and shape type, for `Debug`.
    fn describe(&self) -> String {
        match *self {
            #[cfg(feature = "rapier")]
            Self::Rapier(ref shape, _) => format!("rapier {:?}", shape.shape_type()),
            #[cfg(feature = "avian")]
            Self::Avian(ref collider, _, _) => {
                format!("avian {:?}", collider.shape_scaled().shape_type())
            }
        }
    }
}

/// A collider of any shape from a physics engine (features `rapier`, `avian`), tested through
/// the engine's point projection. Opaque: the plugin fills it from the engine's colliders.
#[derive(Clone)]
pub struct ShapeCollider {
    pub(crate) shape: ShapeKind,
    /// World bounds, grown by the largest margin: nodes outside skip the query.
    pub(crate) aabb_min: Vec3,
    /// See `aabb_min`.
    pub(crate) aabb_max: Vec3,
}

impl std::fmt::Debug for ShapeCollider {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShapeCollider")
            .field("shape", &self.shape.describe())
            .field("aabb_min", &self.aabb_min)
            .field("aabb_max", &self.aabb_max)
            .finish()
    }
}
