//! AnalyzeTool's states (opensim-semantics.md §9.2): coordinates filtered,
//! mapped to the model (missing columns → 0), converted from degrees, speeds
//! from quintic splines at the table's own rows, and each row "assembled":
//! locked coordinates at their lock value with zero speed, prescribed ones
//! at their function, dependent coordinates of couplers from their
//! independent coordinate.

use std::path::Path;

use crate::error::{Error, Location, Result};
use crate::functions::SplineFitter;
use crate::model::Model;
use crate::motion::coordinates::{CoordinateSplines, MissingCoordinate};
use crate::storage::Storage;

/// q and u at every row of the (possibly padded and resampled) table.
#[derive(Debug, Clone)]
pub struct States {
    pub time: Vec<f64>,
    /// `q[row][coordinate]`, tree order.
    pub q: Vec<Vec<f64>>,
    pub u: Vec<Vec<f64>>,
    /// Coordinates the table lacked (set to 0, as AnalyzeTool does).
    pub missing: Vec<String>,
    /// Degree of the interpolating splines through q and u (5: OpenSim's).
    pub spline_degree: usize,
}

impl States {
    pub fn from_coordinates(model: &Model, table: &Storage, file: &Path) -> Result<States> {
        Self::from_coordinates_with_degree(model, table, file, 5)
    }

    /// As [`from_coordinates`](Self::from_coordinates) with interpolating
    /// splines of `degree` (statopt's `<coordinate_spline>`).
    pub fn from_coordinates_with_degree(
        model: &Model,
        table: &Storage,
        file: &Path,
        degree: usize,
    ) -> Result<States> {
        let splines =
            CoordinateSplines::with_degree(model, table, MissingCoordinate::Zero, file, degree)?;
        let n = table.time.len();
        let nq = model.nq();
        let mut q = vec![vec![0.0; nq]; n];
        let mut u = vec![vec![0.0; nq]; n];
        let (mut qq, mut uu, mut aa) = (vec![0.0; nq], vec![0.0; nq], vec![0.0; nq]);
        for (i, &t) in table.time.iter().enumerate() {
            splines.eval(t, &mut qq, &mut uu, &mut aa);
            for c in 0..nq {
                // q at the rows is the data itself; u the spline's derivative.
                q[i][c] = splines.values[c][i];
                u[i][c] = uu[c];
            }
            assemble(model, t, &mut q[i], &mut u[i]);
        }
        Ok(States {
            time: table.time.clone(),
            q,
            u,
            missing: splines.missing,
            spline_degree: degree,
        })
    }

    /// Target accelerations for static optimization (§6.3): the derivative of
    /// a spline through each coordinate's speeds, at the rows (of the same
    /// degree as the states' splines: quintic unless `<coordinate_spline>`).
    pub fn speed_derivatives(&self, file: &Path) -> Result<Vec<Vec<f64>>> {
        let degree = self.spline_degree;
        let n = self.time.len();
        let nq = self.q.first().map_or(0, |r| r.len());
        let mut udot = vec![vec![0.0; nq]; n];
        // S_u′ at the knots, one spline system for all columns (the same
        // bits as `GcvSpline::interpolating(..).derivative(t_i, 1)`).
        let mut fit = SplineFitter::new(degree, &self.time);
        let cols: Vec<Vec<f64>> = (0..nq)
            .map(|c| self.u.iter().map(|r| r[c]).collect())
            .collect();
        let ys: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        let mut slopes = Vec::new();
        fit.knot_slopes_columns(&ys, &mut slopes)
            .map_err(|(_, e)| {
                Error::input(Location::file(file), format!("splining speeds: {e}"))
            })?;
        for (c, sl) in slopes.iter().enumerate() {
            for i in 0..n {
                udot[i][c] = sl[i];
            }
        }
        Ok(udot)
    }
}

/// Make (q, u) satisfy the model's locks, prescriptions and couplers, moving
/// only the constrained coordinates.
pub fn assemble(model: &Model, t: f64, q: &mut [f64], u: &mut [f64]) {
    for (c, coord) in model.coordinates.iter().enumerate() {
        if let Some(f) = &coord.prescribed {
            q[c] = f.value(t);
            u[c] = f.derivative(t, 1);
        } else if coord.locked {
            q[c] = coord.default_value;
            u[c] = 0.0;
        }
    }
    for cp in &model.couplers {
        let i = cp.independent[0];
        let (v, d1, _) = cp.function.eval2(q[i]);
        q[cp.dependent] = cp.scale * v;
        u[cp.dependent] = cp.scale * d1 * u[i];
    }
}
