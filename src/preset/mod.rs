//! Hair presets: a hair's tuning (simulation, mesh, toon material and outlines) saved as a RON
//! file and loaded back, so a look found in the tuning panel can be kept, shared and used in a
//! game.
//!
//! A [`HairPreset`] holds the same settings types the plugins use ([`HairSimSettings`],
//! [`HairMeshSettings`], [`SilhouetteSettings`] for the object-space strokes and the camera's
//! [`ImageSpaceOutline`]) and the [`ToonShading`] of a [`ToonHairMaterial`] with its ramp by
//! name ([`ToonMaterialPreset`]). It is written with Bevy reflection (no serde derives), so a preset
//! file reads like the structs:
//!
//! ```text
//! (
//!     format: 2,
//!     simulation: (edge_stiffness: 1.0, bend_stiffness: 0.8, ...),
//!     mesh: (hair_resolution: 16, shape_resolution: 8, ...),
//!     material: (ramp: ThreeTone, shading: (ramp_mode: Constant, ...)),
//!     silhouettes: Some((enabled: true, width_px: 3.0, ...)),
//!     outline: Some((enabled: false, threshold: 0.3, ...)),
//! )
//! ```
//!
//! A preset starts with its file format (`format: 2`, [`PRESET_FORMAT`]). Presets of earlier
//! formats load: they are migrated, with a warning naming each field that moved (see
//! [`HairPreset::from_ron_migrating`]); a preset of a newer format is an error that says so.
//! Fields left out of a file keep their defaults; an unknown field, a wrong type or a syntax
//! error is an error naming the file, the line and column and what is wrong. Loading never
//! panics.
//!
//! ```no_run
//! use bevy_cartoon_hair::preset::HairPreset;
//!
//! let preset = HairPreset::default();
//! preset.save("spiky.preset.ron").unwrap();
//! let back = HairPreset::load("spiky.preset.ron").unwrap();
//! assert_eq!(back, preset);
//! ```

use std::path::{Path, PathBuf};

use bevy::prelude::*;
use bevy::reflect::serde::{TypedReflectDeserializer, TypedReflectSerializer};
use bevy::reflect::{FromReflect, GetTypeRegistration, TypeRegistry};

mod migrate;

pub use migrate::{PRESET_FORMAT, PresetMigration};

use crate::mesh::HairMeshSettings;
use crate::render::{ImageSpaceOutline, RampMode, ToonHairMaterial, ToonRamps, ToonShading};
use crate::silhouette::SilhouetteSettings;
use crate::sim::HairSimSettings;

/// Which of the default [`ToonRamps`] a material uses.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default, Debug, PartialEq)]
#[non_exhaustive]
pub enum RampKind {
    /// [`ToonRamps::two_tone`].
    TwoTone,
    /// [`ToonRamps::three_tone`].
    #[default]
    ThreeTone,
    /// [`ToonRamps::depth`], made for [`RampMode::Depth`].
    Depth,
    /// [`ToonRamps::back_light`], made for [`RampMode::BackLight`].
    BackLight,
    /// [`ToonRamps::specular`], made for [`RampMode::Specular`].
    Specular,
    /// A ramp of the game's own: applying the preset leaves the material's ramp as it is.
    Custom,
}

impl RampKind {
    /// Every kind, in menu order.
    pub const ALL: [RampKind; 6] = [
        RampKind::TwoTone,
        RampKind::ThreeTone,
        RampKind::Depth,
        RampKind::BackLight,
        RampKind::Specular,
        RampKind::Custom,
    ];

    /// The ramp made for `mode` (three tones for [`RampMode::Constant`]).
    pub fn for_mode(mode: RampMode) -> Self {
        match mode {
            RampMode::Constant => RampKind::ThreeTone,
            RampMode::Depth => RampKind::Depth,
            RampMode::BackLight => RampKind::BackLight,
            RampMode::Specular => RampKind::Specular,
        }
    }

    /// The kind of `ramp` among `ramps`, or [`RampKind::Custom`].
    pub fn of(ramp: &Handle<Image>, ramps: &ToonRamps) -> Self {
        let id = ramp.id();
        [
            (&ramps.two_tone, RampKind::TwoTone),
            (&ramps.three_tone, RampKind::ThreeTone),
            (&ramps.depth, RampKind::Depth),
            (&ramps.back_light, RampKind::BackLight),
            (&ramps.specular, RampKind::Specular),
        ]
        .into_iter()
        .find(|(h, _)| h.id() == id)
        .map_or(RampKind::Custom, |(_, k)| k)
    }

    /// The ramp's handle, `None` for [`RampKind::Custom`].
    pub fn handle(self, ramps: &ToonRamps) -> Option<Handle<Image>> {
        match self {
            RampKind::TwoTone => Some(ramps.two_tone.clone()),
            RampKind::ThreeTone => Some(ramps.three_tone.clone()),
            RampKind::Depth => Some(ramps.depth.clone()),
            RampKind::BackLight => Some(ramps.back_light.clone()),
            RampKind::Specular => Some(ramps.specular.clone()),
            RampKind::Custom => None,
        }
    }

    /// A short name for menus.
    pub fn label(self) -> &'static str {
        match self {
            RampKind::TwoTone => "two tone",
            RampKind::ThreeTone => "three tone",
            RampKind::Depth => "depth",
            RampKind::BackLight => "back light",
            RampKind::Specular => "specular",
            RampKind::Custom => "custom",
        }
    }
}

/// The tunable part of a [`ToonHairMaterial`]: its [`ToonShading`] as it is, and its ramp by
/// name ([`ToonMaterialPreset::ramp`]); the tonal art map is generated, not saved. Its shading's
/// fields are reached directly through `Deref`.
#[derive(Reflect, Clone, Debug, Default, PartialEq, Deref, DerefMut)]
#[reflect(Default, Debug, PartialEq)]
pub struct ToonMaterialPreset {
    /// Which default ramp to use. Default: [`RampKind::ThreeTone`].
    pub ramp: RampKind,
    /// [`ToonHairMaterial::shading`]. Default: [`ToonShading::default`].
    #[deref]
    pub shading: ToonShading,
}

impl ToonMaterialPreset {
    /// The tunable fields of `material`; its ramp is named by looking it up in `ramps`
    /// ([`RampKind::ThreeTone`] when `ramps` is `None`).
    pub fn from_material(material: &ToonHairMaterial, ramps: Option<&ToonRamps>) -> Self {
        Self {
            ramp: ramps.map_or(RampKind::ThreeTone, |r| RampKind::of(&material.ramp, r)),
            shading: material.shading.clone(),
        }
    }

    /// Writes the shading into `material`, and its ramp from `ramps` unless the ramp is
    /// [`RampKind::Custom`]. The tonal art map is left as it is.
    pub fn apply(&self, material: &mut ToonHairMaterial, ramps: &ToonRamps) {
        if let Some(ramp) = self.ramp.handle(ramps) {
            material.ramp = ramp;
        }
        material.shading.clone_from(&self.shading);
    }
}

/// A hair's whole tuning, as saved in a preset file. See the [module docs](self).
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default, Debug, PartialEq)]
pub struct HairPreset {
    /// The file format ([`PRESET_FORMAT`] for presets of this version). Files of earlier
    /// formats are migrated when read ([`HairPreset::from_ron_migrating`]).
    pub format: u32,
    /// How the hair moves.
    pub simulation: HairSimSettings,
    /// How strands become tubes.
    pub mesh: HairMeshSettings,
    /// How the hair is shaded.
    pub material: ToonMaterialPreset,
    /// The object-space strokes (a component of the hair); `None` (as in presets older than
    /// this field) leaves the hair's strokes as they are.
    pub silhouettes: Option<SilhouetteSettings>,
    /// The image-space outline (a component of the camera); `None` leaves the camera as it is.
    pub outline: Option<ImageSpaceOutline>,
}

impl Default for HairPreset {
    fn default() -> Self {
        Self {
            format: PRESET_FORMAT,
            simulation: default(),
            mesh: default(),
            material: default(),
            silhouettes: None,
            outline: None,
        }
    }
}

/// Why a preset could not be saved or loaded. Every message names the file, when there is one
/// ([`HairPreset::from_ron`] reads a string).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HairPresetError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The text is not a valid preset: bad RON syntax, an unknown field, a value of the wrong
    /// type.
    #[error("{}{line}:{column}: {message}", file_prefix(file))]
    Parse {
        /// The file; `None` for text given as a string.
        file: Option<String>,
        /// Line of the error, from 1.
        line: usize,
        /// Column of the error, from 1.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// The preset could not be written as RON (a value RON cannot express).
    #[error("{}cannot write the preset: {message}", file_label(file))]
    Serialize {
        /// The file; `None` for [`HairPreset::to_ron`].
        file: Option<String>,
        /// What went wrong.
        message: String,
    },
}

/// `"file:"` or nothing.
fn file_prefix(file: &Option<String>) -> String {
    file.as_ref().map_or_else(String::new, |f| format!("{f}:"))
}

/// `"file: "` or nothing.
fn file_label(file: &Option<String>) -> String {
    file.as_ref().map_or_else(String::new, |f| format!("{f}: "))
}

/// The looks shipped in `assets/presets/` (built into the crate too), by name: the thesis's
/// user-study defaults (depth detail, Blinn specular, thick unfaded strokes), a clean anime look
/// lit by the scene's own lights and shadows ([`ToonLighting::Scene`](crate::render::ToonLighting)),
/// and a pen sketch with surface hatching. Load one with [`HairPreset::look`]; the tuning panel
/// and the `ninja_head` example (`--preset NAME`) offer them.
pub const LOOKS: &[(&str, &str)] = &[
    (
        "thesis",
        include_str!("../../assets/presets/thesis.preset.ron"),
    ),
    (
        "clean_anime",
        include_str!("../../assets/presets/clean_anime.preset.ron"),
    ),
    (
        "sketch",
        include_str!("../../assets/presets/sketch.preset.ron"),
    ),
    (
        "anime_locks",
        include_str!("../../assets/presets/anime_locks.preset.ron"),
    ),
];

/// A registry holding just the preset's types.
fn preset_registry() -> TypeRegistry {
    let mut registry = TypeRegistry::new();
    registry.register::<HairPreset>();
    registry
}

impl HairPreset {
    /// The preset of a hair: its settings and its material's tunable fields.
    pub fn new(
        simulation: &HairSimSettings,
        mesh: &HairMeshSettings,
        material: &ToonHairMaterial,
        ramps: Option<&ToonRamps>,
    ) -> Self {
        Self {
            simulation: simulation.clone(),
            mesh: mesh.clone(),
            material: ToonMaterialPreset::from_material(material, ramps),
            ..default()
        }
    }

    /// This preset with the hair's stroke settings.
    pub fn with_silhouettes(mut self, silhouettes: Option<&SilhouetteSettings>) -> Self {
        self.silhouettes = silhouettes.cloned();
        self
    }

    /// This preset with the camera's image-space outline.
    pub fn with_outline(mut self, outline: Option<&ImageSpaceOutline>) -> Self {
        self.outline = outline.cloned();
        self
    }

    /// Writes the preset into a hair's settings and material (see
    /// [`ToonMaterialPreset::apply`]).
    pub fn apply(
        &self,
        simulation: &mut HairSimSettings,
        mesh: &mut HairMeshSettings,
        material: &mut ToonHairMaterial,
        ramps: &ToonRamps,
    ) {
        simulation.clone_from(&self.simulation);
        mesh.clone_from(&self.mesh);
        self.material.apply(material, ramps);
    }

    /// The preset as pretty-printed RON.
    ///
    /// # Errors
    ///
    /// [`HairPresetError::Serialize`] if RON cannot express a value.
    pub fn to_ron(&self) -> Result<String, HairPresetError> {
        self.to_ron_named(None)
    }

    fn to_ron_named(&self, file: Option<&str>) -> Result<String, HairPresetError> {
        let registry = preset_registry();
        let serializer = TypedReflectSerializer::new(self, &registry);
        let config = ron::ser::PrettyConfig::new()
            .depth_limit(3)
            .indentor("    ");
        ron::ser::to_string_pretty(&serializer, config).map_err(|e| HairPresetError::Serialize {
            file: file.map(str::to_owned),
            message: e.to_string(),
        })
    }

    /// One of the shipped [`LOOKS`] by name; `None` for an unknown name.
    ///
    /// # Errors
    ///
    /// [`HairPresetError::Parse`] if the shipped file does not parse (a test checks they all do).
    pub fn look(name: &str) -> Option<Result<Self, HairPresetError>> {
        LOOKS.iter().find(|(n, _)| *n == name).map(|(n, text)| {
            Self::from_ron_named(Some(&format!("assets/presets/{n}.preset.ron")), text)
        })
    }

    /// Reads a preset from RON text. Fields left out keep their defaults.
    ///
    /// # Errors
    ///
    /// [`HairPresetError::Parse`] with the line, column and problem (and no file).
    pub fn from_ron(text: &str) -> Result<Self, HairPresetError> {
        Self::from_ron_named(None, text)
    }

    /// Like [`HairPreset::from_ron`], and what was migrated: a preset of an earlier format
    /// (see [`PRESET_FORMAT`]) is brought up to this one, and the [`PresetMigration`] names
    /// every field that moved. [`HairPreset::load`] logs it as a warning.
    ///
    /// # Errors
    ///
    /// As [`HairPreset::from_ron`]; a preset of a newer format than this crate reads is an
    /// error that says so.
    pub fn from_ron_migrating(
        text: &str,
    ) -> Result<(Self, Option<PresetMigration>), HairPresetError> {
        Self::read(None, text)
    }

    fn from_ron_named(file: Option<&str>, text: &str) -> Result<Self, HairPresetError> {
        let (preset, migration) = Self::read(file, text)?;
        if let Some(m) = migration.filter(|m| !m.moved.is_empty()) {
            warn!(
                "{}preset format {} read as format {PRESET_FORMAT}: {}; save it again to \
                 write the current format",
                file_label(&file.map(str::to_owned)),
                m.from,
                m.moved.join(", ")
            );
        }
        Ok(preset)
    }

    fn read(
        file: Option<&str>,
        text: &str,
    ) -> Result<(Self, Option<PresetMigration>), HairPresetError> {
        let located = |offset: usize, message: String| {
            let before = &text[..offset.min(text.len())];
            HairPresetError::Parse {
                file: file.map(str::to_owned),
                line: before.matches('\n').count() + 1,
                column: before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1,
                message,
            }
        };
        let (text, migration) =
            migrate::migrate(text).map_err(|(offset, message)| located(offset, message))?;
        let registry = preset_registry();
        let registration = HairPreset::get_type_registration();
        let seed = TypedReflectDeserializer::new(&registration, &registry);
        let moved = migration.as_ref().is_some_and(|m| !m.moved.is_empty());
        let value = ron::Options::default()
            .from_str_seed(&text, seed)
            .map_err(|e| HairPresetError::Parse {
                file: file.map(str::to_owned),
                line: e.span.start.line,
                column: e.span.start.col,
                message: if moved {
                    format!("{} (in `material`, after moving its shading fields into `material.shading`)", e.code)
                } else {
                    e.code.to_string()
                },
            })?;
        let mut preset = HairPreset::from_reflect(value.as_partial_reflect()).ok_or_else(|| {
            HairPresetError::Parse {
                file: file.map(str::to_owned),
                line: 1,
                column: 1,
                message: "the file does not describe a HairPreset".to_owned(),
            }
        })?;
        preset.format = PRESET_FORMAT;
        Ok((preset, migration))
    }

    /// Saves the preset as a RON file, replacing any file at `path`.
    ///
    /// # Errors
    ///
    /// [`HairPresetError::Io`] naming the file if it cannot be written.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), HairPresetError> {
        let path = path.as_ref();
        let text = self.to_ron_named(Some(&path.display().to_string()))?;
        std::fs::write(path, text + "\n").map_err(|source| HairPresetError::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// Loads a preset from a RON file.
    ///
    /// # Errors
    ///
    /// [`HairPresetError::Io`] if the file cannot be read, [`HairPresetError::Parse`] naming the
    /// file, line and column if it is not a valid preset.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, HairPresetError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| HairPresetError::Io {
            path: path.to_owned(),
            source,
        })?;
        Self::from_ron_named(Some(&path.display().to_string()), &text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curve::QuadraticCurve;
    use crate::render::HatchingMode;

    fn tuned() -> HairPreset {
        HairPreset {
            format: PRESET_FORMAT,
            simulation: HairSimSettings {
                edge_stiffness: 0.9,
                anchor_stiffness: QuadraticCurve::new(0.1, -0.3, 0.6),
                gravity: Vec3::new(0.5, -4.0, 0.0),
                margin_seed: 42,
                ..default()
            },
            mesh: HairMeshSettings {
                hair_resolution: 24,
                shape_resolution: 5,
                taper: QuadraticCurve::linear(1.0, 0.1),
                ..default()
            },
            material: ToonMaterialPreset {
                ramp: RampKind::Specular,
                shading: ToonShading {
                    base_color: Color::srgb(0.98, 0.62, 0.12),
                    ramp_mode: RampMode::Specular,
                    hatching: HatchingMode::Surface,
                    hatch_scale: 2.5,
                    specular_color: Color::linear_rgba(0.2, 0.3, 0.4, 1.0),
                    ..default()
                },
            },
            silhouettes: Some(SilhouetteSettings {
                width_px: 4.5,
                fade: QuadraticCurve::new(0.5, 0.2, 0.1),
                color: Color::srgb(0.2, 0.1, 0.3),
                ..default()
            }),
            outline: Some(ImageSpaceOutline {
                enabled: false,
                threshold: 0.45,
                dilation_x: 3,
                source: crate::render::OutlineSource::Depth,
                ..default()
            }),
        }
    }

    #[test]
    fn round_trips_through_ron_text() {
        let preset = tuned();
        let text = preset.to_ron().unwrap();
        assert!(text.contains("hair_resolution: 24"), "{text}");
        assert!(text.contains("width_px: 4.5"), "{text}");
        assert!(text.contains("dilation_x: 3"), "{text}");
        assert_eq!(HairPreset::from_ron(&text).unwrap(), preset);
    }

    #[test]
    fn round_trips_through_a_file() {
        let path = std::env::temp_dir().join(format!(
            "bevy_cartoon_hair_preset_{}.ron",
            std::process::id()
        ));
        let preset = tuned();
        preset.save(&path).unwrap();
        let back = HairPreset::load(&path);
        let _ = std::fs::remove_file(&path);
        assert_eq!(back.unwrap(), preset);
    }

    #[test]
    fn missing_fields_keep_their_defaults() {
        let preset = HairPreset::from_ron("(mesh: (hair_resolution: 9))").unwrap();
        assert_eq!(preset.mesh.hair_resolution, 9);
        assert_eq!(preset.mesh.shape_resolution, 8);
        assert_eq!(preset.simulation, HairSimSettings::default());
        // Presets older than the outline fields leave strokes and outline alone.
        assert_eq!((preset.silhouettes, preset.outline), (None, None));
    }

    #[test]
    fn malformed_presets_are_errors_naming_file_place_and_problem() {
        let unknown = HairPreset::from_ron("(\n  mesh: (hair_rezolution: 9),\n)").unwrap_err();
        let text = unknown.to_string();
        assert!(text.starts_with("2:"), "{text}");
        assert!(text.contains("hair_rezolution"), "{text}");

        let wrong_type = HairPreset::from_ron("(mesh: (hair_resolution: \"many\"))").unwrap_err();
        assert!(
            matches!(wrong_type, HairPresetError::Parse { .. }),
            "{wrong_type}"
        );

        let syntax = HairPreset::from_ron("(simulation: (damping: 2.0,").unwrap_err();
        assert!(matches!(syntax, HairPresetError::Parse { .. }), "{syntax}");

        let path = std::env::temp_dir().join(format!(
            "bevy_cartoon_hair_bad_preset_{}.ron",
            std::process::id()
        ));
        std::fs::write(&path, "(material: (ramp: Rainbow))").unwrap();
        let bad_file = HairPreset::load(&path).unwrap_err().to_string();
        let _ = std::fs::remove_file(&path);
        assert!(
            bad_file.starts_with(&path.display().to_string()),
            "{bad_file}"
        );
        assert!(bad_file.contains("Rainbow"), "{bad_file}");

        let missing = HairPreset::load("/nonexistent/dir/x.preset.ron").unwrap_err();
        assert!(matches!(missing, HairPresetError::Io { .. }), "{missing}");
        assert!(
            missing
                .to_string()
                .contains("/nonexistent/dir/x.preset.ron")
        );
    }

    #[test]
    fn applying_a_preset_sets_the_matching_ramp() {
        let mut images = Assets::<Image>::default();
        let ramps = ToonRamps::generate(&mut images);
        let preset = tuned();
        let mut sim = HairSimSettings::default();
        let mut mesh = HairMeshSettings::default();
        let mut material = ToonHairMaterial::default();
        preset.apply(&mut sim, &mut mesh, &mut material, &ramps);
        assert_eq!(material.ramp, ramps.specular);
        let back = HairPreset::new(&sim, &mesh, &material, Some(&ramps))
            .with_silhouettes(preset.silhouettes.as_ref())
            .with_outline(preset.outline.as_ref());
        assert_eq!(back, preset);
    }

    #[test]
    fn the_shipped_looks_load_and_differ() {
        use crate::render::{HatchingMode, ToonLighting};
        let look = |name| HairPreset::look(name).expect("shipped").unwrap();
        let (thesis, anime, sketch) = (look("thesis"), look("clean_anime"), look("sketch"));
        assert!(HairPreset::look("nope").is_none());
        // The thesis's user study: depth detail on, Blinn specular on, back light off,
        // thick unfaded strokes.
        assert_eq!(thesis.material.ramp_mode, RampMode::Depth);
        assert!(thesis.material.specular_strength > 0.0);
        assert_eq!(thesis.material.back_light_strength, 0.0);
        let strokes = thesis.silhouettes.clone().unwrap();
        assert!(strokes.width_px >= 4.0);
        assert_eq!(strokes.fade, QuadraticCurve::constant(1.0));
        assert_eq!(anime.material.lighting, ToonLighting::Scene);
        assert_eq!(sketch.material.hatching, HatchingMode::Surface);
        assert!(thesis != anime && anime != sketch && sketch != thesis);
    }

    #[test]
    fn presets_of_every_earlier_format_load() {
        // 0.1.0's shipped thesis look: no `format`, shading already nested; nothing moves.
        let (old, report) = HairPreset::from_ron_migrating(include_str!(
            "../../tests/fixtures/presets/format1_thesis_0.1.0.preset.ron"
        ))
        .unwrap();
        assert_eq!(
            report.as_ref().map(|r| (r.from, r.moved.len())),
            Some((1, 0))
        );
        assert_eq!(old, HairPreset::look("thesis").unwrap().unwrap());
        assert_eq!(old.format, PRESET_FORMAT);
        // The first 0.1 builds: shading fields directly in `material`. They move, each named.
        let (flat, report) = HairPreset::from_ron_migrating(include_str!(
            "../../tests/fixtures/presets/format1_flat_material.preset.ron"
        ))
        .unwrap();
        let report = report.unwrap();
        assert_eq!(report.from, 1);
        assert_eq!(report.moved.len(), 13, "{:?}", report.moved);
        assert!(
            report
                .moved
                .contains(&"material.ramp_mode moved to material.shading.ramp_mode".to_owned())
        );
        let tuned = tuned();
        assert_eq!(flat.material.ramp, RampKind::Specular);
        assert_eq!(flat.material.shading, tuned.material.shading);
        assert_eq!(flat.simulation, tuned.simulation);
        assert_eq!(flat.silhouettes, tuned.silhouettes);
        // Saved again, it is the current format and reads back without a migration.
        let text = flat.to_ron().unwrap();
        assert!(text.trim_start().starts_with("(\n    format: 2,"), "{text}");
        let (back, report) = HairPreset::from_ron_migrating(&text).unwrap();
        assert_eq!((back, report), (flat, None));
    }

    #[test]
    fn newer_or_contradictory_presets_fail_naming_the_field() {
        let e = HairPreset::from_ron_migrating("(\n    format: 7,\n)").unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("2:13: preset format 7 is newer"), "{text}");
        let e = HairPreset::from_ron_migrating(
            "(material: (ramp: Depth, ramp_mode: Depth, shading: (z_min: 2.0)))",
        )
        .unwrap_err();
        assert!(e.to_string().contains("material.ramp_mode"), "{e}");
        // An unknown field of a migrated material is named, with what was done to it.
        let e =
            HairPreset::from_ron_migrating("(material: (ramp: Depth, sparkle: 1.0))").unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("sparkle") && text.contains("material.shading"),
            "{text}"
        );
    }
}
