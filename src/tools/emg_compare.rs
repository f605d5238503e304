//! `statopt-tool emg-compare EMG.sto ACTIVATIONS.sto [ACTIVATIONS.sto ...]`:
//! how well static optimization's activations agree with measured EMG
//! (docs/emg_compare.md). The statistics are `metrics::emg` (which says how
//! they are computed and why), the table and figure `writers::emg`; this
//! driver reads the files, compares and writes. The old paths re-export them.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::storage;

pub use crate::metrics::emg::{
    compare, default_map, on, on_off_agreement, parse_map, pearson, read_map, ChannelMap,
    ChannelResult, Comparison, Options, DEFAULT_ON_FRACTION, DELAY_STEP_MS, MAX_DELAY_MS,
};
pub use crate::writers::emg::{csv_path, write_csv, write_figure, CSV_COLUMNS};

/// Read the EMG and each activation file, compare (labels: `labels`, or
/// each file's parent folder name), write `<out>.csv`, `<out>.png` and
/// `<out>.svg`; returns the comparisons and the files written.
pub fn run(
    emg_path: &Path,
    activations: &[PathBuf],
    labels: &[String],
    map: &[ChannelMap],
    opts: Options,
    out: &Path,
) -> Result<(Vec<Comparison>, Vec<PathBuf>)> {
    if activations.is_empty() {
        return Err(Error::msg("emg-compare needs at least one activation file"));
    }
    if !labels.is_empty() && labels.len() != activations.len() {
        return Err(Error::msg(format!(
            "{} labels for {} activation files: give one per file or none",
            labels.len(),
            activations.len()
        )));
    }
    let emg = storage::read(emg_path)?;
    let mut comparisons = Vec::with_capacity(activations.len());
    for (i, a) in activations.iter().enumerate() {
        let label = labels.get(i).cloned().unwrap_or_else(|| {
            a.parent()
                .and_then(|p| p.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .filter(|n| !n.is_empty())
                .unwrap_or_else(|| a.display().to_string())
        });
        let table = storage::read(a)?;
        comparisons.push(compare(&label, &table, a, &emg, emg_path, map, opts)?);
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let csv_path = csv_path(out);
    write_csv(&comparisons, &csv_path)?;
    let mut files = vec![csv_path];
    files.extend(write_figure(&comparisons, opts.delay, out)?);
    Ok((comparisons, files))
}
