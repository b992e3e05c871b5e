//! The crate's toon look on a character's own hair mesh (a VRM's, a Blender character's): the
//! meshes a [`ToonHairMeshes`] selects are drawn with a [`ToonHairMaterial`] instead of their
//! glTF material, skinned as before.
//!
//! The toon material needs only a mesh's standard attributes (positions and normals; UVs give
//! the angel ring its strand direction), so any skinned or rigid mesh wears it: ramps under the
//! scene's lights and shadows, the angel ring, and the mass outline (its prepass marks the mesh
//! as hair). Meshes not selected keep their own material, so a VRM's MToon-derived materials stay
//! as they are unless the user opts in.
//!
//! Modelled hair is often faceted (flat or ridged locks, low-poly caps), and toon bands follow
//! every facet. [`ToonHairMeshes::mass_normals`] gives the meshes the normals of one smooth
//! shape instead, the ellipsoid that fits each mesh's bounds (the normal transfer anime
//! pipelines do in their modelling tool), so light and shadow fall on the hair as one mass.

use bevy::gltf::GltfMaterialName;
use bevy::mesh::VertexAttributeValues;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;

use crate::math::finite_or;
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
    /// How far each mesh's normals turn toward those of the ellipsoid that fits its bounds
    /// (its bind pose, in its own space), 0 to 1: at 1 the toon bands fall on the hair as on
    /// one smooth shape, not facet by facet; in between, the locks' own relief shows that much.
    /// Each mesh is copied with the new normals (one copy per source mesh and value; the
    /// copy is skinned as the mesh was). Default: `0.0` (the meshes' own normals).
    pub mass_normals: f32,
}

impl ToonHairMeshes {
    /// Meshes whose name, node name or material name passes `test`, in the default material.
    pub fn matching(test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self {
            select: BonePredicate::new(test),
            material: None,
            mass_normals: 0.0,
        }
    }

    /// The same, drawn with `material`.
    pub fn with_material(mut self, material: Handle<ToonHairMaterial>) -> Self {
        self.material = Some(material);
        self
    }

    /// The same, with [`ToonHairMeshes::mass_normals`] at `amount`.
    pub fn with_mass_normals(mut self, amount: f32) -> Self {
        self.mass_normals = amount;
        self
    }
}

/// Turns `mesh`'s normals toward the normals of the ellipsoid that fits its positions' bounds,
/// by `amount` (0 to 1), and renormalises them. A vertex at the ellipsoid's centre, or whose
/// blend cancels out, keeps its normal. Errors when the mesh has no `Float32x3` positions and
/// normals of the same length (a mesh whose data lives only on the GPU has none).
pub fn turn_normals_to_mass(mesh: &mut Mesh, amount: f32) -> Result<(), &'static str> {
    let amount = finite_or(amount, 0.0).clamp(0.0, 1.0);
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return Err("it has no positions on the CPU (Float32x3)");
    };
    let (lo, hi) = positions
        .iter()
        .map(|p| Vec3::from_array(*p))
        .filter(|p| p.is_finite())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    if lo.cmpgt(hi).any() {
        return Err("it has no finite position");
    }
    let centre = (lo + hi) * 0.5;
    // A flat mesh's thin axis still gets a (small) extent, so every direction is defined.
    let half = ((hi - lo) * 0.5).max(Vec3::splat((hi - lo).max_element() * 0.01 + 1e-6));
    let inv_half2 = (half * half).recip();
    let proxy: Vec<Vec3> = positions
        .iter()
        .map(|p| ((Vec3::from_array(*p) - centre) * inv_half2).normalize_or_zero())
        .collect();
    let Some(VertexAttributeValues::Float32x3(normals)) =
        mesh.attribute_mut(Mesh::ATTRIBUTE_NORMAL)
    else {
        return Err("it has no normals on the CPU (Float32x3)");
    };
    if normals.len() != proxy.len() {
        return Err("its normals and positions differ in number");
    }
    for (n, to) in normals.iter_mut().zip(&proxy) {
        let own = Vec3::from_array(*n);
        if *to == Vec3::ZERO || !own.is_finite() {
            continue;
        }
        let turned = own.lerp(*to, amount).normalize_or_zero();
        if turned != Vec3::ZERO {
            *n = turned.to_array();
        }
    }
    Ok(())
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

/// Copies of source meshes with mass normals, by source mesh and amount (its bits). Only ids:
/// a copy no entity uses any more is freed (and its entry dropped at the next dressing).
type MassedMeshes = HashMap<(AssetId<Mesh>, u32), AssetId<Mesh>>;

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
    mut mesh_assets: Option<ResMut<Assets<Mesh>>>,
    mesh_handles: Query<&Mesh3d>,
    mut massed: Local<MassedMeshes>,
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
        let amount = finite_or(wanted.mass_normals, 0.0).clamp(0.0, 1.0);
        if let Some(assets) = &mesh_assets {
            massed.retain(|_, copy| assets.contains(*copy));
        }
        for &e in &dressed {
            let mut entity = commands.entity(e);
            entity
                .remove::<MeshMaterial3d<StandardMaterial>>()
                .insert(MeshMaterial3d(material.clone()));
            let Ok(Mesh3d(source)) = mesh_handles.get(e) else {
                continue;
            };
            let Some(mesh_assets) = mesh_assets.as_deref_mut().filter(|_| amount > 0.0) else {
                continue;
            };
            let key = (source.id(), amount.to_bits());
            if let Some(copy) = massed
                .get(&key)
                .and_then(|id| mesh_assets.get_strong_handle(*id))
            {
                entity.insert(Mesh3d(copy));
                continue;
            }
            let turned = mesh_assets
                .get(source)
                .ok_or("it is not loaded")
                .and_then(|mesh| {
                    let mut copy = mesh.clone();
                    turn_normals_to_mass(&mut copy, amount).map(|()| copy)
                });
            match turned {
                Ok(copy) => {
                    let copy = mesh_assets.add(copy);
                    massed.insert(key, copy.id());
                    entity.insert(Mesh3d(copy));
                }
                Err(reason) => warn!(
                    "ToonHairMeshes on {character}: the mesh of {e} keeps its own normals \
                     (mass_normals {amount}): {reason}"
                ),
            }
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

#[cfg(test)]
mod tests {
    use bevy::asset::RenderAssetUsages;
    use bevy::mesh::PrimitiveTopology;

    use super::*;

    /// A flat-shaded box 2 x 1 x 0.5 (each face its own four vertices, its normal the face's):
    /// the ellipsoid of its bounds has half extents 1, 0.5, 0.25.
    fn faceted_box() -> Mesh {
        Mesh::from(Cuboid::new(2.0, 1.0, 0.5))
    }

    #[test]
    fn mass_normals_turn_facets_to_the_bounds_ellipsoid() {
        let mut mesh = faceted_box();
        let before = mesh
            .attribute(Mesh::ATTRIBUTE_NORMAL)
            .and_then(VertexAttributeValues::as_float3)
            .unwrap()
            .to_vec();
        turn_normals_to_mass(&mut mesh, 1.0).unwrap();
        let positions = mesh
            .attribute(Mesh::ATTRIBUTE_POSITION)
            .and_then(VertexAttributeValues::as_float3)
            .unwrap()
            .to_vec();
        let after = mesh
            .attribute(Mesh::ATTRIBUTE_NORMAL)
            .and_then(VertexAttributeValues::as_float3)
            .unwrap()
            .to_vec();
        let mut corners_alike = 0;
        for ((p, n), old) in positions.iter().zip(&after).zip(&before) {
            let (p, n) = (Vec3::from_array(*p), Vec3::from_array(*n));
            // The ellipsoid's normal at a corner (x/a^2, y/b^2, z/c^2), by hand.
            let expected = Vec3::new(p.x / 1.0, p.y / 0.25, p.z / 0.0625).normalize();
            assert!(
                n.distance(expected) < 1e-5,
                "at {p}: {n} (was {old:?}), expected {expected}"
            );
            assert!((n.length() - 1.0).abs() < 1e-5);
            corners_alike += usize::from(Vec3::from_array(*old).distance(n) > 0.1);
        }
        // Every vertex is a corner: the three faces meeting there had three normals, now one.
        assert_eq!(corners_alike, positions.len());
    }

    #[test]
    fn mass_normals_blend_by_the_amount_and_leave_zero_alone() {
        let own = faceted_box();
        let mut none = own.clone();
        turn_normals_to_mass(&mut none, 0.0).unwrap();
        let normals = |m: &Mesh| {
            m.attribute(Mesh::ATTRIBUTE_NORMAL)
                .and_then(VertexAttributeValues::as_float3)
                .unwrap()
                .iter()
                .map(|n| Vec3::from_array(*n))
                .collect::<Vec<_>>()
        };
        assert_eq!(normals(&none), normals(&own));
        let mut full = own.clone();
        turn_normals_to_mass(&mut full, 1.0).unwrap();
        let mut half = own.clone();
        turn_normals_to_mass(&mut half, 0.5).unwrap();
        for ((h, o), f) in normals(&half).iter().zip(normals(&own)).zip(normals(&full)) {
            assert!(
                (*h - (o + f).normalize()).length() < 1e-5,
                "{h} between {o} and {f}"
            );
        }
        // Out of range and NaN: clamped, and NaN reads as 0.
        let mut nan = own.clone();
        turn_normals_to_mass(&mut nan, f32::NAN).unwrap();
        assert_eq!(normals(&nan), normals(&own));
    }

    /// Two characters sharing one hair mesh, dressed with mass normals: both wear one copy
    /// (normals turned, the source untouched); once neither is left the copy is freed, and a
    /// third character gets a new one.
    #[test]
    fn characters_share_one_mass_normal_copy_until_it_is_freed() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<Image>()
            .init_asset::<ToonHairMaterial>()
            .add_systems(Update, apply_toon_to_user_meshes);
        let ramps = ToonRamps::generate(&mut app.world_mut().resource_mut::<Assets<Image>>());
        app.insert_resource(ramps);
        let source = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(faceted_box());
        let character = |app: &mut App| {
            let root = app
                .world_mut()
                .spawn(ToonHairMeshes::matching(|n| n == "hair").with_mass_normals(1.0))
                .id();
            let hair = app
                .world_mut()
                .spawn((Name::new("hair"), Mesh3d(source.clone()), ChildOf(root)))
                .id();
            (root, hair)
        };
        let worn = |app: &App, hair: Entity| app.world().get::<Mesh3d>(hair).unwrap().0.clone();
        let (a, hair_a) = character(&mut app);
        let (b, hair_b) = character(&mut app);
        app.update();
        let copy = worn(&app, hair_a);
        assert_ne!(copy.id(), source.id(), "the hair still wears its own mesh");
        assert_eq!(worn(&app, hair_b).id(), copy.id(), "two copies of one mesh");
        let meshes = app.world().resource::<Assets<Mesh>>();
        let normals = |m: &Handle<Mesh>| {
            meshes
                .get(m)
                .and_then(|m| m.attribute(Mesh::ATTRIBUTE_NORMAL))
                .and_then(VertexAttributeValues::as_float3)
                .unwrap()
                .to_vec()
        };
        assert_ne!(
            normals(&copy),
            normals(&source),
            "the copy's normals did not turn"
        );
        let built = faceted_box();
        let fresh = built
            .attribute(Mesh::ATTRIBUTE_NORMAL)
            .and_then(VertexAttributeValues::as_float3)
            .unwrap();
        assert_eq!(normals(&source), fresh, "the source mesh changed");
        let copy_id = copy.id();
        drop(copy);
        app.world_mut().entity_mut(a).despawn();
        app.world_mut().entity_mut(b).despawn();
        for _ in 0..3 {
            app.update();
        }
        assert!(
            !app.world().resource::<Assets<Mesh>>().contains(copy_id),
            "the copy outlived every hair that wore it"
        );
        let (_, hair_c) = character(&mut app);
        app.update();
        let again = worn(&app, hair_c);
        assert!(again.id() != source.id() && again.id() != copy_id);
    }

    #[test]
    fn a_mesh_without_normals_on_the_cpu_is_an_error() {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32, 0.0, 0.0]; 3]);
        assert!(turn_normals_to_mass(&mut mesh, 1.0).is_err());
        let mut empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert!(turn_normals_to_mass(&mut empty, 1.0).is_err());
    }
}
