//! Hair modelled as a mesh on hair-bone chains (as VRM, VRoid, Blender and MMD characters bring
//! it), moved by the hair solver: the character of `assets/chain_hair/` (authored by
//! `tools/blender/author_chain_hair.py`) has thick bangs, side locks, a back mass and a ponytail
//! skinned to chains of bones named `hair_*`. The chains swing, collide with the head and neck and
//! take the wind while the character turns its head, the hair mesh wears the crate's toon look
//! with an outline and lines between its modelled locks, and the bangs throw the fringe shadow on
//! the face.
//!
//! With `--vrm` (VRM 1.0) or `--vrm0` (VRM 0.x) the same character is loaded from a `.vrm` file
//! instead: its spring bones, joint parameters, colliders and collider groups come from the file
//! (`VRMC_springBone`, `secondaryAnimation`), and nothing is set up by hand but the look.
//!
//! Run: `cargo run --example bone_chain_hair [-- --vrm | --vrm0]`. Keys: W toggles wind.

use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;
use bevy_cartoon_hair::asset::{CollisionCapsule, CollisionSphere};
use bevy_cartoon_hair::prelude::*;
use bevy_cartoon_hair::render::{FringeShadow, FringeShadowMeshes, LockLines};

#[derive(Component)]
struct Character;

/// Which file the character comes from.
#[derive(Resource, Clone, Copy, PartialEq, Eq)]
enum Source {
    /// `chain_hair.glb`, chains and colliders set up here.
    Gltf,
    /// `chain_hair.vrm` (VRM 1.0).
    Vrm,
    /// `chain_hair_vrm0.vrm` (VRM 0.x).
    Vrm0,
}

fn main() {
    let source = match std::env::args().nth(1).as_deref() {
        Some("--vrm") => Source::Vrm,
        Some("--vrm0") => Source::Vrm0,
        None => Source::Gltf,
        Some(other) => {
            eprintln!("bone_chain_hair: unknown argument {other:?}; use --vrm or --vrm0");
            std::process::exit(2);
        }
    };
    App::new()
        .insert_resource(source)
        .add_plugins((DefaultPlugins, CartoonHairPlugins))
        .add_systems(Startup, setup)
        .add_systems(Update, (turn_head, toggle_wind))
        .run();
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    source: Res<Source>,
    ramps: Res<ToonRamps>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
) {
    let file = match *source {
        Source::Gltf => "chain_hair/chain_hair.glb",
        Source::Vrm => "chain_hair/chain_hair.vrm",
        Source::Vrm0 => "chain_hair/chain_hair_vrm0.vrm",
    };
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset(file));
    // The mesh whose glTF material is "hair" is drawn in the toon look, in the hair's colour.
    let shading = ToonShading {
        base_color: Color::srgb(0.55, 0.22, 0.1),
        ..default()
    };
    let look = materials.add(ToonHairMaterial {
        // The hair's glTF material is double-sided (its cap is open underneath): so is this.
        double_sided: true,
        ..ToonHairMaterial::new(shading, ramps.three_tone.clone())
    });
    let character = commands
        .spawn((
            WorldAssetRoot(scene),
            Character,
            // Each modelled lock a lock of its own, for the outline's lines between locks.
            ToonHairMeshes::matching(|name| name == "hair")
                .with_material(look)
                .with_locks_by_piece(),
            // Everything but the hair cel-shaded too, the skin taking the bangs' shadow (read
            // from the camera's prepasses).
            FringeShadowMeshes::all_except(|name| name == "hair", FringeShadow::cel()),
        ))
        .id();
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(1.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        DepthPrepass,
        NormalPrepass,
        ImageSpaceOutline {
            lock_lines: Some(LockLines::default()),
            ..default()
        },
        Transform::from_xyz(0.6, 1.8, 0.9).looking_at(Vec3::new(0.0, 1.62, 0.0), Vec3::Y),
    ));
    if *source != Source::Gltf {
        // A VRM file brings its springs and colliders: nothing more to set up.
        return;
    }
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
