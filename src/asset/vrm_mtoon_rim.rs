//! The parametric rim light of a VRM file's MToon materials: VRM 1.0's
//! `parametricRimColorFactor`, `parametricRimFresnelPowerFactor`, `parametricRimLiftFactor` and
//! `rimLightingMixFactor` on each glTF material's `VRMC_materials_mtoon`, or VRM 0.x's
//! `_RimColor` (sRGB), `_RimFresnelPower`, `_RimLift` and `_RimLightingMix` in
//! `extensions.VRM.materialProperties` (the entry at the material's index, shader `VRM/MToon`).
//! Both versions draw the rim with the same formula, so the 0.x values are taken as they are;
//! only their defaults differ (a 0.x rim fades with power 1 and glows unlit).
//!
//! MToon adds `colour * pow(saturate(1 - N.V + lift), power)` to the lit surface: a glow along
//! the silhouette, where the surface turns away from the viewer, times
//! `lerp(1, lighting, mix)`. A material whose rim colour is black (the default) adds nothing
//! and gets none. What is read goes on each mesh entity as a [`VrmRim`].
//!
//! The JSON is hostile input: every number is checked against its range, and an error names
//! the file, the JSON path and what to do; a material with an error gets no rim, the others
//! keep theirs.

use bevy::gltf::gltf;
use bevy::prelude::*;
use serde_json::Value;

use super::vrm::VrmError;
use super::vrm_mtoon::{channels, object, per_material, v0_mtoon, v0_section};
use super::vrm_mtoon_shading::factor;

/// The largest Fresnel power read: past it the rim is thinner than a pixel on any screen.
pub const MAX_RIM_POWER: f32 = 100.0;

/// MToon's parametric rim light: on a mesh entity of a VRM scene whose MToon material has one,
/// and on a cel-shaded surface that draws one
/// ([`FringeShadow::rim`](crate::render::FringeShadow::rim)).
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq, Default)]
pub struct VrmRim {
    /// The rim's colour, added to the surface where it faces away from the viewer (linear; VRM
    /// 0.x's sRGB value converted). Default: black (no rim).
    pub color: Color,
    /// How quickly the rim fades from the silhouette inward, in `[0, 100]`: 1 is a broad glow,
    /// 5 a thin line. Default: `5` (VRM 1.0; VRM 0.x's default is 1).
    pub fresnel_power: f32,
    /// Added to `1 - N.V` before the power, in `[-1, 1]`: above 0 the rim spreads over the
    /// surface, below 0 it shrinks toward the silhouette. Default: `0`.
    pub lift: f32,
    /// How much the rim is lit like the surface, in `[0, 1]`: 0 it glows on its own, whatever
    /// the light; 1 it takes the light's colour and the shade. Default: `1` (VRM 1.0; VRM 0.x's
    /// default is 0).
    pub lighting_mix: f32,
}

impl Default for VrmRim {
    fn default() -> Self {
        Self {
            color: Color::BLACK,
            fresnel_power: 5.0,
            lift: 0.0,
            lighting_mix: 1.0,
        }
    }
}

impl VrmRim {
    /// How much of [`VrmRim::color`] a surface shows where the cosine between its normal and
    /// the direction to the viewer is `n_dot_v`: `pow(saturate(1 - n_dot_v + lift), power)`,
    /// the power at least `1e-5` (MToon's guard against `pow(0, 0)`).
    pub fn strength(&self, n_dot_v: f32) -> f32 {
        (1.0 - n_dot_v + self.lift)
            .clamp(0.0, 1.0)
            .powf(self.fresnel_power.max(1e-5))
    }

    /// Whether the rim adds anything: its colour is not black.
    pub fn is_visible(&self) -> bool {
        let c = self.color.to_linear();
        c.red > 0.0 || c.green > 0.0 || c.blue > 0.0
    }
}

/// The rim light of each material of `document`, by material index (`None` for materials that
/// are not MToon, have a black rim or have an error), and what is wrong with the materials that
/// have an error.
pub fn parse_vrm_rims(
    file: &str,
    document: &gltf::Document,
) -> (Vec<Option<VrmRim>>, Vec<VrmError>) {
    let visible = |rim: Result<Option<VrmRim>, VrmError>| rim.map(|r| r.filter(VrmRim::is_visible));
    per_material(
        file,
        document,
        |f, i, v| visible(rim_v1(f, i, v)),
        |f, i, v| visible(rim_v0(f, i, v)),
    )
}

/// The ranges of the rim's three numbers: power, lift, lighting mix.
const POWER: (f32, f32) = (0.0, MAX_RIM_POWER);
const LIFT: (f32, f32) = (-1.0, 1.0);
const MIX: (f32, f32) = (0.0, 1.0);

/// VRM 1.0: `materials[i].extensions.VRMC_materials_mtoon`'s rim factors, each defaulted.
fn rim_v1(file: &str, i: usize, mtoon: &Value) -> Result<Option<VrmRim>, VrmError> {
    let path = format!("materials[{i}].extensions.VRMC_materials_mtoon");
    let mtoon = object(file, &path, mtoon)?;
    let defaults = VrmRim::default();
    let color = match mtoon.get("parametricRimColorFactor") {
        None => defaults.color,
        Some(v) => {
            let c = channels(file, &format!("{path}.parametricRimColorFactor"), v, 3)?;
            Color::linear_rgb(c[0], c[1], c[2])
        }
    };
    let power = factor(file, &path, mtoon, "parametricRimFresnelPowerFactor", POWER)?;
    let lift = factor(file, &path, mtoon, "parametricRimLiftFactor", LIFT)?;
    let mix = factor(file, &path, mtoon, "rimLightingMixFactor", MIX)?;
    Ok(Some(VrmRim {
        color,
        fresnel_power: power.unwrap_or(defaults.fresnel_power),
        lift: lift.unwrap_or(defaults.lift),
        lighting_mix: mix.unwrap_or(defaults.lighting_mix),
    }))
}

/// VRM 0.x: `extensions.VRM.materialProperties[i]` with shader `VRM/MToon`: its
/// `vectorProperties._RimColor` (sRGB with alpha, default black) and `floatProperties`
/// `_RimFresnelPower` (default 1), `_RimLift` (0) and `_RimLightingMix` (0).
fn rim_v0(file: &str, i: usize, properties: &Value) -> Result<Option<VrmRim>, VrmError> {
    let Some((path, properties)) = v0_mtoon(file, i, properties)? else {
        return Ok(None);
    };
    let color = match v0_section(file, &path, properties, "vectorProperties")? {
        Some((path, vectors)) => match vectors.get("_RimColor") {
            Some(v) => {
                let c = channels(file, &format!("{path}._RimColor"), v, 4)?;
                Some(Color::srgb(c[0], c[1], c[2]))
            }
            None => None,
        },
        None => None,
    };
    let (power, lift, mix) = match v0_section(file, &path, properties, "floatProperties")? {
        None => (None, None, None),
        Some((path, floats)) => (
            factor(file, &path, floats, "_RimFresnelPower", POWER)?,
            factor(file, &path, floats, "_RimLift", LIFT)?,
            factor(file, &path, floats, "_RimLightingMix", MIX)?,
        ),
    };
    Ok(Some(VrmRim {
        color: color.unwrap_or(Color::BLACK),
        fresnel_power: power.unwrap_or(1.0),
        lift: lift.unwrap_or(0.0),
        lighting_mix: mix.unwrap_or(0.0),
    }))
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;
    use crate::asset::vrm_mtoon::tests::{
        assert_located, document, random_document, random_factor,
    };

    fn rim(color: Color, fresnel_power: f32, lift: f32, lighting_mix: f32) -> VrmRim {
        VrmRim {
            color,
            fresnel_power,
            lift,
            lighting_mix,
        }
    }

    /// The rim's strength by hand: facing the viewer none, at the silhouette all; power 2 at
    /// `N.V = 0.5` is a quarter; a lift of 0.5 there reaches all; power 0 is everywhere but
    /// where `1 - N.V + lift` is 0 or less.
    #[test]
    fn the_strength_is_mtoons_fresnel_term() {
        let r = rim(Color::WHITE, 2.0, 0.0, 1.0);
        assert_eq!(r.strength(1.0), 0.0);
        assert_eq!(r.strength(0.0), 1.0);
        assert!((r.strength(0.5) - 0.25).abs() < 1e-6);
        assert_eq!(rim(Color::WHITE, 2.0, 0.5, 1.0).strength(0.5), 1.0);
        assert!((rim(Color::WHITE, 3.0, -0.2, 1.0).strength(0.5) - 0.027).abs() < 1e-6);
        let flat = rim(Color::WHITE, 0.0, 0.0, 1.0);
        assert!(
            (flat.strength(0.9) - 1.0).abs() < 1e-4,
            "{}",
            flat.strength(0.9)
        );
        assert_eq!(flat.strength(1.0), 0.0);
        assert_eq!(rim(Color::WHITE, 5.0, -1.0, 1.0).strength(0.0), 0.0);
    }

    /// VRM 1.0: each MToon material's own factors, a missing one at the specification's
    /// default; a black rim (absent or written) and a material without the extension get none.
    #[test]
    fn a_vrm_1_material_gives_its_rim() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[0.5,0.25,0],
                 "parametricRimFresnelPowerFactor":2,"parametricRimLiftFactor":0.1,
                 "rimLightingMixFactor":0.5}}},
                {"name":"plain"},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[0,0,1]}}},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimFresnelPowerFactor":3}}},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[0,0,0]}}}]"#,
            "{}",
        );
        let (rims, errors) = parse_vrm_rims("a.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(
            rims,
            vec![
                Some(rim(Color::linear_rgb(0.5, 0.25, 0.0), 2.0, 0.1, 0.5)),
                None,
                Some(rim(Color::linear_rgb(0.0, 0.0, 1.0), 5.0, 0.0, 1.0)),
                None,
                None,
            ]
        );
    }

    /// VRM 0.x: the entry at the material's index, MToon only; `_RimColor` sRGB; missing
    /// numbers at the 0.x defaults (power 1, lift 0, lighting mix 0); the VRM 1.0 extension
    /// wins.
    #[test]
    fn a_vrm_0_material_gives_its_rim_by_index() {
        let d = document(
            r#"[{"name":"skin"},{"name":"hair"},{"name":"eyes"},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[1,1,1]}}},
                {"name":"coat"}]"#,
            r#"{"VRM":{"materialProperties":[
                {"shader":"VRM/MToon","vectorProperties":{"_RimColor":[1,0.5,0,1]},
                 "floatProperties":{"_RimFresnelPower":4,"_RimLift":0.2,"_RimLightingMix":1}},
                {"shader":"VRM/MToon","vectorProperties":{"_RimColor":[0.5,0.5,0.5,1]}},
                {"shader":"VRM/UnlitTexture","vectorProperties":{"_RimColor":[1,1,1,1]}},
                {"shader":"VRM/MToon","vectorProperties":{"_RimColor":[1,0,0,1]}},
                {"shader":"VRM/MToon","floatProperties":{"_RimFresnelPower":4}}]}}"#,
        );
        let (rims, errors) = parse_vrm_rims("old.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(
            rims[0],
            Some(rim(Color::srgb(1.0, 0.5, 0.0), 4.0, 0.2, 1.0))
        );
        assert_eq!(
            rims[1],
            Some(rim(Color::srgb(0.5, 0.5, 0.5), 1.0, 0.0, 0.0))
        );
        assert_eq!(rims[2], None);
        assert_eq!(
            rims[3],
            Some(rim(Color::linear_rgb(1.0, 1.0, 1.0), 5.0, 0.0, 1.0))
        );
        assert_eq!(rims[4], None);
    }

    /// Hostile values: each error names the file and the JSON path; that material gets no rim,
    /// the others keep theirs.
    #[test]
    fn bad_rims_are_errors_naming_their_path() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[1,2,0]}}},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[1,1,1],
                 "parametricRimFresnelPowerFactor":1e9}}},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[1,1,1],
                 "rimLightingMixFactor":"lit"}}},
                {"extensions":{"VRMC_materials_mtoon":{"parametricRimColorFactor":[1,1,1],
                 "parametricRimLiftFactor":-1}}},
                {}, {}]"#,
            r#"{"VRM":{"materialProperties":[{},{},{},{},
                {"shader":"VRM/MToon","vectorProperties":{"_RimColor":[1,1,1]}},
                {"shader":"VRM/MToon","vectorProperties":{"_RimColor":[1,1,1,1]},
                 "floatProperties":{"_RimLift":1.5}}]}}"#,
        );
        let (rims, errors) = parse_vrm_rims("bad.vrm", &d);
        let messages: Vec<String> = errors.iter().map(ToString::to_string).collect();
        assert_eq!(
            messages,
            [
                "bad.vrm: materials[0].extensions.VRMC_materials_mtoon.parametricRimColorFactor\
                 [1]: 2 is outside [0, 1]; fix the colour in the VRM exporter",
                "bad.vrm: materials[1].extensions.VRMC_materials_mtoon.\
                 parametricRimFresnelPowerFactor: 1000000000 is outside [0, 100]; fix the \
                 material in the VRM exporter",
                "bad.vrm: materials[2].extensions.VRMC_materials_mtoon.rimLightingMixFactor: \
                 expected a number, found a string",
                "bad.vrm: extensions.VRM.materialProperties[4].vectorProperties._RimColor: \
                 expected an array of 4 numbers, found 3 entries; fix the colour in the VRM \
                 exporter",
                "bad.vrm: extensions.VRM.materialProperties[5].floatProperties._RimLift: 1.5 is \
                 outside [-1, 1]; fix the material in the VRM exporter",
            ]
        );
        assert_eq!(rims[..3], [None, None, None]);
        assert_eq!(rims[3], Some(rim(Color::WHITE, 5.0, -1.0, 1.0)));
        assert_eq!(rims[4..], [None, None]);
    }

    /// Random MToon extensions and 0.x entries, 2,000 documents: no panic, one entry per
    /// material, every rim's numbers within their ranges and visible, every error located.
    #[test]
    fn random_materials_give_rims_in_range_or_located_errors() {
        let mut rng = crate::test_support::Rng(0x5249_4d4c_4954);
        let number = |rng: &mut crate::test_support::Rng| random_factor(rng, 5.0, 150.0);
        let colour = |rng: &mut crate::test_support::Rng, n: usize| -> Value {
            let len = if rng.unit() < 0.8 { n } else { n + 1 };
            Value::Array((0..len).map(|_| json!(rng.unit() * 1.2)).collect())
        };
        let (mut found, mut failed) = (0, 0);
        for _ in 0..2_000 {
            let (d, count) = random_document(
                &mut rng,
                |rng| {
                    json!({"parametricRimColorFactor": colour(rng, 3),
                        "parametricRimFresnelPowerFactor": number(rng),
                        "parametricRimLiftFactor": number(rng),
                        "rimLightingMixFactor": number(rng)})
                },
                |rng| {
                    json!({"shader": "VRM/MToon",
                        "vectorProperties": {"_RimColor": colour(rng, 4)},
                        "floatProperties": {"_RimFresnelPower": number(rng),
                            "_RimLift": number(rng), "_RimLightingMix": number(rng)}})
                },
            );
            let (rims, errors) = parse_vrm_rims("r.vrm", &d);
            assert_eq!(rims.len(), count);
            for r in rims.iter().flatten() {
                assert!(r.is_visible(), "{r:?}");
                assert!((0.0..=MAX_RIM_POWER).contains(&r.fresnel_power), "{r:?}");
                assert!((-1.0..=1.0).contains(&r.lift), "{r:?}");
                assert!((0.0..=1.0).contains(&r.lighting_mix), "{r:?}");
                for n_dot_v in [-1.0, 0.0, 0.5, 1.0] {
                    assert!((0.0..=1.0).contains(&r.strength(n_dot_v)), "{r:?}");
                }
                found += 1;
            }
            assert_located(&errors, "r.vrm");
            failed += errors.len();
        }
        assert!(found > 50 && failed > 300, "{found} {failed}");
    }
}
