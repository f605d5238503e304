//! Scratch folders for unit tests in the system's temporary directory,
//! removed when dropped (set `STATOPT_KEEP_TEST_FILES=1` to keep them, e.g.
//! to run `scripts/check_mcap.py` on the MCAP tests' logs). Integration
//! tests write under `CARGO_TARGET_TMPDIR` instead.

use std::path::{Path, PathBuf};

/// A scratch folder, removed with everything in it when dropped.
pub(crate) struct TempDir(PathBuf);

impl TempDir {
    /// A fresh, empty folder named after `name` and the process.
    pub(crate) fn new(name: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("statopt-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("create a scratch folder");
        TempDir(d)
    }

    pub(crate) fn path(&self) -> &Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::env::var_os("STATOPT_KEEP_TEST_FILES").is_none() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A file in a scratch folder of its own, removed when dropped; it derefs to
/// its path.
pub(crate) struct TempFile {
    _dir: TempDir,
    path: PathBuf,
}

impl TempFile {
    /// `name` in a fresh folder named after `group`, `name` and the process.
    pub(crate) fn new(group: &str, name: &str) -> TempFile {
        let dir = TempDir::new(&format!("{group}-{name}"));
        let path = dir.path().join(name);
        TempFile { _dir: dir, path }
    }
}

impl std::ops::Deref for TempFile {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for TempFile {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}
