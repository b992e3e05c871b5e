//! The shade colours of a VRM file's MToon materials: `VRMC_materials_mtoon.shadeColorFactor`
//! (VRM 1.0, linear) on each glTF material, or VRM 0.x's `_ShadeColor` (sRGB) in
//! `extensions.VRM.materialProperties`, the entry at the material's index, for materials whose
//! shader is `VRM/MToon`.
//!
//! MToon draws a surface in two colours, its base colour where lit and its shade colour where
//! the light turns away; Bevy's glTF loader keeps only the base colour. What is read here goes
//! on each mesh entity as a [`VrmShadeColor`], for the render side to paint the dark tones
//! with. A material without a shade colour (another shader, no extension, or no
//! `shadeColorFactor`: the specification's text and its schema give different defaults, so an
//! absent factor is taken as unsaid) gets none.
//!
//! The JSON is hostile input: the materials' entries are bounded, every number is checked
//! against `[0, 1]`, and an error names the file, the JSON path and what to do; a material with
//! an error gets no shade colour, the others keep theirs.

use bevy::gltf::gltf;
use bevy::prelude::*;
use serde_json::Value;

use super::vrm::VrmError;

/// Most entries of VRM 0.x `materialProperties` read.
pub const MAX_VRM_MATERIALS: usize = 4096;

/// On a mesh entity of a VRM scene whose glTF material is MToon with a shade colour: that
/// colour (the colour MToon draws where the light turns away, before its texture).
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub struct VrmShadeColor(pub Color);

/// The shade colour of each material of `document`, by material index, and what is wrong with
/// the materials that have an error.
pub fn parse_vrm_shade_colors(
    file: &str,
    document: &gltf::Document,
) -> (Vec<Option<Color>>, Vec<VrmError>) {
    per_material(file, document, shade_v1, shade_v0)
}

/// What each material of `document` gives, by material index: read by `v1` from its
/// `VRMC_materials_mtoon` extension, else by `v0` from its VRM 0.x `materialProperties` entry
/// (`(file, material index, JSON)`); a material with an error gives `None`, and the errors
/// are returned beside.
pub(super) fn per_material<T>(
    file: &str,
    document: &gltf::Document,
    v1: impl Fn(&str, usize, &Value) -> Result<Option<T>, VrmError>,
    v0: impl Fn(&str, usize, &Value) -> Result<Option<T>, VrmError>,
) -> (Vec<Option<T>>, Vec<VrmError>) {
    let mut errors = Vec::new();
    let properties = v0_material_properties(file, document, &mut errors);
    let found = document
        .materials()
        .enumerate()
        .map(|(i, m)| {
            let found = match m.extension_value("VRMC_materials_mtoon") {
                Some(mtoon) => v1(file, i, mtoon),
                None => properties.get(i).map_or(Ok(None), |p| v0(file, i, p)),
            };
            found.unwrap_or_else(|e| {
                errors.push(e);
                None
            })
        })
        .collect();
    (found, errors)
}

/// VRM 0.x's `extensions.VRM.materialProperties` of `document` (empty when absent); too many
/// entries, or not an array, is an error in `errors` and nothing is read from them.
fn v0_material_properties<'d>(
    file: &str,
    document: &'d gltf::Document,
    errors: &mut Vec<VrmError>,
) -> &'d [Value] {
    let v0 = document
        .extension_value("VRM")
        .and_then(|vrm| vrm.get("materialProperties"));
    match v0 {
        None => &[][..],
        Some(Value::Array(a)) if a.len() <= MAX_VRM_MATERIALS => a.as_slice(),
        Some(Value::Array(a)) => {
            errors.push(error(
                file,
                "extensions.VRM.materialProperties",
                format!(
                    "{} entries, more than the {MAX_VRM_MATERIALS} read; merge materials",
                    a.len()
                ),
            ));
            &[][..]
        }
        Some(other) => {
            errors.push(error(
                file,
                "extensions.VRM.materialProperties",
                format!("expected an array, found {}", super::vrm::kind(other)),
            ));
            &[][..]
        }
    }
}

pub(super) fn error(file: &str, path: &str, message: impl Into<String>) -> VrmError {
    VrmError {
        file: file.to_owned(),
        path: path.to_owned(),
        message: message.into(),
    }
}

pub(super) fn object<'v>(
    file: &str,
    path: &str,
    v: &'v Value,
) -> Result<&'v serde_json::Map<String, Value>, VrmError> {
    v.as_object().ok_or_else(|| {
        error(
            file,
            path,
            format!("expected an object, found {}", super::vrm::kind(v)),
        )
    })
}

/// A JSON object's fields.
pub(super) type Fields = serde_json::Map<String, Value>;

/// VRM 0.x: `extensions.VRM.materialProperties[i]` with its JSON path, when it is an object
/// whose shader is `VRM/MToon` (`None` for another shader).
pub(super) fn v0_mtoon<'v>(
    file: &str,
    i: usize,
    properties: &'v Value,
) -> Result<Option<(String, &'v Fields)>, VrmError> {
    let path = format!("extensions.VRM.materialProperties[{i}]");
    let properties = object(file, &path, properties)?;
    let mtoon = properties.get("shader").and_then(Value::as_str) == Some("VRM/MToon");
    Ok(mtoon.then_some((path, properties)))
}

/// `properties[key]` (a VRM 0.x entry's `floatProperties` or `vectorProperties`, the entry at
/// `path`) as an object, with its JSON path; `None` when absent.
pub(super) fn v0_section<'v>(
    file: &str,
    path: &str,
    properties: &'v Fields,
    key: &str,
) -> Result<Option<(String, &'v Fields)>, VrmError> {
    let Some(v) = properties.get(key) else {
        return Ok(None);
    };
    let path = format!("{path}.{key}");
    let section = object(file, &path, v)?;
    Ok(Some((path, section)))
}

/// VRM 1.0: `materials[i].extensions.VRMC_materials_mtoon.shadeColorFactor`, linear RGB.
fn shade_v1(file: &str, i: usize, mtoon: &Value) -> Result<Option<Color>, VrmError> {
    let path = format!("materials[{i}].extensions.VRMC_materials_mtoon");
    let mtoon = object(file, &path, mtoon)?;
    let Some(factor) = mtoon.get("shadeColorFactor") else {
        return Ok(None);
    };
    let c = channels(file, &format!("{path}.shadeColorFactor"), factor, 3)?;
    Ok(Some(Color::linear_rgb(c[0], c[1], c[2])))
}

/// VRM 0.x: `extensions.VRM.materialProperties[i]` with shader `VRM/MToon`: its
/// `vectorProperties._ShadeColor`, sRGB with alpha (as Unity stores a colour).
fn shade_v0(file: &str, i: usize, properties: &Value) -> Result<Option<Color>, VrmError> {
    let Some((path, properties)) = v0_mtoon(file, i, properties)? else {
        return Ok(None);
    };
    let Some(vectors) = properties.get("vectorProperties") else {
        return Ok(None);
    };
    let Some(shade) = vectors.get("_ShadeColor") else {
        return Ok(None);
    };
    let c = channels(
        file,
        &format!("{path}.vectorProperties._ShadeColor"),
        shade,
        4,
    )?;
    Ok(Some(Color::srgb(c[0], c[1], c[2])))
}

/// `n` numbers in `[0, 1]`.
pub(super) fn channels(file: &str, path: &str, v: &Value, n: usize) -> Result<Vec<f32>, VrmError> {
    let Some(a) = v.as_array().filter(|a| a.len() == n) else {
        return Err(error(
            file,
            path,
            format!(
                "expected an array of {n} numbers, found {}; fix the colour in the VRM exporter",
                match v.as_array() {
                    Some(a) => format!("{} entries", a.len()),
                    None => super::vrm::kind(v).to_owned(),
                }
            ),
        ));
    };
    a.iter()
        .enumerate()
        .map(|(k, c)| {
            let x = c.as_f64().map(|x| x as f32);
            match x {
                Some(x) if (0.0..=1.0).contains(&x) => Ok(x),
                Some(x) => Err(error(
                    file,
                    &format!("{path}[{k}]"),
                    format!("{x} is outside [0, 1]; fix the colour in the VRM exporter"),
                )),
                None => Err(error(
                    file,
                    &format!("{path}[{k}]"),
                    format!("expected a number, found {}", super::vrm::kind(c)),
                )),
            }
        })
        .collect()
}

#[cfg(test)]
pub(super) mod tests {
    use serde_json::json;

    use super::*;

    /// A document with these materials (JSON) and root extensions.
    pub(in crate::asset) fn document(materials: &str, extensions: &str) -> gltf::Document {
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"materials":{materials},"extensions":{extensions}}}"#
        );
        gltf::Gltf::from_slice(json.as_bytes())
            .expect("test document")
            .document
    }

    fn close(a: Option<Color>, b: Color) -> bool {
        a.is_some_and(|a| {
            let (a, b) = (a.to_linear(), b.to_linear());
            (a.red - b.red).abs() < 1e-6
                && (a.green - b.green).abs() < 1e-6
                && (a.blue - b.blue).abs() < 1e-6
        })
    }

    /// VRM 1.0: each material's own extension, linear; a material without the extension, or
    /// with it but no `shadeColorFactor`, has none.
    #[test]
    fn a_vrm_1_material_gives_its_linear_shade_colour() {
        let d = document(
            r#"[{"name":"hair","extensions":{"VRMC_materials_mtoon":{"specVersion":"1.0",
                 "shadeColorFactor":[0.25,0.5,0.75]}}},
                {"name":"plain"},
                {"name":"unsaid","extensions":{"VRMC_materials_mtoon":{"specVersion":"1.0"}}}]"#,
            "{}",
        );
        let (shades, errors) = parse_vrm_shade_colors("a.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(shades.len(), 3);
        assert!(close(shades[0], Color::linear_rgb(0.25, 0.5, 0.75)));
        assert_eq!((shades[1], shades[2]), (None, None));
    }

    /// VRM 0.x: the `materialProperties` entry at the material's index, MToon only, its
    /// `_ShadeColor` read as sRGB (0.5 in sRGB is about 0.214 linear).
    #[test]
    fn a_vrm_0_material_gives_its_srgb_shade_colour_by_index() {
        let d = document(
            r#"[{"name":"skin"},{"name":"hair"},{"name":"eyes"}]"#,
            r#"{"VRM":{"materialProperties":[
                {"name":"skin","shader":"VRM/MToon","vectorProperties":{"_ShadeColor":[1,0.5,0.5,1]}},
                {"name":"hair","shader":"VRM/MToon","vectorProperties":{"_Color":[1,1,1,1]}},
                {"name":"eyes","shader":"VRM/UnlitTexture","vectorProperties":{"_ShadeColor":[0,0,0,1]}}]}}"#,
        );
        let (shades, errors) = parse_vrm_shade_colors("old.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert!(close(shades[0], Color::srgb(1.0, 0.5, 0.5)));
        assert!((shades[0].unwrap().to_linear().green - 0.214_041).abs() < 1e-5);
        assert_eq!((shades[1], shades[2]), (None, None));
    }

    /// A VRM 1.0 extension on a material wins over a VRM 0.x entry at its index; entries past
    /// the materials are not read.
    #[test]
    fn the_vrm_1_extension_wins_and_extra_entries_are_ignored() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"shadeColorFactor":[0,0,1]}}}]"#,
            r#"{"VRM":{"materialProperties":[
                {"shader":"VRM/MToon","vectorProperties":{"_ShadeColor":[1,0,0,1]}},
                {"shader":"VRM/MToon","vectorProperties":{"_ShadeColor":[7,0,0,1]}}]}}"#,
        );
        let (shades, errors) = parse_vrm_shade_colors("a.vrm", &d);
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(shades, vec![Some(Color::linear_rgb(0.0, 0.0, 1.0))]);
    }

    /// Hostile values: each error names the file and the JSON path; the material with the
    /// error gets no shade colour and the others keep theirs.
    #[test]
    fn bad_shade_colours_are_errors_naming_their_path() {
        let d = document(
            r#"[{"extensions":{"VRMC_materials_mtoon":{"shadeColorFactor":[0.1,1.5,0.2]}}},
                {"extensions":{"VRMC_materials_mtoon":{"shadeColorFactor":[0.1,0.2]}}},
                {"extensions":{"VRMC_materials_mtoon":{"shadeColorFactor":[0.1,"red",0.2]}}},
                {"extensions":{"VRMC_materials_mtoon":7}},
                {"extensions":{"VRMC_materials_mtoon":{"shadeColorFactor":[-0.0,0.5,1e-30]}}},
                {}]"#,
            r#"{"VRM":{"materialProperties":[{},{},{},{},{},
                {"shader":"VRM/MToon","vectorProperties":{"_ShadeColor":[0.2,0.2,0.2]}}]}}"#,
        );
        let (shades, errors) = parse_vrm_shade_colors("bad.vrm", &d);
        let messages: Vec<String> = errors.iter().map(ToString::to_string).collect();
        assert_eq!(
            messages,
            [
                "bad.vrm: materials[0].extensions.VRMC_materials_mtoon.shadeColorFactor[1]: 1.5 \
                 is outside [0, 1]; fix the colour in the VRM exporter",
                "bad.vrm: materials[1].extensions.VRMC_materials_mtoon.shadeColorFactor: \
                 expected an array of 3 numbers, found 2 entries; fix the colour in the VRM \
                 exporter",
                "bad.vrm: materials[2].extensions.VRMC_materials_mtoon.shadeColorFactor[1]: \
                 expected a number, found a string",
                "bad.vrm: materials[3].extensions.VRMC_materials_mtoon: expected an object, \
                 found a number",
                "bad.vrm: extensions.VRM.materialProperties[5].vectorProperties._ShadeColor: \
                 expected an array of 4 numbers, found 3 entries; fix the colour in the VRM \
                 exporter",
            ]
        );
        assert_eq!(shades[..4], [None, None, None, None]);
        assert!(close(shades[4], Color::linear_rgb(0.0, 0.5, 0.0)));
        assert_eq!(shades[5], None);
    }

    /// Too many VRM 0.x entries, or not an array: one error, nothing read from them.
    #[test]
    fn vrm_0_material_properties_are_bounded() {
        let entry = r#"{"shader":"VRM/MToon","vectorProperties":{"_ShadeColor":[1,0,0,1]}}"#;
        let many = vec![entry; MAX_VRM_MATERIALS + 1].join(",");
        let d = document(
            r#"[{}]"#,
            &format!(r#"{{"VRM":{{"materialProperties":[{many}]}}}}"#),
        );
        let (shades, errors) = parse_vrm_shade_colors("big.vrm", &d);
        assert_eq!(shades, vec![None]);
        assert_eq!(errors.len(), 1);
        assert!(
            errors[0]
                .to_string()
                .contains("4097 entries, more than the 4096 read"),
            "{errors:?}"
        );
        let d = document(r#"[{}]"#, r#"{"VRM":{"materialProperties":{"a":1}}}"#);
        let (_, errors) = parse_vrm_shade_colors("odd.vrm", &d);
        assert_eq!(
            errors[0].to_string(),
            "odd.vrm: extensions.VRM.materialProperties: expected an array, found an object"
        );
    }

    /// A random JSON value, its keys and numbers drawn mostly from what the reader looks at,
    /// nested at most `depth` deep.
    fn random_value(rng: &mut crate::test_support::Rng, depth: u32) -> Value {
        const KEYS: [&str; 6] = [
            "shadeColorFactor",
            "shader",
            "vectorProperties",
            "_ShadeColor",
            "VRMC_materials_mtoon",
            "x",
        ];
        const NUMBERS: [f64; 9] = [0.0, 0.5, 1.0, -0.0, -1.0, 1.5, 1e30, -1e-30, 255.0];
        let pick = |rng: &mut crate::test_support::Rng, n: usize| {
            ((rng.unit() * n as f32) as usize).min(n - 1)
        };
        match pick(rng, if depth == 0 { 4 } else { 6 }) {
            0 => Value::from(NUMBERS[pick(rng, NUMBERS.len())]),
            1 => Value::from(if rng.unit() < 0.5 { "VRM/MToon" } else { "x" }),
            2 => Value::Null,
            3 => Value::Bool(rng.unit() < 0.5),
            4 => Value::Array(
                (0..pick(rng, 6))
                    .map(|_| random_value(rng, depth - 1))
                    .collect(),
            ),
            _ => Value::Object(
                (0..pick(rng, 4))
                    .map(|_| {
                        (
                            KEYS[pick(rng, KEYS.len())].to_owned(),
                            random_value(rng, depth - 1),
                        )
                    })
                    .collect(),
            ),
        }
    }

    /// A colour-like value: two to five numbers, mostly within `[0, 1]`, or any value.
    fn random_colour(rng: &mut crate::test_support::Rng) -> Value {
        if rng.unit() < 0.2 {
            return random_value(rng, 2);
        }
        let n = 2 + (rng.unit() * 4.0) as usize;
        Value::Array(
            (0..n)
                .map(|_| {
                    if rng.unit() < 0.9 {
                        Value::from(f64::from(rng.unit()))
                    } else {
                        random_value(rng, 0)
                    }
                })
                .collect(),
        )
    }

    /// A random document: up to 3 materials, each with an MToon extension `mtoon` makes (half of
    /// them) or none, and up to 4 VRM 0.x `materialProperties` entries `entry` makes; with its
    /// count of materials.
    pub(in crate::asset) fn random_document(
        rng: &mut crate::test_support::Rng,
        mut mtoon: impl FnMut(&mut crate::test_support::Rng) -> Value,
        mut entry: impl FnMut(&mut crate::test_support::Rng) -> Value,
    ) -> (gltf::Document, usize) {
        let count = (rng.unit() * 4.0) as usize;
        let materials: Vec<Value> = (0..count)
            .map(|_| {
                if rng.unit() < 0.5 {
                    json!({"extensions": {"VRMC_materials_mtoon": mtoon(rng)}})
                } else {
                    json!({})
                }
            })
            .collect();
        let properties: Vec<Value> = (0..(rng.unit() * 5.0) as usize)
            .map(|_| entry(rng))
            .collect();
        let d = document(
            &Value::Array(materials).to_string(),
            &json!({"VRM": {"materialProperties": properties}}).to_string(),
        );
        (d, count)
    }

    /// Every error in `errors` names `file`, a path the material readers read and a message.
    pub(in crate::asset) fn assert_located(errors: &[VrmError], file: &str) {
        for e in errors {
            assert_eq!(e.file, file);
            assert!(
                e.path.starts_with("materials[")
                    || e.path.starts_with("extensions.VRM.materialProperties"),
                "{e}"
            );
            assert!(!e.message.is_empty());
        }
    }

    /// A random JSON value for a material's number: mostly in `[0, 1]`; one time in `kinds` a
    /// number in `[-wild, wild]`, a string or null.
    pub(in crate::asset) fn random_factor(
        rng: &mut crate::test_support::Rng,
        kinds: f32,
        wild: f32,
    ) -> Value {
        match (rng.unit() * kinds) as u32 {
            0 => json!((rng.unit() * 2.0 - 1.0) * wild),
            1 => json!("x"),
            2 => json!(null),
            _ => json!(rng.unit()),
        }
    }

    /// Random materials (each with a random MToon extension or none) and random VRM 0.x
    /// `materialProperties`, 3,000 documents: no panic, one entry per material, every shade
    /// colour finite and within `[0, 1]`, every error naming the file and a path the reader
    /// reads.
    #[test]
    fn random_materials_give_shades_in_range_or_located_errors() {
        let mut rng = crate::test_support::Rng(0x4D54_6F6F_6E21);
        let (mut shades_found, mut errors_found) = (0, 0);
        for _ in 0..3_000 {
            let count = (rng.unit() * 4.0) as usize;
            let materials: Vec<Value> = (0..count)
                .map(|_| {
                    let r = rng.unit();
                    if r < 0.4 {
                        json!({"extensions": {"VRMC_materials_mtoon":
                            {"shadeColorFactor": random_colour(&mut rng)}}})
                    } else if r < 0.6 {
                        json!({"extensions": {"VRMC_materials_mtoon": random_value(&mut rng, 3)}})
                    } else {
                        json!({})
                    }
                })
                .collect();
            let properties = if rng.unit() < 0.3 {
                random_value(&mut rng, 4)
            } else {
                Value::Array(
                    (0..(rng.unit() * 5.0) as usize)
                        .map(|_| {
                            json!({"shader": "VRM/MToon",
                                   "vectorProperties": {"_ShadeColor": random_colour(&mut rng)}})
                        })
                        .collect(),
                )
            };
            let d = document(
                &Value::Array(materials).to_string(),
                &json!({"VRM": {"materialProperties": properties}}).to_string(),
            );
            let (shades, errors) = parse_vrm_shade_colors("r.vrm", &d);
            assert_eq!(shades.len(), count);
            for shade in shades.iter().flatten() {
                let c = shade.to_linear();
                for x in [c.red, c.green, c.blue] {
                    assert!(x.is_finite() && (0.0..=1.0).contains(&x), "{shade:?}");
                }
                shades_found += 1;
            }
            assert_located(&errors, "r.vrm");
            errors_found += errors.len();
        }
        // Both kinds of outcome were reached.
        eprintln!("random materials: {shades_found} shade colours, {errors_found} errors");
        assert!(
            shades_found > 50 && errors_found > 500,
            "{shades_found} {errors_found}"
        );
    }
}
