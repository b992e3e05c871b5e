//! The main world's side of the GPU path: after the CPU's mesh and silhouette stages, each
//! GPU-built hair in view gets a [`GpuTubeInput`] on its mesh entity (this frame's particles,
//! strands, cross-sections, stroke, highlight and shadow jobs), which the render world batches.

use bevy::ecs::query::QueryItem;
use bevy::ecs::system::lifetimeless::Read;
use bevy::prelude::*;
use bevy::render::RenderApp;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::sync_component::SyncComponent;

use super::highlights::{GpuHighlightInput, highlight_input};
use super::order::front_to_back;
use super::shadows::{GpuShadowInput, shadow_input};
use super::strokes::{GpuStrokeInput, stroke_input};
use super::toolbox::vertex_offsets;
use super::tubes::{GpuStrand, GpuTubeHair};
use crate::mesh::highlights::GpuHighlightJob;
use crate::mesh::shadow::GpuShadowJob;
use crate::mesh::{
    ComputedHairMesh, HairInView, HairMeshBuiltOnGpu, HairMeshSettings, HairStrandSections,
    HairTubesFacing, LockSection, SectionSide, fill_section, mass_field, strands_in_order,
};
use crate::silhouette::GpuStrokeJobs;
use crate::sim::{ComputedHair, Hair, HairStrands, Strand, StrandParticles};

/// What the GPU needs this frame to build a hair's tubes, strokes and highlights, on the hair's
/// mesh entity. Written in the main world after the CPU's mesh stage; absent while the hair is
/// on the CPU or out of view (its mesh then keeps the last vertices built).
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub(crate) struct GpuTubeInput {
    /// The hair mesh.
    pub mesh: AssetId<Mesh>,
    /// The hair's record (where it lies in its batch is filled in the render world).
    pub hair: GpuTubeHair,
    /// The strands, in the mesh's order: `first` into `particles`, `section` into `sections`.
    pub strands: Vec<GpuStrand>,
    /// Every strand's particles, world space.
    pub particles: Vec<Vec4>,
    /// The cross-sections in use, `sides` sides each, two vec4 a side (position and normal,
    /// then the around direction, in the ring's frame).
    pub sections: Vec<Vec4>,
    /// The strokes to build from the tubes, one a camera.
    pub strokes: Vec<GpuStrokeInput>,
    /// The specular quads to build from the tubes.
    pub highlights: Option<GpuHighlightInput>,
    /// The shadow ribbons to build from the tubes.
    pub shadows: Option<GpuShadowInput>,
    /// The strands (by their place in the mesh) in the order to draw them, nearest the nearest
    /// camera first; empty without a camera (the mesh's order stays).
    pub draw_order: Vec<u32>,
    /// Indices a strand in the mesh (every strand has the same).
    pub indices_per_strand: u32,
}

impl SyncComponent<RenderApp> for GpuTubeInput {
    type Target = GpuTubeInput;
}

impl ExtractComponent<RenderApp> for GpuTubeInput {
    type QueryData = Read<GpuTubeInput>;
    type QueryFilter = ();
    type Out = GpuTubeInput;

    fn extract_component(input: QueryItem<'_, '_, Self::QueryData>) -> Option<Self::Out> {
        Some(input.clone())
    }
}

/// Writes each GPU-built hair's [`GpuTubeInput`] from this frame's particles.
#[expect(
    clippy::type_complexity,
    reason = "a Bevy system: its parameters are its queries"
)]
pub(crate) fn gather_gpu_tube_inputs(
    mut commands: Commands,
    hairs: Query<
        (
            &HairMeshSettings,
            Option<&HairStrandSections>,
            &HairStrands,
            Ref<ComputedHairMesh>,
            &ComputedHair,
            (&HairInView, &HairTubesFacing),
            &GlobalTransform,
            Has<HairMeshBuiltOnGpu>,
            (
                Option<&GpuStrokeJobs>,
                Option<&GpuHighlightJob>,
                Option<&GpuShadowJob>,
            ),
        ),
        With<Hair>,
    >,
    strands: Query<(&Strand, &StrandParticles)>,
    cameras: Query<(&Camera, &GlobalTransform), With<Camera3d>>,
    meshes: Res<Assets<Mesh>>,
    mut inputs: Query<&mut GpuTubeInput>,
    mut scratch: Local<(
        Vec<(u32, Entity)>,
        (Vec<LockSection>, Vec<SectionSide>),
        Vec<(u32, u32)>,
    )>,
) {
    let (order, (kinds, table), sort_keys) = &mut *scratch;
    for (
        settings,
        per_strand,
        list,
        computed,
        sim,
        (in_view, facing),
        global,
        on_gpu,
        (jobs, quads, ribbons),
    ) in &hairs
    {
        let offsets = meshes.get(&computed.mesh).and_then(|mesh| {
            vertex_offsets(
                mesh,
                [
                    Mesh::ATTRIBUTE_POSITION.id,
                    Mesh::ATTRIBUTE_NORMAL.id,
                    Mesh::ATTRIBUTE_TANGENT.id,
                ],
            )
        });
        // A mesh made or resized this frame is built on the CPU this frame (`ComputedHairMesh`
        // is written only then).
        let (Some([position, normal, tangent, stride]), true, true, false) =
            (offsets, on_gpu, in_view.0, computed.is_changed())
        else {
            if inputs.contains(computed.entity) {
                commands.entity(computed.entity).remove::<GpuTubeInput>();
            }
            continue;
        };
        if !strands_in_order(list, &strands, computed.strands, order) {
            continue;
        }
        let (rings, sides) = (computed.topology.rings(), computed.topology.sides());
        let mut input = GpuTubeInput {
            mesh: computed.mesh.id(),
            ..default()
        };
        if let Ok(mut last) = inputs.get_mut(computed.entity) {
            // Reuse last frame's allocations.
            input.strands = std::mem::take(&mut last.strands);
            input.particles = std::mem::take(&mut last.particles);
            input.sections = std::mem::take(&mut last.sections);
            input.strokes = std::mem::take(&mut last.strokes);
            input.draw_order = std::mem::take(&mut last.draw_order);
        }
        // Contours are found on the closed ring, a half tube's too.
        let closed_sides = computed.topology.closed_sides();
        input.strokes.clear();
        input.strokes.extend(
            jobs.iter().flat_map(|j| &j.0).filter_map(|job| {
                stroke_input(job, &meshes, rings, closed_sides, computed.strands)
            }),
        );
        input.highlights = quads
            .and_then(|q| q.0.as_ref())
            .and_then(|job| highlight_input(job, &meshes, rings, computed.strands));
        input.shadows = ribbons
            .and_then(|r| r.0.as_ref())
            .and_then(|job| shadow_input(job, &meshes, rings, computed.strands));
        input.strands.clear();
        input.particles.clear();
        input.sections.clear();
        // The cross-section tables in use, one per kind, `sides` sides each.
        let section_of = |index: u32| {
            per_strand.map_or(settings.section, |p| {
                p.get(index as usize, settings.section)
            })
        };
        kinds.clear();
        let rotation = global.rotation();
        for &(index, entity) in &*order {
            let Ok((_, particles)) = strands.get(entity) else {
                continue;
            };
            let kind = section_of(index);
            let slot = match kinds.iter().position(|k| *k == kind) {
                Some(slot) => slot,
                None => {
                    kinds.push(kind);
                    fill_section(
                        kind,
                        settings.section_aspect,
                        computed.topology.cos_sin(),
                        table,
                    );
                    input.sections.extend(table.iter().flat_map(|[p, n, a]| {
                        [Vec4::new(p.0, p.1, n.0, n.1), Vec4::new(a.0, a.1, 0.0, 0.0)]
                    }));
                    kinds.len() - 1
                }
            };
            let reference = computed.frame_reference(index, rotation);
            input.strands.push(GpuStrand {
                reference_direction: reference.direction.extend(0.0),
                reference_normal: reference.normal.extend(0.0),
                first: input.particles.len() as u32,
                count: particles.positions.len() as u32,
                section: (slot * closed_sides * 2) as u32,
                hair: 0,
            });
            input
                .particles
                .extend(particles.positions.iter().map(|p| p.extend(1.0)));
        }
        // Drawn nearest first for the camera nearest the hair (the one it is largest in).
        let here = global.translation();
        let eye = cameras
            .iter()
            .filter(|(camera, _)| camera.is_active)
            .map(|(_, at)| at.translation())
            .min_by(|a, b| {
                a.distance_squared(here)
                    .total_cmp(&b.distance_squared(here))
            });
        input.draw_order.clear();
        if let Some(eye) = eye {
            let particles = order
                .iter()
                .filter_map(|&(_, e)| strands.get(e).ok().map(|(_, p)| p.positions.as_slice()));
            front_to_back(eye, particles, sort_keys, &mut input.draw_order);
        }
        input.indices_per_strand = computed.topology.indices.len() as u32;
        let (centre, metric, up, weight) = mass_field(settings, sim)
            .map_or((Vec3::ZERO, Mat3::IDENTITY, Vec3::Y, 0.0), |m| m.parts());
        let taper = settings.taper;
        input.hair = GpuTubeHair {
            stride,
            position_offset: position,
            normal_offset: normal,
            tangent_offset: tangent,
            rings: rings as u32,
            sides: sides as u32,
            strands: input.strands.len() as u32,
            shape: Vec4::new(settings.radius * sim.size(), taper.a, taper.b, taper.c),
            mass_centre: centre.extend(weight),
            metric_x: metric.x_axis.extend(0.0),
            metric_y: metric.y_axis.extend(0.0),
            metric_z: metric.z_axis.extend(0.0),
            up: up.extend(0.0),
            closed_sides: closed_sides as u32,
            eye: match facing.0 {
                Some(eye) if computed.topology.is_ribbon() => eye.extend(2.0),
                Some(eye) if computed.topology.is_facing() => eye.extend(1.0),
                _ => Vec4::ZERO,
            },
            ..default()
        };
        match inputs.get_mut(computed.entity) {
            Ok(mut last) => *last = input,
            Err(_) => {
                commands.entity(computed.entity).try_insert(input);
            }
        }
    }
}

/// What the render world does on the CPU each frame for the GPU-built hairs, without a GPU: each
/// hair's [`GpuTubeInput`] cloned (as extraction does) and its hair record, strands, particles,
/// cross-sections and job records encoded into `staging` as the batches upload them. Returns
/// the hairs. For the benches of the GPU path's CPU cost.
#[doc(hidden)]
pub fn encode_gpu_inputs(world: &mut World, staging: &mut Vec<u8>) -> usize {
    use bevy::render::render_resource::encase::StorageBuffer;
    let mut hairs = 0;
    let mut inputs = world.query::<&GpuTubeInput>();
    for input in inputs.iter(world) {
        let copy = input.clone();
        let mut writer = StorageBuffer::new(Vec::new());
        let strokes: Vec<_> = copy.strokes.iter().map(|s| s.record).collect();
        let highlights: Vec<_> = copy.highlights.iter().map(|h| h.record).collect();
        let shadows: Vec<_> = copy.shadows.iter().map(|h| h.record).collect();
        let written = writer
            .write(&[copy.hair])
            .and_then(|()| writer.write(&copy.strands))
            .and_then(|()| writer.write(&copy.particles))
            .and_then(|()| writer.write(&copy.sections))
            .and_then(|()| writer.write(&strokes))
            .and_then(|()| writer.write(&highlights))
            .and_then(|()| writer.write(&shadows));
        if written.is_ok() {
            staging.extend_from_slice(&writer.into_inner());
            hairs += 1;
        }
    }
    hairs
}
