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

/// One XML element: name, attributes, child elements, concatenated text and
/// the line it starts on.
#[derive(Debug, Clone)]
pub struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub text: String,
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
    let lines = line_starts(text);
    parse_part(text, &file, &lines, Span::Whole).map(|(root, _)| root)
}

/// Parse an XML file into its root element as [`parse_file`] does, the
/// members of the first `<objects>` list inside the element `<split_in …>`
/// (a model's `<ForceSet>`: gait2392's muscles, 72 % of its 0.6 MB) read in
/// two halves, one of them on a thread of its own, beside the rest of the
/// document.
///
/// The same tree, lines and errors as [`parse_file`]: each half is read as
/// the content of an element of its own, and the rest with the list's
/// content left out; the pieces are joined only when each half is a
/// sequence of complete elements with no text of its own and the list's
/// start tag is where it was looked for in the rest. Reading one element's
/// content in two pieces then gives the elements one reading gives. In any
/// other case (and for files under 256 KiB) the file is read in one piece,
/// which also makes every error message the one-piece reading's.
pub fn parse_file_split(path: &Path, split_in: &str) -> Result<Element> {
    PARSED.count(path);
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    if text.len() >= SPLIT_MIN_BYTES {
        if let Some(root) = parse_split(&text, path, split_in) {
            return Ok(root);
        }
    }
    parse_str(&text, path)
}

/// Files smaller than this are read in one piece ([`parse_file_split`]).
const SPLIT_MIN_BYTES: usize = 256 * 1024;

/// The opening and closing tags around a piece read on its own.
const WRAP_OPEN: &str = "<piece>";
const WRAP_CLOSE: &str = "</piece>";

/// Byte offsets of the starts of the text's lines.
fn line_starts(text: &str) -> Vec<usize> {
    std::iter::once(0)
        .chain(memchr::memchr_iter(b'\n', text.as_bytes()).map(|i| i + 1))
        .collect()
}

/// Where a piece being read lies in the whole text (for line numbers).
#[derive(Clone, Copy)]
enum Span {
    /// The whole text.
    Whole,
    /// `WRAP_OPEN`, the whole text's bytes from `start` on, `WRAP_CLOSE`.
    Piece { start: usize },
    /// The whole text without its bytes `cut..cut + removed`; the element
    /// whose start tag ends at `cut` is the hole the pieces fill.
    Rest { cut: usize, removed: usize },
}

impl Span {
    /// The whole text's offset of the piece's offset `pos`.
    fn global(self, pos: u64) -> u64 {
        match self {
            Span::Whole => pos,
            Span::Piece { start } => (start as u64 + pos).saturating_sub(WRAP_OPEN.len() as u64),
            Span::Rest { cut, removed } if pos as usize >= cut => pos + removed as u64,
            Span::Rest { .. } => pos,
        }
    }
}

/// [`parse_file_split`]'s split reading, or None to read in one piece.
fn parse_split(text: &str, path: &Path, split_in: &str) -> Option<Element> {
    let bytes = text.as_bytes();
    let open = format!("<{split_in}");
    let at = memchr::memmem::find_iter(bytes, open.as_bytes()).find(|&i| {
        matches!(
            bytes.get(i + open.len()),
            Some(b' ' | b'\t' | b'\r' | b'\n' | b'>')
        )
    })?;
    let close = format!("</{split_in}>");
    let end = at + memchr::memmem::find(&bytes[at..], close.as_bytes())?;
    // The list's content: after the first `<objects>`, up to the last
    // `</objects>` before the element's end.
    let cs = at + memchr::memmem::find(&bytes[at..end], b"<objects>")? + "<objects>".len();
    let ce = cs + memchr::memmem::rfind(&bytes[cs..end], b"</objects>")?;
    // Two halves, the first about half the file (read beside the rest and
    // the second half); split before a member, found as a line indented
    // as the first member.
    let first = cs + memchr::memchr(b'<', &bytes[cs..ce])?;
    let line = bytes[..first].iter().rposition(|&b| b == b'\n')? + 1;
    let indent = &bytes[line..first];
    if !indent.iter().all(|&b| b == b' ' || b == b'\t') {
        return None;
    }
    let mut marker = Vec::with_capacity(indent.len() + 2);
    marker.push(b'\n');
    marker.extend_from_slice(indent);
    marker.push(b'<');
    let goal = (cs + text.len() / 2).clamp(cs, ce);
    let sp =
        goal + memchr::memmem::find_iter(&bytes[goal..ce], &marker).find(|&i| {
            bytes
                .get(goal + i + marker.len())
                .is_some_and(|b| b.is_ascii_alphabetic() || *b == b'_')
        })? + 1;
    let piece = |a: usize, b: usize| {
        let mut s = String::with_capacity(b - a + WRAP_OPEN.len() + WRAP_CLOSE.len());
        s.push_str(WRAP_OPEN);
        s.push_str(&text[a..b]);
        s.push_str(WRAP_CLOSE);
        s
    };
    let (first_half, second_half) = (piece(cs, sp), piece(sp, ce));
    let mut rest = String::with_capacity(text.len() - (ce - cs));
    rest.push_str(&text[..cs]);
    rest.push_str(&text[ce..]);
    let file: Arc<Path> = Arc::from(path);
    let lines = line_starts(text);
    let read_piece = |s: &str, start: usize| -> Option<Vec<Element>> {
        let (wrap, _) = parse_part(s, &file, &lines, Span::Piece { start }).ok()?;
        (wrap.text.is_empty() && wrap.attrs.is_empty()).then_some(wrap.children)
    };
    let (a, b, outer) = std::thread::scope(|s| {
        let a = std::thread::Builder::new()
            .name("xml-piece".into())
            .spawn_scoped(s, || read_piece(&first_half, cs));
        let outer = parse_part(
            &rest,
            &file,
            &lines,
            Span::Rest {
                cut: cs,
                removed: ce - cs,
            },
        )
        .ok();
        let b = read_piece(&second_half, sp);
        let a = match a {
            Ok(h) => h.join().ok().flatten(),
            Err(_) => read_piece(&first_half, cs),
        };
        (a, b, outer)
    });
    let (mut root, hole) = outer?;
    let mut el = &mut root;
    for i in hole? {
        el = el.children.get_mut(i)?;
    }
    if !el.children.is_empty() || !el.text.is_empty() {
        return None;
    }
    let mut members = a?;
    members.extend(b?);
    el.children = members;
    Some(root)
}

/// Read `text`, a piece of the whole text whose line starts are `lines`:
/// the root element and, for [`Span::Rest`], the path of child indices
/// from the root to the element whose start tag ends at the cut (None if
/// there is none).
fn parse_part(
    text: &str,
    file: &Arc<Path>,
    lines: &[usize],
    span: Span,
) -> Result<(Element, Option<Vec<usize>>)> {
    let file = file.clone();
    let hole_at = match span {
        Span::Rest { cut, .. } => Some(cut as u64),
        _ => None,
    };
    let mut hole = None;
    let line_of = |pos: u64| -> usize {
        let pos = span.global(pos) as usize;
        match lines.binary_search(&pos) {
            Ok(i) => i + 1,
            Err(i) => i,
        }
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

    let mut reader = Reader::from_str(text);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<Element> = Vec::new();
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
                let name = e.name().as_ref().to_string();
                let mut attrs = Vec::new();
                for a in e.attributes() {
                    let a = a.map_err(|err| {
                        err_at(start, format!("malformed attribute in <{name}>: {err}"))
                    })?;
                    let key = a.key.as_ref().to_string();
                    let value = a
                        .normalized_value(version)
                        .map_err(|err| {
                            err_at(start, format!("malformed attribute in <{name}>: {err}"))
                        })?
                        .into_owned();
                    attrs.push((key, value));
                }
                let el = Element {
                    name,
                    attrs,
                    children: Vec::new(),
                    text: String::new(),
                    line: line_of(start + leading_ws(text, start as usize) as u64),
                    file: file.clone(),
                };
                if is_empty {
                    attach(&mut stack, &mut root, el, || {
                        err_at(start, "more than one root element".into())
                    })?;
                } else {
                    if hole_at == Some(reader.buffer_position()) {
                        hole = Some(stack.iter().map(|e| e.children.len()).collect());
                    }
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
                        top.text.push_str(&t.xml_content(version));
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
    let root = root.ok_or_else(|| {
        Error::input(
            Location {
                file: Some(file.to_path_buf()),
                ..Default::default()
            },
            "no XML element found",
        )
    })?;
    Ok((root, hole))
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

    /// A model-like document over `SPLIT_MIN_BYTES`: a force set of `n`
    /// members, each with comments, text and nested `<objects>` lists;
    /// `member(i)` may replace the i-th member's text.
    fn big_document(n: usize, member: impl Fn(usize) -> Option<String>) -> String {
        let mut s = String::from(
            "<?xml version=\"1.0\"?>\n<OpenSimDocument Version=\"40000\">\n\t<Model name=\"m\">\n\t\t<BodySet><objects><Body name=\"b\"/></objects></BodySet>\n\t\t<ForceSet name=\"forces\">\n\t\t\t<objects>\n",
        );
        for i in 0..n {
            s.push_str(&member(i).unwrap_or_else(|| {
                format!(
                    "\t\t\t\t<!-- member {i} -->\n\t\t\t\t<Thelen2003Muscle name=\"m{i}\">\n\t\t\t\t\t<max_isometric_force>{i}.5</max_isometric_force>\n\t\t\t\t\t<GeometryPath>\n\t\t\t\t\t\t<PathPointSet>\n\t\t\t\t\t\t\t<objects>\n\t\t\t\t\t\t\t\t<PathPoint name=\"p{i}\"><location>1 2 &amp; 3</location></PathPoint>\n\t\t\t\t\t\t\t</objects>\n\t\t\t\t\t\t</PathPointSet>\n\t\t\t\t\t</GeometryPath>\n\t\t\t\t</Thelen2003Muscle>\n"
                )
            }));
        }
        s.push_str("\t\t\t</objects>\n\t\t\t<groups/>\n\t\t</ForceSet>\n\t\t<MarkerSet><objects/></MarkerSet>\n\t</Model>\n</OpenSimDocument>\n");
        assert!(s.len() >= SPLIT_MIN_BYTES);
        s
    }

    /// Read in pieces, a document gives the tree (names, attributes, text,
    /// lines) of one reading.
    #[test]
    fn split_reading_gives_the_one_piece_tree() {
        let tmp = crate::test_dir::TempDir::new("xml_split");
        let path = tmp.path().join("big.osim");
        std::fs::write(&path, big_document(1200, |_| None)).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let split = parse_split(&text, &path, "ForceSet").expect("read in pieces");
        let whole = parse_file(&path).unwrap();
        assert_eq!(format!("{split:?}"), format!("{whole:?}"));
        let members = &split.children[0].child("ForceSet").unwrap().children[0].children;
        assert_eq!(members.len(), 1200);
        assert_eq!(
            members[1199].line,
            whole.children[0].children[1].children[0].children[1199].line
        );
        assert_eq!(
            format!("{:?}", parse_file_split(&path, "ForceSet").unwrap()),
            format!("{whole:?}")
        );
    }

    /// The shared models (gait2392, Rajagopal, the knee and walking
    /// models) read in pieces give their one-piece trees.
    #[test]
    fn shared_models_read_in_pieces_as_in_one() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!(
                "SKIP shared_models_read_in_pieces_as_in_one: {} absent",
                dir.display()
            );
            return;
        };
        let mut split = 0;
        for model in entries.flatten() {
            for f in std::fs::read_dir(model.path())
                .into_iter()
                .flatten()
                .flatten()
            {
                let path = f.path();
                if path.extension().is_none_or(|e| e != "osim") {
                    continue;
                }
                let text = std::fs::read_to_string(&path).unwrap();
                let whole = parse_file(&path).unwrap();
                if let Some(pieces) = parse_split(&text, &path, "ForceSet") {
                    assert_eq!(
                        format!("{pieces:?}"),
                        format!("{whole:?}"),
                        "{}",
                        path.display()
                    );
                    split += 1;
                }
            }
        }
        assert!(split >= 2, "only {split} shared models were read in pieces");
    }

    /// What a split reading cannot join (a malformed member in either
    /// half, text among the members) is read in one piece: the one-piece
    /// error or tree.
    #[test]
    fn split_reading_falls_back_to_one_piece() {
        let tmp = crate::test_dir::TempDir::new("xml_split_fallback");
        let path = tmp.path().join("bad.osim");
        for bad in [10, 1100] {
            let doc = big_document(1200, |i| {
                (i == bad)
                    .then(|| "\t\t\t\t<Thelen2003Muscle name=\"x\">\n\t\t\t\t</Thelen>\n".into())
            });
            std::fs::write(&path, &doc).unwrap();
            assert!(parse_split(&doc, &path, "ForceSet").is_none());
            let e = parse_file_split(&path, "ForceSet").unwrap_err().to_string();
            assert_eq!(e, parse_file(&path).unwrap_err().to_string());
            assert!(e.contains("malformed XML"), "{e}");
        }
        let doc = big_document(1200, |i| (i == 900).then(|| "\t\t\t\tloose text\n".into()));
        std::fs::write(&path, &doc).unwrap();
        assert!(parse_split(&doc, &path, "ForceSet").is_none());
        let whole = parse_file(&path).unwrap();
        assert_eq!(
            format!("{:?}", parse_file_split(&path, "ForceSet").unwrap()),
            format!("{whole:?}")
        );
        assert_eq!(
            whole.children[0].child("ForceSet").unwrap().children[0].text(),
            "loose text"
        );
    }

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
