//! Strand meshes: a tapered tube swept along a spline through each strand (thesis 4.3.1-4.3.2).
//!
//! Every hair gets one mesh holding all its strands (one upload per frame), on an entity of its
//! own in world space ([`HairMeshOf`]). The triangle topology and UVs are shared by every strand
//! and rebuilt only when a resolution in [`HairMeshSettings`] changes (the thesis's "Rebuild
//! mesh" button, done automatically); positions and normals are rebuilt every frame, in parallel
//! over strands, from [`StrandParticles`]. The mesh's tangent attribute holds each vertex's
//! strand direction (root to tip, `w = 1`), not Bevy's normal-map convention: the toon
//! material's angel ring runs across it. Normals lean toward the hair's mass
//! ([`HairMeshSettings::mass_normals`]).
//!
//! [`highlights`] adds the optional specular sampling quads (Shin et al. 2006); [`shadow`] the
//! ribbons a hair casts its shadow with.

pub mod culling;
pub mod highlights;
pub mod lod;
mod mass;
mod section;
pub mod shadow;
pub mod tube;

pub use culling::{HairCulling, HairCullingStats, HairInView};
pub use lod::{HairLod, HairLodLevel};
pub use mass::HairMassShape;
pub(crate) use mass::MassField;
pub use section::LockSection;
#[cfg(feature = "render")]
pub(crate) use section::{SectionSide, fill_section};
pub use shadow::HairShadowCaster;

use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::NoAutoAabb;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;

use crate::asset::HairGroom;
use crate::curve::QuadraticCurve;
use crate::parallel;
use crate::schedule::HairSystems;
use crate::sim::{BoneChainHair, ComputedHair, Hair, HairStrands, Strand, StrandParticles};
use tube::{FrameReference, TubeParams, TubeScratch, TubeTopology};

/// How strands are turned into tubes. A component on the [`Hair`] entity (inserted with defaults
/// when missing); edits take effect on the next frame.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairMeshSettings {
    /// Hair resolution: samples of the spline along each strand (rings). More is smoother and
    /// costs linearly. Changing it rebuilds the topology. Clamped to `[2, 256]`. Default: `16`.
    pub hair_resolution: u32,
    /// Shape resolution: vertices around each ring. More is rounder. Changing it rebuilds the
    /// topology. Clamped to `[3, 64]`. Default: `8`.
    pub shape_resolution: u32,
    /// Tube radius at the root, metres. Default: `0.016`.
    pub radius: f32,
    /// The H curve: radius scale along the strand, root `x = 0` to tip `x = 1`, for the tapered
    /// cartoon look. Default: `QuadraticCurve { a: -0.4, b: -0.5, c: 1.0 }` (full at the root, a
    /// point at the tip, fuller in the middle than a cone).
    pub taper: QuadraticCurve,
    /// Hair-mass normals: how far each vertex normal leans from the tube's own normal (0)
    /// toward the normal of [`HairMeshSettings::mass_shape`] at that point (1). Above 0, light
    /// and shadow run across the whole hair as one shape instead of one band per strand, as
    /// anime hair is shaded; the strands' own shading fades as it nears 1. Clamped to
    /// `[0, 1]`. Default: `0.8` (the strands' own shading still shows
    /// inside the mass's light and shadow).
    pub mass_normals: f32,
    /// Cross-section: the tube's width across the strand's rest normal over its width along it.
    /// `1` is round; less is an ellipse; about `0.2` is a flat blade, the flat clumps of anime
    /// hair (pair it with a taper that ends at 0 for sharp tips). Each ring's normal is the
    /// ellipse's, and silhouettes come from the geometry, so both stay right for any shape.
    /// For the polygon [`HairMeshSettings::section`]s, their thickness over their width.
    /// Clamped to `[0.05, 1]`. Default: `1.0`.
    pub section_aspect: f32,
    /// The cross-section of every strand: the round tube, or a flat, triangular or rhombic
    /// lock lying on the hair's mass (see [`LockSection`]); [`HairStrandSections`] overrides it
    /// per strand. A polygon's corners each get a vertex: the shape resolution is rounded up to
    /// a multiple of its corners. Default: [`LockSection::Round`].
    #[reflect(default)]
    pub section: LockSection,
    /// The smooth shape the normals lean toward. Default: [`HairMassShape::Fitted`], an
    /// ellipsoid around the groom's rest shape.
    pub mass_shape: HairMassShape,
}

impl Default for HairMeshSettings {
    fn default() -> Self {
        Self {
            hair_resolution: 16,
            shape_resolution: 8,
            radius: crate::sim::DEFAULT_STRAND_RADIUS,
            taper: QuadraticCurve::new(-0.4, -0.5, 1.0),
            mass_normals: 0.8,
            section_aspect: 1.0,
            section: LockSection::Round,
            mass_shape: HairMassShape::Fitted,
        }
    }
}

/// Per-strand cross-sections of a hair, by strand index in the groom's order, overriding
/// [`HairMeshSettings::section`]; strands past the end keep the hair's. Anime hair mixes them:
/// triangular bangs in front, rhombic spikes behind, flat ribbons on the sides.
///
/// ```
/// # use bevy_cartoon_hair::prelude::*;
/// # use bevy_cartoon_hair::mesh::{HairStrandSections, LockSection};
/// // The first three strands (the bangs) are triangles; the rest use the hair's section.
/// let sections = HairStrandSections(vec![LockSection::Triangle; 3]);
/// # let _ = sections;
/// ```
#[derive(Component, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairStrandSections(pub Vec<LockSection>);

impl HairStrandSections {
    /// The section of strand `index`, `fallback` where none is given.
    pub fn get(&self, index: usize, fallback: LockSection) -> LockSection {
        self.0.get(index).copied().unwrap_or(fallback)
    }
}

/// On a hair whose tube vertices another stage builds (the GPU: `render::HairMeshBuilder`): the
/// mesh stage keeps its topology, bounds, culling and level of detail, and leaves its vertices
/// alone.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairMeshBuiltOnGpu;

/// The mesh entity of a hair (world space, so it is not a child of the bone).
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = HairMeshes)]
pub struct HairMeshOf(pub Entity);

/// The eye a hair's half tubes face this frame ([`TubeTopology::facing`], see
/// [`HairLod::half_tubes`]); `None` while its tubes are closed. On the [`Hair`] entity,
/// inserted with it.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairTubesFacing(pub Option<Vec3>);

/// Keeps a hair's tubes closed ([`HairLod::half_tubes`] off for it): for a look whose texture
/// runs around the tube, as surface hatching does, which a half tube (its `u` fixed on screen)
/// would hold still while the strands turn. The render plugin keeps it on the hairs whose
/// material hatches on the surface.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct HairTubesClosed;

/// A hair's mesh entities; despawning the hair despawns them.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
#[relationship_target(relationship = HairMeshOf, linked_spawn)]
pub struct HairMeshes(Vec<Entity>);

/// Derived mesh state of a hair: its mesh asset and the shared topology. Reflected for
/// inspectors (the topology is not).
#[derive(Component, Reflect, Debug, Clone)]
#[reflect(Component, Debug, from_reflect = false)]
pub struct ComputedHairMesh {
    /// The mesh asset holding every strand.
    pub mesh: Handle<Mesh>,
    /// The shared per-strand topology.
    #[reflect(ignore)]
    pub topology: TubeTopology,
    /// Strands in the mesh.
    pub strands: usize,
    /// The mesh entity.
    pub entity: Entity,
    /// Each strand's rest root direction and a normal to it, in bone space: ring frames start
    /// from these turned by the bone, so they never flip as the strand swings.
    pub rest_frames: Vec<(Vec3, Vec3)>,
}

impl ComputedHairMesh {
    /// Vertices per strand.
    pub fn vertices_per_strand(&self) -> usize {
        self.topology.vertex_count()
    }

    /// The reference strand `strand`'s ring frames start from: its rest frame turned by the
    /// bone's `rotation`.
    pub(crate) fn frame_reference(&self, strand: u32, rotation: Quat) -> FrameReference {
        let (direction, normal) = self
            .rest_frames
            .get(strand as usize)
            .copied()
            .unwrap_or((Vec3::NEG_Y, Vec3::Z));
        FrameReference {
            direction: rotation * direction,
            normal: rotation * normal,
        }
    }
}

/// Builds and updates strand meshes. Part of [`CartoonHairPlugins`](crate::CartoonHairPlugins).
#[derive(Default)]
pub struct HairMeshPlugin;

impl Plugin for HairMeshPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<HairMeshSettings>()
            .register_type::<HairStrandSections>()
            .register_type::<HairMeshBuiltOnGpu>()
            .register_type::<LockSection>()
            .register_type::<highlights::SpecularQuads>()
            .register_required_components::<Hair, HairMeshSettings>()
            .register_required_components::<Hair, highlights::SpecularQuads>()
            .register_required_components::<Hair, highlights::GpuHighlightJob>()
            .register_type::<shadow::HairShadowCaster>()
            .register_type::<shadow::HairShadowMeshOf>()
            .register_required_components::<Hair, shadow::HairShadowCaster>()
            .register_required_components::<Hair, shadow::GpuShadowJob>()
            .register_required_components::<Hair, shadow::TubeRingCentres>()
            .register_type::<HairTubesFacing>()
            .register_type::<HairTubesClosed>()
            .register_required_components::<Hair, HairTubesFacing>()
            .register_type::<culling::HairCulling>()
            .register_type::<culling::HairInView>()
            .register_type::<culling::HairCullingStats>()
            .register_required_components::<Hair, culling::HairCulling>()
            .register_required_components::<Hair, culling::HairInView>()
            .register_type::<lod::HairLod>()
            .register_type::<lod::HairLodLevel>()
            .register_required_components::<Hair, lod::HairLod>()
            .register_required_components::<Hair, lod::HairLodLevel>()
            .init_resource::<culling::HairCullingStats>()
            .add_systems(
                PostUpdate,
                (
                    hand_radius_to_volume,
                    rebuild_strand_meshes,
                    highlights::build_specular_quads,
                    shadow::build_shadow_ribbons,
                    chain_hairs_in_view,
                )
                    .chain()
                    .in_set(HairSystems::BuildMesh)
                    // Culling tests this frame's bounds against this frame's frusta.
                    .after(bevy::camera::visibility::VisibilitySystems::UpdateFrusta),
            );
    }
}

fn settings_topology(s: &HairMeshSettings) -> (usize, usize) {
    (
        (s.hair_resolution as usize).clamp(tube::MIN_RINGS, tube::MAX_RINGS),
        (s.shape_resolution as usize).clamp(tube::MIN_SIDES, tube::MAX_SIDES),
    )
}

/// The sides of a ring for `sides` asked: a multiple of the corners of every section in use.
fn section_sides(
    sides: usize,
    s: &HairMeshSettings,
    per_strand: Option<&HairStrandSections>,
) -> usize {
    let sections =
        std::iter::once(s.section).chain(per_strand.into_iter().flat_map(|p| p.0.iter().copied()));
    section::sides_for(sides, sections, tube::MAX_SIDES)
}

/// The field the hair's normals and tangents lean toward this frame, `None` without mass
/// normals or a usable bone pose. Shared by the CPU's tubes and the GPU's.
pub(crate) fn mass_field(settings: &HairMeshSettings, sim: &ComputedHair) -> Option<MassField> {
    let bone = sim.bone_pose()?;
    let ellipsoid = settings
        .mass_shape
        .ellipsoid(sim.rest_bounds(), sim.bone_scale())?;
    MassField::new(&bone, ellipsoid, settings.mass_normals)
}

/// Distinct lock ids the hair's prepass can write (the normal target's two alpha bits, less the
/// value other objects write).
const LOCK_IDS: usize = 3;

/// Creates a mesh with `strands` copies of the topology (positions and normals zeroed).
pub(crate) fn new_hair_mesh(topology: &TubeTopology, strands: usize) -> Mesh {
    let per = topology.vertex_count();
    let mut indices = Vec::with_capacity(topology.indices.len() * strands);
    let mut uvs = Vec::with_capacity(per * strands);
    let mut uvs_b = Vec::with_capacity(per * strands);
    for s in 0..strands {
        let base = (s * per) as u32;
        indices.extend(topology.indices.iter().map(|i| i + base));
        uvs.extend_from_slice(&topology.uvs);
        // The same `u` half a turn on: where `u` wraps from 1 to 0 this one is continuous, and
        // the shader uses whichever varies less (Tarini 2012), so textures show no seam while
        // the ring keeps one vertex per side (true adjacency for silhouettes). Its whole part
        // is the strand's lock id, its index modulo 3: the hair's prepass writes it for the
        // outline's lines between locks.
        let lock = (s % LOCK_IDS) as f32;
        uvs_b.extend(
            topology
                .uvs
                .iter()
                .map(|[u, v]| [lock + (u + 0.5).fract(), *v]),
        );
    }
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; per * strands])
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_NORMAL,
        vec![[0.0f32, 1.0, 0.0]; per * strands],
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_TANGENT,
        vec![[0.0f32, 1.0, 0.0, 1.0]; per * strands],
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_1, uvs_b)
    .with_inserted_indices(Indices::U32(indices))
}

/// Hands each hair's tube radius to the simulation's volume ([`HairStrandRadius`]), when it
/// changes.
fn hand_radius_to_volume(
    mut commands: Commands,
    hairs: Query<(Entity, &HairMeshSettings), Changed<HairMeshSettings>>,
) {
    for (hair, settings) in &hairs {
        commands
            .entity(hair)
            .try_insert(crate::sim::HairStrandRadius(settings.radius));
    }
}

/// Rebuilds each hair's mesh from its strands' particles: topology when resolutions or the strand
/// count change, positions and normals every frame.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub fn rebuild_strand_meshes(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut hairs: Query<
        (
            Entity,
            &Hair,
            (
                &HairMeshSettings,
                Option<&HairStrandSections>,
                Has<HairMeshBuiltOnGpu>,
                (&shadow::HairShadowCaster, &mut shadow::TubeRingCentres),
                &mut HairTubesFacing,
                Has<HairTubesClosed>,
            ),
            &GlobalTransform,
            &HairStrands,
            Option<&mut ComputedHairMesh>,
            &ComputedHair,
            (
                &HairCulling,
                &mut HairInView,
                &lod::HairLod,
                &mut lod::HairLodLevel,
            ),
        ),
        Without<BoneChainHair>,
    >,
    grooms: Res<Assets<HairGroom>>,
    strands: Query<(&Strand, &StrandParticles)>,
    (mut aabbs, cameras, mut stats): (
        Query<&mut Aabb, With<HairMeshOf>>,
        Query<(&Camera, &Frustum, &GlobalTransform), With<Camera3d>>,
        ResMut<HairCullingStats>,
    ),
    mut scratch: Local<Vec<(u32, Vec<Vec3>)>>,
) {
    let pool = parallel::compute_pool();
    let mut counted = HairCullingStats::default();
    let any_camera = cameras.iter().any(|(c, ..)| c.is_active);
    for (
        hair,
        hair_assets,
        (settings, per_strand, on_gpu, (caster, mut centres), mut facing, kept_closed),
        global,
        strand_list,
        mut computed,
        sim,
        culling,
    ) in &mut hairs
    {
        let (culling, mut in_view, lod, mut level) = culling;
        // A character scaled at run time keeps its tubes in proportion.
        let radius = settings.radius * sim.size();
        // The thickest the tube gets: the H curve's largest value on [0, 1], at least 1.
        let taper = &settings.taper;
        let widest = [0.0, 1.0, (-taper.b / (2.0 * taper.a)).clamp(0.0, 1.0)]
            .into_iter()
            .map(|x| taper.a * x * x + taper.b * x + taper.c)
            .filter(|h| h.is_finite())
            .fold(1.0f32, f32::max);
        // Gather particles in strand order, reusing last frame's buffers.
        let count = strand_list.len();
        let mut gathered = 0;
        for e in strand_list.iter() {
            if let Ok((strand, particles)) = strands.get(e) {
                if gathered == scratch.len() {
                    scratch.push((0, Vec::new()));
                }
                let (index, buffer) = &mut scratch[gathered];
                *index = strand.index;
                buffer.clear();
                buffer.extend_from_slice(&particles.positions);
                gathered += 1;
            }
        }
        if gathered != count {
            continue;
        }
        let scratch = &mut scratch[..gathered];
        scratch.sort_unstable_by_key(|(i, _)| *i);
        // Bounds: the particles, grown by the thickest the tube gets.
        let bounds = particle_bounds(scratch, radius * widest);
        // Hair no camera sees keeps its last mesh (see `culling`); with no camera at all
        // there is nothing to judge by.
        let seen = !culling.enabled
            || !any_camera
            || bounds.is_none_or(|b| {
                culling::seen_by_any(
                    &b,
                    cameras
                        .iter()
                        .filter(|(c, ..)| c.is_active)
                        .map(|(_, f, _)| f),
                )
            });
        in_view.set_if_neq(HairInView(seen));
        // Level of detail from the hair's size on screen, by this frame's bounds. A hair no
        // camera sees keeps its level, so it comes back as it left.
        let on_screen = bounds.and_then(|aabb| {
            cameras
                .iter()
                .filter(|(c, ..)| c.is_active)
                .filter_map(|(c, _, view)| {
                    lod::screen_height_and_width(c, view, &aabb, 2.0 * radius * widest)
                })
                .reduce(|a, b| (a.0.max(b.0), a.1.max(b.1)))
        });
        let next = match on_screen {
            Some((px, strand_px)) if seen => lod::HairLodLevel {
                level: lod.level_for(px, level.level),
                pixels: px,
                strand_pixels: strand_px,
                sides: lod.sides_for(strand_px, level.sides),
                ribbons: lod.ribbons_for(strand_px, level.ribbons),
            },
            _ if !lod.enabled => lod::HairLodLevel::default(),
            _ => *level,
        };
        level.set_if_neq(next);
        let (rings, sides) = settings_topology(settings);
        let (rings, sides) = lod::lod_topology(rings, sides, level.level);
        let sides = match level.sides {
            0 => sides,
            limit => sides.min(usize::from(limit)).max(tube::MIN_SIDES),
        };
        let sides = section_sides(sides, settings, per_strand);
        // Half tubes facing the one camera that sees the hair, where that holds (`HairLod`). A
        // hair no camera sees keeps its tubes, as it keeps its level.
        let round = |s: LockSection| s == LockSection::Round;
        let can_face = lod.half_tubes
            && !kept_closed
            && on_gpu
            && *caster != shadow::HairShadowCaster::Tubes
            && round(settings.section)
            && settings.section_aspect >= 1.0
            && per_strand.is_none_or(|p| p.0.iter().copied().all(round));
        let eye = match (can_face, seen) {
            (false, _) => None,
            (true, true) => bounds.and_then(|b| only_camera_seeing(&b, &cameras)),
            (true, false) => facing.0,
        };
        facing.set_if_neq(HairTubesFacing(eye));
        // Strands a few pixels wide facing the camera: ribbons.
        let ribbon = eye.is_some() && level.ribbons;
        let ring_sides = match eye {
            Some(_) if ribbon => tube::RIBBON_SIDES,
            Some(_) => TubeTopology::facing_sides(sides),
            None => sides,
        };
        let rebuild = computed.as_ref().is_none_or(|c| {
            c.topology.rings() != rings
                || c.topology.sides() != ring_sides
                || c.topology.is_facing() != eye.is_some()
                || c.topology.is_ribbon() != ribbon
                || c.topology.closed_sides() != sides.clamp(tube::MIN_SIDES, tube::MAX_SIDES)
                || c.strands != count
        });
        // Built on creation and on a topology change; read in place on every other frame.
        let mut created = None;
        if rebuild {
            let topology = match eye {
                Some(_) if ribbon => TubeTopology::ribbon(rings, sides),
                Some(_) => TubeTopology::facing(rings, sides),
                None => TubeTopology::new(rings, sides),
            };
            // A new resolution replaces the mesh asset's contents under the same handle: a new
            // asset reaches the renderer a frame late, and the hair would vanish for a frame.
            let kept = computed
                .as_ref()
                .and_then(|c| Some((c.mesh.clone(), meshes.get_mut(&c.mesh)?)))
                .map(|(handle, mut mesh)| {
                    *mesh = new_hair_mesh(&topology, count);
                    handle
                });
            let mesh = kept.unwrap_or_else(|| meshes.add(new_hair_mesh(&topology, count)));
            let entity = match &computed {
                Some(c) => {
                    if c.mesh != mesh {
                        commands.entity(c.entity).insert(Mesh3d(mesh.clone()));
                    }
                    c.entity
                }
                None => commands
                    .spawn((
                        Name::new("hair mesh"),
                        Mesh3d(mesh.clone()),
                        Transform::IDENTITY,
                        // Bounds come from the particles every frame (below), not from a scan
                        // of the mesh, so Bevy culls the hair when no camera sees it.
                        NoAutoAabb,
                        Aabb::from_min_max(Vec3::ZERO, Vec3::ZERO),
                        HairMeshOf(hair),
                    ))
                    .id(),
            };
            let rest_frames = grooms
                .get(&hair_assets.groom)
                .map(rest_frames)
                .unwrap_or_default();
            let c = ComputedHairMesh {
                mesh,
                topology,
                strands: count,
                entity,
                rest_frames,
            };
            match computed.as_deref_mut() {
                Some(existing) => *existing = c,
                None => {
                    // The component lands at the end of the frame; this frame uses the copy.
                    commands.entity(hair).insert(c.clone());
                    created = Some(c);
                }
            }
        }
        let Some(computed) = created.as_ref().or(computed.as_deref()) else {
            continue;
        };
        if let Some(bounds) = bounds {
            match aabbs.get_mut(computed.entity) {
                Ok(mut aabb) => *aabb = bounds,
                Err(_) => {
                    commands.entity(computed.entity).try_insert(bounds);
                }
            }
        }
        counted.hairs += 1;
        if level.level > 0 {
            counted.reduced[usize::from(level.level.min(3)) - 1] += 1;
        }
        if !seen {
            counted.culled += 1;
            continue;
        }
        // The GPU builds its vertices from this frame's particles (`render::GpuTubesPlugin`),
        // but a mesh made this frame (a new resolution) reaches the GPU only after its passes
        // ran: the CPU builds that frame, so the hair is never a frame without vertices. The
        // component is written only here, so the GPU's gather reads a change of it as this.
        if on_gpu && !rebuild {
            continue;
        }
        let Some(mut mesh) = meshes.get_mut(&computed.mesh) else {
            continue;
        };
        // Rings start from the strand's rest frame turned with the bone, so tubes neither twist
        // as the head turns nor flip as strands swing.
        let rotation = global.rotation();
        let params_for = |strand: u32| TubeParams {
            radius,
            taper: [settings.taper.a, settings.taper.b, settings.taper.c],
            reference: computed.frame_reference(strand, rotation),
            aspect: settings.section_aspect,
            section: per_strand.map_or(settings.section, |p| {
                p.get(strand as usize, settings.section)
            }),
            eye,
        };
        let mass = mass_field(settings, sim);
        let per = computed.vertices_per_strand();
        if mesh.count_vertices() != per * scratch.len() {
            continue;
        }
        let mut positions = take_f32x3(&mut mesh, Mesh::ATTRIBUTE_POSITION);
        let mut normals = take_f32x3(&mut mesh, Mesh::ATTRIBUTE_NORMAL);
        normals.resize(positions.len(), [0.0, 1.0, 0.0]);
        let mut tangents = match mesh.remove_attribute(Mesh::ATTRIBUTE_TANGENT) {
            Some(VertexAttributeValues::Float32x4(v)) => v,
            _ => Vec::new(),
        };
        tangents.resize(positions.len(), [0.0, 1.0, 0.0, 1.0]);
        let chunk = scratch.len().div_ceil(parallel::workers(pool)).max(1);
        let topology = &computed.topology;
        // The ring centres, kept for the shadow ribbons when the CPU builds them.
        let rings = topology.rings();
        let centres = &mut centres.0;
        if *caster == shadow::HairShadowCaster::Ribbons && !on_gpu {
            centres.resize(rings * scratch.len(), Vec3::ZERO);
        } else {
            centres.clear();
        }
        let centre_parts = centres
            .chunks_mut(rings * chunk)
            .map(Some)
            .chain(std::iter::repeat_with(|| None));
        let parts = positions
            .chunks_mut(per * chunk)
            .zip(normals.chunks_mut(per * chunk))
            .zip(tangents.chunks_mut(per * chunk))
            .zip(centre_parts)
            .zip(scratch.chunks(chunk));
        #[expect(
            clippy::type_complexity,
            reason = "one part of the mesh per worker: its buffers and its strands"
        )]
        let build = |((((pos, nrm), tan), mut ctr), group): (
            (
                ((&mut [[f32; 3]], &mut [[f32; 3]]), &mut [[f32; 4]]),
                Option<&mut [Vec3]>,
            ),
            &[(u32, Vec<Vec3>)],
        )| {
            // Each worker thread keeps its spline buffers from frame to frame.
            TUBE_SCRATCH.with_borrow_mut(|tmp| {
                for (s, (((p, n), t), (index, particles))) in pos
                    .chunks_mut(per)
                    .zip(nrm.chunks_mut(per))
                    .zip(tan.chunks_mut(per))
                    .zip(group)
                    .enumerate()
                {
                    let params = params_for(*index);
                    tube::build_tube(topology, particles, &params, tmp, p, n, Some(t));
                    if let Some(c) = ctr
                        .as_deref_mut()
                        .and_then(|c| c.get_mut(s * rings..(s + 1) * rings))
                    {
                        for (c, r) in c.iter_mut().zip(tmp.ring_centres()) {
                            *c = *r;
                        }
                    }
                    along_strand(n, t);
                    if let Some(mass) = &mass {
                        mass.apply(p, n);
                        mass.lean_tangents(p, t);
                    }
                }
            });
        };
        parallel::run_parts(pool, parts, &build);
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
        mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
        mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, tangents);
    }
    stats.set_if_neq(counted);
}

/// A hair's strands (`list`) in groom order, as `(index, entity)` in `out`; `false` when not
/// all `count` of them are there yet. The GPU path's gather reads the strands in this order.
#[cfg(feature = "render")]
pub(crate) fn strands_in_order(
    list: &HairStrands,
    strands: &Query<(&Strand, &StrandParticles)>,
    count: usize,
    out: &mut Vec<(u32, Entity)>,
) -> bool {
    out.clear();
    out.extend(
        list.iter()
            .filter_map(|e| strands.get(e).ok().map(|(s, _)| (s.index, e))),
    );
    out.sort_unstable_by_key(|(i, _)| *i);
    out.len() == count
}

/// Where the one active camera whose frustum meets `bounds` is; `None` when none or several do.
fn only_camera_seeing(
    bounds: &Aabb,
    cameras: &Query<(&Camera, &Frustum, &GlobalTransform), With<Camera3d>>,
) -> Option<Vec3> {
    let mut seeing = cameras
        .iter()
        .filter(|(c, f, _)| c.is_active && culling::seen_by_any(bounds, std::iter::once(*f)));
    let (_, _, first) = seeing.next()?;
    seeing.next().is_none().then(|| first.translation())
}

/// Each strand's rest root direction and ring normal, in bone space. The normal lies across the
/// hair's mass (perpendicular to the strand and to the way out of the groom's centre), so a flat
/// or triangular lock lies on the mass with its thin side outward; where that is undefined it is
/// taken from a fixed up vector.
fn rest_frames(groom: &HairGroom) -> Vec<(Vec3, Vec3)> {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for p in groom.strands().flatten().filter(|p| p.is_finite()) {
        (lo, hi) = (lo.min(*p), hi.max(*p));
    }
    let centre = (lo + hi) * 0.5;
    groom
        .strands()
        .map(|s| {
            let f = FrameReference::from_direction(s[1] - s[0]);
            let across = (s[0] - centre).cross(f.direction);
            let normal = across
                .try_normalize()
                .filter(|_| across.length() > 1e-3 * (hi - lo).max_element())
                .unwrap_or(f.normal);
            (f.direction, normal)
        })
        .collect()
}

thread_local! {
    /// The tube builder's buffers, one per thread that builds tubes.
    static TUBE_SCRATCH: std::cell::RefCell<TubeScratch> =
        std::cell::RefCell::new(TubeScratch::default());
}

/// The box around every finite particle, grown by `pad`; `None` if there is none.
/// How far a modelled hair mesh may reach past its bone chains (ribbons around the bones), in
/// metres at the character's size: the culling bounds of a chain hair are its particles grown by
/// this.
pub const CHAIN_MESH_REACH: f32 = 0.1;

/// Culling for hairs built from bone chains ([`BoneChainHair`]): not meshed here, so their view
/// test is their particles' bounds, grown by [`CHAIN_MESH_REACH`], against the cameras. A chain
/// hair no camera sees simulates at [`HairCulling::culled_substep_rate`].
fn chain_hairs_in_view(
    mut hairs: Query<
        (&HairStrands, &ComputedHair, &HairCulling, &mut HairInView),
        With<BoneChainHair>,
    >,
    strands: Query<&StrandParticles>,
    cameras: Query<(&Camera, &Frustum), With<Camera3d>>,
) {
    let any_camera = cameras.iter().any(|(c, _)| c.is_active);
    for (list, sim, culling, mut in_view) in &mut hairs {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in list
            .iter()
            .filter_map(|s| strands.get(s).ok())
            .flat_map(|p| &p.positions)
            .filter(|p| p.is_finite())
        {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let pad = Vec3::splat(CHAIN_MESH_REACH * sim.size());
        let seen = !culling.enabled
            || !any_camera
            || lo.x > hi.x
            || culling::seen_by_any(
                &Aabb::from_min_max(lo - pad, hi + pad),
                cameras.iter().filter(|(c, _)| c.is_active).map(|(_, f)| f),
            );
        in_view.set_if_neq(HairInView(seen));
    }
}

fn particle_bounds(strands: &[(u32, Vec<Vec3>)], pad: f32) -> Option<Aabb> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in strands
        .iter()
        .flat_map(|(_, s)| s)
        .filter(|p| p.is_finite())
    {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let pad = Vec3::splat(if pad.is_finite() { pad.max(0.0) } else { 0.0 });
    (lo.x <= hi.x).then(|| Aabb::from_min_max(lo - pad, hi + pad))
}

/// Turns [`tube::build_tube`]'s tangents (around the ring, Bevy's convention) into the strand's
/// own direction, root to tip (`cross(normal, tangent) * w`), with `w = 1`: the hair mesh's
/// tangent attribute, which the toon material's angel ring reads. Done before the hair-mass
/// normals replace the tube's own.
fn along_strand(normals: &[[f32; 3]], tangents: &mut [[f32; 4]]) {
    for (n, t) in normals.iter().zip(tangents) {
        let around = Vec3::new(t[0], t[1], t[2]);
        let along = Vec3::from_array(*n).cross(around) * t[3];
        *t = along.extend(1.0).to_array();
    }
}

/// Takes a `Float32x3` attribute out of a mesh (empty if missing), to be reinserted.
fn take_f32x3(mesh: &mut Mesh, id: bevy::mesh::MeshVertexAttribute) -> Vec<[f32; 3]> {
    match mesh.remove_attribute(id) {
        Some(VertexAttributeValues::Float32x3(v)) => v,
        _ => Vec::new(),
    }
}

/// The buffers of a mesh rebuilt from scratch every frame (silhouette strokes, highlight
/// strips), taken out of the mesh and cleared so refilling them reuses last frame's memory.
#[derive(Default)]
pub(crate) struct StripBuffers {
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    /// Left empty for meshes without vertex colours.
    pub colors: Vec<[f32; 4]>,
    pub indices: Vec<u32>,
    normals: Vec<[f32; 3]>,
    /// The mesh has vertex colours (kept when it is empty).
    colored: bool,
}

impl StripBuffers {
    /// An empty strip mesh (positions, +Z normals, UVs, indices; vertex colours when
    /// `with_colors`), for [`StripBuffers::take`] and [`StripBuffers::put`] to fill. Like every
    /// strip mesh with nothing in it, it holds one degenerate triangle (see
    /// [`StripBuffers::put`]).
    pub(crate) fn empty_mesh(with_colors: bool) -> Mesh {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
        );
        Self {
            colored: with_colors,
            ..default()
        }
        .put(&mut mesh);
        mesh
    }

    /// A mesh of `quads` separate quads that a compute pass fills (the GPU's strokes and
    /// highlights): positions, +Z normals, UVs and, when `with_colors`, colours, all zero until
    /// the GPU writes them, and each quad's two triangles (vertices `4q..4q + 4`: both ends'
    /// left and right).
    pub fn gpu_quads(quads: usize, with_colors: bool) -> Mesh {
        let vertices = quads * 4;
        let indices: Vec<u32> = (0..quads as u32)
            .flat_map(|q| [0, 1, 2, 1, 3, 2].map(|i| q * 4 + i))
            .collect();
        let mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD | RenderAssetUsages::RENDER_WORLD,
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; vertices])
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, vec![[0.0f32, 0.0, 1.0]; vertices])
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, vec![[0.0f32; 2]; vertices])
        .with_inserted_indices(Indices::U32(indices));
        if with_colors {
            mesh.with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, vec![[0.0f32; 4]; vertices])
        } else {
            mesh
        }
    }

    /// Takes the buffers out of `mesh`, emptied (except the normals, which are constant).
    pub(crate) fn take(mesh: &mut Mesh) -> Self {
        let mut b = Self {
            positions: take_f32x3(mesh, Mesh::ATTRIBUTE_POSITION),
            normals: take_f32x3(mesh, Mesh::ATTRIBUTE_NORMAL),
            ..default()
        };
        if let Some(VertexAttributeValues::Float32x2(v)) =
            mesh.remove_attribute(Mesh::ATTRIBUTE_UV_0)
        {
            b.uvs = v;
        }
        if let Some(VertexAttributeValues::Float32x4(v)) =
            mesh.remove_attribute(Mesh::ATTRIBUTE_COLOR)
        {
            b.colors = v;
            b.colored = true;
        }
        if let Some(Indices::U32(v)) = mesh.remove_indices() {
            b.indices = v;
        }
        b.positions.clear();
        // Normals are all +Z: kept as they are, so that `put` only writes new ones when the
        // mesh grows.
        b.uvs.clear();
        b.colors.clear();
        b.indices.clear();
        b
    }

    /// Puts the buffers back; normals face +Z (the strip materials are unlit). Nothing to draw
    /// is one degenerate triangle (three vertices at the origin, which cover no pixel): Bevy
    /// warns each time a mesh without vertices is uploaded, which a hair whose highlights or
    /// strokes come and go would do every frame.
    pub(crate) fn put(mut self, mesh: &mut Mesh) {
        if self.positions.is_empty() {
            self.positions.resize(3, [0.0; 3]);
            self.uvs.clear();
            self.uvs.resize(3, [0.0; 2]);
            self.colors.clear();
            if self.colored {
                self.colors.resize(3, [0.0; 4]);
            }
            self.indices.clear();
            self.indices.extend([0, 1, 2]);
        }
        self.normals.resize(self.positions.len(), [0.0, 0.0, 1.0]);
        mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, self.positions);
        mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, self.normals);
        mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, self.uvs);
        if !self.colors.is_empty() {
            mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, self.colors);
        }
        mesh.insert_indices(Indices::U32(self.indices));
    }
}
