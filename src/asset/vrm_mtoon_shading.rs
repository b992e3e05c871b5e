//! Where a VRM file's MToon materials turn from their shade colour to their base colour: VRM
//! 1.0's `shadingShiftFactor` and `shadingToonyFactor` on each glTF material's
//! `VRMC_materials_mtoon`, or VRM 0.x's `_ShadeShift` and `_ShadeToony` in
//! `extensions.VRM.materialProperties` (the entry at the material's index, shader `VRM/MToon`),
//! converted to VRM 1.0's terms as UniVRM's migration converts them.
//!
//! MToon 1.0 shades with `linearstep(-1 + toony, 1 - toony, N.L + shift)`: the shade colour below
//! that band of `N.L`, the base colour above it, blended across it. An MToon material whose
//! factors are absent takes the specification's defaults (shift 0, toony 0.9); a material of
//! another shader gets none. What is read goes on each mesh entity as a [`VrmShading`].
//!
//! The JSON is hostile input: every number is checked against the range the specification gives
//! it, and an error names the file, the JSON path and what to do; a material with an error gets
//! no shading band, the others keep theirs.

use bevy::gltf::gltf;
use bevy::prelude::*;
use serde_json::Value;

use super::vrm::VrmError;
use super::vrm_mtoon::{Fields, error, object, per_material, v0_mtoon, v0_section};

/// On a mesh entity of a VRM scene whose glTF material is MToon: where its shading turns from
/// the shade colour to the base colour, in VRM 1.0's terms (see [`VrmShading::lit_band`]).
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub struct VrmShading {
    /// `shadingShiftFactor`, in `[-1, 1]`: added to `N.L` before the step, so a negative shift
    /// moves the shade toward the light. Default: `0`.
    pub shift: f32,
    /// `shadingToonyFactor`, in `[0, 1]`: how hard the step is, from a gradient across the
    /// whole sphere (`0`) to a hard line (`1`). Default: `0.9`.
    pub toony: f32,
}

impl Default for VrmShading {
    fn default() -> Self {
        Self {
            shift: 0.0,
            toony: 0.9,
        }
    }
}

impl VrmShading {
    /// The band of `N.L` (the cosine between the surface normal and the light) over which MToon
    /// blends from the shade colour (below it) to the base colour (above it):
    /// `(-1 + toony - shift, 1 - toony - shift)`. Zero wide when `toony` is 1.
    pub fn lit_band(&self) -> (f32, f32) {
        (
            -1.0 + self.toony - self.shift,
            1.0 - self.toony - self.shift,
        )
    }

    /// VRM 0.x MToon's `_ShadeShift` and `_ShadeToony` in VRM 1.0's terms. VRM 0.x blends from
    /// shade to lit over `N.L` from `shift` to `lerp(1, shift, toony)`; the VRM 1.0 factors
    /// whose band is the same (UniVRM's migration): the defaults `(0, 0.9)` become a shift of
    /// `-0.05` and a toony factor of `0.95`.
    pub fn from_v0(shade_shift: f32, shade_toony: f32) -> Self {
        let low = shade_shift;
        let high = 1.0 + (shade_shift - 1.0) * shade_toony;
        Self {
            shift: -(low + high) * 0.5,
            toony: ((2.0 - (high - low)) * 0.5).clamp(0.0, 1.0),
        }
    }
}

/// The shading band of each material of `document`, by material index (`None` for materials
/// that are not MToon or have an error), and what is wrong with the materials that have one.
pub fn parse_vrm_shading(
    file: &str,
    document: &gltf::Document,
) -> (Vec<Option<VrmShading>>, Vec<VrmError>) {
    per_material(file, document, shading_v1, shading_v0)
}

/// VRM 1.0: `materials[i].extensions.VRMC_materials_mtoon`'s two factors, each defaulted.
fn shading_v1(file: &str, i: usize, mtoon: &Value) -> Result<Option<VrmShading>, VrmError> {
    let path = format!("materials[{i}].extensions.VRMC_materials_mtoon");
    let mtoon = object(file, &path, mtoon)?;
    let defaults = VrmShading::default();
    let shift = factor(file, &path, mtoon, "shadingShiftFactor", (-1.0, 1.0))?;
    let toony = factor(file, &path, mtoon, "shadingToonyFactor", (0.0, 1.0))?;
    Ok(Some(VrmShading {
        shift: shift.unwrap_or(defaults.shift),
        toony: toony.unwrap_or(defaults.toony),
    }))
}

/// VRM 0.x: `extensions.VRM.materialProperties[i]` with shader `VRM/MToon`: its
/// `floatProperties._ShadeShift` (default 0) and `_ShadeToony` (default 0.9), converted.
fn shading_v0(file: &str, i: usize, properties: &Value) -> Result<Option<VrmShading>, VrmError> {
    let Some((path, properties)) = v0_mtoon(file, i, properties)? else {
        return Ok(None);
    };
    let (shift, toony) = match v0_section(file, &path, properties, "floatProperties")? {
        None => (None, None),
        Some((path, floats)) => (
            factor(file, &path, floats, "_ShadeShift", (-1.0, 1.0))?,
            factor(file, &path, floats, "_ShadeToony", (0.0, 1.0))?,
        ),
    };
    Ok(Some(VrmShading::from_v0(
        shift.unwrap_or(0.0),
        toony.unwrap_or(0.9),
    )))
}

/// `object[key]`: absent, or a number in `[low, high]`.
pub(super) fn factor(
    file: &str,
    path: &str,
    object: &Fields,
    key: &str,
    (low, high): (f32, f32),
) -> Result<Option<f32>, VrmError> {
    let Some(v) = object.get(key) else {
        return Ok(None);
    };
    let path = format!("{path}.{key}");
    match v.as_f64().map(|x| x as f32) {
        Some(x) if (low..=high).contains(&x) => Ok(Some(x)),
        Some(x) => Err(error(
            file,
            &path,
            format!("{x} is outside [{low}, {high}]; fix the material in the VRM exporter"),
        )),
        None => Err(error(
            file,
            &path,
            format!("expected a number, found {}", super::vrm::kind(v)),
        )),
    }
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;
    use crate::asset::vrm_mtoon::tests::{
        assert_located, document, random_document, random_factor,
    };

    fn near(a: (f32, f32), b: (f32, f32)) -> bool {
        (a.0 - b.0).abs() < 1e-6 && (a.1 - b.1).abs() < 1e-6
    }

    /// The band MToon 1.0's formula gives, by hand: shift -0.5 and toony 0.9 blend over `N.L`
    /// from 0.4 to 0.6; toony 0 over the whole sphere, moved by the shift; toony 1 is a line.
    #[test]
    fn the_lit_band_is_mtoons_linearstep() {
        let band = |shift, toony| VrmShading { shift, toony }.lit_band();
        assert!(near(band(-0.5, 0.9), (0.4, 0.6)), "{:?}", band(-0.5, 0.9));
        assert!(near(band(0.0, 0.9), (-0.1, 0.1)));
        assert!(near(band(0.25, 0.0), (-1.25, 0.75)));
        assert!(near(band(-0.3, 1.0), (0.3, 0.3)));
    }

    /// VRM 0.x's factors converted as UniVRM converts them (its migration tests' figures: the
    /// 0.x defaults, Lambert), and the band is the 0.x one: from `shift` to
    /// `lerp(1, shift, toony)`.
    #[test]
    fn vrm_0_factors_keep_their_band() {
        let d = VrmShading::from_v0(0.0, 0.9);
        assert!(
            (d.toony - 0.95).abs() < 1e-6 && (d.shift + 0.05).abs() < 1e-6,
            "{d:?}"
        );
        let lambert = VrmShading::from_v0(0.0, 0.0);
        assert!((lambert.toony - 0.5).abs() < 1e-6 && (lambert.shift + 0.5).abs() < 1e-6);
        for (shift, toony) in [
            (0.0, 0.9),
            (-0.4, 0.5),
            (0.3, 0.99),
            (-1.0, 0.0),
            (1.0, 1.0),
        ] {
            let band = VrmShading::from_v0(shift, toony).lit_band();
            let expected = (shift, 1.0 + (shift - 1.0) * toony);
            assert!(
                near(band, expected),
                "{shift} {toony}: {band:?} {expected:?}"
            );
        }
    }

    /// VRM 1.0: each MToon material's own factors, a missing one at the specification's
    /// default; a material without the extension has none.
    #[test]
    fn a_vrm_1_material_gives_its_factors() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"shadingShiftFactor":-0.5,
                 "shadingToonyFactor":0.75}}},
                {"name":"plain"},
                {"extensions":{"VRMC_materials_mtoon":{"shadingToonyFactor":1}}},
                {"extensions":{"VRMC_materials_mtoon":{"specVersion":"1.0"}}}]"#,
            "{}",
        );
        let (bands, errors) = parse_vrm_shading("a.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(
            bands,
            vec![
                Some(VrmShading {
                    shift: -0.5,
                    toony: 0.75
                }),
                None,
                Some(VrmShading {
                    shift: 0.0,
                    toony: 1.0
                }),
                Some(VrmShading::default()),
            ]
        );
    }

    /// VRM 0.x: the entry at the material's index, MToon only, converted; missing factors (or
    /// no `floatProperties`) at the 0.x defaults; the VRM 1.0 extension wins.
    #[test]
    fn a_vrm_0_material_gives_its_factors_by_index() {
        let d = document(
            r#"[{"name":"skin"},{"name":"hair"},{"name":"eyes"},
                {"extensions":{"VRMC_materials_mtoon":{"shadingShiftFactor":0.2}}}]"#,
            r#"{"VRM":{"materialProperties":[
                {"shader":"VRM/MToon","floatProperties":{"_ShadeShift":-0.4,"_ShadeToony":0.5}},
                {"shader":"VRM/MToon"},
                {"shader":"VRM/UnlitTexture","floatProperties":{"_ShadeShift":0.5}},
                {"shader":"VRM/MToon","floatProperties":{"_ShadeShift":0.9}}]}}"#,
        );
        let (bands, errors) = parse_vrm_shading("old.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(bands[0], Some(VrmShading::from_v0(-0.4, 0.5)));
        assert_eq!(bands[1], Some(VrmShading::from_v0(0.0, 0.9)));
        assert_eq!(bands[2], None);
        assert_eq!(
            bands[3],
            Some(VrmShading {
                shift: 0.2,
                toony: 0.9
            })
        );
    }

    /// Hostile values: each error names the file and the JSON path; that material gets no band,
    /// the others keep theirs.
    #[test]
    fn bad_factors_are_errors_naming_their_path() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"shadingShiftFactor":-1.5}}},
                {"extensions":{"VRMC_materials_mtoon":{"shadingToonyFactor":"hard"}}},
                {"extensions":{"VRMC_materials_mtoon":{"shadingToonyFactor":1.01}}},
                {"extensions":{"VRMC_materials_mtoon":{"shadingShiftFactor":-1}}},
                {}, {}]"#,
            r#"{"VRM":{"materialProperties":[{},{},{},{},
                {"shader":"VRM/MToon","floatProperties":{"_ShadeToony":-0.1}},
                {"shader":"VRM/MToon","floatProperties":[0.1]}]}}"#,
        );
        let (bands, errors) = parse_vrm_shading("bad.vrm", &d);
        let messages: Vec<String> = errors.iter().map(ToString::to_string).collect();
        assert_eq!(
            messages,
            [
                "bad.vrm: materials[0].extensions.VRMC_materials_mtoon.shadingShiftFactor: -1.5 \
                 is outside [-1, 1]; fix the material in the VRM exporter",
                "bad.vrm: materials[1].extensions.VRMC_materials_mtoon.shadingToonyFactor: \
                 expected a number, found a string",
                "bad.vrm: materials[2].extensions.VRMC_materials_mtoon.shadingToonyFactor: 1.01 \
                 is outside [0, 1]; fix the material in the VRM exporter",
                "bad.vrm: extensions.VRM.materialProperties[4].floatProperties._ShadeToony: -0.1 \
                 is outside [0, 1]; fix the material in the VRM exporter",
                "bad.vrm: extensions.VRM.materialProperties[5].floatProperties: expected an \
                 object, found an array",
            ]
        );
        assert_eq!(bands[..3], [None, None, None]);
        assert_eq!(
            bands[3],
            Some(VrmShading {
                shift: -1.0,
                toony: 0.9
            })
        );
        assert_eq!(bands[4..], [None, None]);
    }

    /// Random MToon extensions and 0.x entries, 2,000 documents: no panic, one entry per
    /// material, every band's factors within their ranges, every error located.
    #[test]
    fn random_materials_give_bands_in_range_or_located_errors() {
        let mut rng = crate::test_support::Rng(0x5348_4946_5421);
        let number = |rng: &mut crate::test_support::Rng| random_factor(rng, 4.0, 2.0);
        let (mut found, mut failed) = (0, 0);
        for _ in 0..2_000 {
            let (d, count) = random_document(
                &mut rng,
                |rng| json!({"shadingShiftFactor": number(rng), "shadingToonyFactor": number(rng)}),
                |rng| {
                    json!({"shader": "VRM/MToon", "floatProperties": {
                        "_ShadeShift": number(rng), "_ShadeToony": number(rng)}})
                },
            );
            let (bands, errors) = parse_vrm_shading("r.vrm", &d);
            assert_eq!(bands.len(), count);
            for b in bands.iter().flatten() {
                assert!((-1.0..=1.0).contains(&b.shift), "{b:?}");
                assert!((0.0..=1.0).contains(&b.toony), "{b:?}");
                let (lo, hi) = b.lit_band();
                assert!(lo.is_finite() && hi.is_finite() && lo <= hi + 1e-6, "{b:?}");
                found += 1;
            }
            assert_located(&errors, "r.vrm");
            failed += errors.len();
        }
        assert!(found > 100 && failed > 300, "{found} {failed}");
    }
}
