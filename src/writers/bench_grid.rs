//! The table and chart of `statopt-tool bench --grid`: a row per method
//! choice, its time per frame against its error relative to the reference
//! run (`bench_grid.csv`, `bench_grid.png`/`.svg`).

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::plots::{self, RefLine, Scatter, ScatterPoint};

/// One row of the grid table.
#[derive(Debug, Clone, PartialEq)]
pub struct GridRow {
    pub choice: String,
    pub threads: usize,
    pub frames: usize,
    /// Best time per frame of the per-frame loop, ms.
    pub ms_per_frame: f64,
    /// Against the reference run: max and RMS |Δactivation| over the
    /// muscles (every actuator when the model has none) and frames.
    pub max_dactivation: f64,
    pub rms_dactivation: f64,
    /// Max |Δ contact force| (N, vector norm), when the model has contacts.
    pub max_dcontact: Option<f64>,
    /// Max |Δ reaction force| (N, vector norm) of the knee (or first)
    /// reaction, when the setup runs a JointReaction with static optimization.
    pub max_dreaction: Option<f64>,
    /// Max |Δactivation| against OpenSim's activations: the same columns,
    /// common times.
    pub max_dactivation_opensim: Option<f64>,
    /// Failed frames (solver status not solved) of the run.
    pub failed_frames: usize,
}

/// CSV columns, in order.
pub const CSV_COLUMNS: [&str; 11] = [
    "choice",
    "threads",
    "frames",
    "ms_per_frame",
    "max_dactivation",
    "rms_dactivation",
    "max_dcontact_force_N",
    "max_dreaction_force_N",
    "max_dactivation_vs_opensim",
    "failed_frames",
    "pareto",
];

/// Indices of the rows on the Pareto front of (ms per frame, max |Δa|).
pub fn pareto_rows(rows: &[GridRow]) -> Vec<usize> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.ms_per_frame, r.max_dactivation))
        .collect();
    plots::pareto_front(&pts)
}

/// `bench_grid.csv`: one row per choice, [`CSV_COLUMNS`]; empty cells where
/// a column does not apply.
pub fn write_csv(rows: &[GridRow], path: &Path) -> Result<()> {
    let front = pareto_rows(rows);
    let err = |e: csv::Error| Error::input(Location::file(path), format!("cannot write CSV: {e}"));
    let mut w = csv::Writer::from_path(path).map_err(err)?;
    w.write_record(CSV_COLUMNS).map_err(err)?;
    let opt = |v: Option<f64>| v.map(|x| format!("{x:e}")).unwrap_or_default();
    for (i, r) in rows.iter().enumerate() {
        w.write_record([
            r.choice.clone(),
            r.threads.to_string(),
            r.frames.to_string(),
            format!("{}", r.ms_per_frame),
            format!("{:e}", r.max_dactivation),
            format!("{:e}", r.rms_dactivation),
            opt(r.max_dcontact),
            opt(r.max_dreaction),
            opt(r.max_dactivation_opensim),
            r.failed_frames.to_string(),
            front.contains(&i).to_string(),
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

/// Smallest error drawn on the log axis; a zero error (the reference) is
/// drawn there and labelled so.
pub const CHART_FLOOR: f64 = 1e-12;

/// `<stem>.png` and `<stem>.svg`: time per frame against max |Δactivation|.
pub fn write_chart(
    rows: &[GridRow],
    stem: &Path,
    title: &str,
    opensim_ms: Option<f64>,
) -> Result<Vec<PathBuf>> {
    // Points are numbered as the CSV's rows (1 = the reference); the key
    // right of the plot names them, and points on the Pareto front also
    // carry their name.
    let front = pareto_rows(rows);
    let key: Vec<String> = rows
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let zero = if r.max_dactivation == 0.0 {
                " (error 0)"
            } else {
                ""
            };
            format!("{}  {}{zero}", k + 1, r.choice)
        })
        .collect();
    let points = rows
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let y = if r.max_dactivation > 0.0 || r.max_dactivation.is_nan() {
                // NaN (no common frames) is not drawn.
                r.max_dactivation
            } else {
                CHART_FLOOR
            };
            let label = if front.contains(&k) {
                format!("{} {}", k + 1, r.choice)
            } else {
                format!("{}", k + 1)
            };
            ScatterPoint {
                label,
                x: r.ms_per_frame,
                y: if y.is_nan() { y } else { y.max(CHART_FLOOR) },
                color: r.threads.saturating_sub(1),
            }
        })
        .collect();
    let s = Scatter {
        title: title.to_string(),
        x_label: "time per frame (ms, best of repeats)".into(),
        y_label: "max |Δactivation| vs reference".into(),
        points,
        log_x: true,
        log_y: true,
        pareto: true,
        key,
        size: (1400, 800),
        reference: opensim_ms
            .map(|v| {
                vec![RefLine::Vertical {
                    value: v,
                    label: "OpenSim 4.6".into(),
                }]
            })
            .unwrap_or_default(),
    };
    plots::write_scatter(&s, stem)
}
