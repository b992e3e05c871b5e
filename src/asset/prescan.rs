//! One linear pass over a hair XML file before the tree parser sees it. It allocates nothing
//! and refuses, each at its line and column, what the formats never contain and what would
//! make the parser's work or memory grow past the format's limits: a DTD (`<!DOCTYPE`),
//! namespaces (`xmlns`), a tag with more than [`MAX_ATTRIBUTES`] attributes or one attribute
//! twice, elements nested deeper than [`MAX_DEPTH`], more markup (or more attributes in all)
//! than the format allows, and
//! a file that ends early (inside a tag, a comment or an open element). The parser's own
//! checks of attributes and namespaces are quadratic in a tag's attributes and its node limit
//! reports no position: after this pass neither can be reached.

/// Deepest element nesting a hair file may have (ours use 2; unknown elements may nest deeper).
pub const MAX_DEPTH: usize = 32;
/// Most attributes one element may have.
pub const MAX_ATTRIBUTES: usize = 32;

/// Where the scan stopped and why: a byte offset and a message.
pub(crate) type ScanError = (usize, String);

/// What the scan counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Scanned {
    /// Elements, comments, processing instructions and CDATA sections.
    pub markup: usize,
}

/// Scans `input`, allowing at most `max_markup` elements, comments, processing instructions
/// and CDATA sections, and `max_attributes` attributes in all.
pub(crate) fn prescan(
    input: &str,
    max_markup: usize,
    max_attributes: usize,
) -> Result<Scanned, ScanError> {
    let b = input.as_bytes();
    let n = b.len();
    // The open elements: each one's name (start, end) and the offset of its `<`.
    let mut open = [(0usize, 0usize, 0usize); MAX_DEPTH];
    let (mut depth, mut markup, mut root_seen, mut root_closed) = (0usize, 0usize, false, false);
    let mut attributes_in_all = 0usize;
    let mut i = usize::from(input.starts_with('\u{feff}')) * 3;
    let truncated = |what: String| (n, format!("{what}; is it truncated?"));
    let count = |markup: &mut usize, at: usize| {
        *markup += 1;
        if *markup > max_markup {
            return Err((
                at,
                format!(
                    "more than {max_markup} elements, comments and processing instructions, the \
                     most this format's limits allow"
                ),
            ));
        }
        Ok(())
    };
    while i < n {
        let lt = input[i..].find('<').map_or(n, |k| i + k);
        if depth == 0
            && let Some(k) = b[i..lt].iter().position(|c| !c.is_ascii_whitespace())
        {
            return Err(if root_seen {
                (i + k, "content after the root element's end tag".into())
            } else {
                (
                    i + k,
                    "text before the root element; a hair file starts with `<?xml` or its \
                     root element"
                        .into(),
                )
            });
        }
        i = lt;
        if i >= n {
            break;
        }
        let rest = &input[i..];
        let skip_to = |open_len: usize, close: &str, what: &str| {
            rest[open_len..]
                .find(close)
                .map(|k| i + open_len + k + close.len())
                .ok_or_else(|| {
                    let (line, column) = line_column(input, i);
                    truncated(format!(
                        "the file ends inside a {what} opened at {line}:{column} (no `{close}`)"
                    ))
                })
        };
        if rest.starts_with("<!--") {
            count(&mut markup, i)?;
            i = skip_to(4, "-->", "comment")?;
        } else if rest.starts_with("<![CDATA[") {
            if depth == 0 {
                return Err((i, "CDATA outside the root element".into()));
            }
            count(&mut markup, i)?;
            i = skip_to(9, "]]>", "CDATA section")?;
        } else if "<!--".starts_with(rest) || "<![CDATA[".starts_with(rest) {
            return Err(truncated(
                "the file ends inside the start of a comment or CDATA section".into(),
            ));
        } else if rest.starts_with("<!") {
            return Err((
                i,
                "<!DOCTYPE> and other <!...> declarations are not allowed in hair files \
                 (entities could expand without bound)"
                    .into(),
            ));
        } else if rest.starts_with("<?") {
            count(&mut markup, i)?;
            i = skip_to(2, "?>", "processing instruction")?;
        } else if rest.starts_with("</") {
            let (start, end) = name(b, i + 2);
            let tag = &input[start..end];
            let gt = input[end..]
                .find('>')
                .map(|k| end + k)
                .ok_or_else(|| truncated(format!("the file ends inside the end tag </{tag}")))?;
            if depth == 0 {
                return Err((i, format!("</{tag}> closes nothing")));
            }
            let (s, e, at) = open[depth - 1];
            if &input[s..e] != tag {
                let (line, column) = line_column(input, at);
                return Err((
                    i,
                    format!(
                        "</{tag}> closes <{}> (opened at {line}:{column})",
                        &input[s..e]
                    ),
                ));
            }
            depth -= 1;
            root_closed |= depth == 0;
            i = gt + 1;
        } else {
            if root_closed {
                return Err((i, "content after the root element's end tag".into()));
            }
            let (start, end) = name(b, i + 1);
            if start == end {
                return Err(if i + 1 >= n {
                    truncated("the file ends where an element name after `<` was expected".into())
                } else {
                    (
                        i + 1,
                        "expected an element name after `<`; write &lt; for a literal `<` in \
                         text"
                            .into(),
                    )
                });
            }
            count(&mut markup, i)?;
            let (k, empty, in_tag) = attributes(input, i, (start, end))?;
            attributes_in_all += in_tag;
            if attributes_in_all > max_attributes {
                return Err((
                    i,
                    format!(
                        "more than {max_attributes} attributes in all, the most this format's \
                         limits allow"
                    ),
                ));
            }
            if empty {
                root_closed |= depth == 0;
            } else {
                if depth == MAX_DEPTH {
                    return Err((i, format!("elements nest deeper than {MAX_DEPTH} levels")));
                }
                open[depth] = (start, end, i);
                depth += 1;
            }
            root_seen = true;
            i = k;
        }
    }
    if depth > 0 {
        let (s, e, at) = open[depth - 1];
        let (line, column) = line_column(input, at);
        return Err(truncated(format!(
            "the file ends inside <{}> (opened at {line}:{column})",
            &input[s..e]
        )));
    }
    if !root_seen {
        return Err((n, "the file has no root element (is it empty?)".into()));
    }
    Ok(Scanned { markup })
}

/// The name starting at `at` (empty when none does): a letter, `_` or `:`, then anything up to
/// whitespace or a character that ends a name.
fn name(b: &[u8], at: usize) -> (usize, usize) {
    let ends = |c: u8| {
        c.is_ascii_whitespace() || matches!(c, b'/' | b'>' | b'=' | b'<' | b'"' | b'\'' | b'&')
    };
    let starts = |c: u8| c.is_ascii_alphabetic() || matches!(c, b'_' | b':') || c >= 0x80;
    if at >= b.len() || !starts(b[at]) {
        return (at, at);
    }
    let len = b[at..]
        .iter()
        .position(|&c| ends(c))
        .unwrap_or(b.len() - at);
    (at, at + len)
}

/// The attributes of the start tag at `tag` named `element`: at most [`MAX_ATTRIBUTES`], each
/// once, none a namespace declaration, each value quoted. Returns the offset after the tag,
/// whether it is empty (`/>`) and its attributes.
fn attributes(
    input: &str,
    tag: usize,
    (start, end): (usize, usize),
) -> Result<(usize, bool, usize), ScanError> {
    let b = input.as_bytes();
    let n = b.len();
    let element = &input[start..end];
    let mut seen = [(0usize, 0usize); MAX_ATTRIBUTES];
    let mut count = 0;
    let mut k = end;
    let ends_inside = || {
        let (line, column) = line_column(input, tag);
        (
            n,
            format!(
                "the file ends inside the tag <{element}> at {line}:{column}; is it truncated?"
            ),
        )
    };
    loop {
        let before = k;
        while k < n && b[k].is_ascii_whitespace() {
            k += 1;
        }
        if k >= n {
            return Err(ends_inside());
        }
        if b[k] == b'>' {
            return Ok((k + 1, false, count));
        }
        if b[k..].starts_with(b"/>") {
            return Ok((k + 2, true, count));
        }
        let (a, a_end) = name(b, k);
        if a == a_end || k == before {
            return Err((
                k,
                format!("<{element}>: expected whitespace, `>` or `/>` here"),
            ));
        }
        let attr = &input[a..a_end];
        if count == MAX_ATTRIBUTES {
            return Err((
                a,
                format!("<{element}> has more than {MAX_ATTRIBUTES} attributes"),
            ));
        }
        if attr == "xmlns" || attr.starts_with("xmlns:") {
            return Err((
                a,
                format!(
                    "<{element}>: namespace declarations (`{attr}`) are not used in hair files"
                ),
            ));
        }
        if seen[..count].iter().any(|&(s, e)| &input[s..e] == attr) {
            return Err((a, format!("<{element}> has the attribute `{attr}` twice")));
        }
        seen[count] = (a, a_end);
        count += 1;
        k = a_end;
        while k < n && b[k].is_ascii_whitespace() {
            k += 1;
        }
        if k >= n {
            return Err(ends_inside());
        }
        if b[k] != b'=' {
            return Err((
                k,
                format!("<{element}> attribute `{attr}`: expected `=` and a quoted value"),
            ));
        }
        k += 1;
        while k < n && b[k].is_ascii_whitespace() {
            k += 1;
        }
        if k >= n {
            return Err(ends_inside());
        }
        let quote = b[k];
        if quote != b'"' && quote != b'\'' {
            return Err((
                k,
                format!("<{element}> attribute `{attr}`: the value must be in quotes"),
            ));
        }
        let Some(close) = b[k + 1..].iter().position(|&c| c == quote) else {
            return Err((
                n,
                format!(
                    "the file ends inside the value of `{attr}` of <{element}>; is it truncated?"
                ),
            ));
        };
        k = k + 1 + close + 1;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(text: &str) -> (u32, u32, String) {
        let (at, message) = prescan(text, 100, 100).unwrap_err();
        let (line, column) = line_column(text, at);
        (line, column, message)
    }

    #[test]
    fn well_formed_files_pass_and_their_markup_is_counted() {
        let text = "\u{feff}<?xml version=\"1.0\"?>\n<!-- a -->\n<g v='1' w=\"a>b\">\
                    <s>1 2</s><s/><![CDATA[x]]></g>\n<!-- end -->\n";
        assert_eq!(prescan(text, 100, 100), Ok(Scanned { markup: 7 }));
        assert!(prescan(text, 6, 100).is_err());
    }

    #[test]
    fn each_refusal_is_at_its_place() {
        let (line, column, m) = refused("<g>\n <s  xmlns:x=\"u\"/></g>");
        assert_eq!((line, column), (2, 6), "{m}");
        assert!(m.contains("namespace"), "{m}");
        let attrs: String = (0..40).map(|i| format!(" a{i}='1'")).collect();
        let (_, column, m) = refused(&format!("<g{attrs}/>"));
        // `<g`, ten attributes of 7 bytes and 22 of 8, a space: the 33rd's name.
        assert_eq!(column, 1 + 2 + 10 * 7 + 22 * 8 + 1, "{m}");
        assert!(m.contains("more than 32 attributes"), "{m}");
        let (line, column, m) = refused("<g>\n<!DOCTYPE g></g>");
        assert_eq!((line, column), (2, 1), "{m}");
        let (_, _, m) = refused("<g a='1' a='2'/>");
        assert!(m.contains("`a` twice"), "{m}");
        let (_, _, m) = refused(&format!("{}{}", "<x>".repeat(33), "</x>".repeat(33)));
        assert!(m.contains("deeper than 32"), "{m}");
        let (_, _, m) = refused("<g><s></t></g>");
        assert!(m.contains("</t> closes <s> (opened at 1:4)"), "{m}");
        let (_, _, m) = refused("<g/><h/>");
        assert!(m.contains("after the root element"), "{m}");
    }

    #[test]
    fn a_file_cut_short_is_blamed_at_its_end() {
        let full = "<g a=\"1\">\n <s>1 2</s><!-- c --></g>";
        for cut in 1..full.len() {
            let text = &full[..cut];
            let (at, message) = prescan(text, 100, 100).unwrap_err();
            assert_eq!(at, text.len(), "cut at {cut}: {message}");
            assert!(message.contains("truncated"), "cut at {cut}: {message}");
        }
    }
}
