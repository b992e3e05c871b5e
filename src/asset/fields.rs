//! The fields every hair XML file shares, read and checked: numbers and lengths, the header
//! (`version`, `scale`, `units`, `bone`), the limits on coordinates and sizes, and the file's
//! text itself (bounded in size, UTF-8).

use super::error::{HairAssetError, whole_file};
use super::prescan::line_column;
use super::reader::{Element, Xml};

/// Bytes a collision or animation file may take per element (`<sphere>`, `<key>`).
pub const BYTES_PER_ELEMENT: usize = 256;

/// Smallest and largest `scale` a file may have: outside this range dividing by it would turn
/// ordinary numbers into zeros or infinities.
pub const SCALE_RANGE: (f32, f32) = (1e-6, 1e6);
/// Largest absolute value of any coordinate or radius after scaling, in metres. Hair lives near
/// its bone; a larger number is a mistake or an attack, and would overflow the solver's sums.
pub const MAX_COORDINATE: f32 = 1000.0;

/// Reads a required, finite float attribute of the element `xml` just returned.
pub(crate) fn float_attr(xml: &Xml, element: &Element, name: &str) -> Result<f32, HairAssetError> {
    let Some(attr) = xml.attr(name) else {
        return Err(xml.error(
            element.offset,
            format!("<{}> is missing the attribute `{name}`", element.name),
        ));
    };
    parse_finite(&attr.value).map_err(|why| {
        xml.error(
            attr.offset,
            format!(
                "<{}> attribute `{name}` = {:?}: {why}",
                element.name, attr.value
            ),
        )
    })
}

/// Reads an optional float attribute, with a default.
pub(crate) fn float_attr_or(
    xml: &Xml,
    element: &Element,
    name: &str,
    default: f32,
) -> Result<f32, HairAssetError> {
    if xml.attr(name).is_none() {
        return Ok(default);
    }
    float_attr(xml, element, name)
}

/// Reads a length attribute (a coordinate or radius), divides it by the file's scale and checks
/// the result against [`MAX_COORDINATE`], blaming the scale when the scale made it too large.
pub(crate) fn length_attr(
    xml: &Xml,
    element: &Element,
    name: &str,
    scale: f32,
) -> Result<f32, HairAssetError> {
    let raw = float_attr(xml, element, name)?;
    let offset = xml.attr(name).map_or(element.offset, |a| a.offset);
    scaled(xml, offset, raw, scale, || {
        format!("<{}> `{name}`", element.name)
    })
}

/// `raw / scale`, checked to be finite and within [`MAX_COORDINATE`].
pub(crate) fn scaled(
    xml: &Xml,
    offset: usize,
    raw: f32,
    scale: f32,
    what: impl FnOnce() -> String,
) -> Result<f32, HairAssetError> {
    let v = raw / scale;
    if v.is_finite() && v.abs() <= MAX_COORDINATE {
        return Ok(v);
    }
    let what = what();
    let blame = if raw.abs() <= MAX_COORDINATE {
        format!(" (the file's scale {scale:e} makes it that large; check `scale`)")
    } else {
        String::new()
    };
    Err(xml.error(
        offset,
        format!(
            "{what} = {raw} is {v:e} m after dividing by the scale; lengths must lie within \
             {MAX_COORDINATE} m of the bone{blame}"
        ),
    ))
}

/// Parses a decimal float and rejects NaN and infinities.
pub(crate) fn parse_finite(raw: &str) -> Result<f32, &'static str> {
    let t = raw.trim();
    if t.is_empty() {
        return Err("empty, not a number");
    }
    match t.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) if v.is_nan() => Err("number is NaN"),
        Ok(_) => Err("number is infinite (or too large for 32 bits)"),
        Err(_) => Err("not a number"),
    }
}

/// What every hair XML file starts with.
pub(crate) struct Header {
    /// Factor every length was multiplied by; divide to get metres.
    pub scale: f32,
    /// The bone the positions are relative to (may be empty).
    pub bone: String,
    /// Metres one unit of the bone's frame was where the file was made (`bone_scale`).
    pub bone_scale: Option<f32>,
}

/// Checks the root element's name and `version`, reads `scale` (within [`SCALE_RANGE`]) and
/// `bone`, and checks `units` (`meters`, the only unit; `scale` converts others).
pub(crate) fn read_header(
    xml: &Xml,
    root: &Element,
    expected_root: &str,
) -> Result<Header, HairAssetError> {
    if root.name != expected_root {
        return Err(xml.error(
            root.offset,
            format!(
                "expected a <{expected_root}> root element, found <{}>",
                root.name
            ),
        ));
    }
    match xml.attr("version").map(|a| (a.value.as_ref(), a.offset)) {
        Some(("1", _)) => {}
        Some((v, at)) => {
            return Err(xml.error(
                at,
                format!("unsupported format version {v:?} (this crate reads version 1)"),
            ));
        }
        None => {
            return Err(xml.error(
                root.offset,
                format!("<{expected_root}> is missing `version=\"1\"`"),
            ));
        }
    }
    if let Some(units) = xml.attr("units")
        && !matches!(units.value.as_ref(), "meters" | "metres" | "bone")
    {
        return Err(xml.error(
            units.offset,
            format!(
                "units = {:?}: hair files are in metres (`units=\"meters\"`) or in the bone's \
                 own units (`units=\"bone\"`, with `bone_scale`); write other units with a \
                 scale, e.g. centimetres as scale=\"100\"",
                units.value
            ),
        ));
    }
    let (lo, hi) = SCALE_RANGE;
    let bone_scale = match xml.attr("bone_scale") {
        None => None,
        Some(a) => {
            let v = float_attr(xml, root, "bone_scale")?;
            if !(lo..=hi).contains(&v) {
                return Err(xml.error(
                    a.offset,
                    format!("bone_scale must lie between {lo:e} and {hi:e}, found {v:e}"),
                ));
            }
            Some(v)
        }
    };
    let scale = float_attr_or(xml, root, "scale", 1.0)?;
    if !(lo..=hi).contains(&scale) {
        let at = xml.attr("scale").map_or(root.offset, |a| a.offset);
        return Err(xml.error(
            at,
            format!("scale must lie between {lo:e} and {hi:e}, found {scale:e}"),
        ));
    }
    Ok(Header {
        scale,
        bone: xml
            .attr("bone")
            .map(|b| b.value.to_string())
            .unwrap_or_default(),
        bone_scale,
    })
}

/// Reads the whole asset, refusing more than `limit` bytes, and checks it is UTF-8 text.
/// Memory: the buffer grows by an eighth at a time, so it holds at most `limit` bytes plus an
/// eighth of what was read.
pub(crate) async fn read_text(
    reader: &mut dyn bevy::asset::io::Reader,
    file: &str,
    limit: usize,
    what: &str,
) -> Result<String, HairAssetError> {
    use bevy::tasks::futures_lite::AsyncReadExt;
    let mut bytes: Vec<u8> = Vec::new();
    let mut len = 0usize;
    loop {
        if len == bytes.len() {
            let grow = (len / 8).max(64 * 1024);
            let new_len = (len + grow).min(limit + 1);
            if new_len <= len {
                return Err(too_large(file, limit, what));
            }
            bytes.reserve_exact(new_len - len);
            bytes.resize(new_len, 0);
        }
        let n = reader
            .read(&mut bytes[len..])
            .await
            .map_err(|e| whole_file(file, format!("could not read: {e}")))?;
        if n == 0 {
            break;
        }
        len += n;
        if len > limit {
            return Err(too_large(file, limit, what));
        }
    }
    bytes.truncate(len);
    decode_utf8(file, bytes)
}

fn too_large(file: &str, limit: usize, what: &str) -> HairAssetError {
    whole_file(
        file,
        format!(
            "larger than {limit} bytes, the most a {what} within the limits of docs/formats.md \
             can take; reading stopped there (is it a device, or not a hair file?)"
        ),
    )
}

/// Checks that `bytes` is UTF-8, naming UTF-16 and locating the first bad byte.
pub(crate) fn decode_utf8(file: &str, bytes: Vec<u8>) -> Result<String, HairAssetError> {
    let utf16 = match bytes.as_slice() {
        [0xFF, 0xFE, ..] | [0xFE, 0xFF, ..] => Some("UTF-16 (it starts with a byte-order mark)"),
        [b, 0, ..] | [0, b, ..] if b.is_ascii() && *b != 0 => {
            Some("UTF-16 without a byte-order mark (every other byte is zero)")
        }
        _ => None,
    };
    if let Some(kind) = utf16 {
        return Err(whole_file(
            file,
            format!("the file is {kind}; hair files are UTF-8: save it as UTF-8"),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let good = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        // Valid up to `good`, so that prefix is a str.
        let prefix = std::str::from_utf8(&bytes[..good]).unwrap_or("");
        let (line, column) = line_column(prefix, good);
        HairAssetError {
            file: Some(file.to_string()),
            line,
            column,
            message: format!(
                "not UTF-8: byte 0x{:02X} at byte offset {good} (save the file as UTF-8)",
                bytes[good]
            ),
        }
    })
}
