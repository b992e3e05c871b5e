//! The **Hair properties** window (base mesh: H curve, resolutions, *Rebuild mesh*; simulation:
//! S curve, stiffnesses, gravity, damping, margins, *Alter margins*; presets) and the
//! **Effects** window (the hair's [`ToonHairMaterial`]: ramp, depth detail, back light,
//! specular, hatching; then silhouettes and highlights, see `outlines`), with the tonal art map
//! hatching needs, generated once on demand.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};

use super::{HairTuningUi, PanelState, curve_row, drag_row, slider_row};
use crate::hatching::{StrokeImage, TamSettings, generate, tonal_art_map_image};
use crate::mesh::HairMeshSettings;
use crate::mesh::highlights::SpecularQuads;
use crate::preset::{HairPreset, RampKind, ToonMaterialPreset};
use crate::render::{
    HairMaterial, HatchingMode, ImageSpaceOutline, RampMode, ToonHairMaterial, ToonRamps,
};
use crate::silhouette::SilhouetteSettings;
use crate::sim::{Hair, HairSimSettings};

/// The hairs the window edits.
type HairQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        Option<&'static Name>,
        &'static mut HairSimSettings,
        &'static mut HairMeshSettings,
        Option<&'static HairMaterial>,
        Option<&'static mut SilhouetteSettings>,
    ),
    With<Hair>,
>;

fn hair_label(entity: Entity, name: Option<&Name>) -> String {
    match name {
        Some(n) => format!("{n} ({entity})"),
        None => format!("hair {entity}"),
    }
}

/// The Hair properties window.
pub(super) fn properties_window(
    mut contexts: EguiContexts,
    mut tuning: ResMut<HairTuningUi>,
    mut panel: ResMut<PanelState>,
    mut hairs: HairQuery,
    mut outlines: Query<&mut ImageSpaceOutline>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
) {
    let Ok(ctx) = contexts.ctx_mut() else {
        return;
    };
    let width = ctx.content_rect().width();
    egui::Window::new("Hair properties")
        .default_pos([width - 312.0, 12.0])
        .default_width(300.0)
        .resizable(false)
        .show(ctx, |ui| {
            // Which hair, when there are several.
            if hairs.iter().len() > 1 {
                let mut selected = tuning.hair;
                let current = selected
                    .and_then(|e| hairs.get(e).ok())
                    .map(|(e, n, ..)| hair_label(e, n))
                    .unwrap_or_default();
                egui::ComboBox::from_label("Hair")
                    .selected_text(current)
                    .show_ui(ui, |ui| {
                        for (e, n, ..) in &hairs {
                            ui.selectable_value(&mut selected, Some(e), hair_label(e, n));
                        }
                    });
                if selected != tuning.hair {
                    tuning.hair = selected;
                }
            }
            let Some((hair, _, mut sim, mut mesh, material, mut silhouettes)) =
                tuning.hair.and_then(|e| hairs.get_mut(e).ok())
            else {
                ui.label("No hair in the scene yet.");
                return;
            };

            egui::CollapsingHeader::new("Base mesh")
                .default_open(true)
                .show(ui, |ui| mesh_controls(ui, hair, &mut mesh, &mut panel));
            egui::CollapsingHeader::new("Simulation")
                .default_open(true)
                .show(ui, |ui| simulation_controls(ui, &mut sim));
            egui::CollapsingHeader::new("Preset")
                .default_open(true)
                .show(ui, |ui| {
                    let path = tuning.preset_path.clone();
                    let mut edited = path.clone();
                    ui.horizontal(|ui| {
                        ui.label("File");
                        ui.text_edit_singleline(&mut edited);
                    });
                    if edited != path {
                        tuning.preset_path = edited;
                    }
                    let path = tuning.preset_path.clone();
                    ui.horizontal(|ui| {
                        if ui.button("Save").clicked() {
                            let fallback = ToonHairMaterial::default();
                            let m = material
                                .and_then(|m| materials.get(&m.0))
                                .unwrap_or(&fallback);
                            let preset = HairPreset::new(&sim, &mesh, m, Some(&ramps))
                                .with_silhouettes(silhouettes.as_deref())
                                .with_outline(outlines.iter().next());
                            match preset.save(&path) {
                                Ok(()) => panel.report(format!("saved {path}"), false),
                                Err(e) => panel.report(e.to_string(), true),
                            }
                        }
                        if ui.button("Load").clicked() {
                            match HairPreset::load(&path) {
                                Ok(preset) => {
                                    sim.set_if_neq(preset.simulation.clone());
                                    mesh.set_if_neq(preset.mesh.clone());
                                    if let Some(mut m) =
                                        material.and_then(|m| materials.get_mut(&m.0))
                                    {
                                        preset.material.apply(&mut m, &ramps);
                                    }
                                    if let (Some(want), Some(have)) =
                                        (&preset.silhouettes, silhouettes.as_mut())
                                    {
                                        have.set_if_neq(want.clone());
                                    }
                                    if let Some(want) = &preset.outline {
                                        for mut have in &mut outlines {
                                            have.set_if_neq(want.clone());
                                        }
                                    }
                                    panel.pending_mesh = None;
                                    panel.report(format!("loaded {path}"), false);
                                }
                                Err(e) => panel.report(e.to_string(), true),
                            }
                        }
                    });
                    panel.show_message(ui);
                });
        });
}

/// H curve, radius, and the resolutions applied by *Rebuild mesh*.
fn mesh_controls(
    ui: &mut egui::Ui,
    hair: Entity,
    mesh: &mut Mut<HairMeshSettings>,
    panel: &mut PanelState,
) {
    let mut m = (**mesh).clone();
    egui::Grid::new("hair_mesh").num_columns(2).show(ui, |ui| {
        curve_row(ui, "H curve", &mut m.taper);
        drag_row(ui, "Radius (m)", &mut m.radius, 0.0005);
        m.radius = m.radius.max(0.0);
        // Resolutions are edited as a pending copy, applied by the button (as in the thesis).
        let (mut rings, mut sides) = match panel.pending_mesh {
            Some((e, r, s)) if e == hair => (r, s),
            _ => (m.hair_resolution, m.shape_resolution),
        };
        ui.label("Hair resolution");
        ui.add(egui::DragValue::new(&mut rings).range(2..=256));
        ui.end_row();
        ui.label("Shape resolution");
        ui.add(egui::DragValue::new(&mut sides).range(3..=64));
        ui.end_row();
        let pending = (rings, sides) != (m.hair_resolution, m.shape_resolution);
        panel.pending_mesh = pending.then_some((hair, rings, sides));
        ui.label("");
        if ui
            .add_enabled(pending, egui::Button::new("Rebuild mesh"))
            .on_hover_text("Apply the hair and shape resolution")
            .clicked()
        {
            m.hair_resolution = rings;
            m.shape_resolution = sides;
            panel.pending_mesh = None;
        }
        ui.end_row();
    });
    mesh.set_if_neq(m);
}

/// S curve, stiffnesses, gravity, damping, margins.
fn simulation_controls(ui: &mut egui::Ui, sim: &mut Mut<HairSimSettings>) {
    let mut s = (**sim).clone();
    egui::Grid::new("hair_sim").num_columns(2).show(ui, |ui| {
        curve_row(ui, "S curve", &mut s.anchor_stiffness);
        slider_row(ui, "Edge stiffness", &mut s.edge_stiffness, 0.0..=1.0);
        slider_row(ui, "Bend stiffness", &mut s.bend_stiffness, 0.0..=1.0);
        slider_row(ui, "Torsion stiffness", &mut s.torsion_stiffness, 0.0..=1.0);
        ui.label("Gravity");
        ui.horizontal(|ui| {
            for (name, v) in [
                ("x", &mut s.gravity.x),
                ("y", &mut s.gravity.y),
                ("z", &mut s.gravity.z),
            ] {
                ui.add(
                    egui::DragValue::new(v)
                        .speed(0.05)
                        .prefix(format!("{name} ")),
                );
            }
        });
        ui.end_row();
        slider_row(ui, "Damping", &mut s.damping, 0.0..=20.0);
        drag_row(ui, "M min (m)", &mut s.margin_min, 0.0005);
        drag_row(ui, "M max (m)", &mut s.margin_max, 0.0005);
        s.margin_min = s.margin_min.clamp(0.0, 0.2);
        s.margin_max = s.margin_max.clamp(0.0, 0.2);
        ui.label(format!("Margin seed {}", s.margin_seed));
        if ui
            .button("Alter margins")
            .on_hover_text("Draw each strand's margin in [M min, M max] again")
            .clicked()
        {
            s.margin_seed = s.margin_seed.wrapping_add(1);
        }
        ui.end_row();
    });
    sim.set_if_neq(s);
}

/// How the tonal art map is generated when a material first asks for hatching without one
/// (see [`assign_tonal_art_maps`]). Small by default so switching hatching on takes a moment,
/// not seconds.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct HatchingMapSettings(pub TamSettings);

impl Default for HatchingMapSettings {
    fn default() -> Self {
        Self(TamSettings {
            tones: 6,
            resolution: 128,
            mip_levels: 3,
            strokes_per_tone: 60,
            candidates: 4,
            stroke_length: 0.45,
            ..default()
        })
    }
}

/// The tonal art map given to materials that ask for hatching without one: generated on first
/// need, or set it yourself beforehand to use your own map.
#[derive(Resource, Clone, Debug, Default)]
pub struct TonalArtMapCache(pub Option<Handle<Image>>);

/// Gives every [`ToonHairMaterial`] that asks for hatching but has no tonal art map the shared
/// generated one (made once, from [`HatchingMapSettings`]), so that switching hatching on in the
/// panel, or loading a preset with hatching, just works. Runs in `PostUpdate`.
pub fn assign_tonal_art_maps(
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    mut images: ResMut<Assets<Image>>,
    mut cache: ResMut<TonalArtMapCache>,
    settings: Res<HatchingMapSettings>,
    mut failed: Local<bool>,
) {
    let needy: Vec<AssetId<ToonHairMaterial>> = materials
        .iter()
        .filter(|(_, m)| m.hatching != HatchingMode::None && m.tonal_art_map.is_none())
        .map(|(id, _)| id)
        .collect();
    if needy.is_empty() || *failed {
        return;
    }
    let map = match &cache.0 {
        Some(map) => map.clone(),
        None => {
            let start = std::time::Instant::now();
            match generate(&StrokeImage::default(), &settings.0, |_, _| {}) {
                Ok(tam) => {
                    info!(
                        "generated a {} px tonal art map for hatching in {:.2} s",
                        tam.resolution(),
                        start.elapsed().as_secs_f32()
                    );
                    let handle = images.add(tonal_art_map_image(&tam));
                    cache.0 = Some(handle.clone());
                    handle
                }
                Err(e) => {
                    // Once: the settings will not get better by themselves.
                    error!("cannot generate a tonal art map for hatching: {e}");
                    *failed = true;
                    return;
                }
            }
        }
    };
    for id in needy {
        if let Some(mut m) = materials.get_mut(id) {
            m.tonal_art_map = Some(map.clone());
        }
    }
}

const RAMP_MODES: [(RampMode, &str); 4] = [
    (RampMode::Constant, "constant"),
    (RampMode::Depth, "depth detail"),
    (RampMode::BackLight, "back light"),
    (RampMode::Specular, "specular"),
];

const HATCHING_MODES: [(HatchingMode, &str); 3] = [
    (HatchingMode::None, "none"),
    (HatchingMode::Screen, "simple (screen)"),
    (HatchingMode::Surface, "strand surface"),
];

fn label_of<T: PartialEq + Copy>(table: &[(T, &'static str)], value: T) -> &'static str {
    table
        .iter()
        .find(|(v, _)| *v == value)
        .map_or("?", |(_, l)| l)
}

fn combo_row<T: PartialEq + Copy>(
    ui: &mut egui::Ui,
    label: &str,
    value: &mut T,
    table: &[(T, &'static str)],
) {
    ui.label(label);
    egui::ComboBox::from_id_salt(label)
        .selected_text(label_of(table, *value))
        .show_ui(ui, |ui| {
            for (v, l) in table {
                ui.selectable_value(value, *v, *l);
            }
        });
    ui.end_row();
}

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

/// The Effects window.
// A Bevy system: its parameters are its queries.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(super) fn effects_window(
    mut contexts: EguiContexts,
    tuning: Res<HairTuningUi>,
    hairs: Query<&HairMaterial>,
    mut materials: ResMut<Assets<ToonHairMaterial>>,
    ramps: Res<ToonRamps>,
    mut outlines: Query<(&mut SilhouetteSettings, &mut SpecularQuads)>,
    mut cameras: Query<(Entity, Option<&mut ImageSpaceOutline>), With<Camera3d>>,
    mut commands: Commands,
) {
    let Ok(ctx) = contexts.ctx_mut() else {
        return;
    };
    egui::Window::new("Effects")
        .default_pos([12.0, 330.0])
        .default_width(300.0)
        .resizable(false)
        .show(ctx, |ui| {
            let Some(handle) = tuning.hair.and_then(|h| hairs.get(h).ok()) else {
                ui.label("The hair has no toon material yet.");
                return;
            };
            let Some(material) = materials.get(&handle.0) else {
                ui.label("The hair's material is not loaded.");
                return;
            };
            let before = ToonMaterialPreset::from_material(material, Some(&ramps));
            let mut m = before.clone();
            egui::Grid::new("hair_effects")
                .num_columns(2)
                .show(ui, |ui| material_controls(ui, &mut m));
            if m.hatching != HatchingMode::None && material.tonal_art_map.is_none() {
                ui.label("Generating hatching strokes...");
            }
            if m != before
                && let Some(mut material) = materials.get_mut(&handle.0)
            {
                m.apply(&mut material, &ramps);
            }
            if let Some(hair) = tuning.hair
                && let Ok((mut strokes, mut quads)) = outlines.get_mut(hair)
            {
                egui::CollapsingHeader::new("Silhouettes and highlights")
                    .default_open(false)
                    .show(ui, |ui| {
                        let mut camera = cameras.iter_mut().next();
                        let mut toggle = false;
                        let outline = camera.as_mut().and_then(|(_, o)| o.as_mut());
                        super::outlines::outline_controls(
                            ui,
                            &mut strokes,
                            &mut quads,
                            outline,
                            &mut toggle,
                        );
                        if toggle && let Some((entity, outline)) = camera.as_mut() {
                            super::outlines::toggle_image_outline(
                                &mut commands,
                                *entity,
                                outline.as_mut(),
                            );
                        }
                    });
            }
        });
}

/// Every control of the material; a change of ramp mode picks the ramp made for it.
fn material_controls(ui: &mut egui::Ui, m: &mut ToonMaterialPreset) {
    color_row(ui, "Hair colour", &mut m.base_color);
    let mode = m.ramp_mode;
    combo_row(ui, "Ramp mode", &mut m.ramp_mode, &RAMP_MODES);
    if m.ramp_mode != mode {
        m.ramp = RampKind::for_mode(m.ramp_mode);
    }
    let kinds: Vec<(RampKind, &'static str)> = RampKind::ALL
        .iter()
        .filter(|k| **k != RampKind::Custom || m.ramp == RampKind::Custom)
        .map(|k| (*k, k.label()))
        .collect();
    combo_row(ui, "Ramp", &mut m.ramp, &kinds);
    if m.ramp_mode == RampMode::Constant {
        slider_row(ui, "Ramp row", &mut m.ramp_row, 0.0..=1.0);
    }
    drag_row(ui, "Z min (m)", &mut m.z_min, 0.01);
    m.z_min = m.z_min.max(0.001);
    drag_row(ui, "Z scale", &mut m.z_scale, 0.05);
    m.z_scale = m.z_scale.max(1.0);
    slider_row(ui, "Back light r", &mut m.back_light_power, 0.0..=8.0);
    slider_row(ui, "Back light", &mut m.back_light_strength, 0.0..=1.0);
    slider_row(ui, "Specular", &mut m.specular_strength, 0.0..=2.0);
    ui.label("Shininess");
    ui.add(egui::Slider::new(&mut m.shininess, 1.0..=512.0).logarithmic(true));
    ui.end_row();
    combo_row(ui, "Hatching", &mut m.hatching, &HATCHING_MODES);
    ui.label("HScale");
    ui.add(egui::Slider::new(&mut m.hatch_scale, 0.1..=10.0).logarithmic(true));
    ui.end_row();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hatching_materials_get_one_shared_generated_map() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>()
            .init_asset::<ToonHairMaterial>()
            .init_resource::<HatchingMapSettings>()
            .init_resource::<TonalArtMapCache>()
            .add_systems(Update, assign_tonal_art_maps);
        let mut materials = app.world_mut().resource_mut::<Assets<ToonHairMaterial>>();
        let plain = materials.add(ToonHairMaterial::default());
        let hatched = [HatchingMode::Screen, HatchingMode::Surface].map(|hatching| {
            materials.add(ToonHairMaterial {
                hatching,
                ..default()
            })
        });
        app.update();
        let materials = app.world().resource::<Assets<ToonHairMaterial>>();
        assert!(materials.get(&plain).unwrap().tonal_art_map.is_none());
        let maps = hatched.map(|h| materials.get(&h).unwrap().tonal_art_map.clone());
        let map = maps[0].clone().expect("hatching material got a map");
        assert_eq!(maps[1].as_ref(), Some(&map), "one map, shared");
        let image = app.world().resource::<Assets<Image>>().get(&map).unwrap();
        let settings = HatchingMapSettings::default().0;
        assert_eq!(
            image.texture_descriptor.size.depth_or_array_layers as usize,
            settings.tones
        );
    }
}
