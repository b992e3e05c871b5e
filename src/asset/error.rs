//! Errors of the hair asset loaders: always the file, the line and column, and what is wrong.

use std::fmt;

/// A hair asset could not be loaded. Displays as `file:line:column: message`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HairAssetError {
    /// The asset path (or file name) that failed.
    pub file: String,
    /// 1-based line of the offending element or number; `0` when it concerns the whole file.
    pub line: u32,
    /// 1-based column; `0` when it concerns the whole file.
    pub column: u32,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for HairAssetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.file, self.message)
        } else {
            write!(
                f,
                "{}:{}:{}: {}",
                self.file, self.line, self.column, self.message
            )
        }
    }
}

impl std::error::Error for HairAssetError {}

/// Builds errors that point into one parsed document.
pub(crate) struct Locator<'a> {
    pub file: &'a str,
    pub doc: &'a roxmltree::Document<'a>,
    pub input: &'a str,
}

impl<'a> Locator<'a> {
    /// An error at a byte offset of the input.
    pub fn at(&self, offset: usize, message: impl Into<String>) -> HairAssetError {
        let pos = self.doc.text_pos_at(offset.min(self.input.len()));
        HairAssetError {
            file: self.file.to_string(),
            line: pos.row,
            column: pos.col,
            message: message.into(),
        }
    }

    /// An error at an element.
    pub fn node(&self, node: roxmltree::Node, message: impl Into<String>) -> HairAssetError {
        self.at(node.range().start, message)
    }

    /// An error at a slice of the input (a number inside element text), falling back to `node`
    /// when the slice was not borrowed from the input (text with XML entities).
    pub fn slice(
        &self,
        s: &str,
        node: roxmltree::Node,
        message: impl Into<String>,
    ) -> HairAssetError {
        let base = self.input.as_ptr() as usize;
        let p = s.as_ptr() as usize;
        if p >= base && p < base + self.input.len() {
            self.at(p - base, message)
        } else {
            self.node(node, message)
        }
    }

    /// Reads a required, finite float attribute.
    pub fn float_attr(&self, node: roxmltree::Node, name: &str) -> Result<f32, HairAssetError> {
        let Some(raw) = node.attribute(name) else {
            return Err(self.node(
                node,
                format!(
                    "<{}> is missing the attribute `{name}`",
                    node.tag_name().name()
                ),
            ));
        };
        parse_finite(raw).map_err(|why| {
            self.node(
                node,
                format!(
                    "<{}> attribute `{name}` = {raw:?}: {why}",
                    node.tag_name().name()
                ),
            )
        })
    }

    /// Reads an optional float attribute, with a default.
    pub fn float_attr_or(
        &self,
        node: roxmltree::Node,
        name: &str,
        default: f32,
    ) -> Result<f32, HairAssetError> {
        if node.attribute(name).is_none() {
            return Ok(default);
        }
        self.float_attr(node, name)
    }
}

/// Parses a decimal float and rejects NaN and infinities.
pub(crate) fn parse_finite(raw: &str) -> Result<f32, &'static str> {
    match raw.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) if v.is_nan() => Err("number is NaN"),
        Ok(_) => Err("number is infinite"),
        Err(_) => Err("not a number"),
    }
}

/// Parses a document, turning syntax errors into located errors.
pub(crate) fn parse_document<'a>(
    file: &str,
    input: &'a str,
) -> Result<roxmltree::Document<'a>, HairAssetError> {
    roxmltree::Document::parse(input).map_err(|e| {
        let pos = e.pos();
        HairAssetError {
            file: file.to_string(),
            line: pos.row,
            column: pos.col,
            message: format!("malformed XML: {e}"),
        }
    })
}

/// What every hair XML file starts with.
pub(crate) struct Header {
    /// Factor every length was multiplied by; divide to get metres.
    pub scale: f32,
    /// The bone the positions are relative to (may be empty).
    pub bone: String,
}

/// Checks the root element's name and `version`, and reads `scale` (finite, > 0) and `bone`.
pub(crate) fn read_header(
    loc: &Locator,
    root: roxmltree::Node,
    expected_root: &str,
) -> Result<Header, HairAssetError> {
    let name = root.tag_name().name();
    if name != expected_root {
        return Err(loc.node(
            root,
            format!("expected a <{expected_root}> root element, found <{name}>"),
        ));
    }
    match root.attribute("version") {
        Some("1") => {}
        Some(v) => {
            return Err(loc.node(
                root,
                format!("unsupported format version {v:?} (this crate reads version 1)"),
            ));
        }
        None => return Err(loc.node(root, format!("<{name}> is missing `version=\"1\"`"))),
    }
    let scale = loc.float_attr_or(root, "scale", 1.0)?;
    if scale <= 0.0 {
        return Err(loc.node(root, format!("scale must be greater than 0, found {scale}")));
    }
    Ok(Header {
        scale,
        bone: root.attribute("bone").unwrap_or("").to_string(),
    })
}

/// Reads the whole asset into a string, naming the file on failure.
pub(crate) async fn read_text(
    reader: &mut dyn bevy::asset::io::Reader,
    file: &str,
) -> Result<String, HairAssetError> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .await
        .map_err(|e| whole_file(file, format!("could not read: {e}")))?;
    String::from_utf8(bytes).map_err(|e| whole_file(file, format!("not UTF-8: {e}")))
}

/// An error about the whole file.
pub(crate) fn whole_file(file: &str, message: impl Into<String>) -> HairAssetError {
    HairAssetError {
        file: file.to_string(),
        line: 0,
        column: 0,
        message: message.into(),
    }
}
