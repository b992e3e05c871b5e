//! [`HairCollider`]: the crate's own collision shapes, so hair collides without any physics
//! engine.

use bevy::math::{Affine3A, Vec3A};
use bevy::prelude::*;

use crate::asset::{CollisionBox, CollisionCapsule, CollisionPlane, CollisionSphere};

use super::contact::{ContactShape, LocalShape};

/// Shapes every hair collides with, in this entity's space (they move, turn and scale with it,
/// and moving ones are followed per substep, so a fast arm cannot pass through hair between two
/// frames). The plugin puts one on each hair's head collider, from the hair's collision file;
/// add your own (shoulders, arms, a hat brim, the floor) to any entity. Margins keep particles
/// that far outside, or inside with [`HairColliderMode::Inside`].
///
/// A shape that cannot be collided with is left out: a non-finite number, a radius or half
/// extent not above 0 or over 100 km, a plane normal of zero, a point over 100 km from this
/// entity (in its units).
///
/// Only colliders whose bounds (over the frame's motion, grown by the margin) meet a hair's
/// reach are tested against it, so a scene of hundreds of them costs little.
///
/// With the `rapier` feature the head collider also gets a rapier compound collider, so other
/// rapier users see the head; hair collides with the world's other rapier colliders only when it
/// opts in with `HairCollisionGroups`.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
#[require(Transform)]
pub struct HairCollider {
    /// Spheres, centres in this entity's space, radii in its units.
    pub spheres: Vec<CollisionSphere>,
    /// Capsules (an arm, a neck), in this entity's space.
    pub capsules: Vec<CollisionCapsule>,
    /// Planes (a floor, a back): hair stays on the side the normal points to.
    pub planes: Vec<CollisionPlane>,
    /// Oriented boxes (a collar, a chair back).
    pub boxes: Vec<CollisionBox>,
    /// Whether particles are kept outside the shapes (the default) or inside them.
    pub mode: HairColliderMode,
}

/// On a hair: it collides with the [`HairCollider`]s on these entities only, not with the
/// others (its own head collider included, unless listed). Without it a hair collides with every
/// [`HairCollider`]. A VRM character's chains get one from their collider groups; use it to keep
/// a character's hair off another character's colliders. The world's physics colliders are
/// chosen apart from this (`HairCollisionGroups`, `HairCollisionLayers`).
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
pub struct HairCollidesOnly(pub Vec<Entity>);

/// Which side of a [`HairCollider`]'s shapes particles are kept on.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Debug, Default, PartialEq)]
pub enum HairColliderMode {
    /// Outside every shape, by the strand's margin. Default.
    #[default]
    Outside,
    /// Inside every sphere, capsule and box, the margin from its surface (a bubble hair may not
    /// leave, a hood). Planes keep the side their normal points to either way.
    Inside,
}

impl HairCollider {
    /// A collider of spheres only.
    pub fn spheres(spheres: Vec<CollisionSphere>) -> Self {
        Self {
            spheres,
            ..default()
        }
    }

    /// Every shape, in this entity's space.
    pub(crate) fn shapes(&self) -> impl Iterator<Item = LocalShape> + '_ {
        let spheres = self
            .spheres
            .iter()
            .map(|s| LocalShape::Sphere(s.center.into(), s.radius));
        let capsules = self
            .capsules
            .iter()
            .map(|c| LocalShape::Capsule(c.a.into(), c.b.into(), c.radius));
        let planes = self
            .planes
            .iter()
            .map(|p| LocalShape::Plane(p.point.into(), Vec3A::from(p.normal).normalize_or_zero()));
        let boxes = self.boxes.iter().map(|b| {
            let q = Vec4::from(b.rotation).try_normalize().unwrap_or(Vec4::W);
            LocalShape::Box(
                b.center.into(),
                Quat::from_vec4(q),
                Vec3A::from(b.half_extents).abs(),
            )
        });
        // A shape with a non-finite number would put NaN into every strand it touches; one of
        // no size or far out would throw the hair away: such shapes are left out.
        spheres
            .chain(capsules)
            .chain(planes)
            .chain(boxes)
            .filter(LocalShape::is_usable)
    }

    /// Whether particles are kept inside.
    pub(crate) fn inside(&self) -> bool {
        self.mode == HairColliderMode::Inside
    }

    /// Its shapes' bounds with the entity at `pose`: infinite when it keeps particles inside,
    /// empty (min above max) when it has no usable shape.
    pub(crate) fn bounds_at(&self, pose: &Affine3A) -> (Vec3A, Vec3A) {
        bounds_of(self.inside(), self.shapes().map(|s| s.at(pose)))
    }
}

/// The bounds of a collider's `posed` shapes: infinite when it keeps particles `inside`, empty
/// (min above max) when it has none.
pub(crate) fn bounds_of(
    inside: bool,
    posed: impl IntoIterator<Item = ContactShape>,
) -> (Vec3A, Vec3A) {
    posed
        .into_iter()
        .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), shape| {
            let (a, b) = if inside {
                (Vec3A::NEG_INFINITY, Vec3A::INFINITY)
            } else {
                shape.bounds()
            };
            (lo.min(a), hi.max(b))
        })
}
