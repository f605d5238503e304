//! `SimmSpline` (legacy tag `NaturalCubicSpline`): the Forsythe–Malcolm–Moler
//! cubic spline, opensim-semantics.md §3.1 (`OpenSim/Common/SimmSpline.cpp`).
//!
//! - Intervals h_i = max(1e-7, x_{i+1} − x_i).
//! - n = 2: the straight line through both points.
//! - n = 3: no end conditions (s''' = 0 at the ends).
//! - n ≥ 4: s''' at each end equals 6× the third divided difference of the
//!   first (last) four points.
//! - Outside [x₀, x_{n−1}] the spline continues linearly with the end slope
//!   (s'' = 0); within 2e-13 of an end knot the end knot's value, slope and
//!   2c are returned.

use crate::error::{Error, Result};

/// Minimum interval, OpenSim's `TINY_NUMBER`.
pub(crate) const TINY_NUMBER: f64 = 1e-7;
/// OpenSim's `ROUNDOFF_ERROR` used for "at an end knot" tests.
pub(crate) const ROUNDOFF_ERROR: f64 = 2e-13;

/// FMM cubic spline: on [x_k, x_{k+1}], s = y_k + b_k t + c_k t² + d_k t³.
#[derive(Debug, Clone, PartialEq)]
pub struct SimmSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
    d: Vec<f64>,
}

/// Common checks for x/y tabulated functions: equal lengths, at least
/// `min` points, finite numbers, x non-decreasing (equal abscissae are
/// tolerated as OpenSim does, through the 1e-7 minimum interval).
pub(crate) fn check_xy(kind: &str, x: &[f64], y: &[f64], min: usize) -> Result<()> {
    if x.len() != y.len() {
        return Err(Error::msg(format!(
            "{kind}: {} x values but {} y values",
            x.len(),
            y.len()
        )));
    }
    if x.len() < min {
        return Err(Error::msg(format!(
            "{kind}: needs at least {min} points, got {}",
            x.len()
        )));
    }
    if let Some(i) = x.iter().chain(y).position(|v| !v.is_finite()) {
        let n = x.len();
        let (what, j) = if i < n { ("x", i) } else { ("y", i - n) };
        return Err(Error::msg(format!(
            "{kind}: {what}[{j}] is not a finite number"
        )));
    }
    if let Some(i) = (1..x.len()).find(|&i| x[i] < x[i - 1]) {
        return Err(Error::msg(format!(
            "{kind}: x values must be increasing, but x[{}] = {} > x[{}] = {}",
            i - 1,
            x[i - 1],
            i,
            x[i]
        )));
    }
    Ok(())
}

/// Index k of the interval [x_k, x_{k+1}] containing `x`, for x₀ ≤ x ≤ x_{n−1}.
#[inline]
pub(crate) fn interval(xs: &[f64], x: f64) -> usize {
    let n = xs.len();
    (xs[..n - 1].partition_point(|&k| k <= x).max(1) - 1).min(n - 2)
}

impl SimmSpline {
    /// Build the spline through (x, y); n ≥ 2, x non-decreasing.
    pub fn new(x: &[f64], y: &[f64]) -> Result<SimmSpline> {
        check_xy("SimmSpline", x, y, 2)?;
        let n = x.len();
        let mut b = vec![0.0; n];
        let mut c = vec![0.0; n];
        let mut d = vec![0.0; n];
        let h = |i: usize| (x[i + 1] - x[i]).max(TINY_NUMBER);
        if n == 2 {
            let s = (y[1] - y[0]) / h(0);
            b.fill(s);
            return Ok(SimmSpline {
                x: x.to_vec(),
                y: y.to_vec(),
                b,
                c,
                d,
            });
        }
        let last = n - 1;
        // Tridiagonal system in σ_i = s''(x_i)/6 ("c" below before the final
        // scaling): diagonal `diag`, off-diagonal `off` (= h), rhs `c`.
        let mut diag = vec![0.0; n];
        let off: Vec<f64> = (0..last).map(h).collect();
        // slopes of the chords
        let slope: Vec<f64> = (0..last).map(|i| (y[i + 1] - y[i]) / off[i]).collect();
        for i in 1..last {
            diag[i] = 2.0 * (off[i - 1] + off[i]);
            c[i] = slope[i] - slope[i - 1];
        }
        // End conditions: third derivative from the third divided
        // difference of the four end points.
        diag[0] = -off[0];
        diag[last] = -off[last - 1];
        c[0] = 0.0;
        c[last] = 0.0;
        if n > 3 {
            let span = |i: usize, j: usize| (x[j] - x[i]).max(TINY_NUMBER);
            // second divided differences (times 1, as in the rhs above)
            let dd0 = c[2] / span(1, 3) - c[1] / span(0, 2);
            let dd1 = c[last - 1] / span(n - 3, last) - c[n - 3] / span(n - 4, last - 1);
            c[0] = dd0 * off[0] * off[0] / span(0, 3);
            c[last] = -dd1 * off[last - 1] * off[last - 1] / span(n - 4, last);
        }
        // Forward elimination (the system is symmetric: sub = super = off).
        for i in 1..n {
            let t = off[i - 1] / diag[i - 1];
            diag[i] -= t * off[i - 1];
            c[i] -= t * c[i - 1];
        }
        // Back substitution.
        c[last] /= diag[last];
        for i in (0..last).rev() {
            c[i] = (c[i] - off[i] * c[i + 1]) / diag[i];
        }
        // Polynomial coefficients.
        b[last] = slope[last - 1] + off[last - 1] * (c[last - 1] + 2.0 * c[last]);
        for i in 0..last {
            b[i] = slope[i] - off[i] * (c[i + 1] + 2.0 * c[i]);
            d[i] = (c[i + 1] - c[i]) / off[i];
            c[i] *= 3.0;
        }
        c[last] *= 3.0;
        d[last] = d[last - 1];
        if let Some(i) = b.iter().chain(&c).chain(&d).position(|v| !v.is_finite()) {
            return Err(Error::msg(format!(
                "SimmSpline: coefficients are not finite (near point {}); are the x values degenerate?",
                i % n
            )));
        }
        Ok(SimmSpline {
            x: x.to_vec(),
            y: y.to_vec(),
            b,
            c,
            d,
        })
    }

    pub fn x(&self) -> &[f64] {
        &self.x
    }
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// (value, first, second, third derivative) following OpenSim's case
    /// order: extrapolation, then end-knot snapping, then the interval.
    #[inline]
    fn eval3(&self, x: f64) -> (f64, f64, f64, f64) {
        let n = self.x.len();
        let (x0, xl) = (self.x[0], self.x[n - 1]);
        if x < x0 {
            return (self.y[0] + (x - x0) * self.b[0], self.b[0], 0.0, 0.0);
        }
        if x > xl {
            let l = n - 1;
            return (self.y[l] + (x - xl) * self.b[l], self.b[l], 0.0, 0.0);
        }
        if (x - x0).abs() <= ROUNDOFF_ERROR {
            return (self.y[0], self.b[0], 2.0 * self.c[0], 6.0 * self.d[0]);
        }
        if (x - xl).abs() <= ROUNDOFF_ERROR {
            let l = n - 1;
            return (self.y[l], self.b[l], 2.0 * self.c[l], 6.0 * self.d[l]);
        }
        let k = interval(&self.x, x);
        let t = x - self.x[k];
        let (b, c, d) = (self.b[k], self.c[k], self.d[k]);
        (
            self.y[k] + t * (b + t * (c + t * d)),
            b + t * (2.0 * c + 3.0 * t * d),
            2.0 * c + 6.0 * t * d,
            6.0 * d,
        )
    }

    pub fn value(&self, x: f64) -> f64 {
        self.eval3(x).0
    }

    /// Derivative of order 0…3 (OpenSim itself only allows 1 and 2);
    /// higher orders are 0.
    pub fn derivative(&self, x: f64, order: usize) -> f64 {
        let e = self.eval3(x);
        match order {
            0 => e.0,
            1 => e.1,
            2 => e.2,
            3 => e.3,
            _ => 0.0,
        }
    }

    pub fn eval2(&self, x: f64) -> (f64, f64, f64) {
        let e = self.eval3(x);
        (e.0, e.1, e.2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Divided difference f[x_i..x_j] of the data.
    fn divided(x: &[f64], y: &[f64]) -> f64 {
        if x.len() == 1 {
            return y[0];
        }
        let n = x.len();
        (divided(&x[1..], &y[1..]) - divided(&x[..n - 1], &y[..n - 1])) / (x[n - 1] - x[0])
    }

    #[test]
    fn two_points_is_a_line_with_linear_extrapolation() {
        let s = SimmSpline::new(&[1.0, 3.0], &[2.0, 6.0]).unwrap();
        assert_eq!(s.value(2.0), 4.0);
        assert_eq!(s.derivative(2.0, 1), 2.0);
        assert_eq!(s.derivative(2.0, 2), 0.0);
        assert_eq!(s.value(5.0), 10.0);
        assert_eq!(s.value(0.0), 0.0);
    }

    #[test]
    fn fmm_end_conditions_and_continuity() {
        let x = [0.0, 0.3, 0.45, 1.0, 1.2, 1.9, 2.5];
        let y = [1.0, 0.2, -0.3, 0.8, 1.5, 0.1, -1.0];
        let s = SimmSpline::new(&x, &y).unwrap();
        let n = x.len();
        for i in 0..n {
            assert!((s.value(x[i]) - y[i]).abs() < 1e-14);
        }
        // s''' on the first / last interval = 6 × third divided difference
        let d3a = s.derivative(0.1, 3);
        let d3b = s.derivative(2.2, 3);
        assert!(
            (d3a - 6.0 * divided(&x[..4], &y[..4])).abs() < 1e-10,
            "{d3a}"
        );
        assert!(
            (d3b - 6.0 * divided(&x[n - 4..], &y[n - 4..])).abs() < 1e-10,
            "{d3b}"
        );
        // C² at interior knots
        for &k in &x[1..n - 1] {
            for d in 0..3 {
                let l = s.derivative(k - 1e-10, d);
                let r = s.derivative(k + 1e-10, d);
                assert!((l - r).abs() < 1e-6, "d{d} at {k}: {l} {r}");
            }
        }
        // linear extrapolation with the end slope
        let (f0, b0, _) = s.eval2(0.0);
        assert!((s.value(-0.5) - (f0 - 0.5 * b0)).abs() < 1e-14);
        assert_eq!(s.derivative(-0.5, 2), 0.0);
        let (fl, bl, cl) = s.eval2(2.5);
        assert!((s.value(3.0) - (fl + 0.5 * bl)).abs() < 1e-14);
        assert_eq!(s.derivative(3.0, 1), bl);
        // at the end knot s'' = 2c (non-zero for FMM)
        assert!(cl.abs() > 1e-3);
    }

    #[test]
    fn reproduces_cubics() {
        // The FMM end conditions are exact for cubics.
        let p = |t: f64| 1.0 - 2.0 * t + 0.5 * t * t + 0.25 * t * t * t;
        let x = [-1.0, -0.4, 0.0, 0.7, 1.1, 2.0];
        let y: Vec<f64> = x.iter().map(|&t| p(t)).collect();
        let s = SimmSpline::new(&x, &y).unwrap();
        for i in 0..30 {
            let t = -1.0 + i as f64 * 0.1;
            assert!((s.value(t) - p(t)).abs() < 1e-12, "{t}");
            assert!((s.derivative(t, 2) - (1.0 + 1.5 * t)).abs() < 1e-10);
        }
    }

    #[test]
    fn three_points_is_the_parabola() {
        // n = 3: no end conditions, so s''' = 0 on both intervals; with C²
        // the spline is the interpolating parabola.
        let p = |t: f64| 2.0 + t - 3.0 * t * t;
        let x = [0.0, 0.4, 1.0];
        let y: Vec<f64> = x.iter().map(|&t| p(t)).collect();
        let s = SimmSpline::new(&x, &y).unwrap();
        for t in [0.1, 0.5, 0.9] {
            assert!((s.value(t) - p(t)).abs() < 1e-13);
        }
    }

    #[test]
    fn end_knot_snapping() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [0.0, 1.0, 0.0, 1.0];
        let s = SimmSpline::new(&x, &y).unwrap();
        assert_eq!(s.value(1e-13), 0.0);
        assert_eq!(s.value(3.0 - 1e-13), 1.0);
        assert_ne!(s.value(1e-12), 0.0);
    }

    #[test]
    fn bad_input() {
        assert!(SimmSpline::new(&[0.0], &[1.0]).is_err());
        assert!(SimmSpline::new(&[0.0, 1.0], &[1.0]).is_err());
        assert!(SimmSpline::new(&[0.0, 2.0, 1.0], &[1.0, 1.0, 1.0]).is_err());
        assert!(SimmSpline::new(&[0.0, f64::NAN], &[1.0, 1.0]).is_err());
    }
}
