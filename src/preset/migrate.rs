//! Presets of earlier formats, brought up to [`PRESET_FORMAT`] before they are read.
//!
//! | format | written by | what differs |
//! |--------|------------|--------------|
//! | 1 | bevy_cartoon_hair 0.1 | no `format` field; early 0.1 builds kept the material's shading fields (`base_color`, `ramp_mode`, ...) directly in `material` instead of in `material.shading` |
//! | 2 | bevy_cartoon_hair 0.2 | `format: 2` first |
//!
//! The migration works on the text: it reads only the top level of the preset and of its
//! `material`, moves what moved, and leaves every other byte as it was, so the typed reader
//! still reports any other problem at its own line and column.

use std::borrow::Cow;

/// The preset file format this crate writes (the `format` field of a preset file).
pub const PRESET_FORMAT: u32 = 2;

/// Fields of `material` that are not shading fields: they stay where they are.
const MATERIAL_OWN_FIELDS: [&str; 2] = ["ramp", "shading"];

/// What a migration did, for the warning that names it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PresetMigration {
    /// The format the file was written in.
    pub from: u32,
    /// Each change, e.g. "material.base_color moved to material.shading.base_color".
    pub moved: Vec<String>,
}

/// Why a preset could not be migrated: a byte offset and a message.
pub(super) type MigrateError = (usize, String);

/// A field at the top level of a parenthesised RON struct: its name and byte ranges.
#[derive(Debug)]
struct Field {
    name: String,
    /// From the name to the end of the value (without the trailing comma).
    whole: std::ops::Range<usize>,
    /// The value alone.
    value: std::ops::Range<usize>,
}

/// `text` brought up to [`PRESET_FORMAT`], and what was done (`None` when it already was).
pub(super) fn migrate(text: &str) -> Result<(Cow<'_, str>, Option<PresetMigration>), MigrateError> {
    let Some(open) = struct_open(text, 0) else {
        // Not a struct: the typed reader says what is wrong, where.
        return Ok((Cow::Borrowed(text), None));
    };
    let fields = fields_of(text, open)?;
    let format = match fields.iter().find(|f| f.name == "format") {
        None => 1,
        Some(f) => {
            let raw = text[f.value.clone()].trim();
            raw.parse::<u32>().map_err(|_| {
                (
                    f.value.start,
                    format!("`format` must be a whole number, found {raw:?}"),
                )
            })?
        }
    };
    if format > PRESET_FORMAT {
        let at = fields
            .iter()
            .find(|f| f.name == "format")
            .map_or(0, |f| f.value.start);
        return Err((
            at,
            format!(
                "preset format {format} is newer than this bevy_cartoon_hair reads (up to \
                 {PRESET_FORMAT}): update the crate, or save the preset again from this version"
            ),
        ));
    }
    if format == PRESET_FORMAT {
        return Ok((Cow::Borrowed(text), None));
    }
    if format == 0 {
        return Err((
            0,
            "preset format 0 does not exist (the first format is 1)".into(),
        ));
    }
    // Format 1: shading fields directly in `material` move into `material.shading`.
    let mut migration = PresetMigration {
        from: format,
        moved: Vec::new(),
    };
    let Some(material) = fields.iter().find(|f| f.name == "material") else {
        return Ok((Cow::Borrowed(text), Some(migration)));
    };
    let Some(inner_open) = struct_open(text, material.value.start) else {
        return Ok((Cow::Borrowed(text), Some(migration)));
    };
    let inner = fields_of(text, inner_open)?;
    let (kept, moved): (Vec<&Field>, Vec<&Field>) = inner
        .iter()
        .partition(|f| MATERIAL_OWN_FIELDS.contains(&f.name.as_str()));
    if moved.is_empty() {
        return Ok((Cow::Borrowed(text), Some(migration)));
    }
    if kept.iter().any(|f| f.name == "shading") {
        let f = moved[0];
        return Err((
            f.whole.start,
            format!(
                "material.{} is a shading field, and this material also has `shading`: move it \
                 into material.shading",
                f.name
            ),
        ));
    }
    let mut body = String::from("(");
    for f in &kept {
        body.push_str(&text[f.whole.clone()]);
        body.push_str(", ");
    }
    body.push_str("shading: (");
    for f in &moved {
        body.push_str(&text[f.whole.clone()]);
        body.push_str(", ");
        migration.moved.push(format!(
            "material.{0} moved to material.shading.{0}",
            f.name
        ));
    }
    body.push_str("))");
    let mut out = String::with_capacity(text.len() + 16);
    out.push_str(&text[..material.value.start]);
    out.push_str(&body);
    out.push_str(&text[material.value.end..]);
    Ok((Cow::Owned(out), Some(migration)))
}

/// The offset just past the `(` that opens the struct starting at `from` (after whitespace,
/// comments and an optional struct name), or `None` when no struct starts there.
fn struct_open(text: &str, from: usize) -> Option<usize> {
    let bytes = text.as_bytes();
    let mut i = skip_blank(text, from);
    while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
        i += 1;
    }
    i = skip_blank(text, i);
    (bytes.get(i) == Some(&b'(')).then_some(i + 1)
}

/// Whitespace and comments (`// ...`, `/* ... */`) skipped from `i`.
fn skip_blank(text: &str, mut i: usize) -> usize {
    let bytes = text.as_bytes();
    loop {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if bytes[i..].starts_with(b"//") {
            i += text[i..].find('\n').map_or(text.len() - i, |n| n + 1);
        } else if bytes[i..].starts_with(b"/*") {
            i += text[i..].find("*/").map_or(text.len() - i, |n| n + 2);
        } else {
            return i;
        }
    }
}

/// The fields of the struct whose `(` ends just before `open`, up to its `)`.
fn fields_of(text: &str, open: usize) -> Result<Vec<Field>, MigrateError> {
    let bytes = text.as_bytes();
    let mut fields = Vec::new();
    let mut i = open;
    loop {
        i = skip_blank(text, i);
        match bytes.get(i) {
            None => return Err((text.len(), "the file ends inside a struct".into())),
            Some(b')') => return Ok(fields),
            Some(_) => {}
        }
        let start = i;
        while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
            i += 1;
        }
        if i == start {
            return Err((i, "expected a field name".into()));
        }
        let name = text[start..i].to_owned();
        i = skip_blank(text, i);
        if bytes.get(i) != Some(&b':') {
            return Err((i, format!("expected `:` after the field name `{name}`")));
        }
        let value_start = skip_blank(text, i + 1);
        let value_end = value_end(text, value_start)?;
        fields.push(Field {
            name,
            whole: start..value_end,
            value: value_start..value_end,
        });
        i = skip_blank(text, value_end);
        if bytes.get(i) == Some(&b',') {
            i += 1;
        }
    }
}

/// The end of the value starting at `i`: the first `,` or closing bracket outside brackets,
/// strings and comments, with trailing blanks trimmed.
fn value_end(text: &str, mut i: usize) -> Result<usize, MigrateError> {
    let bytes = text.as_bytes();
    let mut depth = 0usize;
    let mut last = i;
    while i < bytes.len() {
        match bytes[i] {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => {
                if depth == 0 {
                    return Ok(last);
                }
                depth -= 1;
            }
            b',' if depth == 0 => return Ok(last),
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
                if i >= bytes.len() {
                    return Err((text.len(), "the file ends inside a string".into()));
                }
            }
            b'/' if matches!(bytes.get(i + 1), Some(b'/' | b'*')) => {
                i = skip_blank(text, i);
                continue;
            }
            _ => {}
        }
        if !bytes[i].is_ascii_whitespace() {
            last = i + 1;
        }
        i += 1;
    }
    Err((text.len(), "the file ends inside a value".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_current_preset_is_left_as_it_is() {
        let text = "(format: 2, material: (ramp: Depth, shading: (z_min: 1.0)))";
        let (out, report) = migrate(text).unwrap();
        assert_eq!(out, text);
        assert_eq!(report, None);
    }

    #[test]
    fn flat_material_fields_move_into_shading() {
        let text = "// old\n(\n    mesh: (radius: 0.01),\n    material: (\n        base_color: \
                    Srgba((red: 1.0, green: 0.5, blue: 0.0, alpha: 1.0)),\n        ramp: Depth,\n        \
                    ramp_mode: Depth, /* note */\n    ),\n)\n";
        let (out, report) = migrate(text).unwrap();
        let report = report.unwrap();
        assert_eq!(report.from, 1);
        assert_eq!(
            report.moved,
            [
                "material.base_color moved to material.shading.base_color",
                "material.ramp_mode moved to material.shading.ramp_mode"
            ]
        );
        assert!(
            out.contains("material: (ramp: Depth, shading: (base_color: Srgba((red: 1.0, green: 0.5, blue: 0.0, alpha: 1.0)), ramp_mode: Depth, ))"),
            "{out}"
        );
        // What came before the material is where it was.
        assert!(out.starts_with("// old\n(\n    mesh: (radius: 0.01),\n"));
    }

    #[test]
    fn newer_and_broken_formats_are_refused_where_they_say_so() {
        let (at, message) = migrate("(format: 3, mesh: ())").unwrap_err();
        assert_eq!(at, 9);
        assert!(message.contains("format 3 is newer"), "{message}");
        let (_, message) = migrate("(format: \"two\")").unwrap_err();
        assert!(message.contains("whole number"), "{message}");
        let (_, message) =
            migrate("(material: (ramp: Depth, z_min: 1.0, shading: ()))").unwrap_err();
        assert!(message.contains("material.z_min"), "{message}");
        assert!(migrate("(material: (ramp: \"unterminated").is_err());
        assert!(migrate("(mesh: (radius: 1.0)").is_err());
    }
}
