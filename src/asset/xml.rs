//! A small, strict, streaming XML reader for the three hair formats.
//!
//! Hair files are hostile input (players and modders replace them), so this reader:
//! - builds no tree: the loaders pull one element or text run at a time, so memory is the input
//!   plus what the loader keeps, and time is linear in the input;
//! - bounds everything it keeps: element depth ([`MAX_DEPTH`]) and attributes per element
//!   ([`MAX_ATTRIBUTES`], duplicates checked in constant time per attribute);
//! - reads no DTD (`<!DOCTYPE ...>` is an error), so no entity can expand; only the five XML
//!   entities and character references are decoded;
//! - reports every error at a line and column of the input, truncated files at their end.

use std::borrow::Cow;

use super::error::HairAssetError;

/// Deepest element nesting a hair file may have (ours use 2; unknown elements may nest deeper).
pub const MAX_DEPTH: usize = 32;
/// Most attributes one element may have.
pub const MAX_ATTRIBUTES: usize = 32;

/// An attribute of the element last returned.
pub(crate) struct Attr<'a> {
    pub name: &'a str,
    pub value: Cow<'a, str>,
    /// Byte offset of the attribute's name.
    pub offset: usize,
}

/// A start tag.
#[derive(Clone, Copy)]
pub(crate) struct Element<'a> {
    pub name: &'a str,
    /// Byte offset of its `<`.
    pub offset: usize,
    /// `<name/>`: no content and no end tag.
    pub empty: bool,
}

/// What comes next inside an element.
pub(crate) enum Item<'a> {
    /// A child element; its attributes are in [`Xml::attrs`] until the next call.
    Element(Element<'a>),
    /// Character data (entities decoded) or a CDATA section, at a byte offset. `borrowed` text is
    /// a slice of the input, so positions inside it can be located.
    Text { text: Cow<'a, str>, offset: usize },
    /// A comment or processing instruction (`what` names it), at a byte offset.
    Markup { what: &'static str, offset: usize },
    /// The end tag of the element whose content was being read.
    End,
}

/// The reader over one file's text.
pub(crate) struct Xml<'a> {
    file: &'a str,
    input: &'a str,
    pos: usize,
    /// Open elements: name and offset of the start tag.
    open: Vec<(&'a str, usize)>,
    attrs: Vec<Attr<'a>>,
}

impl<'a> Xml<'a> {
    /// A reader over `input`; `file` names it in errors. A leading byte-order mark is skipped.
    pub fn new(file: &'a str, input: &'a str) -> Self {
        let pos = if input.starts_with('\u{feff}') { 3 } else { 0 };
        Self {
            file,
            input,
            pos,
            open: Vec::new(),
            attrs: Vec::with_capacity(8),
        }
    }

    /// An error at a byte offset of the input.
    pub fn error(&self, offset: usize, message: impl Into<String>) -> HairAssetError {
        let (line, column) = line_column(self.input, offset);
        HairAssetError {
            file: Some(self.file.to_string()),
            line,
            column,
            message: message.into(),
        }
    }

    /// An error at a slice of the input (a number inside text), or at `fallback` when the slice
    /// is not part of the input (text with entities, decoded into a new string).
    pub fn error_at_slice(
        &self,
        s: &str,
        fallback: usize,
        message: impl Into<String>,
    ) -> HairAssetError {
        self.error(self.offset_of(s, fallback), message)
    }

    /// Byte offset of `s` in the input, or `fallback` when `s` is not a slice of it.
    pub fn offset_of(&self, s: &str, fallback: usize) -> usize {
        let base = self.input.as_ptr() as usize;
        let p = s.as_ptr() as usize;
        if p >= base && p <= base + self.input.len() {
            p - base
        } else {
            fallback
        }
    }

    /// One attribute of the element last returned by [`Xml::root`] or [`Xml::next`].
    pub fn attr(&self, name: &str) -> Option<&Attr<'a>> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// Reads up to and including the root element's start tag.
    pub fn root(&mut self) -> Result<Element<'a>, HairAssetError> {
        loop {
            self.skip_whitespace();
            if self.pos >= self.input.len() {
                return Err(self.error(self.pos, "the file has no root element (is it empty?)"));
            }
            if !self.rest().starts_with('<') {
                return Err(self.error(
                    self.pos,
                    "text before the root element; a hair file starts with `<?xml` or its root \
                     element",
                ));
            }
            match self.markup()? {
                Some(Item::Element(e)) => return Ok(e),
                Some(Item::Text { offset, .. }) => {
                    return Err(self.error(offset, "CDATA before the root element"));
                }
                Some(Item::End) => {
                    return Err(self.error(self.pos, "an end tag before the root element"));
                }
                Some(Item::Markup { .. }) | None => {}
            }
        }
    }

    /// The next item inside the innermost open element.
    pub fn next(&mut self) -> Result<Item<'a>, HairAssetError> {
        let Some(&(name, opened)) = self.open.last() else {
            return Err(self.error(self.pos, "read past the root element (a loader bug)"));
        };
        if self.pos >= self.input.len() {
            let (line, column) = line_column(self.input, opened);
            return Err(self.error(
                self.input.len(),
                format!(
                    "the file ends inside <{name}> (opened at {line}:{column}); is it truncated?"
                ),
            ));
        }
        if !self.rest().starts_with('<') {
            return self.text();
        }
        match self.markup()? {
            Some(item) => Ok(item),
            None => Err(self.error(self.pos, "unexpected markup")),
        }
    }

    /// The next item inside `element` (just returned by [`Xml::root`] or [`Xml::next`]):
    /// [`Item::End`] at once for an empty element (`<name/>`).
    pub fn next_in(&mut self, element: &Element<'a>) -> Result<Item<'a>, HairAssetError> {
        if element.empty {
            return Ok(Item::End);
        }
        self.next()
    }

    /// The next child element of `parent` named `wanted`, or `None` at `parent`'s end. Comments,
    /// processing instructions and other elements (later versions' additions) are skipped;
    /// non-whitespace text is an error with `stray` as its message (nothing is dropped silently).
    pub fn next_child(
        &mut self,
        parent: &Element<'a>,
        wanted: &str,
        stray: &str,
    ) -> Result<Option<Element<'a>>, HairAssetError> {
        self.next_child_of(parent, &[wanted], stray)
    }

    /// [`Xml::next_child`] for elements of any of the names in `wanted`.
    pub fn next_child_of(
        &mut self,
        parent: &Element<'a>,
        wanted: &[&str],
        stray: &str,
    ) -> Result<Option<Element<'a>>, HairAssetError> {
        loop {
            match self.next_in(parent)? {
                Item::End => return Ok(None),
                Item::Markup { .. } => {}
                Item::Text { text, offset } => {
                    if let Some(k) = text.find(|c: char| !c.is_ascii_whitespace()) {
                        return Err(self.error_at_slice(&text[k..], offset, stray));
                    }
                }
                Item::Element(e) if wanted.contains(&e.name) => return Ok(Some(e)),
                Item::Element(e) => self.skip(&e)?,
            }
        }
    }

    /// Skips the content of `element` (just returned by [`Xml::next`]) up to its end tag.
    pub fn skip(&mut self, element: &Element<'a>) -> Result<(), HairAssetError> {
        if element.empty {
            return Ok(());
        }
        let depth = self.open.len();
        while self.open.len() >= depth {
            // Elements nested inside are opened and closed by `next` itself.
            self.next()?;
        }
        Ok(())
    }

    /// After the root element's end tag: only comments, processing instructions and whitespace
    /// may follow.
    pub fn finish(&mut self) -> Result<(), HairAssetError> {
        loop {
            self.skip_whitespace();
            if self.pos >= self.input.len() {
                return Ok(());
            }
            let at = self.pos;
            if !self.rest().starts_with("<!--") && !self.rest().starts_with("<?") {
                return Err(self.error(at, "content after the root element's end tag"));
            }
            self.markup()?;
        }
    }

    fn rest(&self) -> &'a str {
        &self.input[self.pos..]
    }

    fn skip_whitespace(&mut self) {
        let bytes = self.input.as_bytes();
        while self.pos < bytes.len() && matches!(bytes[self.pos], b' ' | b'\t' | b'\r' | b'\n') {
            self.pos += 1;
        }
    }

    /// Character data up to the next `<` (or the end of the input).
    fn text(&mut self) -> Result<Item<'a>, HairAssetError> {
        let start = self.pos;
        let len = self.rest().find('<').unwrap_or(self.rest().len());
        self.pos += len;
        let raw = &self.input[start..start + len];
        Ok(Item::Text {
            text: self.decode(raw, start)?,
            offset: start,
        })
    }

    /// Markup at `<`: a tag, a comment, a processing instruction or CDATA. `None` for markup
    /// that carries nothing (comments and PIs in the prolog return `Some(Markup)` too).
    fn markup(&mut self) -> Result<Option<Item<'a>>, HairAssetError> {
        let start = self.pos;
        let rest = self.rest();
        if let Some(body) = rest.strip_prefix("<!--") {
            let Some(end) = body.find("-->") else {
                return Err(self.unterminated(start, "comment", "-->"));
            };
            self.pos += 4 + end + 3;
            return Ok(Some(Item::Markup {
                what: "a comment",
                offset: start,
            }));
        }
        if let Some(body) = rest.strip_prefix("<![CDATA[") {
            if self.open.is_empty() {
                return Err(self.error(start, "CDATA outside the root element"));
            }
            let Some(end) = body.find("]]>") else {
                return Err(self.unterminated(start, "CDATA section", "]]>"));
            };
            self.pos += 9 + end + 3;
            return Ok(Some(Item::Text {
                text: Cow::Borrowed(&body[..end]),
                offset: start + 9,
            }));
        }
        if rest.starts_with("<!") {
            return Err(self.error(
                start,
                "<!DOCTYPE> and other <!...> declarations are not allowed in hair files \
                 (entities could expand without bound)",
            ));
        }
        if let Some(body) = rest.strip_prefix("<?") {
            let Some(end) = body.find("?>") else {
                return Err(self.unterminated(start, "processing instruction", "?>"));
            };
            self.pos += 2 + end + 2;
            return Ok(Some(Item::Markup {
                what: "a processing instruction",
                offset: start,
            }));
        }
        if rest.starts_with("</") {
            return self.end_tag().map(Some);
        }
        self.start_tag().map(Some)
    }

    fn unterminated(&self, start: usize, what: &str, close: &str) -> HairAssetError {
        let (line, column) = line_column(self.input, start);
        self.error(
            self.input.len(),
            format!(
                "the file ends inside a {what} opened at {line}:{column} (no `{close}`); is it \
                 truncated?"
            ),
        )
    }

    /// A name at the current position.
    fn name(&mut self, what: &str) -> Result<&'a str, HairAssetError> {
        let start = self.pos;
        let rest = self.rest();
        let len = rest
            .find(|c: char| {
                matches!(
                    c,
                    ' ' | '\t' | '\r' | '\n' | '/' | '>' | '=' | '<' | '"' | '\'' | '&'
                )
            })
            .unwrap_or(rest.len());
        let name = &rest[..len];
        let valid_start = name
            .chars()
            .next()
            .is_some_and(|c| c.is_alphabetic() || c == '_' || c == ':');
        if !valid_start {
            if start >= self.input.len() {
                return Err(self.error(
                    start,
                    format!("the file ends where {what} was expected; is it truncated?"),
                ));
            }
            return Err(self.error(
                start,
                format!("expected {what}; write &lt; for a literal `<` in text"),
            ));
        }
        self.pos += len;
        Ok(name)
    }

    fn start_tag(&mut self) -> Result<Item<'a>, HairAssetError> {
        let offset = self.pos;
        self.pos += 1;
        let name = self.name("an element name after `<`")?;
        self.attrs.clear();
        loop {
            let before = self.pos;
            self.skip_whitespace();
            let rest = self.rest();
            if rest.is_empty() {
                let (line, column) = line_column(self.input, offset);
                return Err(self.error(
                    self.pos,
                    format!(
                        "the file ends inside the tag <{name}> at {line}:{column}; is it \
                         truncated?"
                    ),
                ));
            }
            if rest.starts_with("/>") || rest.starts_with('>') {
                let empty = rest.starts_with('/');
                self.pos += if empty { 2 } else { 1 };
                if !empty {
                    if self.open.len() >= MAX_DEPTH {
                        return Err(self.error(
                            offset,
                            format!("elements nest deeper than {MAX_DEPTH} levels"),
                        ));
                    }
                    self.open.push((name, offset));
                }
                return Ok(Item::Element(Element {
                    name,
                    offset,
                    empty,
                }));
            }
            if self.pos == before {
                return Err(self.error(
                    self.pos,
                    format!("<{name}>: expected whitespace, `>` or `/>` here"),
                ));
            }
            self.attribute(name)?;
        }
    }

    fn attribute(&mut self, element: &str) -> Result<(), HairAssetError> {
        let offset = self.pos;
        let name = self.name("an attribute name")?;
        if self.attrs.len() >= MAX_ATTRIBUTES {
            return Err(self.error(
                offset,
                format!("<{element}> has more than {MAX_ATTRIBUTES} attributes"),
            ));
        }
        if self.attrs.iter().any(|a| a.name == name) {
            return Err(self.error(
                offset,
                format!("<{element}> has the attribute `{name}` twice"),
            ));
        }
        self.skip_whitespace();
        if !self.rest().starts_with('=') {
            return Err(self.error(
                self.pos,
                format!("<{element}> attribute `{name}`: expected `=` and a quoted value"),
            ));
        }
        self.pos += 1;
        self.skip_whitespace();
        let quote = match self.rest().chars().next() {
            Some(q @ ('"' | '\'')) => q,
            None => {
                return Err(self.error(
                    self.pos,
                    format!("the file ends inside <{element}>; is it truncated?"),
                ));
            }
            Some(_) => {
                return Err(self.error(
                    self.pos,
                    format!("<{element}> attribute `{name}`: the value must be in quotes"),
                ));
            }
        };
        let start = self.pos + 1;
        let Some(len) = self.input[start..].find(quote) else {
            return Err(self.error(
                self.input.len(),
                format!(
                    "the file ends inside the value of `{name}` of <{element}>; is it truncated?"
                ),
            ));
        };
        let raw = &self.input[start..start + len];
        if let Some(lt) = raw.find('<') {
            return Err(self.error(
                start + lt,
                format!("<{element}> attribute `{name}`: `<` is not allowed in a value"),
            ));
        }
        self.pos = start + len + 1;
        let value = self.decode(raw, start)?;
        self.attrs.push(Attr {
            name,
            value,
            offset,
        });
        Ok(())
    }

    fn end_tag(&mut self) -> Result<Item<'a>, HairAssetError> {
        let offset = self.pos;
        self.pos += 2;
        let name = self.name("an element name after `</`")?;
        self.skip_whitespace();
        if self.rest().is_empty() {
            return Err(self.error(
                self.pos,
                format!("the file ends inside the end tag </{name}; is it truncated?"),
            ));
        }
        if !self.rest().starts_with('>') {
            return Err(self.error(self.pos, format!("</{name}: expected `>`")));
        }
        self.pos += 1;
        match self.open.pop() {
            Some((open, _)) if open == name => Ok(Item::End),
            Some((open, at)) => {
                let (line, column) = line_column(self.input, at);
                Err(self.error(
                    offset,
                    format!("</{name}> closes <{open}> (opened at {line}:{column})"),
                ))
            }
            None => Err(self.error(offset, format!("</{name}> closes nothing"))),
        }
    }

    /// Decodes the five XML entities and character references in `raw` (at byte `offset`).
    fn decode(&self, raw: &'a str, offset: usize) -> Result<Cow<'a, str>, HairAssetError> {
        let Some(first) = raw.find('&') else {
            return Ok(Cow::Borrowed(raw));
        };
        let mut out = String::with_capacity(raw.len());
        out.push_str(&raw[..first]);
        let mut i = first;
        while i < raw.len() {
            let Some(amp) = raw[i..].find('&') else {
                out.push_str(&raw[i..]);
                break;
            };
            out.push_str(&raw[i..i + amp]);
            let at = i + amp;
            let end = raw[at..]
                .char_indices()
                .take(12)
                .find(|&(_, c)| c == ';')
                .map(|(k, _)| at + k);
            let Some(end) = end else {
                return Err(self.error(
                    offset + at,
                    "`&` starts no entity; write &amp; for a literal `&`",
                ));
            };
            let entity = &raw[at + 1..end];
            let c = match entity {
                "lt" => Some('<'),
                "gt" => Some('>'),
                "amp" => Some('&'),
                "quot" => Some('"'),
                "apos" => Some('\''),
                _ => {
                    let code = if let Some(hex) = entity.strip_prefix("#x") {
                        u32::from_str_radix(hex, 16).ok()
                    } else if let Some(dec) = entity.strip_prefix('#') {
                        dec.parse::<u32>().ok()
                    } else {
                        None
                    };
                    code.and_then(char::from_u32).filter(|&c| c != '\0')
                }
            };
            let Some(c) = c else {
                return Err(self.error(
                    offset + at,
                    format!(
                        "unknown entity `&{entity};` (hair files may use only &lt; &gt; &amp; \
                         &quot; &apos; and character references)"
                    ),
                ));
            };
            out.push(c);
            i = end + 1;
        }
        Ok(Cow::Owned(out))
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub(crate) fn line_column(input: &str, offset: usize) -> (u32, u32) {
    let mut offset = offset.min(input.len());
    while !input.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &input[..offset];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |n| n + 1);
    let column = before[line_start..].chars().count() + 1;
    (
        u32::try_from(line).unwrap_or(u32::MAX),
        u32::try_from(column).unwrap_or(u32::MAX),
    )
}
