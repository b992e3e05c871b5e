//! The crate's toon look on a character's own hair mesh (a VRM's, a Blender character's): the
//! meshes a [`ToonHairMeshes`] selects are drawn with a [`ToonHairMaterial`] instead of their
//! glTF material, skinned as before.
//!
//! The toon material needs only a mesh's standard attributes (positions and normals; UVs give
//! the angel ring its strand direction), so any skinned or rigid mesh wears it: ramps under the
//! scene's lights and shadows, the angel ring, and the mass outline (its prepass marks the mesh
//! as hair). Meshes not selected keep their own material, so a VRM's MToon-derived materials stay
//! as they are unless the user opts in.

use bevy::gltf::GltfMaterialName;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;

use crate::sim::{BonePredicate, CharacterSpawned};

use super::{ToonHairMaterial, ToonRamps};

/// Put on a character (a glTF or VRM scene root): its descendant meshes whose entity name, parent
/// (node) name or glTF material name passes `select` are drawn with the toon hair material.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_cartoon_hair::render::ToonHairMeshes;
/// # fn setup(mut commands: Commands, character: Entity) {
/// // Every mesh whose glTF material is called "hair".
/// commands
///     .entity(character)
///     .insert(ToonHairMeshes::matching(|name| name == "hair"));
/// # }
/// ```
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component, Debug)]
pub struct ToonHairMeshes {
    /// Which meshes: tested on the mesh entity's name, its parent's name and its glTF
    /// material's name; one passing is enough.
    #[reflect(ignore)]
    pub select: BonePredicate,
    /// The material. `None`: the crate's default (three-tone ramp, orange); give one for the
    /// hair's own colour.
    pub material: Option<Handle<ToonHairMaterial>>,
}

impl ToonHairMeshes {
    /// Meshes whose name, node name or material name passes `test`, in the default material.
    pub fn matching(test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self {
            select: BonePredicate::new(test),
            material: None,
        }
    }

    /// The same, drawn with `material`.
    pub fn with_material(mut self, material: Handle<ToonHairMaterial>) -> Self {
        self.material = Some(material);
        self
    }
}

/// On a [`ToonHairMeshes`] character once its meshes are dressed: the mesh entities. Remove it
/// to dress them again (after the scene respawned).
#[derive(Component, Clone, Debug, Default, Reflect)]
#[reflect(Component, Debug)]
pub struct ToonHairMeshesApplied(pub Vec<Entity>);

/// The mesh entities under `root` whose name, parent (node) name or glTF material name passes
/// `select` (with `except`: none of whose names passes, a mesh without names included), in one
/// walk of the hierarchy.
pub(crate) fn meshes_passing(
    root: Entity,
    select: &BonePredicate,
    except: bool,
    children: &Query<&Children>,
    meshes: &Query<MeshNames, With<Mesh3d>>,
    names: &Query<&Name>,
) -> Vec<Entity> {
    let mut found = Vec::new();
    let mut stack = vec![root];
    while let Some(e) = stack.pop() {
        if let Ok((name, material_name, parent)) = meshes.get(e) {
            let parent_name = parent.and_then(|p| names.get(p.parent()).ok());
            let passes = [
                name.map(Name::as_str),
                parent_name.map(Name::as_str),
                material_name.map(|m| m.0.as_str()),
            ]
            .into_iter()
            .flatten()
            .any(|n| select.matches(n));
            if passes != except {
                found.push(e);
            }
        }
        if let Ok(kids) = children.get(e) {
            stack.extend(kids.iter());
        }
    }
    found
}

/// A mesh entity's name, glTF material name and parent.
pub(crate) type MeshNames = (
    Option<&'static Name>,
    Option<&'static GltfMaterialName>,
    Option<&'static ChildOf>,
);

/// Dresses the selected meshes of every spawned [`ToonHairMeshes`] character.
#[expect(
    clippy::too_many_arguments,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn apply_toon_to_user_meshes(
    mut commands: Commands,
    characters: Query<(Entity, &ToonHairMeshes), Without<ToonHairMeshesApplied>>,
    roots: Query<(Option<&WorldAssetRoot>, Has<CharacterSpawned>)>,
    server: Option<Res<AssetServer>>,
    children: Query<&Children>,
    meshes: Query<MeshNames, With<Mesh3d>>,
    names: Query<&Name>,
    ramps: Res<ToonRamps>,
    (mut materials, mut default_material): (
        ResMut<Assets<ToonHairMaterial>>,
        Local<Option<Handle<ToonHairMaterial>>>,
    ),
) {
    for (character, wanted) in &characters {
        if let Ok((Some(scene), false)) = roots.get(character) {
            // A scene that failed to load never spawns: stop waiting, and say so.
            if let Some((file, reason)) = crate::sim::scene_failure(server.as_deref(), scene) {
                error!(
                    "ToonHairMeshes on {character}: its scene {file:?} did not load, so no mesh \
                     is drawn with the toon hair material: {reason}"
                );
                commands
                    .entity(character)
                    .insert(ToonHairMeshesApplied(Vec::new()));
            }
            continue;
        }
        let material = match &wanted.material {
            Some(m) => m.clone(),
            None => default_material
                .get_or_insert_with(|| {
                    materials.add(ToonHairMaterial {
                        ramp: ramps.three_tone.clone(),
                        ..default()
                    })
                })
                .clone(),
        };
        let dressed = meshes_passing(character, &wanted.select, false, &children, &meshes, &names);
        for &e in &dressed {
            commands
                .entity(e)
                .remove::<MeshMaterial3d<StandardMaterial>>()
                .insert(MeshMaterial3d(material.clone()));
        }
        if dressed.is_empty() {
            warn!(
                "ToonHairMeshes on {character}: no mesh under it has a name, node name or material \
                 name that passes the test; nothing is drawn with the toon hair material"
            );
        }
        commands
            .entity(character)
            .insert(ToonHairMeshesApplied(dressed));
    }
}
