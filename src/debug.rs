//! Debug drawing and stage timings, without egui: what the tuning panel shows, for any game.
//!
//! - [`HairDebugPlugin`]: gizmos over the hair (particles, springs, anchors, head colliders),
//!   switched by the [`HairDebugDraw`] resource.
//! - [`HairStageTimingsPlugin`]: the time each [`HairSystems`] stage took, in
//!   [`HairStageTimings`] and in Bevy's `DiagnosticsStore` (paths in [`paths`]), with the hair's
//!   counters (strands, substeps, resets, teleports).

use crate::schedule::HairSystems;
use crate::sim::{ComputedHair, HairCollider, HairStrands, Strand, StrandParticles};
use bevy::diagnostic::{Diagnostic, Diagnostics, RegisterDiagnostic};
use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

/// Draws [`HairDebugDraw`]'s choices with gizmos. Not in
/// [`CartoonHairPlugins`](crate::CartoonHairPlugins); the tuning panel adds it.
#[derive(Default)]
pub struct HairDebugPlugin;

impl Plugin for HairDebugPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<HairDebugDraw>()
            .register_type::<HairDebugDraw>()
            .init_gizmo_group::<HairDebugGizmos>()
            .add_systems(Startup, configure_debug_gizmos)
            .add_systems(
                PostUpdate,
                draw_hair_debug
                    // Draw the particles this frame's step wrote.
                    .after(HairSystems::Simulate)
                    .run_if(|d: Res<HairDebugDraw>| d.any()),
            );
    }
}

/// What the debug drawing shows (gizmos, drawn over the scene). Edited by the Debug window;
/// drawn whether or not the panel is shown.
#[derive(Resource, Reflect, Clone, Debug, Default, PartialEq)]
#[reflect(Resource, Default, Debug)]
pub struct HairDebugDraw {
    /// A dot on every simulated particle. Default: `false`.
    pub particles: bool,
    /// The strands' springs: each strand's polyline, and the chain through the extra structural
    /// particles (Selle et al.) whose edge, bend and torsion springs hold it. Default: `false`.
    pub springs: bool,
    /// A line from every particle to its anchor (where the keyframed style pulls it).
    /// Default: `false`.
    pub anchors: bool,
    /// The head collider spheres (and their largest margin). Default: `false`.
    pub colliders: bool,
}

impl HairDebugDraw {
    /// Whether anything is drawn.
    pub fn any(&self) -> bool {
        self.particles || self.springs || self.anchors || self.colliders
    }
}

/// The gizmo group of the debug drawing: drawn in front of the hair (negative depth bias), so
/// particles inside the tubes stay visible.
#[derive(Default, Reflect, GizmoConfigGroup)]
pub struct HairDebugGizmos;

fn configure_debug_gizmos(mut store: ResMut<GizmoConfigStore>) {
    let (config, _) = store.config_mut::<HairDebugGizmos>();
    config.depth_bias = -1.0;
    config.line.width = 1.5;
}

/// Wall-clock milliseconds of the hair stages last frame, smoothed over about ten frames.
///
/// Measured by [`HairStageTimingsPlugin`] between the boundaries of the [`HairSystems`] sets:
/// each value is the time from the end of the previous stage to the end of this one, so it
/// includes any unrelated system the scheduler ran in between (usually none: the sets are
/// chained and the hair stages are most of `PostUpdate`'s work after transform propagation).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct HairStageTimings {
    /// [`HairSystems::Attach`], ms.
    pub attach: f32,
    /// [`HairSystems::Simulate`], ms.
    pub simulate: f32,
    /// [`HairSystems::BuildMesh`], ms.
    pub build_mesh: f32,
    /// [`HairSystems::Silhouettes`] (object-space strokes), ms.
    pub silhouettes: f32,
    /// Frames measured.
    pub frames: u64,
    /// Last frame's stage times, unsmoothed, ms.
    last: [f32; 4],
    boundaries: [Option<Instant>; 5],
}

impl HairStageTimings {
    /// The four stages as `(name, milliseconds)`.
    pub fn stages(&self) -> [(&'static str, f32); 4] {
        [
            ("Attach", self.attach),
            ("Simulate", self.simulate),
            ("Build mesh", self.build_mesh),
            ("Silhouettes", self.silhouettes),
        ]
    }

    fn record(&mut self, boundary: usize) {
        let now = Instant::now();
        self.boundaries[boundary] = Some(now);
        if boundary == 0 {
            return;
        }
        let Some(start) = self.boundaries[boundary - 1] else {
            return;
        };
        let ms = now.saturating_duration_since(start).as_secs_f32() * 1000.0;
        self.last[boundary - 1] = ms;
        // The first frame sets the value; later ones blend in (about ten frames of memory).
        let blend = if self.frames == 0 { 1.0 } else { 0.1 };
        let slot = match boundary {
            1 => &mut self.attach,
            2 => &mut self.simulate,
            3 => &mut self.build_mesh,
            _ => &mut self.silhouettes,
        };
        *slot += (ms - *slot) * blend;
        if boundary == 4 {
            self.frames += 1;
        }
    }
}

fn mark_stage_boundary<const B: usize>(mut timings: ResMut<HairStageTimings>) {
    timings.record(B);
}

/// Diagnostics of the hair: the stage times of [`HairStageTimings`] (ms, unsmoothed by the
/// store's own history) and counters summed over every hair.
pub mod paths {
    use bevy::diagnostic::DiagnosticPath;

    /// [`HairSystems::Attach`](crate::schedule::HairSystems::Attach), ms.
    pub const ATTACH: DiagnosticPath = DiagnosticPath::const_new("hair/attach_ms");
    /// [`HairSystems::Simulate`](crate::schedule::HairSystems::Simulate), ms.
    pub const SIMULATE: DiagnosticPath = DiagnosticPath::const_new("hair/simulate_ms");
    /// [`HairSystems::BuildMesh`](crate::schedule::HairSystems::BuildMesh), ms.
    pub const BUILD_MESH: DiagnosticPath = DiagnosticPath::const_new("hair/build_mesh_ms");
    /// [`HairSystems::Silhouettes`](crate::schedule::HairSystems::Silhouettes), ms.
    pub const SILHOUETTES: DiagnosticPath = DiagnosticPath::const_new("hair/silhouettes_ms");
    /// Guide strands simulated.
    pub const STRANDS: DiagnosticPath = DiagnosticPath::const_new("hair/strands");
    /// Substeps run last frame (the largest over all hairs).
    pub const SUBSTEPS: DiagnosticPath = DiagnosticPath::const_new("hair/substeps");
    /// Strands reset because they stopped being finite, since start (all hairs).
    pub const STRAND_RESETS: DiagnosticPath = DiagnosticPath::const_new("hair/strand_resets");
    /// Frames the bone teleported and carried its hair, since start (all hairs).
    pub const TELEPORTS: DiagnosticPath = DiagnosticPath::const_new("hair/teleports");
}

fn report_diagnostics(
    timings: Res<HairStageTimings>,
    hairs: Query<&ComputedHair>,
    mut diagnostics: Diagnostics,
) {
    let stages = [
        (&paths::ATTACH, timings.last[0]),
        (&paths::SIMULATE, timings.last[1]),
        (&paths::BUILD_MESH, timings.last[2]),
        (&paths::SILHOUETTES, timings.last[3]),
    ];
    for (path, ms) in stages {
        diagnostics.add_measurement(path, || f64::from(ms));
    }
    let (mut strands, mut substeps, mut resets, mut teleports) = (0usize, 0u32, 0u32, 0u32);
    for hair in &hairs {
        strands += hair.strand_count();
        substeps = substeps.max(hair.stats.substeps);
        resets += hair.stats.strand_resets;
        teleports += hair.stats.teleports;
    }
    diagnostics.add_measurement(&paths::STRANDS, || strands as f64);
    diagnostics.add_measurement(&paths::SUBSTEPS, || f64::from(substeps));
    diagnostics.add_measurement(&paths::STRAND_RESETS, || f64::from(resets));
    diagnostics.add_measurement(&paths::TELEPORTS, || f64::from(teleports));
}

/// Measures [`HairStageTimings`] with five small systems around the [`HairSystems`] sets, and
/// reports them (with the hair's counters) to Bevy's `DiagnosticsStore` under `hair/...`, so
/// any diagnostics overlay or `LogDiagnosticsPlugin` shows them. Needs no panel.
#[derive(Default)]
pub struct HairStageTimingsPlugin;

impl Plugin for HairStageTimingsPlugin {
    fn build(&self, app: &mut App) {
        for (path, suffix) in [
            (paths::ATTACH, "ms"),
            (paths::SIMULATE, "ms"),
            (paths::BUILD_MESH, "ms"),
            (paths::SILHOUETTES, "ms"),
            (paths::STRANDS, ""),
            (paths::SUBSTEPS, ""),
            (paths::STRAND_RESETS, ""),
            (paths::TELEPORTS, ""),
        ] {
            app.register_diagnostic(Diagnostic::new(path).with_suffix(suffix));
        }
        app.add_systems(
            PostUpdate,
            report_diagnostics.after(mark_stage_boundary::<4>),
        );
        app.init_resource::<HairStageTimings>().add_systems(
            PostUpdate,
            (
                mark_stage_boundary::<0>
                    // Attach starts after propagation, so the clock must too.
                    .after(TransformSystems::Propagate)
                    .before(HairSystems::Attach),
                mark_stage_boundary::<1>
                    // Between the two stages it closes and opens.
                    .after(HairSystems::Attach)
                    .before(HairSystems::Simulate),
                mark_stage_boundary::<2>
                    // Between the two stages it closes and opens.
                    .after(HairSystems::Simulate)
                    .before(HairSystems::BuildMesh),
                mark_stage_boundary::<3>
                    // Between the two stages it closes and opens.
                    .after(HairSystems::BuildMesh)
                    .before(HairSystems::Silhouettes),
                mark_stage_boundary::<4>.after(HairSystems::Silhouettes),
            ),
        );
    }
}

/// Draws what [`HairDebugDraw`] asks for.
fn draw_hair_debug(
    draw: Res<HairDebugDraw>,
    mut gizmos: Gizmos<HairDebugGizmos>,
    hairs: Query<(&ComputedHair, &HairStrands)>,
    strands: Query<(&Strand, &StrandParticles)>,
    colliders: Query<(&HairCollider, &GlobalTransform)>,
) {
    let particle = Color::srgb(1.0, 0.1, 0.6);
    let strand_line = Color::srgb(1.0, 0.95, 0.2);
    let structural = Color::srgb(0.2, 0.9, 1.0);
    let anchor = Color::srgb(0.3, 1.0, 0.3);
    for (computed, list) in &hairs {
        for (strand, p) in list.iter().filter_map(|e| strands.get(e).ok()) {
            if draw.particles {
                for &x in &p.positions {
                    gizmos.sphere(x, 0.0025, particle).resolution(6);
                }
            }
            if draw.springs {
                gizmos.linestrip(p.positions.iter().copied(), strand_line);
                // Chain order: ghost, root, structural, particle, structural, particle, ...
                if p.structural.len() == p.positions.len() {
                    let chain = p
                        .structural
                        .iter()
                        .zip(&p.positions)
                        .flat_map(|(s, x)| [*s, *x]);
                    gizmos.linestrip(chain, structural);
                }
            }
            if draw.anchors {
                for (i, &x) in p.positions.iter().enumerate() {
                    if let Some(a) = computed.anchor(strand.index as usize, i) {
                        gizmos.line(x, a, anchor);
                    }
                }
            }
        }
    }
    if draw.colliders {
        let colour = Color::srgb(1.0, 0.5, 0.1);
        for (collider, global) in &colliders {
            let pose = global.affine();
            for shape in collider.shapes() {
                draw_shape(&mut gizmos, &shape.at(&pose), colour);
            }
        }
    }
}

/// One collider shape as gizmo lines.
fn draw_shape(
    gizmos: &mut Gizmos<HairDebugGizmos>,
    shape: &crate::sim::solver::ContactShape,
    colour: Color,
) {
    use crate::sim::solver::ContactShape;
    match *shape {
        ContactShape::Sphere { centre, radius } => {
            gizmos
                .sphere(Vec3::from(centre), radius, colour)
                .resolution(16);
        }
        ContactShape::Capsule { a, b, radius } => {
            let (a, b) = (Vec3::from(a), Vec3::from(b));
            gizmos.sphere(a, radius, colour).resolution(12);
            gizmos.sphere(b, radius, colour).resolution(12);
            let axis = (b - a).normalize_or(Vec3::Y);
            let side = axis.any_orthonormal_vector() * radius;
            let other = axis.cross(side);
            for offset in [side, -side, other, -other] {
                gizmos.line(a + offset, b + offset, colour);
            }
        }
        ContactShape::Plane { point, normal } => {
            let (p, n) = (Vec3::from(point), Vec3::from(normal));
            let (u, v) = n.any_orthonormal_pair();
            for i in -4..=4 {
                let f = i as f32 * 0.1;
                gizmos.line(p + u * f - v * 0.4, p + u * f + v * 0.4, colour);
                gizmos.line(p + v * f - u * 0.4, p + v * f + u * 0.4, colour);
            }
            gizmos.arrow(p, p + n * 0.1, colour);
        }
        ContactShape::Box { centre, axes, half } => {
            let rotation = Quat::from_mat3a(&axes);
            gizmos.cube(
                Transform::from_translation(centre.into())
                    .with_rotation(rotation)
                    .with_scale(Vec3::from(half) * 2.0),
                colour,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn sleep_ms(ms: u64) -> impl Fn() {
        move || std::thread::sleep(Duration::from_millis(ms))
    }

    #[test]
    fn timings_measure_each_stage() {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            bevy::diagnostic::DiagnosticsPlugin,
            crate::schedule::HairSchedulePlugin,
            HairStageTimingsPlugin,
        ))
        .add_systems(PostUpdate, sleep_ms(2).in_set(HairSystems::Attach))
        .add_systems(PostUpdate, sleep_ms(12).in_set(HairSystems::Simulate))
        .add_systems(PostUpdate, sleep_ms(6).in_set(HairSystems::BuildMesh))
        .add_systems(PostUpdate, sleep_ms(4).in_set(HairSystems::Silhouettes));
        let start = std::time::Instant::now();
        app.update();
        let frame_ms = start.elapsed().as_secs_f32() * 1000.0;
        let t = app.world().resource::<HairStageTimings>().clone();
        assert_eq!(t.frames, 1);
        // The same numbers reach Bevy's diagnostics store.
        let store = app.world().resource::<bevy::diagnostic::DiagnosticsStore>();
        let simulate = store
            .get(&paths::SIMULATE)
            .and_then(|d| d.measurement())
            .expect("hair/simulate_ms is measured")
            .value;
        assert!(simulate >= 12.0, "{simulate}");
        assert_eq!(
            store
                .get(&paths::STRANDS)
                .and_then(bevy::diagnostic::Diagnostic::value),
            Some(0.0),
            "no hair, no strands"
        );
        assert!(t.attach >= 2.0, "{t:?}");
        assert!(t.simulate >= 12.0, "{t:?}");
        assert!(t.build_mesh >= 6.0, "{t:?}");
        assert!(t.silhouettes >= 4.0, "{t:?}");
        // Each stage is measured on its own: the windows do not overlap, so together they fit in
        // the frame (an upper bound that holds however loaded the machine is).
        assert!(
            t.attach + t.simulate + t.build_mesh + t.silhouettes <= frame_ms + 0.5,
            "{t:?} in {frame_ms} ms"
        );
    }
}
