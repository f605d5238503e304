//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// `../shared/validation` beside the repository, or None (with a clear SKIP
/// line) when it is absent.
pub fn validation_dir(test: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/validation");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIP {test}: ../shared/validation is absent, so the OpenSim reference comparison did not run");
        None
    }
}

pub const CASES: [&str; 3] = ["arm26", "leg6dof9musc_stance", "gait10dof18musc_walk"];

/// A fresh output directory for one test.
pub fn out_dir(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Per-column comparison of two tables on their common time rows.
pub struct ColumnError {
    pub label: String,
    pub max_abs: f64,
    pub peak: f64,
    pub worst_time: f64,
}

/// Compare `ours` against `reference` column by column (matched by label),
/// row by row (rows must have equal times within 1e-9).
pub fn compare(
    ours: &statopt::storage::Storage,
    reference: &statopt::storage::Storage,
) -> Vec<ColumnError> {
    assert_eq!(
        ours.time.len(),
        reference.time.len(),
        "row counts differ: ours {} vs reference {}",
        ours.time.len(),
        reference.time.len()
    );
    for (a, b) in ours.time.iter().zip(&reference.time) {
        assert!((a - b).abs() < 1e-9, "time {a} vs reference {b}");
    }
    let mut out = Vec::new();
    for (j, label) in reference.labels.iter().enumerate() {
        let k = ours
            .column_index(label)
            .unwrap_or_else(|| panic!("our output lacks column '{label}'"));
        let mut e = ColumnError {
            label: label.clone(),
            max_abs: 0.0,
            peak: 0.0,
            worst_time: 0.0,
        };
        for i in 0..reference.time.len() {
            let (r, o) = (reference.rows[i][j], ours.rows[i][k]);
            e.peak = e.peak.max(r.abs());
            let d = (r - o).abs();
            if d > e.max_abs || d.is_nan() {
                e.max_abs = if d.is_nan() { f64::INFINITY } else { d };
                e.worst_time = reference.time[i];
            }
        }
        out.push(e);
    }
    out
}
