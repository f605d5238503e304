//! How many times each file was read, per path, so that tests can check
//! that a run reads each of its inputs once (`storage::times_opened`,
//! `xml::times_parsed`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A process-wide count of reads per path (as spelled by the caller).
pub struct PathCounts(Mutex<Option<HashMap<PathBuf, usize>>>);

impl PathCounts {
    pub const fn new() -> PathCounts {
        PathCounts(Mutex::new(None))
    }

    /// Count one read of `path`.
    pub fn count(&self, path: &Path) {
        let mut m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        *m.get_or_insert_with(HashMap::new)
            .entry(path.to_path_buf())
            .or_insert(0) += 1;
    }

    /// Every path counted, with its count.
    pub fn all(&self) -> Vec<(PathBuf, usize)> {
        let m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        m.as_ref()
            .map(|m| m.iter().map(|(p, n)| (p.clone(), *n)).collect())
            .unwrap_or_default()
    }

    /// How many reads of `path` were counted since the process started.
    pub fn get(&self, path: &Path) -> usize {
        let m = self.0.lock().unwrap_or_else(|e| e.into_inner());
        m.as_ref().and_then(|m| m.get(path)).copied().unwrap_or(0)
    }
}

impl Default for PathCounts {
    fn default() -> Self {
        Self::new()
    }
}
