//! rapier colliders (feature `rapier`).

use bevy::prelude::*;
use bevy_rapier3d::prelude::{Collider, CollisionGroups, Group, Sensor};

use super::{GatherColliders, LocalShape, ShapeKind, WorldColliders, WorldShape};
use crate::sim::HairCollider;
use crate::sim::attach::HeadColliderOf;

/// Opts a hair into colliding with the world's rapier colliders (feature `rapier`), filtered by
/// rapier's own rule: a collider counts when `collider.memberships & hair.filters` and
/// `hair.memberships & collider.filters` are both non-zero (`CollisionGroups::default()`: all).
/// Without this component a hair collides only with [`HairCollider`]s: its own head collider and
/// any you add. Sensors are never collided with.
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug)]
pub struct HairCollisionGroups(pub CollisionGroups);

pub(super) fn build(app: &mut App) {
    app.register_type::<HairCollisionGroups>()
        .add_observer(head_collider)
        .add_systems(
            PostUpdate,
            gather
                .in_set(GatherColliders)
                .in_set(crate::schedule::HairSystems::Simulate),
        );
}

fn groups_match(hair: &CollisionGroups, collider: &CollisionGroups) -> bool {
    (collider.memberships & hair.filters) != Group::NONE
        && (hair.memberships & collider.filters) != Group::NONE
}

/// Other rapier users see the head too: a compound of its spheres and capsules.
fn head_collider(
    add: On<Add<HeadColliderOf>>,
    heads: Query<&HairCollider>,
    mut commands: Commands,
) {
    let Ok(head) = heads.get(add.entity) else {
        return;
    };
    // Planes are left out: an infinite half space in a head's compound would be one for every
    // other rapier user too.
    let spheres = head
        .spheres
        .iter()
        .map(|s| (s.center, Quat::IDENTITY, Collider::ball(s.radius)));
    let capsules = head.capsules.iter().map(|c| {
        (
            Vec3::ZERO,
            Quat::IDENTITY,
            Collider::capsule(c.a, c.b, c.radius),
        )
    });
    commands
        .entity(add.entity)
        .insert(Collider::compound(spheres.chain(capsules).collect()));
}

/// The world's rapier colliders, for the hairs that opted in.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
fn gather(
    mut world: ResMut<WorldColliders>,
    hairs: Query<(Entity, &HairCollisionGroups)>,
    colliders: Query<
        (
            Entity,
            &Collider,
            &GlobalTransform,
            Option<&CollisionGroups>,
        ),
        (Without<HairCollider>, Without<Sensor>),
    >,
) {
    if hairs.is_empty() {
        return;
    }
    for (entity, collider, global, groups) in &colliders {
        let groups = groups.copied().unwrap_or_default();
        let seen = hairs
            .iter()
            .filter(|(_, hair)| groups_match(&hair.0, &groups))
            .map(|(e, _)| e);
        // rapier's shape is already scaled (`Collider::raw`).
        let shape = &collider.raw;
        let shape = match local_shapes(shape) {
            Some(shapes) => WorldShape::Local(shapes),
            None => WorldShape::Other(ShapeKind::Rapier(shape.clone(), Default::default())),
        };
        world.push(entity, global, shape, seen);
    }
}

super::local_shapes_for!(bevy_rapier3d::parry);
