//! The hair XML formats read with `roxmltree`, behind a small pull cursor the loaders walk.
//!
//! Hair files are hostile input (players and modders replace them), so:
//! - a linear pre-scan ([`super::prescan`]) runs first and refuses a DTD, namespaces, more than
//!   [`MAX_ATTRIBUTES`](super::MAX_ATTRIBUTES) attributes on a tag, nesting deeper than
//!   [`MAX_DEPTH`](super::MAX_DEPTH), more markup than the format allows and a file cut short,
//!   each at its line and column; the tree the parser then builds is bounded by the file's size
//!   limit and that count (`docs/formats.md`);
//! - only the five XML entities and character references are decoded (no DTD, so no entity
//!   can expand);
//! - every error names the file, a line and a column.

use std::borrow::Cow;

use roxmltree::{Document, Node, NodeId, NodeType, ParsingOptions, StringStorage};

use super::error::HairAssetError;
use super::prescan::{line_column, prescan};

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
    /// No content (`<name/>` or `<name></name>`).
    pub empty: bool,
}

/// What comes next inside an element.
pub(crate) enum Item<'a> {
    /// A child element; its attributes are in [`Xml::attr`] until the next call.
    Element(Element<'a>),
    /// Character data (entities decoded, CDATA sections joined in), at a byte offset.
    /// `borrowed` text is a slice of the input, so positions inside it can be located.
    Text { text: Cow<'a, str>, offset: usize },
    /// A comment or processing instruction (`what` names it), at a byte offset.
    Markup { what: &'static str, offset: usize },
    /// The end of the element whose content was being read.
    End,
}

/// The cursor over one file's tree.
pub(crate) struct Xml<'a> {
    file: &'a str,
    input: &'a str,
    /// Most elements, comments, processing instructions and CDATA sections the file may have,
    /// and most attributes in all.
    max_markup: usize,
    max_attributes: usize,
    doc: Option<Document<'a>>,
    /// Open elements: the next child of each to visit.
    open: Vec<Option<NodeId>>,
    attrs: Vec<Attr<'a>>,
}

impl<'a> Xml<'a> {
    /// A reader over `input`, which may hold at most `max_markup` elements, comments,
    /// processing instructions and CDATA sections and `max_attributes` attributes in all;
    /// `file` names it in errors.
    pub fn new(
        file: &'a str,
        input: &'a str,
        (max_markup, max_attributes): (usize, usize),
    ) -> Self {
        Self {
            file,
            input,
            max_markup,
            max_attributes,
            doc: None,
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

    /// Scans and parses the file and returns its root element.
    pub fn root(&mut self) -> Result<Element<'a>, HairAssetError> {
        let scanned = prescan(self.input, self.max_markup, self.max_attributes)
            .map_err(|(at, message)| self.error(at, message))?;
        // Text lies between tags, so the tree holds at most two text nodes a piece of markup
        // (inside an element and after it) beside the markup itself: the scan has counted it,
        // so this limit is never what stops a file.
        let nodes = scanned.markup.saturating_mul(3).saturating_add(8);
        let doc = Document::parse_with_options(
            self.input,
            ParsingOptions {
                allow_dtd: false,
                nodes_limit: u32::try_from(nodes).unwrap_or(u32::MAX),
                ..ParsingOptions::default()
            },
        )
        .map_err(|e| self.parse_error(&e))?;
        let element = enter(doc.root_element(), &mut self.attrs, &mut self.open);
        self.doc = Some(doc);
        Ok(element)
    }

    /// The next item inside the innermost open element.
    pub fn next(&mut self) -> Result<Item<'a>, HairAssetError> {
        let (Some(doc), Some(&next)) = (self.doc.as_ref(), self.open.last()) else {
            return Err(self.error(0, "read past the root element (a loader bug)"));
        };
        let Some(node) = next.and_then(|id| doc.get_node(id)) else {
            self.open.pop();
            return Ok(Item::End);
        };
        if let Some(last) = self.open.last_mut() {
            *last = node.next_sibling().map(|n| n.id());
        }
        let offset = node.range().start;
        Ok(match node.node_type() {
            NodeType::Element => Item::Element(enter(node, &mut self.attrs, &mut self.open)),
            NodeType::Text => Item::Text {
                text: match node.text_storage() {
                    Some(StringStorage::Borrowed(s)) => Cow::Borrowed(*s),
                    Some(owned) => Cow::Owned(owned.as_str().to_string()),
                    None => Cow::Borrowed(""),
                },
                offset,
            },
            NodeType::Comment => Item::Markup {
                what: "a comment",
                offset,
            },
            NodeType::PI | NodeType::Root => Item::Markup {
                what: "a processing instruction",
                offset,
            },
        })
    }

    /// The next item inside `element` (just returned by [`Xml::root`] or [`Xml::next`]):
    /// [`Item::End`] at once for an element without content.
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

    /// Skips the content of `element` (just returned by [`Xml::next`]).
    pub fn skip(&mut self, element: &Element<'a>) -> Result<(), HairAssetError> {
        if !element.empty {
            self.open.pop();
        }
        Ok(())
    }

    /// After the root element: the pre-scan has allowed only comments, processing
    /// instructions and whitespace there.
    pub fn finish(&mut self) -> Result<(), HairAssetError> {
        Ok(())
    }

    /// The parser's error, at its place, in the words of the other errors.
    fn parse_error(&self, e: &roxmltree::Error) -> HairAssetError {
        use roxmltree::Error as E;
        let pos = e.pos();
        let message = match e {
            E::UnknownEntityReference(name, _) => format!(
                "unknown entity `&{name};` (hair files may use only &lt; &gt; &amp; &quot; \
                 &apos; and character references)"
            ),
            E::MalformedEntityReference(_) => {
                "`&` starts no entity; write &amp; for a literal `&`".to_string()
            }
            E::InvalidAttributeValue(_) => "`<` is not allowed in an attribute value".to_string(),
            // The pre-scan refuses these first; should the parser still meet one, it is said
            // at the start of the file.
            E::UnclosedRootNode | E::UnexpectedEndOfStream => {
                return self.error(
                    self.input.len(),
                    "the file ends before its elements are closed; is it truncated?",
                );
            }
            other => {
                // The parser's words without its own position (given as line:column anyway).
                let text = other.to_string();
                let words = text
                    .rsplit_once(" at ")
                    .filter(|(_, at)| at.contains(':'))
                    .map_or(text.as_str(), |(w, _)| w)
                    .to_string();
                format!("not well-formed XML: {words}")
            }
        };
        HairAssetError {
            file: Some(self.file.to_string()),
            line: pos.row,
            column: pos.col,
            message,
        }
    }
}

/// Makes `node` the element last returned: its attributes into `attrs`, and its content next
/// in `open` when it has any.
fn enter<'a>(
    node: Node<'_, 'a>,
    attrs: &mut Vec<Attr<'a>>,
    open: &mut Vec<Option<NodeId>>,
) -> Element<'a> {
    attrs.clear();
    attrs.extend(node.attributes().map(|a| Attr {
        name: a.name(),
        value: match a.value_storage() {
            StringStorage::Borrowed(s) => Cow::Borrowed(*s),
            owned => Cow::Owned(owned.as_str().to_string()),
        },
        offset: a.range_qname().start,
    }));
    let empty = !node.has_children();
    if !empty {
        open.push(node.first_child().map(|c| c.id()));
    }
    Element {
        name: node.tag_name().name(),
        offset: node.range().start,
        empty,
    }
}
