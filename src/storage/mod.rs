//! OpenSim `.sto` / `.mot` tables (semantics §1).
//!
//! [`read`] accepts the legacy `Storage` format (version ≤ 1, §1.2–1.3) and
//! the `TimeSeriesTable` format (version 3, §1.4). [`StoWriter`] writes the
//! legacy format exactly as OpenSim's `Storage::print` does (§1.1), row by
//! row, so that an interrupted run leaves a valid file.

pub mod key;
mod read;
pub mod results;
mod source;
mod write;

pub use read::{open_rows, open_rows_in, read, read_file, RowMark, RowReader};
pub use source::{opened, read_bytes, times_opened, TableFile, IN_MEMORY_LIMIT};
/// A frame time as a message says it: rounded to the nanosecond with
/// trailing zeros dropped, so that a time computed on the motion's grid
/// (`0.5833328799999886`) reads as the motion's own row time
/// (`0.58333288`); never more decimals than that.
pub fn fmt_time(t: f64) -> String {
    if !t.is_finite() {
        return format!("{t}");
    }
    let s = format!("{:.9}", t);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

pub use write::{
    complete_rows, create_output, format_c_fixed, write, StoWriter, DEFAULT_PRECISION,
};

/// A table of samples over time, as OpenSim's `Storage`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Storage {
    /// Storage name (first header line of a legacy file).
    pub name: String,
    /// Data column labels, without `time`.
    pub labels: Vec<String>,
    /// Time of each row.
    pub time: Vec<f64>,
    /// `rows[i][j]` = value of `labels[j]` at `time[i]`.
    pub rows: Vec<Vec<f64>>,
    /// Whether rotational columns are in degrees (§1.3).
    pub in_degrees: bool,
    /// Header key/value pairs other than the structural ones (`version`,
    /// `nRows`, `nColumns`, `inDegrees`, `DataType`, `OpenSimVersion`), in file
    /// order. Free-text header lines (the description) are joined with `\n`
    /// under the key `header`, as `TimeSeriesTable` does.
    pub metadata: Vec<(String, String)>,
}

impl Storage {
    /// Index into `labels` of the column labelled `label` (first match).
    pub fn column_index(&self, label: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == label)
    }

    /// Copy of data column `j` (panics if `j >= labels.len()`, a programming error).
    pub fn column(&self, j: usize) -> Vec<f64> {
        assert!(j < self.labels.len(), "column index {j} out of range");
        self.rows.iter().map(|r| r[j]).collect()
    }

    /// Overwrite data column `j` with `values` (one per row).
    pub fn set_column(&mut self, j: usize, values: &[f64]) {
        assert!(j < self.labels.len(), "column index {j} out of range");
        assert_eq!(values.len(), self.rows.len(), "column length mismatch");
        for (r, v) in self.rows.iter_mut().zip(values) {
            r[j] = *v;
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }

    /// Value of metadata key `key`, if present.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

#[cfg(test)]
mod tests;
