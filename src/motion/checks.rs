//! Checks of a motion against the model and the setup that OpenSim makes
//! silently or with a console line, and statopt says out loud: columns that
//! match no coordinate, a low-pass cut-off at or above the Nyquist frequency
//! (OpenSim lowers it to 0.49 fs, which hardly filters), and a time column
//! whose steps differ (rows a hair apart make every derivative explode).
//!
//! Both the streamed and the in-memory state pipelines feed the same
//! [`TimeSteps`] and call [`motion_warnings`], so they say the same.

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::model::Model;

/// Smallest and largest step of a time column, and the row after the
/// smallest step (for the message).
#[derive(Debug, Clone, Copy)]
pub struct TimeSteps {
    pub min: f64,
    pub max: f64,
    /// Time of the row that ends the smallest step.
    pub min_at: f64,
    prev: Option<f64>,
    rows: usize,
}

impl Default for TimeSteps {
    fn default() -> Self {
        TimeSteps {
            min: f64::INFINITY,
            max: 0.0,
            min_at: f64::NAN,
            prev: None,
            rows: 0,
        }
    }
}

impl TimeSteps {
    /// Feed the time of the next row.
    pub fn push(&mut self, t: f64) {
        if let Some(p) = self.prev {
            let dt = t - p;
            if dt < self.min {
                self.min = dt;
                self.min_at = t;
            }
            self.max = self.max.max(dt);
        }
        self.prev = Some(t);
        self.rows += 1;
    }

    /// The steps of a whole time column.
    pub fn of(time: &[f64]) -> TimeSteps {
        let mut s = TimeSteps::default();
        for &t in time {
            s.push(t);
        }
        s
    }
}

/// A step this much smaller than the largest marks rows that are almost
/// duplicates: splined speeds and accelerations there are meaningless (a
/// 1e-6 s step in 0.01 s data gave reactions of 5.9e29 N).
pub const NEAR_DUPLICATE_RATIO: f64 = 1e-3;

/// Steps differing by more than this fraction of the largest are reported
/// as non-uniform (time stamps rounded to 1 ms in 60 Hz data differ by 6 %:
/// not worth a word).
pub const NON_UNIFORM_TOLERANCE: f64 = 0.25;

/// Warnings (and, for near-duplicate rows, an error) about a motion file.
/// `labels` are the file's data columns (without `time`).
pub fn motion_warnings(
    model: &Model,
    file: &Path,
    labels: &[String],
    steps: &TimeSteps,
    cutoff: f64,
) -> Result<Vec<String>> {
    let mut out = Vec::new();
    out.extend(unmatched_columns_warning(
        file,
        &unmatched_columns(model, labels),
    ));
    out.extend(time_warnings(file, steps, cutoff)?);
    Ok(out)
}

/// Columns of `labels` that name no coordinate (nor speed) of the model.
pub fn unmatched_columns(model: &Model, labels: &[String]) -> Vec<String> {
    labels
        .iter()
        .filter(|l| !matches_model(model, l))
        .cloned()
        .collect()
}

/// The warning for columns that match no coordinate, if there are any.
pub fn unmatched_columns_warning(file: &Path, unused: &[String]) -> Option<String> {
    if unused.is_empty() {
        return None;
    }
    let shown = unused.len().min(8);
    Some(format!(
        "{}: {} column(s) match no coordinate of the model and were ignored: {}{} (check their spelling if they are meant to)",
        file.display(),
        unused.len(),
        unused[..shown].join(", "),
        if shown < unused.len() { ", ..." } else { "" }
    ))
}

/// Errors and warnings about the time column (see the module doc).
pub fn time_warnings(file: &Path, steps: &TimeSteps, cutoff: f64) -> Result<Vec<String>> {
    let mut out = Vec::new();
    if steps.rows >= 2 {
        if !(steps.min > 0.0) {
            return Err(Error::input(
                Location::file(file),
                format!(
                    "the time column does not increase (step {} s at t = {}): rows must have strictly increasing times",
                    steps.min, steps.min_at
                ),
            ));
        }
        if steps.min < NEAR_DUPLICATE_RATIO * steps.max {
            return Err(Error::input(
                Location::file(file),
                format!(
                    "the time column's steps range from {:e} s (the row at t = {}) to {:e} s: rows that close make splined speeds and accelerations meaningless; remove the near-duplicate row or resample the motion to a uniform step",
                    steps.min, steps.min_at, steps.max
                ),
            ));
        }
        if steps.max - steps.min > NON_UNIFORM_TOLERANCE * steps.max {
            out.push(format!(
                "{}: the time column is not uniform (steps from {} s to {} s){}",
                file.display(),
                steps.min,
                steps.max,
                if cutoff >= 0.0 {
                    "; as OpenSim does, it is resampled at the smallest step before filtering"
                } else {
                    "; speeds and accelerations come from splines through the rows as they are"
                }
            ));
        }
        if cutoff >= 0.0 {
            let fs = 1.0 / steps.min;
            if cutoff >= 0.5 * fs {
                out.push(format!(
                    "lowpass_cutoff_frequency_for_coordinates {cutoff} Hz is at or above the Nyquist frequency of {} ({} Hz, sampled at {fs} Hz): as OpenSim does, it is lowered to 0.49 fs = {} Hz, which barely filters; give a cut-off well below {} Hz (6 Hz is usual for walking)",
                    file.display(),
                    0.5 * fs,
                    0.49 * fs,
                    0.5 * fs
                ));
            }
        }
    }
    Ok(out)
}

/// Whether a column label names a coordinate of the model (its name, or a
/// state path ending in it or in `<name>/value`) or one of its speeds
/// (`<name>/speed`, `<name>_u`).
fn matches_model(model: &Model, label: &str) -> bool {
    let segs: Vec<&str> = label.split('/').filter(|s| !s.is_empty()).collect();
    let name = match segs.as_slice() {
        [.., c, "value"] | [.., c, "speed"] => *c,
        [.., last] => *last,
        [] => return false,
    };
    let name = name
        .strip_suffix("_u")
        .filter(|_| segs.len() == 1)
        .map_or(name, |n| {
            if model.coordinates.iter().any(|c| c.name == name) {
                name
            } else {
                n
            }
        });
    model.coordinates.iter().any(|c| c.name == name)
}

/// A warning when an explicitly given time limit lies past the data
/// (`initial_time` before the first row, `final_time` after the last);
/// infinite limits mean "all rows" and draw none.
pub fn time_range_warnings(
    setup_file: &Path,
    data_file: &Path,
    initial: f64,
    final_: f64,
    first: f64,
    last: f64,
) -> Vec<String> {
    let mut out = Vec::new();
    // Within 1 % of the data's span (a final_time of 2 on data ending at
    // 1.999) is what the user meant.
    let tol = 0.01 * (last - first).abs() + 1e-9 * (1.0 + last.abs());
    if final_.is_finite() && final_ > last + tol {
        out.push(format!(
            "{}: the requested end time {final_} is past the last time of {} ({last}); the run ends there",
            setup_file.display(),
            data_file.display()
        ));
    }
    if initial.is_finite() && initial < first - tol {
        out.push(format!(
            "{}: the requested start time {initial} is before the first time of {} ({first}); the run starts there",
            setup_file.display(),
            data_file.display()
        ));
    }
    out
}

/// How far a motion's values for coupler-driven (dependent) coordinates lie
/// from what their couplers give. statopt sets dependent coordinates and
/// their speeds from their couplers whatever the file holds; OpenSim's
/// assembler does so for positions only and keeps the speeds it splined
/// from the column; a file that disagrees (e.g. Moco's coordinates.sto, whose
/// `knee_angle_*_beta` columns hold degrees in a radian file) is said, not
/// refused.
#[derive(Debug, Clone, Default)]
pub struct DependentMismatch {
    /// Per coupler of the model: largest |file − coupler value| and its time.
    worst: Vec<(f64, f64)>,
    /// Per coupler: largest |file − coupler value in degrees| (the column
    /// holding the coupler's value converted to degrees, as generators that
    /// treat every angle-like column as rotational write it).
    worst_degrees: Vec<f64>,
}

/// A difference below this (rad or m) is rounding in the file.
pub const DEPENDENT_TOLERANCE: f64 = 1e-6;

impl DependentMismatch {
    pub fn new(model: &Model) -> Self {
        DependentMismatch {
            worst: vec![(0.0, f64::NAN); model.couplers.len()],
            worst_degrees: vec![0.0; model.couplers.len()],
        }
    }

    /// Feed one row: `value(c)` gives coordinate c's file value (model
    /// units), or None when the file has no column for it.
    pub fn push(&mut self, model: &Model, t: f64, value: impl Fn(usize) -> Option<f64>) {
        for (k, cp) in model.couplers.iter().enumerate() {
            let (Some(dep), Some(ind)) = (value(cp.dependent), value(cp.independent[0])) else {
                continue;
            };
            let given = cp.scale * cp.function.value(ind);
            let d = (dep - given).abs();
            if d > self.worst[k].0 {
                self.worst[k] = (d, t);
            }
            let dd = (dep - given.to_degrees()).abs();
            if dd > self.worst_degrees[k] {
                self.worst_degrees[k] = dd;
            }
        }
    }

    pub fn warnings(&self, model: &Model, file: &Path) -> Vec<String> {
        model
            .couplers
            .iter()
            .zip(self.worst.iter().zip(&self.worst_degrees))
            .filter(|(_, ((d, _), _))| *d > DEPENDENT_TOLERANCE)
            .map(|(cp, ((d, t), dd))| {
                let dependent = &model.coordinates[cp.dependent];
                if *dd <= DEPENDENT_TOLERANCE.to_degrees() {
                    format!(
                        "{}: the column of dependent coordinate {} holds its coupler {}'s values in degrees, where OpenSim reads radians (its motion type is not rotational): OpenSim's assembler corrects the positions through the coupler but keeps the speeds splined from this column, 57.3× too large; statopt takes its positions and speeds from the coupler",
                        file.display(),
                        dependent.name,
                        cp.name
                    )
                } else {
                    format!(
                        "{}: the column of dependent coordinate {} differs from its coupler {} by up to {d:.4} (at t = {}); statopt takes its positions and speeds from the coupler. OpenSim's assembler corrects the positions through the coupler but keeps the speeds splined from this column, so OpenSim's results differ where the joint moves fast; write the column in the coupler's units to compare (docs/knee_contact.md)",
                        file.display(),
                        dependent.name,
                        cp.name,
                        crate::storage::fmt_time(*t)
                    )
                }
            })
            .collect()
    }
}
