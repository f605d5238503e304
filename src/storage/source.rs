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

/// A table file: its path and, when it was read into memory, its bytes.
/// Cloning shares them.
#[derive(Clone)]
pub struct TableFile {
    path: PathBuf,
    bytes: Option<SharedBytes>,
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
        })
    }

    /// The file `path`, read from the disk by each reader.
    pub fn on_disk(path: &Path) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: None,
        }
    }

    /// The output `path` a run kept in memory (`super::results`), read from
    /// those bytes.
    pub(super) fn kept(path: &Path, bytes: Arc<Vec<u8>>) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: Some(SharedBytes(bytes)),
        }
    }

    /// The bytes of the file `path` given in memory (e.g. a table a run
    /// kept, `super::results`): readers parse them as the file's and open
    /// nothing.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> TableFile {
        TableFile {
            path: path.to_path_buf(),
            bytes: Some(SharedBytes(Arc::new(bytes))),
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
