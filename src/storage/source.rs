//! Where a table's bytes come from: its file on disk, or the file's bytes
//! read once into memory ([`TableFile`]).
//!
//! A run reads its coordinates file once ([`TableFile::read`]) and hands the
//! value to every reader of the motion (the states stream and its passes,
//! the `<reduce_model>` scan, predict-grf's feet, the in-memory fallbacks).
//! Each reader parses those bytes with the same code as a file
//! ([`super::read_file`], [`super::open_rows_in`]), so results are those of
//! reading the file, bit for bit, and messages name the file and line as
//! they do.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Result};

/// Largest file [`TableFile::read`] holds in memory: 256 MiB. A motion is
/// about 16 bytes per value, so this is some 400,000 rows of 40 columns,
/// longer than any recorded trial (10 minutes at 200 Hz is 120,000 rows).
/// Holding it adds the file's size to the run's memory, and no reader opens
/// or reads the file again (each still parses the bytes it needs). A larger
/// file (1,000,000 rows of 40 columns is about 640 MB) is read from the
/// disk by every pass, as [`crate::motion::stream`] is designed to, so that
/// memory stays bounded whatever the length of the motion; the operating
/// system's page cache serves the repeated passes.
pub const IN_MEMORY_LIMIT: u64 = 256 << 20;

/// Largest file whose data rows [`TableFile::parse_rows_ahead`] parses:
/// 2 MiB (a motion of some 150,000 values; gait2392's coordinates are
/// 0.6 MB). The parsed values take about half the file's size again, so
/// longer files are parsed only as they are streamed.
pub const PARSE_AHEAD_LIMIT: usize = 2 << 20;

/// A table file: its path and, when it was read into memory, its bytes
/// (and, once [`TableFile::parse_rows_ahead`] has run, its data rows).
/// Cloning shares them.
#[derive(Clone)]
pub struct TableFile {
    path: PathBuf,
    bytes: Option<SharedBytes>,
    ahead: Arc<std::sync::OnceLock<Arc<ParsedRows>>>,
}

/// A legacy table's data lines as the row reader's fast path parses them
/// (`read::parse_line_fast`, the same function on the same bytes), from
/// the first after the column labels up to the first line it does not
/// take (a blank or unusual line, and the rest of the file, are left to
/// the row reader). Each line by its byte range in the file.
pub(super) struct ParsedRows {
    columns: usize,
    starts: Vec<u64>,
    ends: Vec<u64>,
    times: Vec<f64>,
    values: Vec<f64>,
}

impl ParsedRows {
    /// Data columns per row (time not counted).
    pub(super) fn columns(&self) -> usize {
        self.columns
    }

    /// Index of the line starting at byte `offset` (tried first: `hint`).
    pub(super) fn find(&self, offset: u64, hint: usize) -> Option<usize> {
        if self.starts.get(hint) == Some(&offset) {
            return Some(hint);
        }
        self.starts.binary_search(&offset).ok()
    }

    /// Byte offset after line `k` (after its newline).
    pub(super) fn end(&self, k: usize) -> u64 {
        self.ends[k]
    }

    pub(super) fn time(&self, k: usize) -> f64 {
        self.times[k]
    }

    pub(super) fn values(&self, k: usize) -> &[f64] {
        &self.values[k * self.columns..(k + 1) * self.columns]
    }

    /// Parse the data lines of the legacy table `b` (see [`ParsedRows`]).
    fn parse(b: &[u8]) -> ParsedRows {
        let mut rows = ParsedRows {
            columns: 0,
            starts: Vec::new(),
            ends: Vec::new(),
            times: Vec::new(),
            values: Vec::new(),
        };
        // Lines as the row reader reads them: up to '\n', without it and
        // a trailing '\r'; the offset after each.
        let mut lines = b.split_inclusive(|&c| c == b'\n').scan(0u64, |offset, l| {
            let start = *offset;
            *offset += l.len() as u64;
            let l = l.strip_suffix(b"\n").unwrap_or(l);
            Some((start, *offset, l.strip_suffix(b"\r").unwrap_or(l)))
        });
        // The header up to `endheader` (the reader's rule: the line trimmed
        // of spaces and tabs, up to a space, tab or '='), then the labels.
        let endheader = |l: &[u8]| {
            let t = l
                .iter()
                .position(|&c| c != b' ' && c != b'\t')
                .map_or(&l[l.len()..], |i| &l[i..]);
            let key = t.split(|&c| matches!(c, b' ' | b'\t' | b'=')).next();
            key == Some(b"endheader".as_slice())
        };
        if !lines.by_ref().any(|(_, _, l)| endheader(l)) {
            return rows;
        }
        let mut lines = lines
            .skip_while(|(_, _, l)| l.trim_ascii().is_empty())
            .skip(1) // the column labels
            .peekable();
        // Columns as counted on the first data line; the reader uses these
        // rows only when its labels say the same.
        let Some((_, _, first)) = lines.peek() else {
            return rows;
        };
        let tokens = first
            .split(|&c| c <= b' ' && matches!(c, b' ' | b'\t' | b'\n' | 0x0B | 0x0C | b'\r'))
            .filter(|t| !t.is_empty())
            .count();
        if tokens < 2 {
            return rows;
        }
        rows.columns = tokens - 1;
        let mut row = Vec::with_capacity(rows.columns);
        for (start, end, l) in lines {
            let Some(t) = super::read::parse_line_fast(l, rows.columns, &mut row) else {
                break;
            };
            rows.starts.push(start);
            rows.ends.push(end);
            rows.times.push(t);
            rows.values.extend_from_slice(&row);
        }
        rows
    }
}

/// A file's bytes, shared by the readers of a [`TableFile`] (kept in the
/// `Vec` they were read into: no second copy).
#[derive(Clone)]
pub(super) struct SharedBytes(Arc<Vec<u8>>);

impl AsRef<[u8]> for SharedBytes {
    fn as_ref(&self) -> &[u8] {
        &self.0
    }
}

impl std::fmt::Debug for TableFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TableFile")
            .field("path", &self.path)
            .field("in_memory_bytes", &self.bytes.as_ref().map(|b| b.0.len()))
            .finish()
    }
}

impl TableFile {
    /// Read `path` into memory, once (the one disk read of the file for
    /// every reader given this value), unless it is larger than
    /// [`IN_MEMORY_LIMIT`]: then the readers read the file from the disk.
    pub fn read(path: &Path) -> Result<TableFile> {
        Self::read_up_to(path, IN_MEMORY_LIMIT)
    }

    /// [`read`](Self::read) with the size limit `limit` (bytes).
    pub fn read_up_to(path: &Path, limit: u64) -> Result<TableFile> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.is_file() && meta.len() > limit {
            return Ok(Self::on_disk(path));
        }
        let bytes = SharedBytes(Arc::new(read_bytes(path)?));
        Ok(TableFile {
            path: path.to_path_buf(),
            bytes: Some(bytes),
            ahead: Default::default(),
        })
    }

    /// The file `path`, read from the disk by each reader.
    pub fn on_disk(path: &Path) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: None,
            ahead: Default::default(),
        }
    }

    /// The output `path` a run kept in memory (`super::results`), read from
    /// those bytes.
    pub(super) fn kept(path: &Path, bytes: Arc<Vec<u8>>) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: Some(SharedBytes(bytes)),
            ahead: Default::default(),
        }
    }

    /// The bytes of the file `path` given in memory (e.g. a table a run
    /// kept, `super::results`): readers parse them as the file's and open
    /// nothing.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: Some(SharedBytes(Arc::new(bytes))),
            ahead: Default::default(),
        }
    }

    /// The file's path (what messages name).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the bytes are held in memory.
    pub fn in_memory(&self) -> bool {
        self.bytes.is_some()
    }

    /// The bytes, when held in memory.
    pub(super) fn bytes(&self) -> Option<&SharedBytes> {
        self.bytes.as_ref()
    }

    /// Parse the data rows of a file held in memory and at most
    /// [`PARSE_AHEAD_LIMIT`] long now, on the calling thread, for every
    /// reader of this value and its clones (the row reader then takes each
    /// line parsed here instead of parsing it: [`ParsedRows`]). A run's
    /// driver calls it on a thread with time to spare (static optimization:
    /// the external loads' thread, while the main thread reads the model).
    /// Does nothing for a file on disk, a larger one, or a second time.
    pub fn parse_rows_ahead(&self) {
        let Some(bytes) = &self.bytes else {
            return;
        };
        if bytes.0.len() <= PARSE_AHEAD_LIMIT {
            self.ahead
                .get_or_init(|| Arc::new(ParsedRows::parse(bytes.as_ref())));
        }
    }

    /// The data rows [`Self::parse_rows_ahead`] parsed, if it ran.
    pub(super) fn parsed_rows(&self) -> Option<Arc<ParsedRows>> {
        self.ahead.get().cloned()
    }
}

/// How many times each path was opened for reading by this module's readers
/// ([`super::read`], [`super::open_rows`], [`TableFile::read`], ...), so that
/// tests can check that a run reads its motion once.
static OPENED: crate::file_counts::PathCounts = crate::file_counts::PathCounts::new();

/// Count one opening of `path`.
pub(super) fn count_open(path: &Path) {
    OPENED.count(path);
}

/// How many times the table readers opened the file `path` (as spelled by
/// the caller that opened it) since the process started.
pub fn times_opened(path: &Path) -> usize {
    OPENED.get(path)
}

/// Every path the table readers opened, with how many times (as spelled by
/// the callers that opened them), since the process started.
pub fn opened() -> Vec<(std::path::PathBuf, usize)> {
    OPENED.all()
}

/// The whole file, counted as one opening (any file a run reads back, e.g.
/// `--resume`'s log, so that [`times_opened`] sees every reading).
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    count_open(path);
    std::fs::read(path).map_err(|e| Error::io(path, e))
}

/// The file opened for reading, counted as one opening.
pub(super) fn open_file(path: &Path) -> Result<std::fs::File> {
    count_open(path);
    std::fs::File::open(path).map_err(|e| Error::io(path, e))
}
