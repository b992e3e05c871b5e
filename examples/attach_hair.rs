//! The least a game needs: add the plugins, spawn a glTF character, attach hair to a bone.
//!
//! Run: `cargo run --example attach_hair`.

use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::prelude::*;

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, CartoonHairPlugins))
        .add_systems(Startup, setup)
        .run();
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset("ninja/ninja.glb"));
    let hair = Hair {
        groom: assets.load("ninja/ninja.hair.xml"),
        animation: None,
        collision: Some(assets.load("ninja/ninja.collision.xml")),
    };
    let ninja = commands.spawn(WorldAssetRoot(scene)).id();
    // The hair is our own entity: once the scene has spawned, the plugin finds the bone named
    // "head" and makes this entity its child. A wrong name is an error that lists the bones.
    commands.spawn((hair, AttachToBone::named(ninja, "head")));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.5, 1.8, 1.2).looking_at(Vec3::new(0.0, 1.65, 0.0), Vec3::Y),
    ));
}
