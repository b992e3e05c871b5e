//! The silhouette and highlight part of the **Effects** window: the outline method (object-space
//! strokes, image-space edges, both or none) with the thesis's parameters, the E curve, and the
//! specular sampling quads switch.

use bevy::prelude::*;
use bevy_egui::egui;

use super::{curve_row, drag_row, optional_color_rows, slider_row};
use crate::mesh::highlights::SpecularQuads;
use crate::render::{ImageSpaceOutline, OutlineSource};
use crate::silhouette::SilhouetteSettings;

/// Which outline the hair and camera draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum OutlineMethod {
    None,
    ObjectSpace,
    ImageSpace,
    Both,
}

impl OutlineMethod {
    const ALL: [(Self, &'static str); 4] = [
        (Self::None, "none"),
        (Self::ObjectSpace, "object-space strokes"),
        (Self::ImageSpace, "image-space edges"),
        (Self::Both, "both"),
    ];

    fn from_flags(object: bool, image: bool) -> Self {
        match (object, image) {
            (false, false) => Self::None,
            (true, false) => Self::ObjectSpace,
            (false, true) => Self::ImageSpace,
            (true, true) => Self::Both,
        }
    }

    fn flags(self) -> (bool, bool) {
        match self {
            Self::None => (false, false),
            Self::ObjectSpace => (true, false),
            Self::ImageSpace => (false, true),
            Self::Both => (true, true),
        }
    }
}

/// Outline and highlight controls. `camera` is the camera's image-space outline (a default one is
/// inserted by the caller when `insert_outline` comes back set).
pub(super) fn outline_controls(
    ui: &mut egui::Ui,
    strokes: &mut Mut<SilhouetteSettings>,
    quads: &mut Mut<SpecularQuads>,
    camera: Option<&mut Mut<ImageSpaceOutline>>,
    insert_outline: &mut bool,
) {
    let mut s = (**strokes).clone();
    let mut q = (**quads).clone();
    let image_on = camera.as_ref().is_some_and(|c| c.enabled);
    let before = OutlineMethod::from_flags(s.enabled, image_on);
    let mut method = before;
    egui::Grid::new("hair_outlines")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("Silhouettes");
            egui::ComboBox::from_id_salt("outline method")
                .selected_text(
                    OutlineMethod::ALL
                        .iter()
                        .find(|(m, _)| *m == method)
                        .map_or("?", |m| m.1),
                )
                .show_ui(ui, |ui| {
                    for (m, label) in OutlineMethod::ALL {
                        ui.selectable_value(&mut method, m, label);
                    }
                });
            ui.end_row();
            if s.enabled {
                slider_row(ui, "Stroke width (px)", &mut s.width_px, 0.5..=12.0);
                slider_row(ui, "Angle scale", &mut s.angle_scale, 0.0..=2.0);
                slider_row(ui, "Depth scale", &mut s.depth_scale, 0.0..=2.0);
                slider_row(ui, "Stroke scale", &mut s.stroke_scale, 0.1..=4.0);
                slider_row(ui, "Stroke limit (px)", &mut s.stroke_limit_px, 0.5..=32.0);
                curve_row(ui, "E curve", &mut s.fade);
                drag_row(ui, "Depth bias (radii)", &mut s.depth_bias, 0.01);
                s.depth_bias = s.depth_bias.clamp(0.0, 4.0);
            }
            if let Some(camera) = camera
                && camera.enabled
            {
                let mut c = (**camera).clone();
                let mut x = c.dilation_x as f32;
                let mut y = c.dilation_y as f32;
                slider_row(ui, "X dilation", &mut x, 0.0..=8.0);
                slider_row(ui, "Y dilation", &mut y, 0.0..=8.0);
                slider_row(ui, "Edge threshold", &mut c.threshold, 0.01..=2.0);
                ui.label("Edges from");
                egui::ComboBox::from_id_salt("outline source")
                    .selected_text(format!("{:?}", c.source))
                    .show_ui(ui, |ui| {
                        for source in [
                            OutlineSource::Mass,
                            OutlineSource::DepthAndNormals,
                            OutlineSource::Depth,
                            OutlineSource::Normals,
                        ] {
                            ui.selectable_value(&mut c.source, source, format!("{source:?}"));
                        }
                    });
                ui.end_row();
                if c.source == OutlineSource::Mass {
                    optional_color_rows(
                        ui,
                        (
                            "Outline colour",
                            "the hair's, darkened, along hair",
                            "Outline tint",
                        ),
                        &mut c.hair_tint,
                        Color::srgb(0.45, 0.3, 0.3),
                    );
                    let mut inner = c.inner_threshold.is_some();
                    ui.label("Inner lines");
                    ui.checkbox(&mut inner, "normal creases");
                    ui.end_row();
                    c.inner_threshold = match (inner, c.inner_threshold) {
                        (false, _) => None,
                        (true, t) => {
                            let mut t = t.unwrap_or(0.3);
                            slider_row(ui, "Inner threshold", &mut t, 0.05..=2.0);
                            Some(t)
                        }
                    };
                    let mut locks = c.lock_lines.is_some();
                    ui.label("Lock lines");
                    ui.checkbox(&mut locks, "where locks overlap");
                    ui.end_row();
                    c.lock_lines = match (locks, c.lock_lines) {
                        (false, _) => None,
                        (true, l) => {
                            let mut l = l.unwrap_or_default();
                            slider_row(ui, "Lock step", &mut l.threshold, 0.0005..=0.05);
                            let mut w = l.width_px as f32;
                            slider_row(ui, "Lock line px", &mut w, 1.0..=4.0);
                            l.width_px = w.round() as u32;
                            slider_row(ui, "Fade from (m)", &mut l.fade.x, 0.0..=20.0);
                            slider_row(ui, "Fade to (m)", &mut l.fade.y, 0.0..=40.0);
                            optional_color_rows(
                                ui,
                                ("Lock line colour", "the hair's, darkened", "Lock line tint"),
                                &mut l.hair_tint,
                                Color::srgb(0.5, 0.35, 0.35),
                            );
                            Some(l)
                        }
                    };
                }
                c.dilation_x = x.round() as u32;
                c.dilation_y = y.round() as u32;
                camera.set_if_neq(c);
            }
            ui.label("Specular quads");
            ui.checkbox(&mut q.enabled, "sampling quads (Shin)");
            ui.end_row();
            if q.enabled {
                slider_row(ui, "Quad threshold", &mut q.threshold, 0.05..=0.99);
            }
        });
    if method != before {
        let (object, image) = method.flags();
        s.enabled = object;
        if image != image_on {
            *insert_outline = true;
        }
    }
    strokes.set_if_neq(s);
    quads.set_if_neq(q);
}

/// Switches a camera's image-space outline on or off, inserting one the first time.
pub(super) fn toggle_image_outline(
    commands: &mut Commands,
    camera: Entity,
    current: Option<&mut Mut<ImageSpaceOutline>>,
) {
    match current {
        Some(c) => c.enabled = !c.enabled,
        None => {
            commands.entity(camera).insert(ImageSpaceOutline::default());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn methods_round_trip_through_their_flags() {
        for (m, _) in OutlineMethod::ALL {
            let (o, i) = m.flags();
            assert_eq!(OutlineMethod::from_flags(o, i), m);
        }
    }
}
