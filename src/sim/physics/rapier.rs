//! rapier colliders (feature `rapier`).

use bevy::math::Vec3A;
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
    add: On<Add, HeadColliderOf>,
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

/// A rapier shape as analytic shapes in the collider's space, when it is a ball, capsule,
/// cuboid or half space, or a compound of those.
fn local_shapes(shape: &bevy_rapier3d::parry::shape::SharedShape) -> Option<Vec<LocalShape>> {
    use bevy_rapier3d::parry::shape::Shape;
    fn one(shape: &dyn Shape, at: Vec3A, rotation: Quat) -> Option<LocalShape> {
        let v = |v: bevy_rapier3d::parry::math::Vector| Vec3A::new(v.x, v.y, v.z);
        if let Some(ball) = shape.as_ball() {
            Some(LocalShape::Sphere(at, ball.radius))
        } else if let Some(c) = shape.as_capsule() {
            Some(LocalShape::Capsule(
                at + rotation * v(c.segment.a),
                at + rotation * v(c.segment.b),
                c.radius,
            ))
        } else if let Some(c) = shape.as_cuboid() {
            Some(LocalShape::Box(at, rotation, v(c.half_extents)))
        } else {
            shape
                .as_halfspace()
                .map(|h| LocalShape::Plane(at, (rotation * v(h.normal)).normalize_or(Vec3A::Y)))
        }
    }
    if let Some(compound) = shape.as_compound() {
        compound
            .shapes()
            .iter()
            .map(|(pose, s)| {
                let r = pose.rotation;
                let t = pose.translation;
                one(
                    &**s,
                    Vec3A::new(t.x, t.y, t.z),
                    Quat::from_xyzw(r.x, r.y, r.z, r.w),
                )
            })
            .collect()
    } else {
        one(&**shape, Vec3A::ZERO, Quat::IDENTITY).map(|s| vec![s])
    }
}
