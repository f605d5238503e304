//! Closed-form functions of opensim-semantics.md §3: `PolynomialFunction`
//! (coefficients in decreasing powers) and `StepFunction` (Simbody's
//! `Function::Step`, the quintic smooth step of §8.4).

/// Polynomial c₀xᴺ + … + c_N: (value, first, second derivative), Horner.
#[inline]
pub(crate) fn poly_eval2(c: &[f64], x: f64) -> (f64, f64, f64) {
    let mut p = 0.0;
    let mut d1 = 0.0;
    let mut d2 = 0.0;
    for &a in c {
        d2 = d2 * x + d1;
        d1 = d1 * x + p;
        p = p * x + a;
    }
    (p, d1, 2.0 * d2)
}

/// Derivative of any order of the polynomial with coefficients `c`
/// (decreasing powers).
pub(crate) fn poly_derivative(c: &[f64], x: f64, order: usize) -> f64 {
    let n = c.len();
    if order >= n {
        return 0.0;
    }
    // Term of power p = n-1-i contributes c_i p!/(p-order)! x^(p-order).
    let mut acc = 0.0;
    for (i, &a) in c.iter().enumerate().take(n - order) {
        let p = n - 1 - i;
        let mut f = 1.0;
        for q in (p - order + 1)..=p {
            f *= q as f64;
        }
        acc = acc * x + a * f;
    }
    acc
}

/// Smooth step from (t0, y0) to (t1, y1): y0 + (y1−y0)·u³(10 − 15u + 6u²)
/// with u = (x−t0)/(t1−t0) clamped to [0, 1]. Derivatives of the given
/// order (0…5 non-trivial; the quintic's 6th and higher vanish). Requires
/// t0 ≠ t1 (checked at construction).
pub(crate) fn step_derivative(t0: f64, t1: f64, y0: f64, y1: f64, x: f64, order: usize) -> f64 {
    let w = t1 - t0;
    let u = (x - t0) / w;
    if u <= 0.0 || u >= 1.0 {
        return match order {
            0 if u <= 0.0 => y0,
            0 => y1,
            _ => 0.0,
        };
    }
    let dy = y1 - y0;
    let s = match order {
        0 => return y0 + dy * u * u * u * (10.0 + u * (-15.0 + 6.0 * u)),
        1 => 30.0 * u * u * (1.0 - u) * (1.0 - u),
        2 => 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u),
        3 => 60.0 * (1.0 + u * (-6.0 + 6.0 * u)),
        4 => 360.0 * (2.0 * u - 1.0),
        5 => 720.0,
        _ => 0.0,
    };
    dy * s / w.powi(order as i32)
}

pub(crate) fn step_eval2(t0: f64, t1: f64, y0: f64, y1: f64, x: f64) -> (f64, f64, f64) {
    (
        step_derivative(t0, t1, y0, y1, x, 0),
        step_derivative(t0, t1, y0, y1, x, 1),
        step_derivative(t0, t1, y0, y1, x, 2),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_doc_example() {
        // opensim-semantics.md §3 [4.6]: coefficients (2, 3, 5) at x = 2 → 19
        assert_eq!(poly_eval2(&[2.0, 3.0, 5.0], 2.0), (19.0, 11.0, 4.0));
        assert_eq!(poly_derivative(&[2.0, 3.0, 5.0], 2.0, 0), 19.0);
        assert_eq!(poly_derivative(&[2.0, 3.0, 5.0], 2.0, 1), 11.0);
        assert_eq!(poly_derivative(&[2.0, 3.0, 5.0], 2.0, 2), 4.0);
        assert_eq!(poly_derivative(&[2.0, 3.0, 5.0], 2.0, 3), 0.0);
        // x³ − x: third derivative 6
        assert_eq!(poly_derivative(&[1.0, 0.0, -1.0, 0.0], 0.7, 3), 6.0);
        assert_eq!(poly_eval2(&[], 1.0), (0.0, 0.0, 0.0));
    }

    #[test]
    fn step_shape() {
        let f = |x, o| step_derivative(1.0, 3.0, 2.0, 6.0, x, o);
        assert_eq!(f(0.0, 0), 2.0);
        assert_eq!(f(4.0, 0), 6.0);
        assert_eq!(f(2.0, 0), 4.0); // midpoint
        assert_eq!(f(2.0, 1), 4.0 * 30.0 / 16.0 / 2.0);
        assert_eq!(f(0.5, 1), 0.0);
        // derivatives against central differences
        for &x in &[1.3, 1.9, 2.6] {
            for o in 0..5 {
                let h = 1e-5;
                let fd = (f(x + h, o) - f(x - h, o)) / (2.0 * h);
                let an = f(x, o + 1);
                assert!((fd - an).abs() < 1e-5 * (1.0 + an.abs()), "o {o} x {x}");
            }
        }
        // reversed interval: still y0 before t0 (which is now on the right)
        let g = |x| step_derivative(3.0, 1.0, 0.0, 1.0, x, 0);
        assert_eq!(g(4.0), 0.0);
        assert_eq!(g(0.0), 1.0);
    }
}
