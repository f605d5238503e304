//! A small element tree over quick-xml events, with 1-based line numbers.
//!
//! OpenSim documents are read into this tree first so that every later error
//! ("unknown joint type", "socket names a frame that does not exist") can name
//! the file, the element and the line. quick-xml does the tokenizing; this
//! module only records what it reports.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use quick_xml::events::Event;
use quick_xml::{Reader, XmlVersion};

use crate::error::{Error, Location, Result};

/// The string type of the tree's names, attribute keys and values and
/// texts: up to 24 bytes are held inline (most of an OpenSim document's
/// names and values, and short texts such as `0 0 0` or `true`), so that
/// reading a document allocates for long texts only.
pub use compact_str::CompactString as XmlString;

/// One XML element: name, attributes, child elements, concatenated text and
/// the line it starts on.
#[derive(Debug, Clone)]
pub struct Element {
    pub name: XmlString,
    pub attrs: Vec<(XmlString, XmlString)>,
    pub children: Vec<Element>,
    pub text: XmlString,
    pub line: usize,
    pub file: Arc<Path>,
}

/// Parse an XML file into its root element.
pub fn parse_file(path: &Path) -> Result<Element> {
    PARSED.count(path);
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_str(&text, path)
}

/// How many times [`parse_file`] read each path, so that tests can check
/// that a run parses its model once.
static PARSED: crate::file_counts::PathCounts = crate::file_counts::PathCounts::new();

/// How many times [`parse_file`] read the file `path` (as spelled by its
/// caller) since the process started.
pub fn times_parsed(path: &Path) -> usize {
    PARSED.get(path)
}

/// Parse XML text; `file` is used only for error messages.
pub fn parse_str(text: &str, file: &Path) -> Result<Element> {
    let file: Arc<Path> = Arc::from(file);
    let bytes = text.as_bytes();
    // Line of a byte position: one more than the newlines before it.
    let line_of = |pos: u64| -> usize {
        let pos = (pos as usize).min(bytes.len());
        1 + memchr::memchr_iter(b'\n', &bytes[..pos]).count()
    };
    let err_at = |pos: u64, msg: String| {
        Error::input(
            Location {
                file: Some(file.to_path_buf()),
                line: Some(line_of(pos)),
                element: None,
            },
            msg,
        )
    };

    // Elements come in document order: each one's line is counted on from
    // the previous element's (position, line).
    let mut line_cursor = (0usize, 1usize);
    let line_after = |cursor: &mut (usize, usize), pos: usize| -> usize {
        let pos = pos.min(bytes.len());
        if pos < cursor.0 {
            *cursor = (pos, line_of(pos as u64));
        } else {
            cursor.1 += memchr::memchr_iter(b'\n', &bytes[cursor.0..pos]).count();
            cursor.0 = pos;
        }
        cursor.1
    };

    let mut reader = Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<Element> = Vec::new();
    let mut attr_scratch: Vec<(XmlString, XmlString)> = Vec::new();
    let mut root: Option<Element> = None;
    let version = XmlVersion::Implicit1_0;

    loop {
        let start = reader.buffer_position();
        let ev = reader
            .read_event()
            .map_err(|e| err_at(reader.error_position(), format!("malformed XML: {e}")))?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let is_empty = matches!(ev, Event::Empty(_));
                let name = XmlString::from(e.name().as_ref());
                for a in e.attributes() {
                    let a = a.map_err(|err| {
                        err_at(start, format!("malformed attribute in <{name}>: {err}"))
                    })?;
                    let key = XmlString::from(a.key.as_ref());
                    let value = XmlString::from(
                        a.normalized_value(version)
                            .map_err(|err| {
                                err_at(start, format!("malformed attribute in <{name}>: {err}"))
                            })?
                            .as_ref(),
                    );
                    attr_scratch.push((key, value));
                }
                // Collected through a scratch list so that each element's
                // list is allocated once, at its size.
                let attrs = if attr_scratch.is_empty() {
                    Vec::new()
                } else {
                    attr_scratch.drain(..).collect()
                };
                let el = Element {
                    name,
                    attrs,
                    children: Vec::new(),
                    text: XmlString::const_new(""),
                    line: line_after(
                        &mut line_cursor,
                        start as usize + leading_ws(text, start as usize),
                    ),
                    file: file.clone(),
                };
                if is_empty {
                    attach(&mut stack, &mut root, el, || {
                        err_at(start, "more than one root element".into())
                    })?;
                } else {
                    stack.push(el);
                }
            }
            Event::End(_) => {
                let el = stack
                    .pop()
                    .ok_or_else(|| err_at(start, "unexpected closing tag".into()))?;
                attach(&mut stack, &mut root, el, || {
                    err_at(start, "more than one root element".into())
                })?;
            }
            Event::Text(t) => {
                if let Some(top) = stack.last_mut() {
                    // Whitespace before an element's first text (the
                    // indentation between child elements) is never read:
                    // `text()` trims it.
                    if !(top.text.is_empty()
                        && AsRef::<[u8]>::as_ref(&*t)
                            .iter()
                            .all(u8::is_ascii_whitespace))
                    {
                        let piece = t.xml_content(version);
                        if top.text.is_empty() {
                            // One text event (the usual case) is stored at its size.
                            top.text = XmlString::from(piece.as_ref());
                        } else {
                            top.text.push_str(&piece);
                        }
                    }
                }
            }
            Event::CData(t) => {
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&t.into_inner());
                }
            }
            Event::GeneralRef(r) => {
                let resolved: Cow<str> = match r.resolve_char_ref() {
                    Ok(Some(c)) => Cow::Owned(c.to_string()),
                    _ => {
                        let name = r.xml_content(version);
                        match name.as_ref() {
                            "amp" => "&".into(),
                            "lt" => "<".into(),
                            "gt" => ">".into(),
                            "quot" => "\"".into(),
                            "apos" => "'".into(),
                            other => {
                                return Err(err_at(start, format!("unknown XML entity &{other};")))
                            }
                        }
                    }
                };
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&resolved);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(Error::input(
            Location {
                file: Some(file.to_path_buf()),
                line: Some(open.line),
                element: Some(format!("<{}>", open.name)),
            },
            "malformed XML: element is never closed (file truncated?)",
        ));
    }
    root.ok_or_else(|| {
        Error::input(
            Location {
                file: Some(file.to_path_buf()),
                ..Default::default()
            },
            "no XML element found",
        )
    })
}

fn leading_ws(text: &str, pos: usize) -> usize {
    text.as_bytes()[pos.min(text.len())..]
        .iter()
        .take_while(|b| b.is_ascii_whitespace())
        .count()
}

fn attach(
    stack: &mut [Element],
    root: &mut Option<Element>,
    el: Element,
    dup: impl FnOnce() -> Error,
) -> Result<()> {
    match stack.last_mut() {
        Some(parent) => parent.children.push(el),
        None => {
            if root.is_some() {
                return Err(dup());
            }
            *root = Some(el);
        }
    }
    Ok(())
}

impl Element {
    /// Location of this element for error messages: file, line and `<Name name="...">`.
    pub fn loc(&self) -> Location {
        Location {
            file: Some(self.file.to_path_buf()),
            line: Some(self.line),
            element: Some(self.describe()),
        }
    }

    /// `<Body name="femur_r">` or `<mass>`.
    pub fn describe(&self) -> String {
        match self.attr("name") {
            Some(n) => format!("<{} name=\"{}\">", self.name, n),
            None => format!("<{}>", self.name),
        }
    }

    /// An input error located at this element.
    pub fn error(&self, msg: impl Into<String>) -> Error {
        Error::input(self.loc(), msg)
    }

    pub fn file_path(&self) -> PathBuf {
        self.file.to_path_buf()
    }

    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The `name` attribute, or "" when absent.
    pub fn name_attr(&self) -> &str {
        self.attr("name").unwrap_or("")
    }

    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> + 'a {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// The element's text with surrounding whitespace removed.
    pub fn text(&self) -> &str {
        self.text.trim()
    }

    /// Text of the child `name`, trimmed; None if the child is absent.
    pub fn child_text(&self, name: &str) -> Option<&str> {
        self.child(name).map(|c| c.text())
    }

    /// Follow a path of child names, e.g. `["BodySet", "objects"]`.
    pub fn path(&self, names: &[&str]) -> Option<&Element> {
        let mut el = self;
        for n in names {
            el = el.child(n)?;
        }
        Some(el)
    }

    /// Parse this element's text as finite numbers separated by whitespace or
    /// commas. `NaN` and `Inf` are refused with an error naming the element:
    /// no property read this way has a meaning for them (the few that do,
    /// such as `max_control`, use [`Element::numbers_allow_inf`]).
    pub fn numbers(&self) -> Result<Vec<f64>> {
        let v = self.numbers_allow_inf()?;
        if let Some(x) = v.iter().find(|x| x.is_infinite()) {
            return Err(self.error(format!(
                "value {x} is not finite (Inf is not accepted here)"
            )));
        }
        Ok(v)
    }

    /// Like [`Element::numbers`], but `Inf` / `-Inf` are accepted (bounds
    /// such as `max_control`, `time_range` or a coordinate's `range`, where
    /// OpenSim itself writes `-Inf Inf` for "unbounded"). `NaN` is refused.
    pub fn numbers_allow_inf(&self) -> Result<Vec<f64>> {
        let v = parse_numbers(self.text())
            .map_err(|tok| self.error(format!("expected numbers, found '{tok}'")))?;
        if v.iter().any(|x| x.is_nan()) {
            return Err(self.error(format!(
                "NaN in '{}' is not accepted: every number must be given",
                self.text()
            )));
        }
        Ok(v)
    }

    /// Parse this element's text as exactly `n` numbers.
    pub fn numbers_n(&self, n: usize) -> Result<Vec<f64>> {
        let v = self.numbers()?;
        if v.len() != n {
            return Err(self.error(format!("expected {n} numbers, found {}", v.len())));
        }
        Ok(v)
    }

    pub fn f64(&self) -> Result<f64> {
        Ok(self.numbers_n(1)?[0])
    }

    pub fn vec3(&self) -> Result<nalgebra::Vector3<f64>> {
        let v = self.numbers_n(3)?;
        Ok(nalgebra::Vector3::new(v[0], v[1], v[2]))
    }

    pub fn bool(&self) -> Result<bool> {
        match self.text().to_ascii_lowercase().as_str() {
            "true" | "1" | "yes" => Ok(true),
            "false" | "0" | "no" => Ok(false),
            other => Err(self.error(format!("expected true or false, found '{other}'"))),
        }
    }

    pub fn int(&self) -> Result<i64> {
        self.text()
            .parse::<i64>()
            .map_err(|_| self.error(format!("expected an integer, found '{}'", self.text())))
    }

    /// Optional child parsed as one number that may be `Inf` / `-Inf` (not
    /// `NaN`), with a default when absent.
    pub fn child_f64_or_inf(&self, name: &str, default: f64) -> Result<f64> {
        match self.child(name) {
            Some(c) if !c.text().is_empty() => {
                let v = c.numbers_allow_inf()?;
                if v.len() != 1 {
                    return Err(c.error(format!("expected 1 number, found {}", v.len())));
                }
                Ok(v[0])
            }
            _ => Ok(default),
        }
    }

    /// Optional child parsed as f64, with a default when absent.
    pub fn child_f64_or(&self, name: &str, default: f64) -> Result<f64> {
        match self.child(name) {
            Some(c) if !c.text().is_empty() => c.f64(),
            _ => Ok(default),
        }
    }

    pub fn child_bool_or(&self, name: &str, default: bool) -> Result<bool> {
        match self.child(name) {
            Some(c) if !c.text().is_empty() => c.bool(),
            _ => Ok(default),
        }
    }

    pub fn child_vec3_or(&self, name: &str, default: [f64; 3]) -> Result<nalgebra::Vector3<f64>> {
        match self.child(name) {
            Some(c) if !c.text().is_empty() => c.vec3(),
            _ => Ok(nalgebra::Vector3::from(default)),
        }
    }

    /// Required child; error names the missing property.
    pub fn req(&self, name: &str) -> Result<&Element> {
        self.child(name)
            .ok_or_else(|| self.error(format!("missing property <{name}>")))
    }

    /// Whitespace-separated list of words in this element's text.
    pub fn words(&self) -> Vec<String> {
        self.text().split_whitespace().map(str::to_string).collect()
    }
}

/// Parse whitespace- or comma-separated numbers, accepting OpenSim's `Inf`,
/// `-Inf`, `NaN` spellings. On failure returns the offending token.
pub fn parse_numbers(s: &str) -> std::result::Result<Vec<f64>, String> {
    s.split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .map(|t| parse_number(t).ok_or_else(|| t.to_string()))
        .collect()
}

/// One number in OpenSim's spelling (`1e-3`, `Inf`, `-inf`, `NaN`, `1.#INF`).
pub fn parse_number(t: &str) -> Option<f64> {
    if let Ok(v) = t.parse::<f64>() {
        return Some(v);
    }
    match t.to_ascii_lowercase().as_str() {
        "inf" | "+inf" | "infinity" | "1.#inf" => Some(f64::INFINITY),
        "-inf" | "-infinity" | "-1.#inf" => Some(f64::NEG_INFINITY),
        "nan" | "-nan" | "1.#ind" | "-1.#ind" => Some(f64::NAN),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Text around comments and child elements concatenates as read; the
    /// indentation before an element's first text is dropped (`text()`
    /// trims it anyway), whitespace between two pieces of text is kept.
    #[test]
    fn text_pieces_and_indentation() {
        let src = "<A>\n  <B/>\n  1 <!--c--> 2\n  <C>3<!--x--> <!--y-->4</C>\n</A>";
        let root = parse_str(src, Path::new("t.xml")).unwrap();
        assert_eq!(root.text(), "1  2");
        assert_eq!(root.child("C").unwrap().text(), "3 4");
        assert_eq!(root.child("B").unwrap().text, "");
        assert_eq!(root.child("C").unwrap().line, 4);
    }

    #[test]
    fn tree_with_lines_and_text() {
        let src = "<?xml version=\"1.0\"?>\n<A name=\"a\">\n  <B>1 2 3</B>\n  <C/>\n  <D>x &amp; y</D>\n</A>\n";
        let root = parse_str(src, Path::new("t.xml")).unwrap();
        assert_eq!(root.name, "A");
        assert_eq!(root.line, 2);
        assert_eq!(root.child("B").unwrap().line, 3);
        assert_eq!(
            root.child("B").unwrap().numbers().unwrap(),
            vec![1.0, 2.0, 3.0]
        );
        assert_eq!(root.child("C").unwrap().line, 4);
        assert_eq!(root.child("D").unwrap().text(), "x & y");
    }

    /// Lines counted on from the previous element are each element's line,
    /// with several elements on a line, CRLF line ends, comments and
    /// whitespace before a tag.
    #[test]
    fn lines_in_document_order() {
        let src =
            "<A>\r\n<B/><C>x</C>\r\n\r\n  <!-- c\n -->  <D a=\"1\"\n b=\"2\">\n<E/></D><F/>\n</A>";
        let root = parse_str(src, Path::new("t.xml")).unwrap();
        let lines: Vec<(&str, usize)> = root
            .children
            .iter()
            .map(|c| (c.name.as_str(), c.line))
            .collect();
        assert_eq!(lines, vec![("B", 2), ("C", 2), ("D", 5), ("F", 7)]);
        assert_eq!(root.child("D").unwrap().child("E").unwrap().line, 7);
        assert_eq!(root.child("D").unwrap().attr("b"), Some("2"));
    }

    /// Long names, values and texts (kept on the heap) and short ones (kept
    /// inline) read the same; several text pieces concatenate.
    #[test]
    fn long_and_short_strings() {
        let long = "x".repeat(100);
        let src = format!(
            "<A n=\"{long}\"><{long}>{long} 1</{long}><b>1 2</b><c>a<!--x-->{long}</c></A>"
        );
        let root = parse_str(&src, Path::new("t.xml")).unwrap();
        assert_eq!(root.attr("n"), Some(long.as_str()));
        assert_eq!(root.children[0].name, long.as_str());
        assert_eq!(root.children[0].text(), format!("{long} 1"));
        assert_eq!(root.child_text("b"), Some("1 2"));
        assert_eq!(root.child_text("c"), Some(format!("a{long}").as_str()));
    }

    #[test]
    fn truncated_document_is_an_error_with_line() {
        let src = "<A>\n<B>\n<C>1</C>\n";
        let e = parse_str(src, Path::new("t.xml")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("t.xml"), "{msg}");
        assert!(
            msg.contains("never closed") || msg.contains("malformed"),
            "{msg}"
        );
        assert_eq!(e.exit_code(), 2);
    }

    #[test]
    fn mismatched_tag_names_line() {
        let src = "<A>\n<B>\n</C>\n</A>";
        let e = parse_str(src, Path::new("t.xml")).unwrap_err();
        assert!(e.to_string().contains("line 3"), "{e}");
    }

    #[test]
    fn bad_number_names_element() {
        let src = "<A>\n <mass>abc</mass></A>";
        let root = parse_str(src, Path::new("m.osim")).unwrap();
        let e = root.child("mass").unwrap().f64().unwrap_err().to_string();
        assert!(
            e.contains("m.osim")
                && e.contains("line 2")
                && e.contains("<mass>")
                && e.contains("abc"),
            "{e}"
        );
    }

    #[test]
    fn inf_spellings() {
        assert_eq!(
            parse_numbers("Inf -Inf 1e3").unwrap(),
            vec![f64::INFINITY, f64::NEG_INFINITY, 1000.0]
        );
    }
}
