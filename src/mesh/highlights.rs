//! Specular sampling quads (Shin et al. 2006; thesis 4.3.6), an optional highlight mode.
//!
//! Each strand's spline is sampled; at every sample the strongest Blinn response the tube can
//! give is `(N*.H)^s`, where `N*` is the tube normal closest to the half vector `H`. Samples above
//! a threshold are grouped into runs of neighbours, and each run becomes a camera-facing textured
//! strip. The thesis placed these strips on the strand's axis, where the strand itself hid them;
//! here they sit on the tube's surface at `N*` and are pulled a little toward the camera, so they
//! show on the hair where its highlight is.
//!
//! For a hair whose tubes the GPU builds ([`HairMeshBuiltOnGpu`]),
//! the strips are built on the GPU too: [`build_specular_quads`] gives the hair a mesh of fixed
//! topology ([`gpu_highlight_mesh`]) and a [`GpuHighlightJob`], and the render plugin's pass
//! samples each strand at its rings (the tube's own spline samples, so [`SpecularQuads::samples`]
//! is not used there) with the same test and placement.

use bevy::camera::visibility::NoFrustumCulling;
use bevy::prelude::*;

use super::tube::sample_spline;
use super::{ComputedHairMesh, HairMeshBuiltOnGpu, HairMeshSettings, StripBuffers};
use crate::sim::{ComputedHair, Hair, HairStrands, Strand, StrandParticles};

/// Specular sampling quads of a hair. Off by default; inserted with defaults when missing.
#[derive(Component, Reflect, Clone, Debug, PartialEq)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct SpecularQuads {
    /// Draw highlight strips. Default: `false`.
    pub enabled: bool,
    /// Samples whose best specular `(N*.H)^shininess` exceeds this join a highlight. Lower gives
    /// longer highlights. Default: `0.6`.
    pub threshold: f32,
    /// Shininess exponent of the sampled specular. Default: `30.0`.
    pub shininess: f32,
    /// Strip width as a fraction of the tube radius there. Default: `0.5`.
    pub width: f32,
    /// Samples along each strand. Default: `24`.
    pub samples: u32,
}

impl Default for SpecularQuads {
    fn default() -> Self {
        Self {
            enabled: false,
            threshold: 0.6,
            shininess: 30.0,
            width: 0.5,
            samples: 24,
        }
    }
}

/// The highlight strip entity of a hair (world space).
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Eq)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = HairHighlights)]
pub struct HairHighlightsOf(pub Entity);

/// A hair's highlight entities; despawning the hair despawns them.
#[derive(Component, Reflect, Debug, Default)]
#[reflect(Component, Debug, Default)]
#[relationship_target(relationship = HairHighlightsOf, linked_spawn)]
pub struct HairHighlights(Vec<Entity>);

/// The highlight strips of a hair to build on the GPU this frame (see the module docs); on the
/// [`Hair`] entity (inserted with it), `None` inside while the CPU builds them or none are
/// shown.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct GpuHighlightJob(pub Option<GpuHighlights>);

/// What the GPU needs to build a hair's highlight strips.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuHighlights {
    /// The mesh the GPU fills ([`gpu_highlight_mesh`]).
    pub mesh: AssetId<Mesh>,
    /// The eye.
    pub eye: Vec3,
    /// The direction toward the light.
    pub to_light: Vec3,
    /// The settings.
    pub settings: SpecularQuads,
}

/// Vertices of a GPU-built highlight mesh: a quad per ring segment of every strand.
pub fn gpu_highlight_vertex_count(strands: usize, rings: usize) -> usize {
    strands * rings.saturating_sub(1) * 4
}

/// A highlight mesh the GPU fills ([`gpu_highlight_vertex_count`]): positions, +Z normals and
/// UVs (zero until the GPU writes them) and the fixed triangles of every quad.
pub fn gpu_highlight_mesh(strands: usize, rings: usize) -> Mesh {
    StripBuffers::gpu_quads(gpu_highlight_vertex_count(strands, rings) / 4, false)
}

/// Runs of consecutive indices whose value exceeds `threshold` (at least two samples each).
pub fn highlight_runs(values: &[f32], threshold: f32, out: &mut Vec<(usize, usize)>) {
    out.clear();
    let mut start = None;
    for (i, v) in values.iter().enumerate() {
        match (start, *v > threshold) {
            (None, true) => start = Some(i),
            (Some(s), false) => {
                if i - s >= 2 {
                    out.push((s, i));
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start
        && values.len() - s >= 2
    {
        out.push((s, values.len()));
    }
}

/// The best Blinn response a tube with axis `t` can give for half vector `h`, and the surface
/// normal that gives it.
pub fn tube_specular(t: Vec3, h: Vec3, shininess: f32) -> (f32, Vec3) {
    let n = (h - t * t.dot(h)).normalize_or_zero();
    let cos = n.dot(h).max(0.0);
    (cos.powf(shininess.max(1.0)), n)
}

/// Highlight strips for one camera and one light: see the module docs.
#[derive(Default)]
pub struct HighlightBuilder {
    samples: Vec<Vec3>,
    values: Vec<f32>,
    normals: Vec<Vec3>,
    runs: Vec<(usize, usize)>,
    /// Output positions.
    pub positions: Vec<[f32; 3]>,
    /// Output texture coordinates (u along the strip, v across).
    pub uvs: Vec<[f32; 2]>,
    /// Output triangle list.
    pub indices: Vec<u32>,
}

impl HighlightBuilder {
    /// Clears the output.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.uvs.clear();
        self.indices.clear();
    }

    /// Appends the strips of one strand. `radius_at(x)` is the tube radius at `x` in `[0, 1]`.
    pub fn add_strand(
        &mut self,
        particles: &[Vec3],
        settings: &SpecularQuads,
        eye: Vec3,
        to_light: Vec3,
        radius_at: impl Fn(f32) -> f32,
    ) {
        let n = (settings.samples as usize).clamp(2, 256);
        sample_spline(particles, n, &mut self.samples);
        self.values.clear();
        self.normals.clear();
        for i in 0..self.samples.len() {
            let p = self.samples[i];
            let a = self.samples[i.saturating_sub(1)];
            let b = self.samples[(i + 1).min(self.samples.len() - 1)];
            let t = (b - a).normalize_or(Vec3::Y);
            let v = (eye - p).normalize_or(Vec3::Z);
            let h = (to_light + v).normalize_or(v);
            let (spec, normal) = tube_specular(t, h, settings.shininess);
            self.values.push(spec);
            self.normals.push(normal);
        }
        highlight_runs(&self.values, settings.threshold, &mut self.runs);
        let last = (self.samples.len() - 1).max(1) as f32;
        for &(start, end) in &self.runs {
            for i in start..end {
                let p = self.samples[i];
                let x = i as f32 / last;
                let r = radius_at(x).max(0.0);
                let a = self.samples[i.saturating_sub(1)];
                let b = self.samples[(i + 1).min(self.samples.len() - 1)];
                let t = (b - a).normalize_or(Vec3::Y);
                let v = (eye - p).normalize_or(Vec3::Z);
                // On the surface where the highlight is, then toward the eye so it is not
                // hidden by the tube it belongs to.
                let centre = p + self.normals[i] * r + v * (0.5 * r);
                let side = t.cross(v).normalize_or(Vec3::X) * (0.5 * settings.width * r);
                let u = (i - start) as f32 / (end - start - 1).max(1) as f32;
                let base = self.positions.len() as u32;
                self.positions.push((centre - side).to_array());
                self.positions.push((centre + side).to_array());
                self.uvs.push([u, 0.0]);
                self.uvs.push([u, 1.0]);
                if i > start {
                    self.indices.extend_from_slice(&[
                        base - 2,
                        base - 1,
                        base,
                        base - 1,
                        base + 1,
                        base,
                    ]);
                }
            }
        }
    }
}

/// Rebuilds every hair's highlight strips for the first active 3D camera and the first
/// directional light.
// A Bevy system: its parameters are its queries.
#[expect(
    clippy::type_complexity,
    clippy::too_many_arguments,
    reason = "a Bevy system: its parameters are its queries"
)]
pub fn build_specular_quads(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut hairs: Query<
        (
            Entity,
            &SpecularQuads,
            &HairMeshSettings,
            &HairStrands,
            Option<&HairHighlights>,
            &super::HairInView,
            &super::HairLodLevel,
            &ComputedHairMesh,
            &mut GpuHighlightJob,
            &ComputedHair,
        ),
        (With<Hair>, With<ComputedHairMesh>),
    >,
    on_gpu: Query<(), With<HairMeshBuiltOnGpu>>,
    strands: Query<(&Strand, &StrandParticles)>,
    highlight_meshes: Query<&Mesh3d, With<HairHighlightsOf>>,
    mut visibility: Query<&mut Visibility, With<HairHighlightsOf>>,
    cameras: Query<(&Camera, &GlobalTransform), With<Camera3d>>,
    lights: Query<&GlobalTransform, With<DirectionalLight>>,
    mut builder: Local<HighlightBuilder>,
) {
    let eye = cameras
        .iter()
        .find(|(c, _)| c.is_active)
        .map(|(_, t)| t.translation());
    let to_light = lights
        .iter()
        .next()
        .map(|t| t.back().as_vec3())
        .unwrap_or(Vec3::Y);
    for (
        hair,
        settings,
        mesh_settings,
        strand_list,
        highlights,
        in_view,
        lod,
        computed,
        mut job,
        sim,
    ) in &mut hairs
    {
        let gpu = on_gpu.contains(hair);
        if job.0.is_some() {
            job.0 = None;
        }
        let existing = highlights.and_then(|h| h.iter().next());
        // Hair no camera sees gets no quads (see `culling`), nor hair at level of detail 2 or
        // coarser (see `lod`).
        let shown = settings.enabled && in_view.0 && lod.level < 2;
        // Shown while its mesh holds quads: a mesh with none (the light behind the hair) holds
        // a degenerate triangle, not worth a draw call. Set once the mesh is known this frame.
        let mut show = |drawn: bool| {
            if let Some(e) = existing
                && let Ok(mut v) = visibility.get_mut(e)
            {
                v.set_if_neq(if shown && drawn {
                    Visibility::Inherited
                } else {
                    Visibility::Hidden
                });
            }
        };
        let (Some(eye), true) = (eye, shown) else {
            show(true);
            continue;
        };
        let handle: Handle<Mesh> = match existing.and_then(|e| highlight_meshes.get(e).ok()) {
            Some(m) => m.0.clone(),
            None => {
                if existing.is_none() {
                    let mesh = meshes.add(StripBuffers::empty_mesh(false));
                    commands.spawn((
                        Name::new("hair highlights"),
                        Mesh3d(mesh),
                        Transform::IDENTITY,
                        NoFrustumCulling,
                        // Light strips and ink lines cast no shadow.
                        bevy::light::NotShadowCaster,
                        HairHighlightsOf(hair),
                    ));
                }
                continue;
            }
        };
        if gpu {
            // The GPU's mesh has a quad per ring segment; made once for each topology.
            let rings = computed.topology.rings();
            let count = gpu_highlight_vertex_count(computed.strands, rings);
            if meshes.get(&handle).map(Mesh::count_vertices) != Some(count)
                && let Some(mut mesh) = meshes.get_mut(&handle)
            {
                *mesh = gpu_highlight_mesh(computed.strands, rings);
            }
            job.0 = Some(GpuHighlights {
                mesh: handle.id(),
                eye,
                to_light,
                settings: settings.clone(),
            });
            show(true);
            continue;
        }
        builder.clear();
        // Level 1 of detail samples each strand half as often.
        let settings = &SpecularQuads {
            samples: if lod.level >= 1 {
                (settings.samples / 2).max(4)
            } else {
                settings.samples
            },
            ..settings.clone()
        };
        // The tube's radius, scaled with the character as the tube is.
        let radius = mesh_settings.radius * sim.size();
        for e in strand_list.iter() {
            if let Ok((_, particles)) = strands.get(e) {
                let radius_at = |x: f32| radius * mesh_settings.taper.eval(x).max(0.0);
                builder.add_strand(&particles.positions, settings, eye, to_light, radius_at);
            }
        }
        if let Some(mut mesh) = meshes.get_mut(&handle) {
            let mut buffers = StripBuffers::take(&mut mesh);
            buffers.positions.extend_from_slice(&builder.positions);
            buffers.uvs.extend_from_slice(&builder.uvs);
            buffers.indices.extend_from_slice(&builder.indices);
            buffers.put(&mut mesh);
        }
        show(!builder.indices.is_empty());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::mesh::{Indices, VertexAttributeValues};

    #[test]
    fn runs_group_neighbours_above_the_threshold() {
        let mut runs = Vec::new();
        highlight_runs(
            &[0.1, 0.9, 0.95, 0.2, 0.9, 0.3, 0.8, 0.9, 0.99],
            0.5,
            &mut runs,
        );
        // A lone sample (index 4) makes no strip.
        assert_eq!(runs, vec![(1, 3), (6, 9)]);
        highlight_runs(&[0.0; 5], 0.5, &mut runs);
        assert!(runs.is_empty());
    }

    #[test]
    fn tube_specular_peaks_when_the_half_vector_is_across_the_axis() {
        let (across, n) = tube_specular(Vec3::X, Vec3::Y, 30.0);
        assert!((across - 1.0).abs() < 1e-6 && n.abs_diff_eq(Vec3::Y, 1e-6));
        let (along, _) = tube_specular(Vec3::X, Vec3::new(1.0, 0.2, 0.0).normalize(), 30.0);
        assert!(along < 0.01, "{along}");
    }

    #[test]
    fn strips_sit_on_the_lit_side_of_the_tube() {
        let mut b = HighlightBuilder::default();
        let particles: Vec<Vec3> = (0..6)
            .map(|i| Vec3::new(i as f32 * 0.2 - 0.5, 0.0, 0.0))
            .collect();
        let settings = SpecularQuads {
            enabled: true,
            ..default()
        };
        // Eye in front, light above: the highlight is on the top-front of the tube.
        b.add_strand(
            &particles,
            &settings,
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::Y,
            |_| 0.1,
        );
        assert!(!b.indices.is_empty(), "no strip built");
        assert!(
            b.positions.iter().all(|p| p[1] > 0.0 && p[2] > 0.0),
            "{:?}",
            b.positions
        );
        // Light behind the strand from the eye: no highlight.
        b.clear();
        b.add_strand(
            &particles,
            &settings,
            Vec3::new(0.0, 0.0, 3.0),
            Vec3::NEG_Z,
            |_| 0.1,
        );
        assert!(b.indices.is_empty());
    }

    /// A strip mesh with nothing to draw still has vertices (Bevy warns at every upload of a
    /// mesh without), one triangle of no area, and keeps its vertex colours (the same pipeline
    /// as when it has strokes); filled again, it holds only what was put in.
    #[test]
    fn an_empty_strip_mesh_is_one_degenerate_triangle() {
        for colored in [false, true] {
            let mut mesh = StripBuffers::empty_mesh(colored);
            for _ in 0..2 {
                let positions = mesh
                    .attribute(Mesh::ATTRIBUTE_POSITION)
                    .and_then(|a| a.as_float3())
                    .unwrap()
                    .to_vec();
                assert_eq!(positions.len(), 3);
                let [a, b, c] = [0, 1, 2].map(|i| Vec3::from_array(positions[i]));
                assert_eq!((b - a).cross(c - a), Vec3::ZERO);
                assert_eq!(mesh.indices().map(Indices::len), Some(3));
                assert_eq!(mesh.attribute(Mesh::ATTRIBUTE_COLOR).is_some(), colored);
                assert_eq!(
                    mesh.attribute(Mesh::ATTRIBUTE_UV_0)
                        .map(VertexAttributeValues::len),
                    Some(3)
                );
                // Emptied again: the same.
                StripBuffers::take(&mut mesh).put(&mut mesh);
            }
            let mut b = StripBuffers::take(&mut mesh);
            b.positions
                .extend([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
            b.uvs.extend([[0.0; 2]; 3]);
            if colored {
                b.colors.extend([[1.0; 4]; 3]);
            }
            b.indices.extend([0, 2, 1]);
            b.put(&mut mesh);
            assert_eq!(mesh.count_vertices(), 3);
            assert_eq!(
                mesh.indices().map(|i| i.iter().collect::<Vec<_>>()),
                Some(vec![0, 2, 1])
            );
            let p = mesh
                .attribute(Mesh::ATTRIBUTE_POSITION)
                .unwrap()
                .as_float3()
                .unwrap();
            assert_eq!(p[0], [1.0, 0.0, 0.0]);
        }
    }
}
