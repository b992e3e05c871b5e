//! Hair modelled as a mesh on hair-bone chains (as VRM, VRoid, Blender and MMD characters bring
//! it), moved by the hair solver: the character of `assets/chain_hair/` (authored by
//! `tools/blender/author_chain_hair.py`) has bangs, side locks and a ponytail skinned to chains
//! of bones named `hair_*`. The chains swing, collide with the head and neck and take the wind
//! while the character turns its head.
//!
//! Run: `cargo run --example bone_chain_hair`. Keys: W toggles wind.

use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::asset::{CollisionCapsule, CollisionSphere};
use bevy_cartoon_hair::prelude::*;

#[derive(Component)]
struct Character;

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, CartoonHairPlugins))
        .add_systems(Startup, setup)
        .add_systems(Update, (turn_head, toggle_wind))
        .run();
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset("chain_hair/chain_hair.glb"));
    let character = commands.spawn((WorldAssetRoot(scene), Character)).id();
    // Every bone whose name starts with "hair_" (and whose parent's does not) starts a chain.
    commands.spawn((
        HairBoneChains::matching(character, |name| name.starts_with("hair_")),
        HairSimSettings {
            bend_stiffness: 0.5,
            ..default()
        },
    ));
    // The head and neck, on the head bone: every hair, chained or groomed, stays out of them.
    commands.spawn((
        HairCollider {
            spheres: vec![
                CollisionSphere {
                    center: Vec3::new(0.0, 0.09, -0.01),
                    radius: 0.1,
                },
                CollisionSphere {
                    center: Vec3::new(0.0, 0.045, 0.035),
                    radius: 0.08,
                },
            ],
            capsules: vec![CollisionCapsule {
                a: Vec3::new(0.0, -0.02, 0.0),
                b: Vec3::new(0.0, -0.2, 0.0),
                radius: 0.055,
            }],
            ..default()
        },
        AttachToBone::named(character, "head"),
    ));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.6, 1.8, 0.9).looking_at(Vec3::new(0.0, 1.62, 0.0), Vec3::Y),
    ));
}

/// Turns the whole character from side to side, with a quick shake every few seconds.
fn turn_head(time: Res<Time>, mut characters: Query<&mut Transform, With<Character>>) {
    let t = time.elapsed_secs();
    let shake = if t % 5.0 > 4.0 {
        0.5 * (t * 25.0).sin()
    } else {
        0.0
    };
    for mut tf in &mut characters {
        tf.rotation = Quat::from_rotation_y(0.6 * (t * 0.8).sin() + shake);
    }
}

fn toggle_wind(
    keys: Res<ButtonInput<KeyCode>>,
    wind: Option<Res<HairWind>>,
    mut commands: Commands,
) {
    if keys.just_pressed(KeyCode::KeyW) {
        match wind {
            Some(_) => commands.remove_resource::<HairWind>(),
            None => commands.insert_resource(HairWind {
                velocity: Vec3::new(4.0, 0.0, 1.2),
                ..default()
            }),
        }
    }
}
