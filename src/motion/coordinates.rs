//! From a coordinates table to per-frame (q, u, u̇) the way OpenSim's tools
//! do it (opensim-semantics.md §1.3, §6.3, §9.2): columns are matched to model
//! coordinates by name, rotational columns converted from degrees, and every
//! coordinate is splined with a quintic interpolating GCV spline.

use crate::error::{Error, Location, Result};
use crate::functions::{GcvSpline, SplineFitter};
use crate::model::{Model, MotionType};
use crate::storage::Storage;

/// What a coordinate missing from the table gets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MissingCoordinate {
    /// The coordinate's `default_value` (InverseDynamicsTool).
    DefaultValue,
    /// Zero (AnalyzeTool's `formCompleteStorages`).
    Zero,
}

/// One spline per model coordinate (tree order) through the table's rows.
#[derive(Debug, Clone)]
pub struct CoordinateSplines {
    /// The table's time column (frames are selected among these rows).
    pub time: Vec<f64>,
    /// Coordinate values at the rows (radians / meters), `values[c][row]`.
    pub values: Vec<Vec<f64>>,
    splines: Vec<Option<GcvSpline>>,
    constants: Vec<f64>,
    /// Coordinates the table lacks.
    pub missing: Vec<String>,
}

/// Index of the table column holding coordinate `name`: the label itself, or
/// a state-variable path whose last or second-to-last segment is the name.
pub fn column_for(table: &Storage, name: &str) -> Option<usize> {
    table.labels.iter().position(|l| l == name).or_else(|| {
        table.labels.iter().position(|l| {
            let segs: Vec<&str> = l.split('/').filter(|s| !s.is_empty()).collect();
            segs.len() > 1
                && (segs[segs.len() - 1] == name
                    || (segs[segs.len() - 2] == name && segs[segs.len() - 1] == "value"))
        })
    })
}

/// Refuse a column whose values lie far outside the coordinate's range: the
/// sign of wrong units (degrees in a file whose header says `inDegrees=no`,
/// millimetres for metres). "Far": beyond the range widened on each side by
/// its width (at least 2π for rotational coordinates). Checked only for a
/// finite, non-empty range.
fn check_units(
    c: &crate::model::Coordinate,
    table: &Storage,
    j: usize,
    v: &[f64],
    file: &std::path::Path,
) -> Result<()> {
    for (i, x) in v.iter().enumerate() {
        if let Some(e) = units_error(
            c,
            &table.labels[j],
            table.in_degrees,
            i,
            table.time[i],
            *x,
            file,
        ) {
            return Err(e);
        }
    }
    Ok(())
}

/// The error for one value (in model units, row `i` 0-based) of coordinate
/// `c` read from column `label`, when it lies far outside the coordinate's
/// range (see `check_units`); None when it does not.
#[inline]
pub(crate) fn units_error(
    c: &crate::model::Coordinate,
    label: &str,
    in_degrees: bool,
    i: usize,
    t: f64,
    x: f64,
    file: &std::path::Path,
) -> Option<Error> {
    let [lo, hi] = c.range;
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return None;
    }
    let rotational = c.motion_type == MotionType::Rotational;
    let margin = if rotational {
        (hi - lo).max(2.0 * std::f64::consts::PI)
    } else {
        hi - lo
    };
    if x >= lo - margin && x <= hi + margin {
        return None;
    }
    units_message(c, label, in_degrees, i, t, x, file)
}

#[cold]
#[inline(never)]
fn units_message(
    c: &crate::model::Coordinate,
    label: &str,
    in_degrees: bool,
    i: usize,
    t: f64,
    x: f64,
    file: &std::path::Path,
) -> Option<Error> {
    let [lo, hi] = c.range;
    let rotational = c.motion_type == MotionType::Rotational;
    let (unit, hint) = if rotational {
        (
            "rad",
            if in_degrees {
                "is the motion in radians while its header says inDegrees=yes?"
            } else {
                "is the motion in degrees while its header says inDegrees=no (or lacks inDegrees=yes)?"
            },
        )
    } else {
        ("m", "is the motion in millimetres instead of metres?")
    };
    Some(Error::input(
        Location::file(file).with_element(format!("column '{label}'")),
        format!(
            "row {} (time {t}): value {x} {unit} is far outside coordinate {}'s range [{lo}, {hi}] {unit}; {hint}",
            i + 1,
            c.name
        ),
    ))
}

impl CoordinateSplines {
    pub fn new(
        model: &Model,
        table: &Storage,
        missing: MissingCoordinate,
        file: &std::path::Path,
    ) -> Result<Self> {
        Self::with_degree(model, table, missing, file, 5)
    }

    /// As [`new`](Self::new) with interpolating splines of `degree` (1, 3 or 5).
    pub fn with_degree(
        model: &Model,
        table: &Storage,
        missing: MissingCoordinate,
        file: &std::path::Path,
        degree: usize,
    ) -> Result<Self> {
        if table.time.len() < 6 {
            return Err(Error::input(
                Location::file(file),
                format!(
                    "the motion has {} rows; at least 6 are needed for OpenSim's quintic splines",
                    table.time.len()
                ),
            ));
        }
        let mut values = Vec::with_capacity(model.nq());
        let mut splines = Vec::with_capacity(model.nq());
        let mut constants = Vec::with_capacity(model.nq());
        let mut missing_names = Vec::new();
        // one spline system for every column (same bits as one per column)
        let mut fit = SplineFitter::new(degree, &table.time);
        for c in &model.coordinates {
            match column_for(table, &c.name) {
                Some(j) => {
                    let scale = if table.in_degrees && c.motion_type == MotionType::Rotational {
                        std::f64::consts::PI / 180.0
                    } else {
                        1.0
                    };
                    let v: Vec<f64> = table.rows.iter().map(|r| r[j] * scale).collect();
                    // Dependent coordinates are set by their couplers.
                    if !c.dependent {
                        check_units(c, table, j, &v, file)?;
                    }
                    let s = fit.spline(&v).map_err(|e| {
                        e.context(format!("{}: column '{}'", file.display(), table.labels[j]))
                    })?;
                    values.push(v);
                    splines.push(Some(s));
                    constants.push(0.0);
                }
                None => {
                    let k = match missing {
                        MissingCoordinate::DefaultValue => c.default_value,
                        MissingCoordinate::Zero => 0.0,
                    };
                    missing_names.push(c.name.clone());
                    values.push(vec![k; table.time.len()]);
                    splines.push(None);
                    constants.push(k);
                }
            }
        }
        Ok(CoordinateSplines {
            time: table.time.clone(),
            values,
            splines,
            constants,
            missing: missing_names,
        })
    }

    /// q = S(t), u = S'(t), u̇ = S''(t) for every coordinate (InverseDynamicsTool).
    pub fn eval(&self, t: f64, q: &mut [f64], u: &mut [f64], udot: &mut [f64]) {
        for (c, s) in self.splines.iter().enumerate() {
            match s {
                Some(s) => {
                    q[c] = s.value(t);
                    u[c] = s.derivative(t, 1);
                    udot[c] = s.derivative(t, 2);
                }
                None => {
                    q[c] = self.constants[c];
                    u[c] = 0.0;
                    udot[c] = 0.0;
                }
            }
        }
    }
}

/// OpenSim's `Storage::findIndex`: the last row whose time is <= t (exact
/// comparison), 0 if t precedes every row.
pub fn find_index(time: &[f64], t: f64) -> usize {
    match time.iter().position(|&ti| t < ti) {
        Some(0) | None if time.is_empty() => 0,
        Some(0) => 0,
        Some(i) => i - 1,
        None => time.len() - 1,
    }
}

/// Rows `first..=last` of a [`CoordinateSplines`] as blocks of frames for the
/// frame driver: q = S, u = S′, u̇ = S″ at each row's time (the
/// InverseDynamicsTool's states), computed a block at a time.
pub struct SplineFrames<'a> {
    splines: &'a CoordinateSplines,
    next: usize,
    last: usize,
    block: usize,
}

impl CoordinateSplines {
    /// The rows `first..=last` as [`SplineFrames`].
    pub fn frames(&self, first: usize, last: usize) -> SplineFrames<'_> {
        SplineFrames {
            splines: self,
            next: first,
            last,
            block: crate::motion::stream::DEFAULT_BLOCK,
        }
    }
}

impl crate::motion::stream::FrameSource for SplineFrames<'_> {
    fn next_block(&mut self) -> Result<Option<crate::motion::stream::StateBlock>> {
        if self.next > self.last || self.next >= self.splines.time.len() {
            return Ok(None);
        }
        let a = self.next;
        let b = (a + self.block - 1).min(self.last);
        let nq = self.splines.splines.len();
        let time: Vec<f64> = self.splines.time[a..=b].to_vec();
        let mut q = vec![vec![0.0; nq]; time.len()];
        let mut u = q.clone();
        let mut udot = q.clone();
        for (k, &t) in time.iter().enumerate() {
            self.splines.eval(t, &mut q[k], &mut u[k], &mut udot[k]);
        }
        self.next = b + 1;
        Ok(Some(crate::motion::stream::StateBlock {
            first: a,
            time,
            q,
            u,
            udot,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::find_index;

    #[test]
    fn find_index_semantics() {
        let t = [0.0, 0.1, 0.2, 0.30000000000000004];
        assert_eq!(find_index(&t, -1.0), 0);
        assert_eq!(find_index(&t, 0.1), 1);
        assert_eq!(find_index(&t, 0.15), 1);
        assert_eq!(find_index(&t, 0.3), 2);
        assert_eq!(find_index(&t, 9.0), 3);
    }
}
