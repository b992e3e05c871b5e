//! The live tuning panel (thesis 3.6 and 4.4): three egui windows over the game, shown and hidden
//! together with [`HairTuningUi::visible`] (the `ninja_head` example toggles it with M).
//!
//! | window | what it holds |
//! |--------|---------------|
//! | **Debug** | draw particles, springs, anchors and head colliders ([`HairDebugDraw`]); pause and step ([`HairSimControl`](crate::sim::HairSimControl)); milliseconds per stage ([`HairStageTimings`]); the hair's step counters. |
//! | **Hair properties** | the H curve, hair and shape resolution with *Rebuild mesh*, the S curve, edge, bend and torsion stiffness, gravity, damping, margins with *Alter margins*; presets (save and load). |
//! | **Effects** | the toon material: ramp mode and ramp, depth detail (Zmin, Zscale), back lighting, specular, hatching and HScale; the outline method (object-space strokes, image-space edges, both or none) with the thesis's stroke parameters and the E curve; the specular sampling quads. |
//!
//! Every control edits the plugin's own types: [`HairSimSettings`](crate::sim::HairSimSettings)
//! and [`HairMeshSettings`](crate::mesh::HairMeshSettings) on the hair entity, the
//! [`ToonHairMaterial`](crate::render::ToonHairMaterial) asset behind its
//! [`HairMaterial`](crate::render::HairMaterial), [`SilhouetteSettings`](crate::silhouette::SilhouetteSettings)
//! and [`SpecularQuads`](crate::mesh::highlights::SpecularQuads) on the hair, and the camera's
//! [`ImageSpaceOutline`](crate::render::ImageSpaceOutline). There is no copy to keep in sync: an edit takes
//! effect on the next frame, and a change made by game code shows in the panel. Values are
//! written back only when a control changed them, so an open panel does not mark settings or
//! materials as changed every frame. The one exception is the resolution pair, which the thesis
//! applies with *Rebuild mesh*: it is edited as a pending copy and applied by the button.
//!
//! The panel edits one hair at a time ([`HairTuningUi::hair`]; the first hair when unset).

mod debug;
mod outlines;
mod panels;

pub use crate::debug::{
    HairDebugDraw, HairDebugGizmos, HairDebugPlugin, HairStageTimings, HairStageTimingsPlugin,
};
pub use crate::render::{HatchingMapSettings, TonalArtMapCache, assign_tonal_art_maps};
pub use bevy_egui;

use bevy::prelude::*;
use bevy_egui::{
    EguiGlobalSettings, EguiPlugin, EguiPreUpdateSet, EguiPrimaryContextPass, PrimaryEguiContext,
    egui,
};

use crate::sim::Hair;

/// Gives the primary egui context (where the panel draws) to one camera while none has it: the
/// first active camera that renders to a window, or else the first active camera.
fn give_the_panel_a_camera(
    mut commands: Commands,
    primary: Query<(), With<PrimaryEguiContext>>,
    cameras: Query<(Entity, &Camera, Option<&bevy::camera::RenderTarget>)>,
) {
    if !primary.is_empty() {
        return;
    }
    let mut active: Vec<_> = cameras.iter().filter(|(_, c, _)| c.is_active).collect();
    active.sort_by_key(|(e, ..)| *e);
    let on_window = |target: Option<&bevy::camera::RenderTarget>| {
        matches!(target, None | Some(bevy::camera::RenderTarget::Window(_)))
    };
    let chosen = active
        .iter()
        .find(|(_, _, target)| on_window(*target))
        .or(active.first());
    if let Some((camera, ..)) = chosen {
        commands.entity(*camera).insert(PrimaryEguiContext);
    }
}

/// Whether the tuning panel is shown, which hair it edits, and where presets go.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default, Debug)]
pub struct HairTuningUi {
    /// Show the three windows. Toggle it from a key (the example uses M). Default: `false`.
    pub visible: bool,
    /// The hair the panel edits; `None` (or a despawned entity) picks the first hair.
    /// Default: `None`.
    pub hair: Option<Entity>,
    /// The preset file the *Save* and *Load* buttons use. Default: `"hair.preset.ron"`.
    pub preset_path: String,
}

impl Default for HairTuningUi {
    fn default() -> Self {
        Self {
            visible: false,
            hair: None,
            preset_path: "hair.preset.ron".into(),
        }
    }
}

impl HairTuningUi {
    /// Shows the panel if hidden and hides it if shown.
    pub fn toggle(&mut self) {
        self.visible = !self.visible;
    }
}

/// Run condition: the tuning panel is shown.
pub fn tuning_ui_visible(ui: Option<Res<HairTuningUi>>) -> bool {
    ui.is_some_and(|ui| ui.visible)
}

/// Run condition: egui is using the keyboard (a text field has focus or a popup is open), so
/// game keys should be ignored. `false` when egui is not running.
pub fn tuning_ui_wants_keyboard(wants: Option<Res<bevy_egui::input::EguiWantsInput>>) -> bool {
    wants.is_some_and(|w| w.wants_any_keyboard_input())
}

/// Panel state that is not a setting: pending edits and the last message.
#[derive(Resource, Default)]
pub(crate) struct PanelState {
    /// Resolutions being edited, applied by *Rebuild mesh*: `(hair, hair_resolution,
    /// shape_resolution)`.
    pending_mesh: Option<(Entity, u32, u32)>,
    /// The last preset or hatching message, and whether it is an error.
    message: Option<(String, bool)>,
}

impl PanelState {
    fn report(&mut self, message: impl Into<String>, error: bool) {
        let message = message.into();
        if error {
            warn!("{message}");
        } else {
            info!("{message}");
        }
        self.message = Some((message, error));
    }

    fn show_message(&self, ui: &mut egui::Ui) {
        if let Some((text, error)) = &self.message {
            let color = if *error {
                egui::Color32::from_rgb(255, 120, 100)
            } else {
                egui::Color32::from_rgb(150, 220, 150)
            };
            ui.colored_label(color, text);
        }
    }
}

/// The tuning panel (feature `ui`). Not part of [`CartoonHairPlugins`](crate::CartoonHairPlugins):
/// add it next to them during development. Adds bevy_egui's [`EguiPlugin`] unless the app
/// already has it.
#[derive(Default)]
pub struct HairTuningUiPlugin;

impl Plugin for HairTuningUiPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<EguiPlugin>() {
            // bevy_egui's own choice of camera runs twice (startup and first frame) with separate
            // memories, so with two cameras spawned at startup it can give each a primary
            // context, and then panics. One system picks one camera here instead.
            app.insert_resource(EguiGlobalSettings {
                auto_create_primary_context: false,
                ..default()
            })
            .add_plugins(EguiPlugin::default())
            .add_systems(
                PreUpdate,
                give_the_panel_a_camera.before(EguiPreUpdateSet::InitContexts),
            );
        }
        if !app.is_plugin_added::<HairStageTimingsPlugin>() {
            app.add_plugins(HairStageTimingsPlugin);
        }
        if !app.is_plugin_added::<HairDebugPlugin>() {
            app.add_plugins(HairDebugPlugin);
        }
        app.init_resource::<HairTuningUi>()
            .init_resource::<TuningPanelLayout>()
            .init_resource::<PanelState>()
            .register_type::<HairTuningUi>()
            .add_systems(Update, select_hair)
            .add_systems(
                EguiPrimaryContextPass,
                (
                    debug::debug_window,
                    panels::properties_window,
                    panels::effects_window,
                )
                    .chain()
                    .run_if(tuning_ui_visible),
            );
    }
}

/// Keeps [`HairTuningUi::hair`] on an existing hair.
fn select_hair(mut ui: ResMut<HairTuningUi>, hairs: Query<Entity, With<Hair>>) {
    if ui.hair.is_some_and(|e| hairs.contains(e)) {
        return;
    }
    let first = hairs.iter().min();
    if ui.hair != first {
        ui.hair = first;
    }
}

/// Where the panel's windows were drawn in the last frame (egui points; `None` for a window
/// not drawn). The Effects window is placed below the Debug window from it.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct TuningPanelLayout {
    /// The Debug window.
    pub debug: Option<egui::Rect>,
    /// The Hair properties window.
    pub properties: Option<egui::Rect>,
    /// The Effects window.
    pub effects: Option<egui::Rect>,
}

/// A labelled row of three drag values editing a quadratic curve; `true` when changed.
fn curve_row(ui: &mut egui::Ui, label: &str, curve: &mut crate::curve::QuadraticCurve) -> bool {
    let mut changed = false;
    ui.label(label);
    ui.horizontal(|ui| {
        for (name, v) in [
            ("a", &mut curve.a),
            ("b", &mut curve.b),
            ("c", &mut curve.c),
        ] {
            changed |= ui
                .add(
                    egui::DragValue::new(v)
                        .speed(0.01)
                        .prefix(format!("{name} ")),
                )
                .changed();
        }
    });
    ui.end_row();
    changed
}

/// A labelled slider row in a grid; `true` when changed.
fn slider_row(
    ui: &mut egui::Ui,
    label: &str,
    value: &mut f32,
    range: std::ops::RangeInclusive<f32>,
) -> bool {
    ui.label(label);
    let changed = ui.add(egui::Slider::new(value, range)).changed();
    ui.end_row();
    changed
}

/// A labelled colour button (linear RGB; the alpha is kept).
fn color_row(ui: &mut egui::Ui, label: &str, color: &mut Color) {
    ui.label(label);
    // egui's float colour button works in linear RGB.
    let c = color.to_linear();
    let mut rgb = [c.red, c.green, c.blue];
    if ui.color_edit_button_rgb(&mut rgb).changed() {
        *color = Color::linear_rgba(rgb[0], rgb[1], rgb[2], c.alpha);
    }
    ui.end_row();
}

/// A checkbox row that switches a colour on (`default` when it was off) or off, and the
/// colour's button row while it is on: an optional tint.
fn optional_color_rows(
    ui: &mut egui::Ui,
    (label, check, color_label): (&str, &str, &str),
    color: &mut Option<Color>,
    default: Color,
) {
    let mut on = color.is_some();
    ui.label(label);
    ui.checkbox(&mut on, check);
    ui.end_row();
    *color = on.then(|| {
        let mut c = color.unwrap_or(default);
        color_row(ui, color_label, &mut c);
        c
    });
}

/// A labelled drag value row in a grid; `true` when changed.
fn drag_row(ui: &mut egui::Ui, label: &str, value: &mut f32, speed: f64) -> bool {
    ui.label(label);
    let changed = ui
        .add(egui::DragValue::new(value).speed(speed).max_decimals(4))
        .changed();
    ui.end_row();
    changed
}
