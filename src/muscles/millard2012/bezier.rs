//! Quintic Bézier corners and the C²-continuous smooth segmented function
//! built from them, semantics §4.5 (`OpenSim/Common/SegmentedQuinticBezierToolkit.cpp`,
//! `SmoothSegmentedFunction.cpp`). Written from the description of the
//! algorithm: each segment is a quintic Bézier (x(u), y(u)), u ∈ [0, 1];
//! evaluating y at x solves x(u) = x by Newton iteration; outside the curve's
//! domain [x0, x1] the curve is a straight line with the end slope.

/// Newton tolerance on x(u) − x (`UTOL` = 100·Eps).
const UTOL: f64 = f64::EPSILON * 1e2;
/// Newton iteration limit (`MAXITER`).
const MAXITER: usize = 20;
/// Samples per segment for the initial guess of u(x) (`NUM_SAMPLE_PTS`).
const NUM_SAMPLE_PTS: usize = 100;

/// Control points of one quintic Bézier segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlPoints {
    pub x: [f64; 6],
    pub y: [f64; 6],
}

/// The curviness mapping c ↦ 0.1 + 0.8 c (`scaleCurviness`).
pub fn scale_curviness(curviness: f64) -> f64 {
    0.1 + 0.8 * curviness
}

/// Control points of a C-shaped corner from (x0, y0) with slope dydx0 to
/// (x1, y1) with slope dydx1 (`calcQuinticBezierCornerControlPoints`).
/// The two tangent lines meet at (x_C, y_C); the inner control points sit at
/// the fraction `curviness` (already scaled) of the way from each end point
/// towards that intersection, each one doubled. Fails when the geometry
/// would produce an S-shaped curve.
pub fn corner_control_points(
    x0: f64,
    y0: f64,
    dydx0: f64,
    x1: f64,
    y1: f64,
    dydx1: f64,
    curviness: f64,
) -> Result<ControlPoints, String> {
    if !(0.0..=1.0).contains(&curviness) {
        return Err(format!(
            "curviness must be between 0 and 1 (is {curviness})"
        ));
    }
    let root_eps = f64::EPSILON.sqrt();
    let xc = if (dydx0 - dydx1).abs() > root_eps {
        (y1 - y0 - x1 * dydx1 + x0 * dydx0) / (dydx0 - dydx1)
    } else {
        (x1 + x0) / 2.0
    };
    let yc = (xc - x1) * dydx1 + y1;
    // Triangle side lengths (squared): the chord must be the longest side.
    let a = (xc - x0).powi(2) + (yc - y0).powi(2);
    let b = (xc - x1).powi(2) + (yc - y1).powi(2);
    let c = (x1 - x0).powi(2) + (y1 - y0).powi(2);
    if !(c > a && c > b) {
        return Err(format!(
            "the tangent lines at ({x0}, {y0}) slope {dydx0} and ({x1}, {y1}) slope {dydx1} \
             do not form a C-shaped corner"
        ));
    }
    let x0m = x0 + curviness * (xc - x0);
    let y0m = y0 + curviness * (yc - y0);
    let x1m = x1 + curviness * (xc - x1);
    let y1m = y1 + curviness * (yc - y1);
    Ok(ControlPoints {
        x: [x0, x0m, x0m, x1m, x1m, x1],
        y: [y0, y0m, y0m, y1m, y1m, y1],
    })
}

/// d^order/du^order of the quintic Bézier with control values `p` at u
/// (Bernstein form with forward differences); zero above order 5.
pub fn bezier_deriv_u(u: f64, p: &[f64; 6], order: usize) -> f64 {
    if order > 5 {
        return 0.0;
    }
    // Forward differences of the control values, `order` times.
    let mut d = *p;
    let n = 5 - order;
    for k in 0..order {
        for i in 0..(5 - k) {
            d[i] = d[i + 1] - d[i];
        }
    }
    // Factor 5!/(5-order)!.
    let mut factor = 1.0;
    for k in 0..order {
        factor *= (5 - k) as f64;
    }
    // Bernstein polynomial of degree n at u (de Casteljau for stability).
    let mut b = [0.0; 6];
    b[..=n].copy_from_slice(&d[..=n]);
    for r in 1..=n {
        for i in 0..=(n - r) {
            b[i] = (1.0 - u) * b[i] + u * b[i + 1];
        }
    }
    factor * b[0]
}

/// d^order y/dx^order of a Bézier segment at parameter u, orders 0–3
/// (`calcQuinticBezierCurveDerivDYDX`); NaN for higher orders.
pub fn bezier_deriv_dydx(u: f64, xp: &[f64; 6], yp: &[f64; 6], order: usize) -> f64 {
    match order {
        0 => bezier_deriv_u(u, yp, 0),
        1 => bezier_deriv_u(u, yp, 1) / bezier_deriv_u(u, xp, 1),
        2 => {
            let (xd, yd) = (bezier_deriv_u(u, xp, 1), bezier_deriv_u(u, yp, 1));
            let (xdd, ydd) = (bezier_deriv_u(u, xp, 2), bezier_deriv_u(u, yp, 2));
            (ydd * xd - yd * xdd) / (xd * xd * xd)
        }
        3 => {
            let (x1, y1) = (bezier_deriv_u(u, xp, 1), bezier_deriv_u(u, yp, 1));
            let (x2, y2) = (bezier_deriv_u(u, xp, 2), bezier_deriv_u(u, yp, 2));
            let (x3, y3) = (bezier_deriv_u(u, xp, 3), bezier_deriv_u(u, yp, 3));
            // g = d2y/dx2 = (y2 x1 − y1 x2)/x1³; d3y/dx3 = (dg/du)/x1.
            let num = y2 * x1 - y1 * x2;
            let dnum = y3 * x1 - y1 * x3;
            let g_u = (dnum * x1 - 3.0 * num * x2) / x1.powi(4);
            g_u / x1
        }
        _ => f64::NAN,
    }
}

/// A chain of quintic Bézier segments with linear extrapolation
/// (`SmoothSegmentedFunction`).
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothSegmentedFunction {
    segments: Vec<ControlPoints>,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    dydx0: f64,
    dydx1: f64,
    /// Per segment: x sampled at u = i/(N−1), for the initial guess of u(x).
    samples: Vec<Vec<f64>>,
}

impl SmoothSegmentedFunction {
    /// Build from segments and the end conditions used for extrapolation.
    pub fn new(
        segments: Vec<ControlPoints>,
        x0: f64,
        x1: f64,
        y0: f64,
        y1: f64,
        dydx0: f64,
        dydx1: f64,
    ) -> SmoothSegmentedFunction {
        let samples = segments
            .iter()
            .map(|s| {
                (0..NUM_SAMPLE_PTS)
                    .map(|i| bezier_deriv_u(i as f64 / (NUM_SAMPLE_PTS - 1) as f64, &s.x, 0))
                    .collect()
            })
            .collect();
        SmoothSegmentedFunction {
            segments,
            x0,
            x1,
            y0,
            y1,
            dydx0,
            dydx1,
            samples,
        }
    }

    pub fn segments(&self) -> &[ControlPoints] {
        &self.segments
    }

    /// The Bézier domain [x0, x1].
    pub fn domain(&self) -> (f64, f64) {
        (self.x0, self.x1)
    }

    /// y(x).
    pub fn value(&self, x: f64) -> f64 {
        self.derivative(x, 0)
    }

    /// d^order y/dx^order at x (order 0 is the value). Outside [x0, x1] the
    /// curve is linear: value, end slope, then zeros. Orders above 3 give NaN.
    pub fn derivative(&self, x: f64, order: usize) -> f64 {
        if x < self.x0 {
            return match order {
                0 => self.y0 + self.dydx0 * (x - self.x0),
                1 => self.dydx0,
                _ => 0.0,
            };
        }
        if x > self.x1 {
            return match order {
                0 => self.y1 + self.dydx1 * (x - self.x1),
                1 => self.dydx1,
                _ => 0.0,
            };
        }
        if x.is_nan() {
            return f64::NAN;
        }
        let idx = self.segment_index(x);
        let seg = &self.segments[idx];
        let u = self.solve_u(idx, x);
        bezier_deriv_dydx(u, &seg.x, &seg.y, order)
    }

    /// First segment with x0_i ≤ x < x5_i, else the last one (`calcIndex`).
    fn segment_index(&self, x: f64) -> usize {
        self.segments
            .iter()
            .position(|s| x >= s.x[0] && x < s.x[5])
            .unwrap_or(self.segments.len() - 1)
    }

    /// Solve x(u) = x on one segment (`calcU`): initial guess from the
    /// sampled curve, Newton iteration with u clamped to [0, 1], and a
    /// bisection fallback should Newton not reach the tolerance.
    fn solve_u(&self, idx: usize, x: f64) -> f64 {
        let xp = &self.segments[idx].x;
        let xs = &self.samples[idx];
        let n = xs.len();
        let du = 1.0 / (n - 1) as f64;
        // Bracketing sample interval (x(u) is increasing on a valid corner).
        let j = match xs.iter().position(|&xi| xi > x) {
            Some(0) => 0,
            Some(j) => j - 1,
            None => n - 2,
        };
        let (xa, xb) = (xs[j], xs[j + 1]);
        let t = if xb > xa {
            ((x - xa) / (xb - xa)).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let mut u = ((j as f64 + t) * du).clamp(0.0, 1.0);
        let mut f = bezier_deriv_u(u, xp, 0) - x;
        let mut iter = 0;
        while f.abs() > UTOL && iter < MAXITER {
            let df = bezier_deriv_u(u, xp, 1);
            if df.abs() > 0.0 {
                u = (u - f / df).clamp(0.0, 1.0);
                f = bezier_deriv_u(u, xp, 0) - x;
            } else {
                break;
            }
            iter += 1;
        }
        if f.abs() <= UTOL {
            return u;
        }
        // Bisection on [0, 1] (x(u) monotone): robust fallback.
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if bezier_deriv_u(mid, xp, 0) < x {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= f64::EPSILON {
                break;
            }
        }
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn power_form(u: f64, p: &[f64; 6]) -> f64 {
        // Direct Bernstein sum (binomial coefficients 1 5 10 10 5 1).
        let c = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        (0..6)
            .map(|k| c[k] * (1.0 - u).powi(5 - k as i32) * u.powi(k as i32) * p[k])
            .sum()
    }

    #[test]
    fn bezier_value_and_derivatives_match_bernstein_sum() {
        let p = [0.3, -1.0, 2.0, 0.5, 4.0, 1.5];
        for i in 0..=10 {
            let u = i as f64 / 10.0;
            assert_relative_eq!(bezier_deriv_u(u, &p, 0), power_form(u, &p), epsilon = 1e-13);
            // Central differences (the polynomial extends beyond [0, 1]).
            let h = 1e-5;
            let fd = (power_form(u + h, &p) - power_form(u - h, &p)) / (2.0 * h);
            assert_relative_eq!(bezier_deriv_u(u, &p, 1), fd, epsilon = 1e-6);
            let fd2 =
                (power_form(u + h, &p) - 2.0 * power_form(u, &p) + power_form(u - h, &p)) / (h * h);
            assert_relative_eq!(bezier_deriv_u(u, &p, 2), fd2, epsilon = 1e-3);
        }
        // End tangents: 5 (p1 − p0) and 5 (p5 − p4).
        assert_relative_eq!(bezier_deriv_u(0.0, &p, 1), 5.0 * (p[1] - p[0]));
        assert_relative_eq!(bezier_deriv_u(1.0, &p, 1), 5.0 * (p[5] - p[4]));
        assert_relative_eq!(
            bezier_deriv_u(0.3, &p, 5),
            120.0 * (p[5] - 5.0 * p[4] + 10.0 * p[3] - 10.0 * p[2] + 5.0 * p[1] - p[0]),
            epsilon = 1e-9
        );
    }

    #[test]
    fn corner_interpolates_end_points_and_slopes() {
        let cp = corner_control_points(0.0, 0.0, 0.0, 1.0, 1.0, 3.0, scale_curviness(0.5)).unwrap();
        let f = SmoothSegmentedFunction::new(vec![cp], 0.0, 1.0, 0.0, 1.0, 0.0, 3.0);
        assert_relative_eq!(f.value(0.0), 0.0, epsilon = 1e-14);
        assert_relative_eq!(f.value(1.0), 1.0, epsilon = 1e-14);
        assert_relative_eq!(f.derivative(1e-9, 1), 0.0, epsilon = 1e-6);
        assert_relative_eq!(f.derivative(1.0, 1), 3.0, epsilon = 1e-9);
        // Linear extension.
        assert_relative_eq!(f.value(2.0), 4.0, epsilon = 1e-14);
        assert_relative_eq!(f.value(-1.0), 0.0);
        // Numerical derivative inside agrees with the analytic one.
        for i in 1..20 {
            let x = i as f64 / 20.0;
            let h = 1e-6;
            let fd = (f.value(x + h) - f.value(x - h)) / (2.0 * h);
            assert_relative_eq!(f.derivative(x, 1), fd, epsilon = 1e-6);
            let fd2 = (f.derivative(x + h, 1) - f.derivative(x - h, 1)) / (2.0 * h);
            assert_relative_eq!(f.derivative(x, 2), fd2, epsilon = 1e-4, max_relative = 1e-5);
            let fd3 = (f.derivative(x + h, 2) - f.derivative(x - h, 2)) / (2.0 * h);
            assert_relative_eq!(f.derivative(x, 3), fd3, epsilon = 1e-3, max_relative = 1e-4);
        }
    }

    #[test]
    fn s_shaped_corner_is_rejected() {
        assert!(corner_control_points(0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.5).is_ok());
        assert!(corner_control_points(0.0, 0.0, 0.0, 1.0, 1.0, -1.0, 0.5).is_err());
        assert!(corner_control_points(0.0, 0.0, 0.0, 1.0, 1.0, 3.0, 1.5).is_err());
    }
}
