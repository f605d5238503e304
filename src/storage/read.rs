//! Reading `.sto` / `.mot` files (semantics §1.2–1.4).

use super::source::TableFile;
use super::Storage;
use crate::error::{Error, Location, Result};
use std::path::Path;

/// Read an OpenSim table file.
///
/// The header (up to `endheader`) is parsed first (§1.2). A `version` ≤ 1
/// (a missing `version` counts as 0) selects the legacy `Storage` rules:
/// labels and values separated by spaces or tabs, `nRows` rows read (lines
/// after them are ignored, as OpenSim does; when `nRows` is absent, all rows
/// to the end of the file are read), version-0 `.mot` files forced to degrees
/// (§1.3). A higher version selects the `TimeSeriesTable` rules (§1.4):
/// tab-delimited, first label exactly `time`, data up to the first empty
/// line, `DataType` double, `Vec3` (flattened `_x _y _z`) or `SpatialVec`
/// (flattened `_rx _ry _rz _tx _ty _tz`).
///
/// Stricter than OpenSim, on purpose: the first label must be `time` in both
/// formats, the label count must match `nColumns`, every row must hold
/// exactly one value per column, values must be finite numbers and time must
/// strictly increase. Each violation is an [`Error::Input`] naming the file,
/// the line and (where there is one) the column.
///
/// A table this run wrote (kept by a [`super::results::Capture`]) is read
/// from the bytes kept in memory: the file is not opened.
pub fn read(path: &Path) -> Result<Storage> {
    use super::results::Output;
    match super::results::get(path) {
        Some(Output::Table(t)) => return t.table(path).cloned(),
        Some(Output::Bytes(bytes)) => return read_text(path, &bytes),
        None => {}
    }
    let bytes = super::source::read_bytes(path)?;
    read_text(path, &bytes)
}

/// [`read`] on a [`TableFile`]: from its bytes when they are in memory,
/// else from the disk.
pub fn read_file(file: &TableFile) -> Result<Storage> {
    match file.bytes() {
        Some(bytes) => read_text(file.path(), bytes.as_ref()),
        None => read(file.path()),
    }
}

/// [`read`] on the bytes of the file `path`.
pub(super) fn read_text(path: &Path, bytes: &[u8]) -> Result<Storage> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        Error::input(
            Location::file(path),
            format!(
                "file is not valid UTF-8 text (byte offset {})",
                e.valid_up_to()
            ),
        )
    })?;
    // Lines with their 1-based numbers, trailing CR removed.
    let lines: Vec<(usize, &str)> = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .collect();
    let is_mot = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase().contains(".mot"))
        .unwrap_or(false);
    let header = parse_header(path, &lines)?;
    let body = &lines[header.end_index + 1..];
    if header.version <= 1 {
        read_legacy(path, header, body, is_mot)
    } else {
        read_table(path, header, body)
    }
}

/// What the header block says.
struct Header {
    version: i64,
    n_rows: i64,
    n_columns: i64,
    /// Line number of `nColumns` (for error messages).
    n_columns_line: usize,
    in_degrees: Option<bool>,
    /// `Angles are in degrees/radians.` seen while version was 0.
    legacy_angles: Option<bool>,
    name: Option<String>,
    data_type: Option<(usize, String)>,
    metadata: Vec<(String, String)>,
    /// Index into `lines` of the `endheader` line.
    end_index: usize,
}

fn loc(path: &Path, line: usize) -> Location {
    Location::file(path).with_line(line)
}

/// C `atoi`-like parse of a header integer, but an error if no digits.
fn header_int(path: &Path, line: usize, key: &str, value: &str) -> Result<i64> {
    let v = value.trim();
    let end = v
        .char_indices()
        .find(|&(i, c)| !(c.is_ascii_digit() || (i == 0 && (c == '-' || c == '+'))))
        .map(|(i, _)| i)
        .unwrap_or(v.len());
    v[..end].parse::<i64>().map_err(|_| {
        Error::input(
            loc(path, line),
            format!("header key '{key}' needs an integer, found '{value}'"),
        )
    })
}

/// Does a line look like data (TimeSeriesTable's `[0-9][0-9.\t -]+`)?
fn looks_like_data(line: &str) -> bool {
    let mut chars = line.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_digit())
        && line.len() >= 2
        && chars.all(|c| c.is_ascii_digit() || matches!(c, '.' | '\t' | ' ' | '-'))
}

fn parse_header(path: &Path, lines: &[(usize, &str)]) -> Result<Header> {
    let mut h = Header {
        version: 0,
        n_rows: 0,
        n_columns: 0,
        n_columns_line: 0,
        in_degrees: None,
        legacy_angles: None,
        name: None,
        data_type: None,
        metadata: Vec::new(),
        end_index: 0,
    };
    let mut first_line = true;
    let mut free_text: Vec<&str> = Vec::new();
    let mut first_data_like: Option<usize> = None;
    for (idx, &(no, raw)) in lines.iter().enumerate() {
        let line = raw.trim_matches(|c| c == ' ' || c == '\t');
        if line.is_empty() {
            continue;
        }
        let delim = line.find([' ', '\t', '=']).unwrap_or(line.len());
        let key = &line[..delim];
        let rest = line[delim..].trim_start_matches([' ', '\t', '=']);
        let was_first = first_line;
        first_line = false;
        match key {
            "endheader" => {
                h.end_index = idx;
                if !free_text.is_empty() {
                    h.metadata.push(("header".into(), free_text.join("\n")));
                }
                return Ok(h);
            }
            "name" => h.name = Some(rest.to_string()),
            "nr" | "nRows" | "datarows" => h.n_rows = header_int(path, no, key, rest)?,
            "nc" | "nColumns" | "datacolumns" => {
                h.n_columns = header_int(path, no, key, rest)?;
                h.n_columns_line = no;
            }
            "version" => h.version = header_int(path, no, key, rest)?,
            "inDegrees" => {
                let l = rest.to_ascii_lowercase();
                h.in_degrees = Some(l == "yes" || l == "y");
            }
            "DataType" => h.data_type = Some((no, rest.to_string())),
            "OpenSimVersion" => {}
            "Angles" if h.version == 0 => {
                if line == "Angles are in degrees." {
                    h.legacy_angles = Some(true);
                } else if line == "Angles are in radians." {
                    h.legacy_angles = Some(false);
                }
                free_text.push(line);
            }
            _ => {
                if first_data_like.is_none() && looks_like_data(line) {
                    first_data_like = Some(no);
                }
                if let Some((k, v)) = line.split_once('=') {
                    h.metadata
                        .push((k.trim().to_string(), v.trim().to_string()));
                } else if was_first && h.name.is_none() {
                    h.name = Some(line.to_string());
                } else {
                    free_text.push(line);
                }
            }
        }
    }
    let msg = match first_data_like {
        Some(l) => format!("missing 'endheader' line (line {l} already looks like data)"),
        None => "missing 'endheader' line: the file has no end of header".to_string(),
    };
    Err(Error::input(Location::file(path), msg))
}

/// Parse one data value; `label` names the column for errors.
fn value(path: &Path, line: usize, label: &str, token: &str) -> Result<f64> {
    let at = || {
        Location::file(path)
            .with_line(line)
            .with_element(format!("column '{label}'"))
    };
    match crate::xml::parse_number(token) {
        Some(v) if v.is_finite() => Ok(v),
        Some(_) => Err(Error::input(
            at(),
            format!("value '{token}' is not finite (NaN/Inf are not accepted in input data)"),
        )),
        None => Err(Error::input(at(), format!("'{token}' is not a number"))),
    }
}

fn check_time(path: &Path, st: &Storage, line: usize) -> Result<()> {
    let n = st.time.len();
    if n >= 2 && st.time[n - 1] <= st.time[n - 2] {
        return Err(Error::input(
            Location::file(path)
                .with_line(line)
                .with_element("column 'time'"),
            format!(
                "time must increase from row to row, but {} follows {}",
                st.time[n - 1],
                st.time[n - 2]
            ),
        ));
    }
    Ok(())
}

/// The label line of a legacy file checked against the header, as an empty
/// table (labels, units, name, metadata), and the number of rows to read.
fn legacy_table(
    path: &Path,
    h: Header,
    label_line: usize,
    label_text: &str,
    is_mot: bool,
) -> Result<(Storage, usize)> {
    let mut labels: Vec<String> = label_text
        .split([' ', '\t', '\r'])
        .filter(|t| !t.is_empty())
        .map(str::to_string)
        .collect();
    if labels.first().map(String::as_str) != Some("time") {
        return Err(Error::input(
            loc(path, label_line),
            format!(
                "the first column label must be 'time', found '{}' (files without a time column are not supported)",
                labels.first().map(String::as_str).unwrap_or("")
            ),
        ));
    }
    if h.n_columns > 0 && labels.len() as i64 != h.n_columns {
        return Err(Error::input(
            loc(path, label_line),
            format!(
                "header says nColumns={} (line {}) but the label line has {} labels",
                h.n_columns,
                h.n_columns_line,
                labels.len()
            ),
        ));
    }
    labels.remove(0);
    let in_degrees = if h.version < 1 && is_mot {
        true // §1.3: version-0 .mot files are always in degrees
    } else {
        h.in_degrees
            .or(if h.version == 0 {
                h.legacy_angles
            } else {
                None
            })
            .unwrap_or(false)
    };
    let limit = if h.n_rows > 0 {
        h.n_rows as usize
    } else {
        usize::MAX
    };
    let st = Storage {
        name: h.name.unwrap_or_default(),
        labels,
        time: Vec::new(),
        rows: Vec::new(),
        in_degrees,
        metadata: h.metadata,
    };
    Ok((st, limit))
}

fn missing_legacy_counts(path: &Path, h: &Header) -> Result<()> {
    if h.n_rows < 1 && h.n_columns < 1 {
        return Err(Error::input(
            Location::file(path),
            "header gives neither nRows nor nColumns (a legacy storage file needs them)",
        ));
    }
    Ok(())
}

fn too_few_rows(path: &Path, line: usize, n_rows: usize, got: usize) -> Error {
    Error::input(
        loc(path, line),
        format!("header says nRows={n_rows} but the file ends after {got} data rows"),
    )
}

fn read_legacy(path: &Path, h: Header, body: &[(usize, &str)], is_mot: bool) -> Result<Storage> {
    let end_line = body.first().map(|l| l.0 - 1).unwrap_or(0);
    missing_legacy_counts(path, &h)?;
    let mut it = body
        .iter()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|&(n, l)| (n, l));
    let (label_line, label_text) = it
        .next()
        .ok_or_else(|| Error::input(loc(path, end_line), "no column labels after 'endheader'"))?;
    let (mut st, limit) = legacy_table(path, h, label_line, label_text, is_mot)?;
    let nc = st.labels.len();
    let mut last_line = label_line;
    for (no, text) in it {
        if st.time.len() >= limit {
            break; // OpenSim reads exactly nRows rows and ignores the rest
        }
        last_line = no;
        let mut row = Vec::with_capacity(nc);
        if let Some(t) = parse_line_fast(text.as_bytes(), nc, &mut row) {
            st.time.push(t);
            st.rows.push(row);
            check_time(path, &st, no)?;
            continue;
        }
        empty_cell(path, &st.labels, no, text)?;
        let toks: Vec<&str> = text.split_whitespace().collect();
        push_row(path, &mut st, no, &toks, nc)?;
    }
    if limit != usize::MAX && st.time.len() < limit {
        return Err(too_few_rows(path, last_line, limit, st.time.len()));
    }
    Ok(st)
}

/// A tab-separated row with an empty cell (two tabs in a row) names the
/// cell's own column; split on white space, the gap would shift the values
/// and blame the last column instead.
fn empty_cell(path: &Path, labels: &[String], no: usize, line: &str) -> Result<()> {
    if !line.contains('\t') {
        return Ok(());
    }
    let mut cells = line.trim_end_matches(['\t', ' ', '\r']).split('\t');
    if let Some(k) = cells.position(|c| c.trim().is_empty()) {
        let column = if k == 0 {
            "time"
        } else {
            labels.get(k - 1).map_or("?", String::as_str)
        };
        return Err(Error::input(
            Location::file(path)
                .with_line(no)
                .with_element(format!("column '{column}'")),
            "empty cell: every column needs a value on every row",
        ));
    }
    Ok(())
}

/// These ASCII bytes are what `char::is_whitespace` (`split_whitespace`,
/// `trim`) accepts below U+0080 (all ≤ b' ').
#[inline(always)]
fn is_ws(b: u8) -> bool {
    b <= b' ' && matches!(b, b' ' | b'\t' | b'\n' | 0x0B | 0x0C | b'\r')
}

/// The common case of a legacy data line, in one pass over its bytes and
/// without allocation: no empty cell ([`empty_cell`]'s rule) and exactly
/// time and `nc` white-space separated values, all finite numbers that
/// `str::parse` reads. Then [`empty_cell`] passes and `parse_row` of the
/// line's white-space tokens gives the same time and row. None otherwise
/// (`row` is left in any state): the caller then takes the general path,
/// which says what is wrong. Anything unusual (non-ASCII text included: a
/// token holding it does not parse) is left to the general path.
pub(super) fn parse_line_fast(b: &[u8], nc: usize, row: &mut Vec<f64>) -> Option<f64> {
    // On bytes, not yet known to be UTF-8: a token that is not a plain
    // decimal is parsed as a str when its bytes are UTF-8 (then they are
    // what the line's token would be: tokens end only at ASCII white
    // space), and a line that is not UTF-8 takes the general path.
    row.clear();
    let mut time = 0.0;
    let mut count = 0;
    let mut i = 0;
    loop {
        // A gap between tokens holds at most one tab (and none before the
        // first token): then every tab-separated cell holds a token. The
        // gap after the last token must be all tabs, spaces and CRs
        // (what `empty_cell` trims).
        let mut tabs = 0;
        let mut odd = false;
        loop {
            // Spaces (the padding of fixed-width columns) count for nothing.
            while i < b.len() && b[i] == b' ' {
                i += 1;
            }
            if i < b.len() && is_ws(b[i]) {
                tabs += (b[i] == b'\t') as usize;
                odd |= !matches!(b[i], b'\t' | b'\r');
                i += 1;
            } else {
                break;
            }
        }
        if i == b.len() {
            if odd {
                return None;
            }
            break;
        }
        if tabs > (count > 0) as usize || count > nc {
            return None;
        }
        let v = match decimal_token(b, i) {
            Some((v, end)) => {
                i = end;
                v
            }
            None => {
                let start = i;
                while i < b.len() && !is_ws(b[i]) {
                    i += 1;
                }
                let v: f64 = std::str::from_utf8(&b[start..i]).ok()?.parse().ok()?;
                v
            }
        };
        if !v.is_finite() {
            return None;
        }
        if count == 0 {
            time = v;
        } else {
            row.push(v);
        }
        count += 1;
    }
    (count == nc + 1).then_some(time)
}

/// The token of `b` that starts at `i`, when it is a plain decimal
/// (`[+-]digits[.digits]`, at most 15 significant digits, at most 22 after
/// the point): its value and end (the next white space or the end of `b`).
/// Clinger's fast path: the integer of the digits and 10ᵉ are exact
/// doubles, so one division rounds correctly, as `str::parse` does
/// (correct rounding has one answer). None for any other token.
#[inline(always)]
fn decimal_token(b: &[u8], mut i: usize) -> Option<(f64, usize)> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let neg = b[i] == b'-';
    i += (neg || b[i] == b'+') as usize;
    let mut w: u64 = 0;
    let int_start = i;
    while let Some(v) = eight_digits_at(b, i) {
        w = w.wrapping_mul(100_000_000).wrapping_add(v);
        i += 8;
    }
    while i < b.len() && b[i].is_ascii_digit() {
        w = w.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
        i += 1;
    }
    let mut digits = i - int_start;
    let mut e = 0;
    if i < b.len() && b[i] == b'.' {
        i += 1;
        let frac_start = i;
        while let Some(v) = eight_digits_at(b, i) {
            w = w.wrapping_mul(100_000_000).wrapping_add(v);
            i += 8;
        }
        while i < b.len() && b[i].is_ascii_digit() {
            w = w.wrapping_mul(10).wrapping_add((b[i] - b'0') as u64);
            i += 1;
        }
        e = i - frac_start;
        digits += e;
    }
    // (w is exact when digits ≤ 15)
    if (i < b.len() && !is_ws(b[i])) || digits == 0 || digits > 15 || e > 22 {
        return None;
    }
    let v = w as f64 / POW10[e];
    Some((if neg { -v } else { v }, i))
}

/// The eight bytes of `b` from `i` as a number, when there are eight and
/// all are ASCII digits (the first the most significant): eight steps of
/// `w · 10 + digit` at once, so `w · 10⁸ + this` equals them modulo 2⁶⁴.
#[inline(always)]
fn eight_digits_at(b: &[u8], i: usize) -> Option<u64> {
    let bytes: [u8; 8] = b.get(i..i + 8)?.try_into().ok()?;
    let x = u64::from_le_bytes(bytes);
    // Each byte 0x30..=0x39: high nibble 3, and adding 6 leaves it 3 (a
    // byte that carries into the next fails its own test first).
    const HIGH: u64 = 0xF0F0_F0F0_F0F0_F0F0;
    if (x & HIGH) | ((x.wrapping_add(0x0606_0606_0606_0606) & HIGH) >> 4) != 0x3333_3333_3333_3333 {
        return None;
    }
    // Digits d0 (lowest byte, the first) .. d7; pairs, then quads, then all.
    let x = x - 0x3030_3030_3030_3030;
    let x = x.wrapping_mul(10).wrapping_add(x >> 8);
    const LOW: u64 = 0x0000_00FF_0000_00FF;
    let x = ((x & LOW).wrapping_mul(100 + (1_000_000 << 32)))
        .wrapping_add(((x >> 16) & LOW).wrapping_mul(1 + (10_000 << 32)))
        >> 32;
    Some(x)
}

/// Parse `toks` = time then `labels.len()` values into `row`; returns the time.
fn parse_row(
    path: &Path,
    labels: &[String],
    no: usize,
    toks: &[&str],
    row: &mut Vec<f64>,
) -> Result<f64> {
    let nc = labels.len();
    if toks.len() < nc + 1 {
        let missing = if toks.is_empty() {
            "time".to_string()
        } else {
            labels[toks.len() - 1].clone()
        };
        return Err(Error::input(
            Location::file(path)
                .with_line(no)
                .with_element(format!("column '{missing}'")),
            format!(
                "row has {} values, expected {} (time + {} columns)",
                toks.len(),
                nc + 1,
                nc
            ),
        ));
    }
    if toks.len() > nc + 1 {
        return Err(Error::input(
            loc(path, no),
            format!(
                "row has {} values, expected {} (time + {} columns)",
                toks.len(),
                nc + 1,
                nc
            ),
        ));
    }
    let t = value(path, no, "time", toks[0])?;
    row.clear();
    for (j, tok) in toks[1..].iter().enumerate() {
        row.push(value(path, no, &labels[j], tok)?);
    }
    Ok(t)
}

/// Parse `toks` = time then `nc` values into a new row of `st`.
fn push_row(path: &Path, st: &mut Storage, no: usize, toks: &[&str], nc: usize) -> Result<()> {
    debug_assert_eq!(nc, st.labels.len());
    let mut row = Vec::with_capacity(nc);
    let t = parse_row(path, &st.labels, no, toks, &mut row)?;
    st.time.push(t);
    st.rows.push(row);
    check_time(path, st, no)
}

/// Split a TimeSeriesTable line on tabs like `FileAdapter::tokenize`
/// (tokens trimmed; empty inner tokens kept; a trailing tab adds nothing).
fn tab_tokens(line: &str) -> Vec<&str> {
    let mut toks: Vec<&str> = line.split('\t').map(str::trim).collect();
    if line.ends_with('\t') {
        toks.pop();
    }
    toks
}

fn read_table(path: &Path, h: Header, body: &[(usize, &str)]) -> Result<Storage> {
    let end_line = body.first().map(|l| l.0 - 1).unwrap_or(0);
    let (width, suffixes) = table_width(path, &h)?;
    let mut it = body
        .iter()
        .copied()
        .skip_while(|(_, l)| l.trim().is_empty());
    let (label_line, label_text) = it
        .next()
        .ok_or_else(|| Error::input(loc(path, end_line), "no column labels after 'endheader'"))?;
    let (mut st, shape) = table_labels(path, h, width, suffixes, label_line, label_text)?;
    for (no, text) in it {
        if text.trim().is_empty() {
            break; // TimeSeriesTable stops at the first empty line
        }
        let mut row = Vec::with_capacity(st.labels.len());
        let t = table_row(path, no, text, &shape, &st.labels, &mut row)?;
        st.time.push(t);
        st.rows.push(row);
        check_time(path, &st, no)?;
    }
    Ok(st)
}

/// Columns per element of a TimeSeriesTable of the header's `DataType`,
/// and their label suffixes.
fn table_width(path: &Path, h: &Header) -> Result<(usize, &'static [&'static str])> {
    match &h.data_type {
        None => Ok((1, &[""])),
        Some((_, t)) if t == "double" => Ok((1, &[""])),
        Some((_, t)) if t == "Vec3" => Ok((3, &["_x", "_y", "_z"])),
        Some((_, t)) if t == "SpatialVec" => Ok((6, &["_rx", "_ry", "_rz", "_tx", "_ty", "_tz"])),
        Some((no, t)) => Err(Error::input(
            loc(path, *no),
            format!("DataType '{t}' is not supported (double, Vec3 and SpatialVec are)"),
        )),
    }
}

/// A TimeSeriesTable's elements (labels as written) and columns per element.
struct TableShape {
    elems: Vec<String>,
    width: usize,
}

/// The label line of a TimeSeriesTable, as an empty table (labels
/// flattened, name, metadata) and the shape of its rows.
fn table_labels(
    path: &Path,
    h: Header,
    width: usize,
    suffixes: &[&str],
    label_line: usize,
    label_text: &str,
) -> Result<(Storage, TableShape)> {
    let raw: Vec<&str> = tab_tokens(label_text)
        .into_iter()
        .filter(|t| !t.is_empty())
        .collect();
    if raw.first() != Some(&"time") {
        return Err(Error::input(
            loc(path, label_line),
            format!(
                "the first column label must be exactly 'time' (tab-delimited), found '{}'",
                raw.first().copied().unwrap_or("")
            ),
        ));
    }
    let elems: Vec<String> = raw[1..].iter().map(|s| s.to_string()).collect();
    let labels: Vec<String> = elems
        .iter()
        .flat_map(|l| suffixes.iter().map(move |s| format!("{l}{s}")))
        .collect();
    let st = Storage {
        name: h.name.clone().unwrap_or_default(),
        labels,
        time: Vec::new(),
        rows: Vec::new(),
        in_degrees: h.in_degrees.unwrap_or(false),
        metadata: h.metadata,
    };
    Ok((st, TableShape { elems, width }))
}

/// One data line of a TimeSeriesTable (line `no`): its values into `row`
/// (cleared first), its time returned.
fn table_row(
    path: &Path,
    no: usize,
    text: &str,
    shape: &TableShape,
    labels: &[String],
    row: &mut Vec<f64>,
) -> Result<f64> {
    let (elems, width) = (&shape.elems, shape.width);
    let toks = tab_tokens(text);
    if toks.len() != elems.len() + 1 {
        let at = if toks.len() < elems.len() + 1 && !toks.is_empty() {
            Location::file(path)
                .with_line(no)
                .with_element(format!("column '{}'", elems[toks.len() - 1]))
        } else {
            loc(path, no)
        };
        return Err(Error::input(
            at,
            format!(
                "row has {} tab-separated elements, expected {} (time + {} columns)",
                toks.len(),
                elems.len() + 1,
                elems.len()
            ),
        ));
    }
    let t = value(path, no, "time", toks[0])?;
    row.clear();
    for (j, tok) in toks[1..].iter().enumerate() {
        if width == 1 {
            row.push(value(path, no, &labels[j], tok)?);
            continue;
        }
        let comps: Vec<&str> = tok.split(',').map(str::trim).collect();
        if comps.len() != width {
            return Err(Error::input(
                Location::file(path)
                    .with_line(no)
                    .with_element(format!("column '{}'", elems[j])),
                format!("element '{tok}' must have {width} comma-separated components"),
            ));
        }
        for (k, c) in comps.iter().enumerate() {
            row.push(value(path, no, &labels[j * width + k], c)?);
        }
    }
    Ok(t)
}

/// Row-by-row reader of an OpenSim table: the header and labels are parsed
/// (and checked) as [`read`] does, then one data row at a time, so a long
/// `.sto`/`.mot` file is never held in memory, in the legacy format as in
/// the `TimeSeriesTable` format (version ≥ 2, its rows up to the first empty
/// line), with [`read`]'s checks and messages.
pub struct RowReader {
    path: std::path::PathBuf,
    /// Labels, units, name and metadata of the table; no rows.
    pub table: Storage,
    lines: LineSource,
    /// Number of the last line read.
    line_no: usize,
    format: RowFormat,
    limit: usize,
    count: usize,
    last_time: f64,
    last_line: usize,
    /// The data rows a [`TableFile`] parsed ahead ([`super::source`]), and
    /// the index of the one expected next.
    parsed: Option<(std::sync::Arc<super::source::ParsedRows>, usize)>,
    /// A table this run kept as values (`super::results`): its rows are
    /// handed out in turn, nothing is parsed.
    kept: Option<std::sync::Arc<super::results::KeptTable>>,
}

/// A position between rows, to come back to with [`RowReader::seek`].
#[derive(Debug, Clone, Copy)]
pub struct RowMark {
    offset: u64,
    line_no: usize,
    count: usize,
    last_time: f64,
    last_line: usize,
}

/// Lines of a file with their byte offsets (trailing CR removed).
struct LineSource {
    reader: Box<dyn BufReadSeek>,
    offset: u64,
    buf: Vec<u8>,
}

/// What a [`LineSource`] reads from: a file (buffered) or bytes in memory.
trait BufReadSeek: std::io::BufRead + std::io::Seek + Send + Sync {}
impl<T: std::io::BufRead + std::io::Seek + Send + Sync> BufReadSeek for T {}

impl LineSource {
    /// The next line (in a buffer reused from line to line); an error of
    /// kind `InvalidData` on invalid UTF-8.
    fn next_line(&mut self) -> Option<std::result::Result<&str, std::io::Error>> {
        use std::io::BufRead;
        self.buf.clear();
        match self.reader.read_until(b'\n', &mut self.buf) {
            Ok(0) => None,
            Ok(n) => {
                self.offset += n as u64;
                if self.buf.last() == Some(&b'\n') {
                    self.buf.pop();
                }
                if self.buf.last() == Some(&b'\r') {
                    self.buf.pop();
                }
                Some(std::str::from_utf8(&self.buf).map_err(|_| {
                    std::io::Error::new(std::io::ErrorKind::InvalidData, "invalid UTF-8")
                }))
            }
            Err(e) => Some(Err(e)),
        }
    }
}

/// A line's read error: invalid UTF-8 at `line`, or the I/O error.
fn utf8_error(path: &Path, line: usize, e: std::io::Error) -> Error {
    if e.kind() == std::io::ErrorKind::InvalidData {
        Error::input(loc(path, line), "file is not valid UTF-8 text")
    } else {
        Error::io(path, e)
    }
}

/// How a [`RowReader`]'s data lines are read.
enum RowFormat {
    Legacy,
    /// A TimeSeriesTable (version ≥ 2): rows up to the first empty line.
    Table {
        shape: TableShape,
        ended: bool,
    },
}

/// Open `path` for [`RowReader::next_row`].
/// A table this run wrote (kept by a [`super::results::Capture`]) is read
/// from the bytes kept in memory: the file is not opened.
pub fn open_rows(path: &Path) -> Result<RowReader> {
    use super::results::Output;
    match super::results::get(path) {
        Some(Output::Table(t)) => {
            let table = t.table(path)?;
            Ok(RowReader {
                path: path.to_path_buf(),
                table: Storage {
                    time: Vec::new(),
                    rows: Vec::new(),
                    ..table.clone()
                },
                lines: LineSource {
                    reader: Box::new(std::io::Cursor::new(Vec::new())),
                    offset: 0,
                    buf: Vec::new(),
                },
                line_no: 0,
                format: RowFormat::Legacy,
                limit: table.len(),
                count: 0,
                last_time: f64::NEG_INFINITY,
                last_line: 0,
                parsed: None,
                kept: Some(t),
            })
        }
        Some(Output::Bytes(bytes)) => open_rows_in(&TableFile::kept(path, bytes)),
        None => open_rows_in(&TableFile::on_disk(path)),
    }
}

/// [`open_rows`] on a [`TableFile`]: its bytes in memory when it holds
/// them (the file is not opened again), else the file on disk.
pub fn open_rows_in(file: &TableFile) -> Result<RowReader> {
    let path = file.path();
    let reader: Box<dyn BufReadSeek> = match file.bytes() {
        Some(bytes) => Box::new(std::io::Cursor::new(bytes.clone())),
        None => Box::new(std::io::BufReader::new(super::source::open_file(path)?)),
    };
    let mut lines = LineSource {
        reader,
        offset: 0,
        buf: Vec::new(),
    };
    let mut header: Vec<String> = Vec::new();
    let utf8 = |e: std::io::Error| {
        if e.kind() == std::io::ErrorKind::InvalidData {
            Error::input(Location::file(path), "file is not valid UTF-8 text")
        } else {
            Error::io(path, e)
        }
    };
    // Header lines up to `endheader` (parse_header reports a missing one).
    while let Some(line) = lines.next_line() {
        let line = line.map_err(utf8)?;
        let t = line.trim_matches(|c| c == ' ' || c == '\t');
        let key = &t[..t.find([' ', '\t', '=']).unwrap_or(t.len())];
        let end = key == "endheader";
        header.push(line.to_string());
        if end {
            break;
        }
    }
    let numbered: Vec<(usize, &str)> = header
        .iter()
        .enumerate()
        .map(|(i, l)| (i + 1, l.as_str()))
        .collect();
    let h = parse_header(path, &numbered)?;
    let width = if h.version > 1 {
        Some(table_width(path, &h)?)
    } else {
        missing_legacy_counts(path, &h)?;
        None
    };
    let is_mot = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase().contains(".mot"))
        .unwrap_or(false);
    let end_line = header.len();
    let mut line_no = end_line;
    let (label_line, label_text) = loop {
        let Some(line) = lines.next_line() else {
            return Err(Error::input(
                loc(path, end_line),
                "no column labels after 'endheader'",
            ));
        };
        line_no += 1;
        let line = line.map_err(utf8)?;
        if !line.trim().is_empty() {
            break (line_no, line.to_string());
        }
    };
    if let Some((width, suffixes)) = width {
        let (table, shape) = table_labels(path, h, width, suffixes, label_line, &label_text)?;
        return Ok(RowReader {
            path: path.to_path_buf(),
            table,
            lines,
            line_no,
            format: RowFormat::Table {
                shape,
                ended: false,
            },
            limit: usize::MAX,
            count: 0,
            last_time: f64::NEG_INFINITY,
            last_line: label_line,
            parsed: None,
            kept: None,
        });
    }
    let (table, limit) = legacy_table(path, h, label_line, &label_text, is_mot)?;
    let parsed = file
        .parsed_rows()
        .filter(|p| p.columns() == table.labels.len())
        .map(|p| (p, 0));
    Ok(RowReader {
        path: path.to_path_buf(),
        table,
        lines,
        line_no,
        format: RowFormat::Legacy,
        limit,
        count: 0,
        last_time: f64::NEG_INFINITY,
        last_line: label_line,
        parsed,
        kept: None,
    })
}

impl RowReader {
    /// Rows read so far.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The position before the next row.
    pub fn mark(&self) -> RowMark {
        RowMark {
            offset: self.lines.offset,
            line_no: self.line_no,
            count: self.count,
            last_time: self.last_time,
            last_line: self.last_line,
        }
    }

    /// Go back (or forward) to a position [`mark`](Self::mark) returned
    /// while reading this file.
    pub fn seek(&mut self, m: &RowMark) -> Result<()> {
        use std::io::Seek;
        if self.kept.is_some() {
            self.count = m.count;
            return Ok(());
        }
        if let RowFormat::Table { ended, .. } = &mut self.format {
            *ended = false;
        }
        self.lines
            .reader
            .seek(std::io::SeekFrom::Start(m.offset))
            .map_err(|e| Error::io(&self.path, e))?;
        self.lines.offset = m.offset;
        self.line_no = m.line_no;
        self.count = m.count;
        self.last_time = m.last_time;
        self.last_line = m.last_line;
        Ok(())
    }

    /// Position the reader before row `k`, from the nearest of `marks`
    /// (row index, mark) at or before it, then by reading forward.
    pub fn seek_row(&mut self, k: usize, marks: &[(usize, RowMark)]) -> Result<()> {
        let best = marks.iter().rev().find(|(r, _)| *r <= k);
        if let Some((_, m)) = best {
            if !(self.count <= k && self.count >= m.count) {
                self.seek(m)?;
            }
        } else if self.count > k {
            return Err(Error::msg(format!(
                "{}: no position recorded before row {k}",
                self.path.display()
            )));
        }
        let mut row = Vec::new();
        while self.count < k {
            if self.next_row(&mut row)?.is_none() {
                return Err(Error::msg(format!(
                    "{}: the file changed while it was read (row {k} missing)",
                    self.path.display()
                )));
            }
        }
        Ok(())
    }

    /// The data line at the reader's position, when it was parsed ahead:
    /// its values into `row`, the reader moved past it, its time.
    fn parsed_ahead(&mut self, row: &mut Vec<f64>) -> Option<f64> {
        use std::io::Seek;
        let (rows, next) = self.parsed.as_mut()?;
        let k = rows.find(self.lines.offset, *next)?;
        let end = rows.end(k);
        self.lines.reader.seek(std::io::SeekFrom::Start(end)).ok()?;
        self.lines.offset = end;
        *next = k + 1;
        row.clear();
        row.extend_from_slice(rows.values(k));
        Some(rows.time(k))
    }

    /// The next row's values (one per label) into `row`; its time, or None
    /// after the last row.
    pub fn next_row(&mut self, row: &mut Vec<f64>) -> Result<Option<f64>> {
        if self.count >= self.limit {
            return Ok(None); // OpenSim reads exactly nRows rows
        }
        if let Some(kept) = &self.kept {
            // Checked when opened (`KeptTable::table`).
            let k = self.count;
            let t = kept.table(&self.path)?;
            row.clear();
            row.extend_from_slice(&t.rows[k]);
            self.count += 1;
            return Ok(Some(t.time[k]));
        }
        let ahead = self.parsed_ahead(row);
        let line_no = &mut self.line_no;
        let (t, no) = match &mut self.format {
            // The line starting here was parsed ahead: the general path's
            // fast case (below) on the same bytes.
            _ if ahead.is_some() => {
                *line_no += 1;
                (ahead.unwrap_or_default(), *line_no)
            }
            RowFormat::Table { shape, ended } => {
                if *ended {
                    return Ok(None);
                }
                let Some(line) = self.lines.next_line() else {
                    *ended = true;
                    return Ok(None);
                };
                *line_no += 1;
                let line = line.map_err(|e| utf8_error(&self.path, *line_no, e))?;
                if line.trim().is_empty() {
                    // TimeSeriesTable stops at the first empty line.
                    *ended = true;
                    return Ok(None);
                }
                let t = table_row(&self.path, *line_no, line, shape, &self.table.labels, row)?;
                (t, *line_no)
            }
            RowFormat::Legacy => loop {
                let Some(line) = self.lines.next_line() else {
                    if self.limit != usize::MAX {
                        return Err(too_few_rows(
                            &self.path,
                            self.last_line,
                            self.limit,
                            self.count,
                        ));
                    }
                    return Ok(None);
                };
                *line_no += 1;
                let line = line.map_err(|e| utf8_error(&self.path, *line_no, e))?;
                if line.trim().is_empty() {
                    continue;
                }
                let t = match parse_line_fast(line.as_bytes(), self.table.labels.len(), row) {
                    Some(t) => t,
                    None => {
                        empty_cell(&self.path, &self.table.labels, *line_no, line)?;
                        let toks: Vec<&str> = line.split_whitespace().collect();
                        parse_row(&self.path, &self.table.labels, *line_no, &toks, row)?
                    }
                };
                break (t, *line_no);
            },
        };
        if self.count >= 1 && t <= self.last_time {
            return Err(Error::input(
                Location::file(&self.path)
                    .with_line(no)
                    .with_element("column 'time'"),
                format!(
                    "time must increase from row to row, but {} follows {}",
                    t, self.last_time
                ),
            ));
        }
        self.count += 1;
        self.last_time = t;
        self.last_line = no;
        Ok(Some(t))
    }
}

#[cfg(test)]
mod fast_line_tests {
    use super::*;

    /// `decimal_token` = `str::parse::<f64>` bit for bit when it answers.
    #[test]
    fn decimal_token_is_parse() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n
        };
        let fixed = [
            "0",
            "-0",
            "+0",
            "0.",
            ".0",
            ".",
            "-",
            "+",
            "",
            "1.5",
            "-1.5",
            "00012.50",
            "123456789012345",
            "1234567890123456",
            "0.1234567890123456789012",
            "1e5",
            "1.5E-3",
            "inf",
            "nan",
            "1..2",
            "1.2.3",
            "--1",
            "9007199254740993",
            "0.30000000000000004",
            "4.52639516",
            "-17.99348041",
            "743.0973413",
            "0.0000000000000000000001",
        ];
        let mut cases: Vec<String> = fixed.iter().map(|s| s.to_string()).collect();
        for _ in 0..200_000 {
            let mut s = String::new();
            match rnd(3) {
                0 => s.push('-'),
                1 if rnd(4) == 0 => s.push('+'),
                _ => {}
            }
            let int = rnd(12);
            for _ in 0..int {
                s.push((b'0' + rnd(10) as u8) as char);
            }
            if rnd(5) != 0 {
                s.push('.');
                for _ in 0..rnd(24) {
                    s.push((b'0' + rnd(10) as u8) as char);
                }
            }
            cases.push(s);
        }
        let mut fast = 0;
        for s in &cases {
            let want = s.parse::<f64>().ok().map(f64::to_bits);
            if s.is_empty() {
                continue; // a token is never empty
            }
            if let Some((v, end)) = decimal_token(s.as_bytes(), 0) {
                fast += 1;
                assert_eq!(end, s.len(), "{s:?}");
                assert_eq!(Some(v.to_bits()), want, "{s:?}");
            }
        }
        assert!(fast > 100_000, "{fast}");
    }

    /// `eight_digits_at` = the digits' number, and None unless all eight
    /// bytes are digits.
    #[test]
    fn eight_digits_at_reads_eight_digits() {
        let mut state = 0x1234_5678_9abc_def1u64;
        for k in 0..100_000u64 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let n = if k < 10 {
                [
                    0, 1, 9, 10, 99_999_999, 12_345_678, 10_000_000, 90_000_009, 5, 7,
                ][k as usize]
            } else {
                state % 100_000_000
            };
            let text = format!("{n:08}");
            assert_eq!(eight_digits_at(text.as_bytes(), 0), Some(n), "{text}");
            // Any one byte not a digit: None.
            let mut bad = text.clone().into_bytes();
            bad[(state >> 40) as usize % 8] =
                [b'/', b':', b'.', b' ', 0xF9, 0x3F, b'a', 0][(state >> 50) as usize % 8];
            assert_eq!(eight_digits_at(&bad, 0), None, "{bad:?}");
        }
        assert_eq!(eight_digits_at(b"1234567", 0), None);
        assert_eq!(eight_digits_at(b"x12345678", 1), Some(12_345_678));
    }

    /// `parse_line_fast` accepts a line only when the general path
    /// (`empty_cell`, then `parse_row` of the white-space tokens) accepts it,
    /// with the same time and row bits; it accepts the ordinary lines.
    #[test]
    fn fast_path_agrees_with_the_general_path() {
        let labels: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let path = Path::new("x.sto");
        let pieces = [
            "0.5", "-1e-3", "2", "1.25E+2", "nan", "inf", "x", "", " ", "\t", "\t\t", "  ",
            "\u{a0}", "\u{b}", "\u{c}", "\r", "-0", "+7.", ".5", "1,5", "1.#INF", "3e400",
        ];
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as usize
        };
        let mut accepted = 0;
        let mut lines: Vec<String> = vec![
            "0.1\t1\t2\t3".into(),
            "0.1 1 2 3".into(),
            "  0.1\t 1\t2 \t3\t\r".into(),
            "0.1\t\t2\t3".into(),
            "\t0.1\t1\t2\t3".into(),
            "0.1\t1\t2\t3\t4".into(),
            "0.1\t1\t2".into(),
            "0.1\t1\u{a0}\t2\t3".into(),
            "0.1\u{a0}1\u{a0}2\u{a0}3".into(),
            "0.1\t1\t2\t\u{b}3".into(),
            "0.1\t1\t2\t3\t\u{b}".into(),
        ];
        for _ in 0..20000 {
            let mut l = String::new();
            // mostly 4 numbers with ordinary separators, sometimes not
            let numbers = [
                "0.5",
                "-1e-3",
                "2",
                "1.25E+2",
                "-0",
                "+7.",
                ".5",
                "12345.678901",
            ];
            let count = if rnd(4) == 0 { rnd(12) } else { 4 };
            for _ in 0..count {
                let sep = [" ", "\t", "  ", "\t "][rnd(4)];
                if rnd(8) == 0 {
                    l.push_str(pieces[rnd(pieces.len())]);
                } else {
                    l.push_str(numbers[rnd(numbers.len())]);
                }
                l.push_str(if rnd(8) == 0 {
                    pieces[rnd(pieces.len())]
                } else {
                    sep
                });
            }
            lines.push(l);
        }
        for l in &lines {
            let mut row = Vec::new();
            let fast = parse_line_fast(l.as_bytes(), labels.len(), &mut row);
            let general = empty_cell(path, &labels, 1, l).and_then(|_| {
                let toks: Vec<&str> = l.split_whitespace().collect();
                let mut r = Vec::new();
                parse_row(path, &labels, 1, &toks, &mut r).map(|t| (t, r))
            });
            if let Some(t) = fast {
                accepted += 1;
                let (gt, grow) = general.unwrap_or_else(|e| panic!("{l:?}: fast ok, general {e}"));
                assert_eq!(t.to_bits(), gt.to_bits(), "{l:?}");
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&row), bits(&grow), "{l:?}");
            }
        }
        assert!(accepted >= 2000, "{accepted}");
        for l in &lines[..3] {
            assert!(
                parse_line_fast(l.as_bytes(), 3, &mut Vec::new()).is_some(),
                "{l:?}"
            );
        }
    }
}
