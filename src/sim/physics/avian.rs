//! avian colliders (feature `avian`).

use avian3d::prelude::{Collider, ColliderDensity, CollisionLayers, Sensor};
use bevy::prelude::*;

use super::{GatherColliders, LocalShape, ShapeKind, WorldColliders, WorldShape};
use crate::sim::HairCollider;
use crate::sim::attach::HeadColliderOf;

/// Opts a hair into colliding with the world's avian colliders (feature `avian`), filtered by
/// avian's own rule ([`CollisionLayers::interacts_with`]; `CollisionLayers::default()`: all).
/// Without this component a hair collides only with [`HairCollider`]s: its own head collider and
/// any you add. Sensors are never collided with. Shapes are scaled as avian scales them (its
/// physics plugins keep a collider's scale in step with its transform).
#[derive(Component, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Debug)]
pub struct HairCollisionLayers(pub CollisionLayers);

pub(super) fn build(app: &mut App) {
    app.register_type::<HairCollisionLayers>()
        .add_observer(head_collider)
        .add_systems(
            PostUpdate,
            gather
                .in_set(GatherColliders)
                .in_set(crate::schedule::HairSystems::Simulate),
        );
}

/// Other avian users see the head too: a compound of its spheres and capsules, of zero density so a
/// character body it becomes part of keeps its mass.
fn head_collider(
    add: On<Add<HeadColliderOf>>,
    heads: Query<&HairCollider>,
    mut commands: Commands,
) {
    let Ok(head) = heads.get(add.entity) else {
        return;
    };
    commands.entity(add.entity).insert((
        // Planes are left out: an infinite half space in a head's compound would be one for
        // every other avian user too.
        Collider::compound(
            head.spheres
                .iter()
                .map(|s| (s.center, Quat::IDENTITY, Collider::sphere(s.radius)))
                .chain(head.capsules.iter().map(|c| {
                    (
                        Vec3::ZERO,
                        Quat::IDENTITY,
                        Collider::capsule_endpoints(c.radius, c.a, c.b),
                    )
                }))
                .collect(),
        ),
        ColliderDensity(0.0),
    ));
}

/// The world's avian colliders, for the hairs that opted in.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
fn gather(
    mut world: ResMut<WorldColliders>,
    hairs: Query<(Entity, &HairCollisionLayers)>,
    colliders: Query<
        (Entity, &Collider, &GlobalTransform, &CollisionLayers),
        (Without<HairCollider>, Without<Sensor>),
    >,
) {
    if hairs.is_empty() {
        return;
    }
    for (entity, collider, global, layers) in &colliders {
        let seen = hairs
            .iter()
            .filter(|(_, hair)| hair.0.interacts_with(*layers))
            .map(|(e, _)| e);
        // avian's shape is already scaled (`shape_scaled`).
        let scaled = collider.shape_scaled();
        let shape = match local_shapes(scaled) {
            Some(shapes) => WorldShape::Local(shapes),
            None => WorldShape::Other(ShapeKind::Avian(
                collider.clone(),
                Vec3::ZERO,
                Quat::IDENTITY,
            )),
        };
        world.push(entity, global, shape, seen);
    }
}

super::local_shapes_for!(avian3d::parry);
