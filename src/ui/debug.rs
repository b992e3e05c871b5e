//! The **Debug** window: what to draw over the hair, pause and step, stage timings and the
//! simulation's counters.

use bevy::platform::time::Instant;
use bevy::prelude::*;
use bevy::transform::TransformSystems;
use bevy_egui::{EguiContexts, egui};
use bevy_rapier3d::prelude::Collider;

use super::HairTuningUi;
use crate::HairSystems;
use crate::sim::{
    ComputedHair, HairSimControl, HairStrands, HeadColliderOf, Strand, StrandParticles,
};

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

pub(super) fn configure_debug_gizmos(mut store: ResMut<GizmoConfigStore>) {
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

/// Measures [`HairStageTimings`] with five small systems around the [`HairSystems`] sets. Part
/// of the tuning panel's plugin; add it alone to read timings without the panel.
#[derive(Default)]
pub struct HairStageTimingsPlugin;

impl Plugin for HairStageTimingsPlugin {
    fn build(&self, app: &mut App) {
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
pub(super) fn draw_hair_debug(
    draw: Res<HairDebugDraw>,
    mut gizmos: Gizmos<HairDebugGizmos>,
    hairs: Query<(&ComputedHair, &HairStrands)>,
    strands: Query<(&Strand, &StrandParticles)>,
    colliders: Query<(&Collider, &GlobalTransform), With<HeadColliderOf>>,
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
        for (collider, global) in &colliders {
            let scale = global.scale().x.abs();
            let mut ball = |centre: Vec3, radius: f32| {
                let centre = global.transform_point(centre);
                gizmos
                    .sphere(centre, radius * scale, Color::srgb(1.0, 0.5, 0.1))
                    .resolution(16);
            };
            if let Some(b) = collider.raw.as_ball() {
                ball(Vec3::ZERO, b.radius);
            } else if let Some(compound) = collider.raw.as_compound() {
                for (pose, shape) in compound.shapes() {
                    if let Some(b) = shape.as_ball() {
                        ball(pose.translation, b.radius);
                    }
                }
            }
        }
    }
}

/// The Debug window.
pub(super) fn debug_window(
    mut contexts: EguiContexts,
    mut draw: ResMut<HairDebugDraw>,
    mut control: ResMut<HairSimControl>,
    timings: Res<HairStageTimings>,
    tuning: Res<HairTuningUi>,
    hairs: Query<&ComputedHair>,
) {
    let Ok(ctx) = contexts.ctx_mut() else {
        return;
    };
    egui::Window::new("Debug")
        .default_pos([12.0, 12.0])
        .default_width(230.0)
        .resizable(false)
        .show(ctx, |ui| {
            let mut d = draw.clone();
            ui.horizontal(|ui| {
                ui.checkbox(&mut d.particles, "Particles");
                ui.checkbox(&mut d.springs, "Springs");
            });
            ui.horizontal(|ui| {
                ui.checkbox(&mut d.anchors, "Anchors");
                ui.checkbox(&mut d.colliders, "Colliders");
            });
            draw.set_if_neq(d);

            ui.separator();
            let mut c = control.clone();
            ui.horizontal(|ui| {
                ui.checkbox(&mut c.paused, "Pause");
                if ui.button("Step").clicked() {
                    c.step_once = true;
                }
                ui.add(
                    egui::DragValue::new(&mut c.step_time)
                        .speed(0.001)
                        .range(0.001..=0.1)
                        .suffix(" s"),
                );
            });
            control.set_if_neq(c);

            ui.separator();
            egui::Grid::new("hair_timings")
                .striped(true)
                .show(ui, |ui| {
                    for (name, ms) in timings.stages() {
                        ui.label(name);
                        ui.monospace(format!("{ms:7.3} ms"));
                        ui.end_row();
                    }
                });

            ui.separator();
            let Some(computed) = tuning.hair.and_then(|h| hairs.get(h).ok()) else {
                ui.label("No simulated hair yet.");
                return;
            };
            let s = computed.stats;
            egui::Grid::new("hair_stats").show(ui, |ui| {
                let rows = [
                    [
                        ("Strands", computed.strand_count() as u32),
                        ("Substeps", s.substeps),
                    ],
                    [("Teleports", s.teleports), ("Resets", s.strand_resets)],
                ];
                for row in rows {
                    for (name, value) in row {
                        ui.label(name);
                        ui.monospace(value.to_string());
                    }
                    ui.end_row();
                }
                ui.label("Bad bone frames")
                    .on_hover_text("Frames skipped: the bone's transform was not usable");
                ui.monospace(s.invalid_bone_frames.to_string());
                ui.end_row();
            });
        });
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
            crate::HairSchedulePlugin,
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
