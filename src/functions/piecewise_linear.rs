//! `PiecewiseLinearFunction`, opensim-semantics.md §3
//! (`OpenSim/Common/PiecewiseLinearFunction.cpp`): slopes
//! b_i = (y_{i+1} − y_i)/max(1e-7, x_{i+1} − x_i), b_{n−1} = b_{n−2};
//! linear interpolation, linear extrapolation with the end slopes, second
//! derivative 0. A single point gives a constant.

use super::simm_spline::{check_xy, interval, ROUNDOFF_ERROR, TINY_NUMBER};
use crate::error::Result;

#[derive(Debug, Clone, PartialEq)]
pub struct PiecewiseLinear {
    x: Vec<f64>,
    y: Vec<f64>,
    b: Vec<f64>,
}

impl PiecewiseLinear {
    /// n ≥ 1 points, x non-decreasing.
    pub fn new(x: &[f64], y: &[f64]) -> Result<PiecewiseLinear> {
        check_xy("PiecewiseLinearFunction", x, y, 1)?;
        let n = x.len();
        let mut b = vec![0.0; n];
        for i in 0..n.saturating_sub(1) {
            b[i] = (y[i + 1] - y[i]) / (x[i + 1] - x[i]).max(TINY_NUMBER);
        }
        if n >= 2 {
            b[n - 1] = b[n - 2];
        }
        Ok(PiecewiseLinear {
            x: x.to_vec(),
            y: y.to_vec(),
            b,
        })
    }

    pub fn x(&self) -> &[f64] {
        &self.x
    }
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// (value, slope) following OpenSim's case order.
    #[inline]
    fn eval1(&self, x: f64) -> (f64, f64) {
        let n = self.x.len();
        let (x0, xl) = (self.x[0], self.x[n - 1]);
        if x < x0 {
            return (self.y[0] + (x - x0) * self.b[0], self.b[0]);
        }
        if x > xl {
            return (self.y[n - 1] + (x - xl) * self.b[n - 1], self.b[n - 1]);
        }
        if (x - x0).abs() <= ROUNDOFF_ERROR {
            return (self.y[0], self.b[0]);
        }
        if (x - xl).abs() <= ROUNDOFF_ERROR {
            return (self.y[n - 1], self.b[n - 1]);
        }
        let k = interval(&self.x, x);
        (self.y[k] + (x - self.x[k]) * self.b[k], self.b[k])
    }

    pub fn value(&self, x: f64) -> f64 {
        self.eval1(x).0
    }

    pub fn derivative(&self, x: f64, order: usize) -> f64 {
        match order {
            0 => self.eval1(x).0,
            1 => self.eval1(x).1,
            _ => 0.0,
        }
    }

    pub fn eval2(&self, x: f64) -> (f64, f64, f64) {
        let (v, d) = self.eval1(x);
        (v, d, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_and_end_slope_extrapolation() {
        let f = PiecewiseLinear::new(&[0.0, 1.0, 3.0], &[0.0, 2.0, 3.0]).unwrap();
        assert_eq!(f.value(0.5), 1.0);
        assert_eq!(f.value(2.0), 2.5);
        assert_eq!(f.derivative(2.0, 1), 0.5);
        assert_eq!(f.derivative(2.0, 2), 0.0);
        // left: slope 2; right: slope 0.5
        assert_eq!(f.value(-1.0), -2.0);
        assert_eq!(f.value(5.0), 4.0);
        assert_eq!(f.derivative(5.0, 1), 0.5);
        assert_eq!(f.eval2(-1.0), (-2.0, 2.0, 0.0));
    }

    #[test]
    fn single_point_is_constant() {
        let f = PiecewiseLinear::new(&[1.0], &[4.0]).unwrap();
        assert_eq!(f.value(-3.0), 4.0);
        assert_eq!(f.value(1.0), 4.0);
        assert_eq!(f.value(7.0), 4.0);
        assert_eq!(f.derivative(7.0, 1), 0.0);
    }
}
