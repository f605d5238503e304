//! OpenSim `Function`s of one argument (opensim-semantics.md §3):
//! Constant, LinearFunction, PolynomialFunction, MultiplierFunction,
//! PiecewiseLinearFunction, SimmSpline (FMM cubic, §3.1), GCVSpline
//! (natural interpolating spline, §3.2) and StepFunction.
//!
//! Reading from XML is in [`parse`]; each spline family has its own file.

mod gcv_spline;
mod parse;
mod piecewise_linear;
mod simm_spline;
mod simple;

pub use gcv_spline::GcvSpline;
pub use piecewise_linear::PiecewiseLinear;
pub use simm_spline::SimmSpline;

/// A function of one real argument with derivatives.
#[derive(Debug, Clone, PartialEq)]
pub enum Function {
    /// `Constant`: value; all derivatives 0.
    Constant(f64),
    /// `LinearFunction` with coefficients [slope, intercept].
    Linear {
        slope: f64,
        intercept: f64,
    },
    /// `PolynomialFunction`: coefficients in decreasing powers.
    Polynomial(Vec<f64>),
    PiecewiseLinear(PiecewiseLinear),
    SimmSpline(SimmSpline),
    GcvSpline(GcvSpline),
    /// `MultiplierFunction`: scale · inner(x), derivatives scaled too.
    Multiplier {
        scale: f64,
        inner: Box<Function>,
    },
    /// `StepFunction`: Simbody's quintic smooth step from (t0, y0) to (t1, y1).
    Step {
        t0: f64,
        t1: f64,
        y0: f64,
        y1: f64,
    },
}

impl Function {
    pub fn value(&self, x: f64) -> f64 {
        match self {
            Function::Constant(v) => *v,
            Function::Linear { slope, intercept } => slope * x + intercept,
            Function::Polynomial(c) => simple::poly_eval2(c, x).0,
            Function::PiecewiseLinear(f) => f.value(x),
            Function::SimmSpline(f) => f.value(x),
            Function::GcvSpline(f) => f.value(x),
            Function::Multiplier { scale, inner } => scale * inner.value(x),
            Function::Step { t0, t1, y0, y1 } => simple::step_derivative(*t0, *t1, *y0, *y1, x, 0),
        }
    }

    /// Derivative of the given order (0 = value). Orders 1 and 2 are what
    /// OpenSim uses; higher orders give the exact derivative of the
    /// piecewise polynomial (0 where it has none).
    pub fn derivative(&self, x: f64, order: usize) -> f64 {
        if order == 0 {
            return self.value(x);
        }
        match self {
            Function::Constant(_) => 0.0,
            Function::Linear { slope, .. } => {
                if order == 1 {
                    *slope
                } else {
                    0.0
                }
            }
            Function::Polynomial(c) => simple::poly_derivative(c, x, order),
            Function::PiecewiseLinear(f) => f.derivative(x, order),
            Function::SimmSpline(f) => f.derivative(x, order),
            Function::GcvSpline(f) => f.derivative(x, order),
            Function::Multiplier { scale, inner } => scale * inner.derivative(x, order),
            Function::Step { t0, t1, y0, y1 } => {
                simple::step_derivative(*t0, *t1, *y0, *y1, x, order)
            }
        }
    }

    /// (value, first, second derivative) in one call (one interval search
    /// for the tabulated functions).
    #[inline]
    pub fn eval2(&self, x: f64) -> (f64, f64, f64) {
        match self {
            Function::Constant(v) => (*v, 0.0, 0.0),
            Function::Linear { slope, intercept } => (slope * x + intercept, *slope, 0.0),
            Function::Polynomial(c) => simple::poly_eval2(c, x),
            Function::PiecewiseLinear(f) => f.eval2(x),
            Function::SimmSpline(f) => f.eval2(x),
            Function::GcvSpline(f) => f.eval2(x),
            Function::Multiplier { scale, inner } => {
                let (v, d1, d2) = inner.eval2(x);
                (scale * v, scale * d1, scale * d2)
            }
            Function::Step { t0, t1, y0, y1 } => simple::step_eval2(*t0, *t1, *y0, *y1, x),
        }
    }

    /// True for a `LinearFunction` with slope exactly ±1 (the test OpenSim
    /// uses to call a CustomJoint coordinate Rotational/Translational, §2.6).
    /// A MultiplierFunction does not count, as in OpenSim.
    pub fn is_unit_slope_linear(&self) -> bool {
        matches!(self, Function::Linear { slope, .. } if slope.abs() == 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_and_multiplier() {
        let f = Function::Multiplier {
            scale: 2.0,
            inner: Box::new(Function::Polynomial(vec![2.0, 3.0, 5.0])),
        };
        assert_eq!(f.value(2.0), 38.0);
        assert_eq!(f.derivative(2.0, 1), 22.0);
        assert_eq!(f.eval2(2.0), (38.0, 22.0, 8.0));
        let l = Function::Linear {
            slope: -1.0,
            intercept: 0.5,
        };
        assert_eq!(l.eval2(2.0), (-1.5, -1.0, 0.0));
        assert_eq!(l.derivative(2.0, 2), 0.0);
        assert!(l.is_unit_slope_linear());
        assert_eq!(Function::Constant(3.0).eval2(7.0), (3.0, 0.0, 0.0));
        assert_eq!(Function::Constant(3.0).derivative(7.0, 1), 0.0);
    }

    #[test]
    fn eval2_agrees_with_derivative_for_all_kinds() {
        let x = [0.0, 0.2, 0.5, 0.9, 1.4, 1.5, 2.0];
        let y = [0.1, 0.4, -0.2, 0.3, 0.9, 1.0, 0.2];
        let fs = [
            Function::SimmSpline(SimmSpline::new(&x, &y).unwrap()),
            Function::GcvSpline(GcvSpline::interpolating(5, &x, &y).unwrap()),
            Function::GcvSpline(GcvSpline::interpolating(3, &x, &y).unwrap()),
            Function::PiecewiseLinear(PiecewiseLinear::new(&x, &y).unwrap()),
            Function::Step {
                t0: 0.3,
                t1: 1.1,
                y0: -1.0,
                y1: 2.0,
            },
            Function::Polynomial(vec![0.5, -1.0, 2.0, 0.3]),
        ];
        for f in &fs {
            for i in 0..45 {
                let t = -0.5 + 0.07 * i as f64;
                let (a, b, c) = f.eval2(t);
                assert!((a - f.value(t)).abs() < 1e-12, "{f:?} {t}");
                assert!((b - f.derivative(t, 1)).abs() < 1e-10, "{f:?} {t}");
                assert!((c - f.derivative(t, 2)).abs() < 1e-8, "{f:?} {t}");
            }
        }
    }
}
