//! The chain bench's crowd driven by bevy_vrm1 0.11's own spring-bone system: what a Bevy game
//! that loads its avatars with bevy_vrm1 pays for their hair today, in the same headless app as
//! ours (Bevy's propagation of the bones included).
//!
//! The chains are built as bevy_vrm1's loader builds them from a VRM file (`SpringRoot` on each
//! chain's first joint, `SpringJointProps` on every joint, each joint's rest state from its
//! child's rest offset), with one more joint entity per chain for the tail (VRM names its tails
//! as nodes). The joints' rest state is a crate-private component, inserted here through Bevy's
//! reflection, with the fields bevy_vrm1's loader gives it. bevy_vrm1's system runs after Bevy's
//! propagation, one thread, one step a frame; it collides with spheres only (its capsule test
//! is not written yet), so the neck and shoulder capsules cost it a lookup each and no test.

use bevy::prelude::*;
use bevy::reflect::structs::DynamicStruct;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformSystems;
use bevy_vrm1::prelude::VrmSystemSets;
use bevy_vrm1::prelude::{Capsule, ColliderShape, Sphere};
use bevy_vrm1::vrm::spring_bone::{
    SpringCenterNode, SpringColliders, SpringJointProps, SpringJoints, SpringRoot,
    VrmSpringBonePlugin,
};
use std::time::Duration;

use super::{CHAINS, DRAG, GRAVITY_POWER, HEAD, HIT_RADIUS, JOINTS, STIFFNESS, body, joint_local};

/// The type path of bevy_vrm1's per-joint rest and tail state.
const JOINT_STATE: &str = "bevy_vrm1::vrm::spring_bone::SpringJointState";

/// A headless app of `characters` characters whose 40 chains of 6 joints bevy_vrm1's spring
/// system moves, at `fps`; returns the app and each character's root.
pub fn app(characters: usize, fps: f64) -> (App, Vec<Entity>) {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(bevy_cartoon_hair::compute_on_every_core()),
        TransformPlugin,
        VrmSpringBonePlugin,
    ))
    // bevy_vrm1's own plugin orders its sets after the avatar's constraints and expressions,
    // which run after Bevy's propagation; here there are none.
    .configure_sets(
        PostUpdate,
        VrmSystemSets::SpringBone.after(TransformSystems::Propagate),
    )
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / fps,
    )));
    let props = SpringJointProps {
        drag_force: DRAG,
        gravity_dir: Vec3::NEG_Y,
        gravity_power: GRAVITY_POWER,
        hit_radius: HIT_RADIUS,
        stiffness: STIFFNESS,
    };
    let (spheres, capsules) = body();
    let mut roots = Vec::new();
    for i in 0..characters {
        let mut joint_states = Vec::new();
        let world = app.world_mut();
        let root = world
            .spawn(Transform::from_xyz(i as f32 * 1.0, 0.0, 0.0))
            .id();
        let head = world
            .spawn((Transform::from_translation(HEAD), ChildOf(root)))
            .id();
        // Each collider on a node of its own under the head, as a VRM file places them.
        let mut colliders = Vec::new();
        for s in &spheres {
            let shape = ColliderShape::Sphere(Sphere {
                offset: s.center.to_array(),
                radius: s.radius,
            });
            colliders.push((
                world.spawn((Transform::IDENTITY, ChildOf(head))).id(),
                shape,
            ));
        }
        for c in &capsules {
            let shape = ColliderShape::Capsule(Capsule {
                offset: c.a.to_array(),
                radius: c.radius,
                tail: c.b.to_array(),
            });
            colliders.push((
                world.spawn((Transform::IDENTITY, ChildOf(head))).id(),
                shape,
            ));
        }
        for c in 0..CHAINS {
            let mut parent = head;
            let mut joints = Vec::new();
            // The joints, then the tail continuing the last bone.
            for k in 0..=JOINTS {
                let local = joint_local(c, k.min(JOINTS - 1));
                parent = world
                    .spawn((Transform::from_translation(local), ChildOf(parent), props))
                    .id();
                joints.push(parent);
            }
            // Each joint's rest state, as bevy_vrm1's loader makes it from the rest pose: the
            // child's offset (axis and length) and the joint's own local transform.
            for (k, &joint) in joints.iter().take(JOINTS).enumerate() {
                let child = joint_local(c, (k + 1).min(JOINTS - 1));
                let rest = Transform::from_translation(joint_local(c, k));
                joint_states.push((joint, child, rest));
            }
            world.entity_mut(joints[0]).insert(SpringRoot {
                joints: SpringJoints(joints),
                colliders: SpringColliders(colliders.clone()),
                center_node: SpringCenterNode(None),
            });
        }
        for (joint, child, rest) in joint_states {
            insert_joint_state(app.world_mut(), joint, child, rest);
        }
        roots.push(root);
    }
    app.update();
    app.update();
    (app, roots)
}

/// Inserts bevy_vrm1's rest state on `joint`, whose child lies at `child` in its frame and whose
/// rest local transform is `rest` (tails unseeded: bevy_vrm1 seeds them on the first frame).
fn insert_joint_state(world: &mut World, joint: Entity, child: Vec3, rest: Transform) {
    let registry = world.resource::<AppTypeRegistry>().clone();
    let registry = registry.read();
    let registration = registry
        .get_with_type_path(JOINT_STATE)
        .unwrap_or_else(|| panic!("bevy_vrm1 no longer registers {JOINT_STATE}"));
    let component = registration
        .data::<ReflectComponent>()
        .unwrap_or_else(|| panic!("{JOINT_STATE} is not a reflected component"));
    let mut state = DynamicStruct::default();
    state.insert("prev_tail", Vec3::ZERO);
    state.insert("current_tail", Vec3::ZERO);
    state.insert("bone_axis", child.normalize_or_zero());
    state.insert("bone_length", child.length());
    state.insert("initial_local_matrix", rest.to_matrix());
    state.insert("initial_local_rotation", rest.rotation);
    component.insert(&mut world.entity_mut(joint), &state, &registry);
}
