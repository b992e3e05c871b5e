//! The **Debug** window: what to draw over the hair, pause and step, stage timings and the
//! simulation's counters. The drawing and the timings themselves live in [`crate::debug`](mod@crate::debug) and
//! work without the panel.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};

use super::{HairTuningUi, TuningPanelLayout};
use crate::debug::{HairDebugDraw, HairStageTimings};
use crate::mesh::HairCullingStats;
use crate::sim::{ComputedHair, HairTime, HairTimeExt};

/// The Debug window's title (egui keeps its place under this id).
const DEBUG_WINDOW: &str = "Debug";

/// The Debug window.
pub(super) fn debug_window(
    mut contexts: EguiContexts,
    mut draw: ResMut<HairDebugDraw>,
    mut hair_time: ResMut<Time<HairTime>>,
    timings: Res<HairStageTimings>,
    (tuning, mut layout): (Res<HairTuningUi>, ResMut<TuningPanelLayout>),
    culling: Res<HairCullingStats>,
    hairs: Query<&ComputedHair>,
) {
    let Ok(ctx) = contexts.ctx_mut() else {
        return;
    };
    let shown = egui::Window::new(DEBUG_WINDOW)
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
            ui.horizontal(|ui| {
                let mut paused = hair_time.is_paused();
                if ui.checkbox(&mut paused, "Pause").changed() {
                    hair_time.toggle_pause();
                }
                if ui.button("Step").clicked() {
                    hair_time.step_once();
                }
                let mut step = hair_time.context().step_seconds();
                if ui
                    .add(
                        egui::DragValue::new(&mut step)
                            .speed(0.001)
                            .range(0.001..=0.1)
                            .suffix(" s"),
                    )
                    .changed()
                {
                    hair_time.set_step_seconds(step);
                }
            });

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
            ui.label(format!(
                "Culled: {} of {} hairs; reduced: {} + {} + {}",
                culling.culled,
                culling.hairs,
                culling.reduced[0],
                culling.reduced[1],
                culling.reduced[2]
            ))
            .on_hover_text(
                "Culled: hair no camera sees, simulated but with no mesh, strokes or \
                 highlights. Reduced: hair small on screen drawn at level of detail 1 + 2 + 3 \
                 (HairLod: fewer tube rings and sides; levels 2 and 3 have no specular quads)",
            );

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
                    [
                        ("Colliders", s.colliders),
                        ("Bad bones", s.invalid_bone_frames),
                    ],
                    [
                        ("Volume pairs", s.volume_pairs),
                        ("Spread", s.volume_spread),
                    ],
                ];
                let hints = [
                    "",
                    "Substeps simulated last frame",
                    "Frames the bone jumped and carried the hair",
                    "Strands reset after their state stopped being finite",
                    "Collider shapes tested against this hair last frame (after the broad phase)",
                    "Frames skipped: the bone's transform was not usable",
                    "Pairs of strands the volume pushed apart last frame",
                    "Particles the volume spread by the hair's density last frame (hair far \
                     denser than its volume radius; see sim::volume)",
                ];
                for (r, row) in rows.into_iter().enumerate() {
                    for (c, (name, value)) in row.into_iter().enumerate() {
                        let label = ui.label(name);
                        let hint = hints[r * 2 + c];
                        if !hint.is_empty() {
                            label.on_hover_text(hint);
                        }
                        ui.monospace(value.to_string());
                    }
                    ui.end_row();
                }
            });
        });
    layout.debug = shown.map(|s| s.response.rect);
}
