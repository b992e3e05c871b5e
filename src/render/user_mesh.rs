//! The crate's toon look on a character's own hair mesh (a VRM's, a Blender character's): the
//! meshes a [`ToonHairMeshes`] selects are drawn with a [`ToonHairMaterial`] instead of their
//! glTF material, skinned as before.
//!
//! The toon material needs only a mesh's standard attributes (positions and normals; UVs give
//! the angel ring its strand direction and carry a painted texture), so any skinned or rigid
//! mesh wears it: ramps under the scene's lights and shadows, the angel ring, and the mass
//! outline (its prepass marks the mesh as hair). Without a material of the user's, each glTF
//! material's meshes wear a toon material in its colours (base colour and texture), sides and
//! cut-out; a material of the user's is worn as it is, or over each mesh's own colours
//! ([`HairPaint`](super::HairPaint), `gltf_paint.rs`).
//! Meshes not selected keep their own material, so a VRM's MToon-derived materials stay as they
//! are unless the user opts in.
//!
//! Modelled hair is often faceted (flat or ridged locks, low-poly caps), and toon bands follow
//! every facet. [`ToonHairMeshes::mass_normals`] gives the meshes the normals of smooth
//! shapes instead, the ellipsoid that fits each mesh's bounds or ellipsoids of the user's own
//! (the normal transfer anime pipelines do in their modelling tool, from proxy shapes), so
//! light and shadow fall on the hair as one mass.

use bevy::gltf::GltfMaterialName;
use bevy::mesh::VertexAttributeValues;
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;

use crate::math::finite_or;
use crate::mesh::HairMassShape;
use crate::sim::{BonePredicate, CharacterSpawned};

use super::gltf_paint::{BandRamps, GltfPaint, HairPaint, LookCopies, MtoonParts};
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
    /// The material. `None`: for each glTF material, a toon material in its colours (the
    /// three-tone ramp times its base colour and base colour texture, its darkest tone a VRM's
    /// MToon shade colour where the material has one; a VRM's MToon material with a shading
    /// band, [`VrmShading`](crate::asset::VrmShading), turns from shade to lit in two tones
    /// where the band says, as MToon does), double-sided and cut out as it is; orange for a
    /// mesh without one. Give one for a look of your own, worn as it is, or over
    /// each mesh's own colours with [`HairPaint::Gltf`].
    pub material: Option<Handle<ToonHairMaterial>>,
    /// With a [`material`](Self::material) of yours: whether every mesh wears it as it is
    /// ([`HairPaint::Material`], the default) or each keeps its glTF material's colours,
    /// texture, sides and cut-out under it ([`HairPaint::Gltf`]).
    #[reflect(default)]
    pub paint: HairPaint,
    /// How far each mesh's normals turn toward those of [`ToonHairMeshes::mass_shapes`]
    /// (by default the ellipsoid that fits the mesh's bounds), 0 to 1: at 1 the toon bands
    /// fall on the hair as on one smooth shape, not facet by facet; in between, the locks' own
    /// relief shows that much. Each mesh is copied with the new normals (one copy per source
    /// mesh, value and shapes; the copy is skinned as the mesh was). Default: `0.0` (the
    /// meshes' own normals).
    pub mass_normals: f32,
    /// The shapes the normals turn toward, in each mesh's own space (its bind pose, the
    /// coordinates of its vertices; a glTF's are Y-up, so Blender's `(x, y, z)` is
    /// `(x, z, -y)`). Each vertex takes the normal of the shape it is nearest to, measured in
    /// each shape's own size (a point on a shape's surface is at 1, on one twice as large at
    /// 2), blended smoothly where two are about as near. One ellipsoid spanning a long ponytail
    /// or lock shades it as part of the head's mass; give the head and the ponytail an
    /// ellipsoid each. [`HairMassShape::Fitted`] is the ellipsoid of the mesh's bounds.
    /// Default: empty, which is `[HairMassShape::Fitted]`.
    #[reflect(default)]
    pub mass_shapes: Vec<HairMassShape>,
    /// Where the toon material reads "along the strand" (its coloured tips, the angel ring's
    /// strand direction, hatching). Default: [`StrandUvs::Mesh`], the mesh's own UVs.
    #[reflect(default)]
    pub strand_uvs: StrandUvs,
    /// Give each separate piece of the meshes (a lock modelled as its own shell) a lock id, so
    /// the outline's [`LockLines`](super::LockLines) draw lines where one modelled lock lies
    /// over another, as between the crate's strands (see [`lock_ids_by_piece`](super::lock_ids_by_piece)).
    /// Each mesh is copied with the ids in its second UVs, which replace any it has. Locks
    /// modelled as one connected mesh are one piece and get no lines between them. Default:
    /// `false`.
    #[reflect(default)]
    pub locks_by_piece: bool,
}

/// Where the toon material on a [`ToonHairMeshes`] mesh reads the strand's direction. It reads
/// UV `v` as the way along a strand (0 at the root, 1 at the tip: the tip colour and the angel
/// ring's direction) and `u` as the way around (hatching), as the crate's own strand tubes are
/// laid out. A modelled mesh's UVs are a texture's layout instead (a VRM's atlas), or absent,
/// and then the tips, the ring and the strokes follow that layout, or are not drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
#[reflect(Default, Debug, PartialEq)]
pub enum StrandUvs {
    /// The mesh's own UVs, as they are.
    #[default]
    Mesh,
    /// Hair hanging from the top of the head: `v` runs from the top of the mesh's bounds (0)
    /// to its bottom (1) in its bind pose, and `u` once around its vertical axis (the seam at
    /// `+z`, the front of a glTF character). The mesh is copied with these UVs, skinned as
    /// before; its own are replaced, so a base colour texture would be sampled with these
    /// instead of its layout (a warning says so): for unpainted hair. Hair
    /// whose tips point up (spikes) is not hanging: give it UVs of its own.
    Height,
}

impl ToonHairMeshes {
    /// Meshes whose name, node name or material name passes `test`, in the default material.
    pub fn matching(test: impl Fn(&str) -> bool + Send + Sync + 'static) -> Self {
        Self {
            select: BonePredicate::new(test),
            material: None,
            paint: HairPaint::Material,
            mass_normals: 0.0,
            mass_shapes: Vec::new(),
            strand_uvs: StrandUvs::Mesh,
            locks_by_piece: false,
        }
    }

    /// The same, drawn with `material`.
    pub fn with_material(mut self, material: Handle<ToonHairMaterial>) -> Self {
        self.material = Some(material);
        self
    }

    /// The same, the colours from `paint` ([`ToonHairMeshes::paint`]).
    pub fn with_paint(mut self, paint: HairPaint) -> Self {
        self.paint = paint;
        self
    }

    /// The same, with [`ToonHairMeshes::mass_normals`] at `amount`.
    pub fn with_mass_normals(mut self, amount: f32) -> Self {
        self.mass_normals = amount;
        self
    }

    /// The same, the normals turned toward `shapes` ([`ToonHairMeshes::mass_shapes`]).
    pub fn with_mass_shapes(mut self, shapes: impl IntoIterator<Item = HairMassShape>) -> Self {
        self.mass_shapes = shapes.into_iter().collect();
        self
    }

    /// The same, each separate piece a lock of its own ([`ToonHairMeshes::locks_by_piece`]).
    pub fn with_locks_by_piece(mut self) -> Self {
        self.locks_by_piece = true;
        self
    }

    /// The same, the strand's direction read from `uvs` ([`ToonHairMeshes::strand_uvs`]).
    pub fn with_strand_uvs(mut self, uvs: StrandUvs) -> Self {
        self.strand_uvs = uvs;
        self
    }
}

/// How sharply a vertex's normal goes over from one mass shape to the next: a shape whose
/// relative distance is 0.1 more than the nearest's weighs `exp(-0.8)` as much.
const SHAPE_BLEND_SHARPNESS: f32 = 8.0;

/// Turns `mesh`'s normals toward the normals of `shapes` (in the mesh's own space; empty:
/// the ellipsoid that fits its positions' bounds, as [`HairMassShape::Fitted`]), by `amount`
/// (0 to 1), and renormalises them. With several shapes each vertex takes the normal of the one
/// it is nearest to relative to their sizes, blended where two are about as near (see
/// [`ToonHairMeshes::mass_shapes`]). A vertex at a shape's centre, or whose blend cancels out,
/// keeps its normal. Errors when the mesh has no `Float32x3` positions and normals of the same
/// length (a mesh whose data lives only on the GPU has none), or a shape is not finite.
pub fn turn_normals_to_mass(
    mesh: &mut Mesh,
    amount: f32,
    shapes: &[HairMassShape],
) -> Result<(), String> {
    let amount = finite_or(amount, 0.0).clamp(0.0, 1.0);
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return Err("it has no positions on the CPU (Float32x3)".into());
    };
    let bounds = finite_bounds(positions)?;
    let fitted = [HairMassShape::Fitted];
    let shapes = if shapes.is_empty() { &fitted } else { shapes };
    // Each shape as its centre and its half extents' inverse.
    let ellipsoids = shapes
        .iter()
        .enumerate()
        .map(|(i, shape)| {
            shape
                .ellipsoid(Some(bounds), Vec3::ONE)
                .map(|(centre, half)| (centre, half.recip()))
                .ok_or_else(|| format!("its mass shape {i} is not finite: {shape:?}"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let proxy: Vec<Vec3> = positions
        .iter()
        .map(|p| mass_normal(Vec3::from_array(*p), &ellipsoids))
        .collect();
    let Some(VertexAttributeValues::Float32x3(normals)) =
        mesh.attribute_mut(Mesh::ATTRIBUTE_NORMAL)
    else {
        return Err("it has no normals on the CPU (Float32x3)".into());
    };
    if normals.len() != proxy.len() {
        return Err("its normals and positions differ in number".into());
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

/// Gives `mesh` the UVs of [`StrandUvs::Height`]: `v` from the top of its positions' bounds (0)
/// to the bottom (1), `u` the angle around the vertical axis through the bounds' centre, 0 to 1
/// from `+z` round through `+x`. A vertex whose position is not finite gets `(0, 0)`. Errors
/// when the mesh has no `Float32x3` positions on the CPU or none of them is finite.
pub fn strand_uvs_from_height(mesh: &mut Mesh) -> Result<(), String> {
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return Err("it has no positions on the CPU (Float32x3)".into());
    };
    let (lo, hi) = finite_bounds(positions)?;
    let centre = (lo + hi) * 0.5;
    let height = (hi.y - lo.y).max(1e-9);
    let uvs: Vec<[f32; 2]> = positions
        .iter()
        .map(|p| {
            let p = Vec3::from_array(*p);
            if !p.is_finite() {
                return [0.0, 0.0];
            }
            let d = p - centre;
            let around = d.x.atan2(d.z) / std::f32::consts::TAU;
            [
                around.rem_euclid(1.0),
                ((hi.y - p.y) / height).clamp(0.0, 1.0),
            ]
        })
        .collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs);
    Ok(())
}

/// The bounds of `positions`' finite points; an error when none is finite.
fn finite_bounds(positions: &[[f32; 3]]) -> Result<(Vec3, Vec3), String> {
    let (lo, hi) = positions
        .iter()
        .map(|p| Vec3::from_array(*p))
        .filter(|p| p.is_finite())
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    if lo.cmpgt(hi).any() {
        return Err("it has no finite position".into());
    }
    Ok((lo, hi))
}

/// The normal at `p` of the ellipsoids `(centre, 1 / half extents)`: each one's (the gradient
/// of `|(p - c) / h|²`) weighted by how much nearer it is than the others relative to its size.
/// Zero at a lone shape's centre or where the blend cancels out.
fn mass_normal(p: Vec3, ellipsoids: &[(Vec3, Vec3)]) -> Vec3 {
    if let [(centre, inv_half)] = ellipsoids {
        return ((p - *centre) * *inv_half * *inv_half).normalize_or_zero();
    }
    let near = ellipsoids
        .iter()
        .map(|(c, inv)| ((p - *c) * *inv).length())
        .fold(f32::INFINITY, f32::min);
    if !near.is_finite() {
        return Vec3::ZERO;
    }
    ellipsoids
        .iter()
        .map(|(c, inv)| {
            let u = (p - *c) * *inv;
            let weight = (-SHAPE_BLEND_SHARPNESS * (u.length() - near)).exp();
            (u * *inv).normalize_or_zero() * weight
        })
        .sum::<Vec3>()
        .normalize_or_zero()
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

/// Copies of source meshes with mass normals, strand UVs or lock ids, by source mesh, amount (its
/// bits), shapes (a hash of their bits), UVs and lock ids. Only ids: a copy no entity uses any more is freed (and its entry
/// dropped at the next dressing).
type MassedMeshes = HashMap<(AssetId<Mesh>, u32, u64, StrandUvs, bool), AssetId<Mesh>>;

/// The look a `ToonHairMeshes` without a material of the user's wears (the three-tone ramp, in
/// each mesh's glTF paint), made once.
type DefaultLook = Option<Handle<ToonHairMaterial>>;

/// A hash of `shapes`' bits, for [`MassedMeshes`]' keys.
fn shapes_key(shapes: &[HairMassShape]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::hash::DefaultHasher::new();
    for shape in shapes {
        match shape {
            HairMassShape::Ellipsoid {
                centre,
                half_extents,
            } => centre
                .to_array()
                .iter()
                .chain(&half_extents.to_array())
                .for_each(|x| x.to_bits().hash(&mut hasher)),
            // Fitted, and any shape added later, by its debug form.
            other => format!("{other:?}").hash(&mut hasher),
        }
    }
    hasher.finish()
}

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
    (mut materials, mut default_look, mut copies): (
        ResMut<Assets<ToonHairMaterial>>,
        Local<DefaultLook>,
        ResMut<LookCopies>,
    ),
    (gltf_materials, standard): (
        Query<&MeshMaterial3d<StandardMaterial>>,
        Option<Res<Assets<StandardMaterial>>>,
    ),
    (shades, mut band_ramps, mut images): (
        Query<MtoonParts>,
        ResMut<BandRamps>,
        Option<ResMut<Assets<Image>>>,
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
        let dressed = meshes_passing(character, &wanted.select, false, &children, &meshes, &names);
        let amount = finite_or(wanted.mass_normals, 0.0).clamp(0.0, 1.0);
        let shapes = shapes_key(&wanted.mass_shapes);
        if let Some(assets) = &mesh_assets {
            massed.retain(|_, copy| assets.contains(*copy));
        }
        for &e in &dressed {
            let gltf_id = gltf_materials.get(e).ok().map(|m| m.0.id());
            let gltf = gltf_id.and_then(|id| standard.as_deref()?.get(id));
            // Its colours, sides (hair modelled as sheets) and cut-out (cards), as its glTF
            // material has them; the default look turns where an MToon material's band says.
            let (shade, band, rim) = shades.get(e).unwrap_or_default();
            let paint = gltf_id.zip(gltf).map(|(id, m)| {
                let mut paint = GltfPaint::of(m, shade);
                paint.rim = rim.copied();
                if let (Some(band), Some(images), None) =
                    (band, images.as_deref_mut(), &wanted.material)
                {
                    paint.band_ramp = Some(band_ramps.of(band, images));
                }
                (id, paint)
            });
            // The look: the user's, or the three-tone default; worn in the mesh's glTF paint
            // (one copy per glTF material) unless the user's is to be worn as it is.
            let (look, in_paint) = match &wanted.material {
                Some(look) => (look.clone(), wanted.paint == HairPaint::Gltf),
                None => {
                    let look = default_look.get_or_insert_with(|| {
                        materials.add(ToonHairMaterial {
                            ramp: ramps.three_tone.clone(),
                            ..default()
                        })
                    });
                    (look.clone(), true)
                }
            };
            let blends = paint.as_ref().is_some_and(|(_, p)| p.blends);
            if let Some(m) = gltf.filter(|_| in_paint && blends) {
                warn!(
                    "ToonHairMeshes on {character}: the glTF material of mesh {e} blends with \
                     alpha ({:?}), which the toon material does not: it is cut out instead, at \
                     alpha 0.5 unless its toon material sets ToonHairMaterial::alpha_cutoff",
                    m.alpha_mode
                );
            }
            let material = match paint {
                Some((gltf_id, paint)) if in_paint => {
                    match copies.copy(&look, gltf_id, paint, &mut materials, &ramps) {
                        Some(copy) => copy,
                        None => {
                            warn!(
                                "ToonHairMeshes on {character}: its material is not in the \
                                 assets, so mesh {e} wears it as it is, without its glTF \
                                 material's colours"
                            );
                            look
                        }
                    }
                }
                paint => {
                    // A mesh the user's material is worn on as it is: say where it falls short
                    // of the glTF material.
                    let given = materials.get(&look);
                    let paint = paint.map(|(_, p)| p);
                    let gltf_double_sided = paint.as_ref().is_some_and(|p| p.double_sided);
                    let gltf_cut = paint.as_ref().is_some_and(|p| p.alpha_cutoff.is_some());
                    if gltf_double_sided && given.is_some_and(|m| !m.double_sided) {
                        warn!(
                            "ToonHairMeshes on {character}: the glTF material of mesh {e} is \
                             double-sided and its toon material is not, so the mesh's back \
                             faces are not drawn (holes where the hair is a single sheet); set \
                             ToonHairMaterial::double_sided on that material"
                        );
                    }
                    if gltf_cut && given.is_some_and(|m| m.alpha_cutoff.is_none()) {
                        warn!(
                            "ToonHairMeshes on {character}: the glTF material of mesh {e} is \
                             drawn with alpha (cut out or blended) and its toon material is \
                             opaque, so its see-through parts are drawn solid; set \
                             ToonHairMaterial::alpha_cutoff on that material, or dress the mesh \
                             with HairPaint::Gltf"
                        );
                    }
                    look
                }
            };
            let uvs = wanted.strand_uvs;
            let painted = materials
                .get(&material)
                .is_some_and(|m| m.base_color_texture.is_some());
            if uvs == StrandUvs::Height && painted {
                warn!(
                    "ToonHairMeshes on {character}: mesh {e} is painted (its toon material has a \
                     base colour texture) and its strand UVs are by height, which replace the UVs \
                     the paint is laid out by; use StrandUvs::Mesh for painted hair"
                );
            }
            let mut entity = commands.entity(e);
            entity
                .remove::<MeshMaterial3d<StandardMaterial>>()
                .insert(MeshMaterial3d(material));
            let Ok(Mesh3d(source)) = mesh_handles.get(e) else {
                continue;
            };
            let locks = wanted.locks_by_piece;
            if !locks
                && let Some(mesh) = mesh_assets.as_deref().and_then(|a| a.get(source))
                && super::lock_ids::second_uvs_read_as_locks(mesh)
            {
                warn!(
                    "ToonHairMeshes on {character}: mesh {e} has second UVs whose u reaches 1 \
                     or more, which the hair's prepass reads as lock ids: the outline's lines \
                     between locks would follow their tiles; dress it with_locks_by_piece(), or \
                     remove its second UVs"
                );
            }
            let Some(mesh_assets) = mesh_assets
                .as_deref_mut()
                .filter(|_| amount > 0.0 || uvs != StrandUvs::Mesh || locks)
            else {
                continue;
            };
            let key = (source.id(), amount.to_bits(), shapes, uvs, locks);
            if let Some(copy) = massed
                .get(&key)
                .and_then(|id| mesh_assets.get_strong_handle(*id))
            {
                entity.insert(Mesh3d(copy));
                continue;
            }
            let changed = mesh_assets
                .get(source)
                .ok_or_else(|| "it is not loaded".to_string())
                .and_then(|mesh| {
                    let mut copy = mesh.clone();
                    if amount > 0.0 {
                        turn_normals_to_mass(&mut copy, amount, &wanted.mass_shapes)?;
                    }
                    if uvs == StrandUvs::Height {
                        strand_uvs_from_height(&mut copy)?;
                    }
                    if locks {
                        super::lock_ids_by_piece(&mut copy)?;
                    }
                    Ok(copy)
                });
            match changed {
                Ok(copy) => {
                    let copy = mesh_assets.add(copy);
                    massed.insert(key, copy.id());
                    entity.insert(Mesh3d(copy));
                }
                Err(reason) => warn!(
                    "ToonHairMeshes on {character}: the mesh of {e} is drawn as it is, without \
                     mass normals ({amount}), strand UVs ({uvs:?}) or lock ids by piece \
                     ({locks}): {reason}"
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
        turn_normals_to_mass(&mut mesh, 1.0, &[]).unwrap();
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
        turn_normals_to_mass(&mut none, 0.0, &[]).unwrap();
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
        turn_normals_to_mass(&mut full, 1.0, &[]).unwrap();
        let mut half = own.clone();
        turn_normals_to_mass(&mut half, 0.5, &[]).unwrap();
        for ((h, o), f) in normals(&half).iter().zip(normals(&own)).zip(normals(&full)) {
            assert!(
                (*h - (o + f).normalize()).length() < 1e-5,
                "{h} between {o} and {f}"
            );
        }
        // Out of range and NaN: clamped, and NaN reads as 0.
        let mut nan = own.clone();
        turn_normals_to_mass(&mut nan, f32::NAN, &[]).unwrap();
        assert_eq!(normals(&nan), normals(&own));
    }

    /// An app with meshes, images, toon materials and ramps, running the dressing system.
    fn dressing_app() -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<Image>()
            .init_asset::<ToonHairMaterial>()
            .init_asset::<StandardMaterial>()
            .init_resource::<LookCopies>()
            .init_resource::<BandRamps>()
            .add_systems(
                Update,
                (
                    apply_toon_to_user_meshes,
                    super::super::gltf_paint::follow_look_edits,
                ),
            );
        let ramps = ToonRamps::generate(&mut app.world_mut().resource_mut::<Assets<Image>>());
        app.insert_resource(ramps);
        app
    }

    /// Two characters sharing one hair mesh, dressed with mass normals: both wear one copy
    /// (normals turned, the source untouched); once neither is left the copy is freed, and a
    /// third character gets a new one.
    #[test]
    fn characters_share_one_mass_normal_copy_until_it_is_freed() {
        let mut app = dressing_app();
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
        // Other shapes: a copy of their own.
        let shaped = app
            .world_mut()
            .spawn(
                ToonHairMeshes::matching(|n| n == "hair")
                    .with_mass_normals(1.0)
                    .with_mass_shapes([HairMassShape::Ellipsoid {
                        centre: Vec3::X,
                        half_extents: Vec3::ONE,
                    }]),
            )
            .id();
        let hair_d = app
            .world_mut()
            .spawn((Name::new("hair"), Mesh3d(source.clone()), ChildOf(shaped)))
            .id();
        app.update();
        let other = worn(&app, hair_d);
        assert!(other.id() != again.id() && other.id() != source.id());
        let meshes = app.world().resource::<Assets<Mesh>>();
        let (a, b) = (meshes.get(&other).unwrap(), meshes.get(&again).unwrap());
        assert_ne!(normals_of(a), normals_of(b));
    }

    /// Without a material of the user's, each glTF material's meshes are drawn in a toon
    /// material cut out as the glTF material is: opaque stays opaque, a mask keeps its cut-off,
    /// blended alpha (which the toon material does not blend) is cut at half.
    #[test]
    fn the_default_material_is_cut_out_as_the_gltf_material_is() {
        let mut app = dressing_app();
        let source = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(faceted_box());
        let root = app
            .world_mut()
            .spawn(ToonHairMeshes::matching(|n| n.starts_with("hair")))
            .id();
        let modes = [
            AlphaMode::Opaque,
            AlphaMode::Mask(0.3),
            AlphaMode::Blend,
            AlphaMode::Premultiplied,
        ];
        let hairs: Vec<Entity> = modes
            .iter()
            .enumerate()
            .map(|(i, &alpha_mode)| {
                let gltf = app
                    .world_mut()
                    .resource_mut::<Assets<StandardMaterial>>()
                    .add(StandardMaterial {
                        alpha_mode,
                        ..default()
                    });
                app.world_mut()
                    .spawn((
                        Name::new(format!("hair {i}")),
                        Mesh3d(source.clone()),
                        MeshMaterial3d(gltf),
                        ChildOf(root),
                    ))
                    .id()
            })
            .collect();
        app.update();
        let cutoffs: Vec<Option<f32>> = hairs
            .iter()
            .map(|&e| {
                let toon = app.world().get::<MeshMaterial3d<ToonHairMaterial>>(e);
                let toon = toon.expect("the mesh was not dressed");
                let materials = app.world().resource::<Assets<ToonHairMaterial>>();
                materials.get(&toon.0).unwrap().alpha_cutoff
            })
            .collect();
        assert_eq!(cutoffs, [None, Some(0.3), Some(0.5), Some(0.5)]);
    }

    /// A look of the user's on meshes of two painted glTF materials: each glTF material's
    /// meshes share one copy of the look in its paint; an edit to the look reaches both copies,
    /// which keep their paint; with `HairPaint::Material` every mesh wears the look itself.
    #[test]
    fn a_look_of_yours_keeps_each_meshes_paint_and_follows_your_edits() {
        let mut app = dressing_app();
        let source = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(faceted_box());
        let world = app.world_mut();
        let textures: Vec<Handle<Image>> = (0..2)
            .map(|_| world.resource_mut::<Assets<Image>>().add(Image::default()))
            .collect();
        let gltf: Vec<Handle<StandardMaterial>> = textures
            .iter()
            .zip([Color::srgb(1.0, 0.5, 0.5), Color::WHITE])
            .map(|(t, base_color)| {
                world
                    .resource_mut::<Assets<StandardMaterial>>()
                    .add(StandardMaterial {
                        base_color,
                        base_color_texture: Some(t.clone()),
                        double_sided: true,
                        cull_mode: None,
                        ..default()
                    })
            })
            .collect();
        let look = world
            .resource_mut::<Assets<ToonHairMaterial>>()
            .add(ToonHairMaterial {
                shading: super::super::ToonShading {
                    base_color: Color::srgb(0.0, 0.0, 1.0),
                    angel_ring: 0.7,
                    ..default()
                },
                ..default()
            });
        let dress = |world: &mut World, paint: HairPaint| {
            let root = world
                .spawn(
                    ToonHairMeshes::matching(|n| n.starts_with("hair"))
                        .with_material(look.clone())
                        .with_paint(paint),
                )
                .id();
            // Meshes 0 and 1 in the first glTF material, 2 in the second.
            [0, 0, 1]
                .map(|k| {
                    world
                        .spawn((
                            Name::new("hair"),
                            Mesh3d(source.clone()),
                            MeshMaterial3d(gltf[k].clone()),
                            ChildOf(root),
                        ))
                        .id()
                })
                .to_vec()
        };
        let painted = dress(world, HairPaint::Gltf);
        let recoloured = dress(world, HairPaint::Material);
        app.update();
        let worn = |app: &App, e: Entity| {
            let handle = app
                .world()
                .get::<MeshMaterial3d<ToonHairMaterial>>(e)
                .expect("the mesh was not dressed")
                .0
                .clone();
            let m = app.world().resource::<Assets<ToonHairMaterial>>();
            (handle.id(), m.get(&handle).unwrap().clone())
        };
        let (a, b, c) = (
            worn(&app, painted[0]),
            worn(&app, painted[1]),
            worn(&app, painted[2]),
        );
        assert_eq!(a.0, b.0, "one copy for one glTF material");
        assert!(a.0 != c.0 && a.0 != look.id() && c.0 != look.id());
        for ((_, m), k) in [(&a, 0), (&c, 1)] {
            assert_eq!(m.base_color_texture.as_ref(), Some(&textures[k]));
            assert_eq!(m.base_color, gltf_color(&app, &gltf[k]));
            assert_eq!(m.angel_ring, 0.7);
            assert!(m.double_sided);
        }
        for &e in &recoloured {
            assert_eq!(
                worn(&app, e).0,
                look.id(),
                "HairPaint::Material wears the look"
            );
        }
        // An edit to the look reaches its copies, in their paint.
        app.world_mut()
            .resource_mut::<Assets<ToonHairMaterial>>()
            .get_mut(&look)
            .unwrap()
            .angel_ring = 0.2;
        app.update();
        app.update();
        for (e, k) in [(painted[0], 0), (painted[2], 1)] {
            let (_, m) = worn(&app, e);
            assert_eq!(m.angel_ring, 0.2, "the edit did not reach mesh {e}'s copy");
            assert_eq!(m.base_color_texture.as_ref(), Some(&textures[k]));
            assert_eq!(m.base_color, gltf_color(&app, &gltf[k]));
        }
    }

    fn gltf_color(app: &App, m: &Handle<StandardMaterial>) -> Color {
        app.world()
            .resource::<Assets<StandardMaterial>>()
            .get(m)
            .unwrap()
            .base_color
    }

    /// A mesh of loose points, each with the normal +Z, for testing the mass shapes.
    fn points(positions: &[[f32; 3]]) -> Mesh {
        Mesh::new(PrimitiveTopology::PointList, RenderAssetUsages::default())
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions.to_vec())
            .with_inserted_attribute(
                Mesh::ATTRIBUTE_NORMAL,
                vec![[0.0f32, 0.0, 1.0]; positions.len()],
            )
    }

    fn normals_of(mesh: &Mesh) -> Vec<Vec3> {
        mesh.attribute(Mesh::ATTRIBUTE_NORMAL)
            .and_then(VertexAttributeValues::as_float3)
            .unwrap()
            .iter()
            .map(|n| Vec3::from_array(*n))
            .collect()
    }

    /// Two shapes, a unit sphere at the origin (the head) and an ellipsoid at x = 3 with half
    /// extents 0.5, 2, 0.5 (a ponytail). Expected normals worked out by hand (relative distance
    /// `|(p - c) / h|`, normal `(p - c) / h²`, weights `exp(-8 (q - nearest))`).
    #[test]
    fn each_vertex_takes_the_normal_of_the_mass_shape_it_is_nearest() {
        let shapes = [
            HairMassShape::Ellipsoid {
                centre: Vec3::ZERO,
                half_extents: Vec3::ONE,
            },
            HairMassShape::Ellipsoid {
                centre: Vec3::new(3.0, 0.0, 0.0),
                half_extents: Vec3::new(0.5, 2.0, 0.5),
            },
        ];
        let mut mesh = points(&[[0.0, 1.0, 0.0], [3.0, 1.5, 0.5], [2.0, 0.5, 0.0]]);
        turn_normals_to_mass(&mut mesh, 1.0, &shapes).unwrap();
        let n = normals_of(&mesh);
        // On the sphere, six times its size from the ponytail: the sphere's normal.
        assert!(n[0].distance(Vec3::Y) < 1e-5, "{}", n[0]);
        // 1.25 from the ponytail, 3.39 from the sphere: the ponytail's (0, 0.75/2, 1/0.5).
        let tail = Vec3::new(0.0, 0.375, 2.0).normalize();
        assert!(n[1].distance(tail) < 1e-5, "{} against {tail}", n[1]);
        // 2.06 from the sphere, 2.02 from the ponytail: both, the sphere's (0.970, 0.243, 0)
        // weighing exp(-8 x 0.046) = 0.69 of the ponytail's (-0.9995, 0.031, 0).
        let blend = Vec3::new(-0.85482, 0.518_925, 0.0);
        assert!(n[2].distance(blend) < 1e-4, "{} against {blend}", n[2]);
        // The bounds' ellipsoid alone gives none of these.
        let mut fitted = points(&[[0.0, 1.0, 0.0], [3.0, 1.5, 0.5], [2.0, 0.5, 0.0]]);
        turn_normals_to_mass(&mut fitted, 1.0, &[]).unwrap();
        assert!(normals_of(&fitted)[1].distance(tail) > 0.1);
    }

    /// The bounds' ellipsoid given by hand is the fitted shape, and a shape that is not finite
    /// is an error naming it (the mesh keeps its normals).
    #[test]
    fn a_given_ellipsoid_matches_the_fitted_one_and_a_broken_one_is_refused() {
        let mut given = faceted_box();
        turn_normals_to_mass(
            &mut given,
            1.0,
            &[HairMassShape::Ellipsoid {
                centre: Vec3::ZERO,
                half_extents: Vec3::new(1.0, 0.5, 0.25),
            }],
        )
        .unwrap();
        let mut fitted = faceted_box();
        turn_normals_to_mass(&mut fitted, 1.0, &[HairMassShape::Fitted]).unwrap();
        for (a, b) in normals_of(&given).iter().zip(normals_of(&fitted)) {
            assert!(a.distance(b) < 1e-6, "{a} against {b}");
        }
        let mut broken = faceted_box();
        let err = turn_normals_to_mass(
            &mut broken,
            1.0,
            &[
                HairMassShape::Fitted,
                HairMassShape::Ellipsoid {
                    centre: Vec3::new(f32::NAN, 0.0, 0.0),
                    half_extents: Vec3::ONE,
                },
            ],
        )
        .unwrap_err();
        assert!(err.contains("mass shape 1"), "{err}");
        assert_eq!(normals_of(&broken), normals_of(&faceted_box()));
    }

    /// Four points around a vertical axis, top to bottom, and one not finite. UVs by hand: `v`
    /// from the top (y = 2) to the bottom (y = -2), `u` the angle from `+z` toward `+x`.
    #[test]
    fn strand_uvs_run_from_the_top_down_and_around() {
        let mut mesh = points(&[
            [0.0, 2.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, -2.0, -1.0],
            [-1.0, 0.0, 0.0],
            [f32::NAN, 0.0, 0.0],
        ]);
        strand_uvs_from_height(&mut mesh).unwrap();
        let Some(VertexAttributeValues::Float32x2(uvs)) = mesh.attribute(Mesh::ATTRIBUTE_UV_0)
        else {
            panic!("no UVs");
        };
        let expected = [[0.0, 0.0], [0.25, 0.5], [0.5, 1.0], [0.75, 0.5], [0.0, 0.0]];
        for (uv, want) in uvs.iter().zip(expected) {
            assert!(
                Vec2::from_array(*uv).distance(Vec2::from_array(want)) < 1e-6,
                "{uv:?} against {want:?}"
            );
        }
        let mut empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert!(strand_uvs_from_height(&mut empty).is_err());
    }

    /// A hair mesh without UVs dressed with `StrandUvs::Height` wears a copy with them; the
    /// source keeps none, and the copy keeps the source's normals (no mass normals asked).
    #[test]
    fn a_mesh_dressed_with_height_uvs_wears_a_copy_with_them() {
        let mut app = dressing_app();
        let mut bare = faceted_box();
        bare.remove_attribute(Mesh::ATTRIBUTE_UV_0);
        let source = app.world_mut().resource_mut::<Assets<Mesh>>().add(bare);
        let root = app
            .world_mut()
            .spawn(ToonHairMeshes::matching(|n| n == "hair").with_strand_uvs(StrandUvs::Height))
            .id();
        let hair = app
            .world_mut()
            .spawn((Name::new("hair"), Mesh3d(source.clone()), ChildOf(root)))
            .id();
        app.update();
        let worn = app.world().get::<Mesh3d>(hair).unwrap().0.clone();
        assert_ne!(worn.id(), source.id());
        let meshes = app.world().resource::<Assets<Mesh>>();
        let (copy, source) = (meshes.get(&worn).unwrap(), meshes.get(&source).unwrap());
        assert!(copy.attribute(Mesh::ATTRIBUTE_UV_0).is_some());
        assert!(source.attribute(Mesh::ATTRIBUTE_UV_0).is_none());
        assert_eq!(normals_of(copy), normals_of(source));
    }

    #[test]
    fn a_mesh_without_normals_on_the_cpu_is_an_error() {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32, 0.0, 0.0]; 3]);
        assert!(turn_normals_to_mass(&mut mesh, 1.0, &[]).is_err());
        let mut empty = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::default(),
        );
        assert!(turn_normals_to_mass(&mut empty, 1.0, &[]).is_err());
    }
}
