//! [`HairCollider`]: the crate's own collision shape, so hair collides without any physics
//! engine.

use bevy::prelude::*;

use crate::asset::CollisionSphere;

/// Spheres every hair collides with, in this entity's space (they move, turn and scale with it;
/// moving ones are followed per substep). The plugin puts one on each hair's head collider, from
/// the hair's collision file; add your own (shoulders, hands, a hat) to any entity. Margins keep
/// particles that far outside.
///
/// With the `rapier` feature the head collider also gets a rapier compound collider, so other
/// rapier users see the head; hair collides with the world's other rapier colliders only when it
/// opts in with `HairCollisionGroups`.
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Debug, Default, PartialEq)]
#[require(Transform)]
pub struct HairCollider {
    /// The spheres, centres in this entity's space, radii in its units.
    pub spheres: Vec<CollisionSphere>,
}
