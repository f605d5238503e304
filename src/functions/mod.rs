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

pub use gcv_spline::{GcvSpline, SplineFitter, TransientBasis};
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

    /// `(value(x), derivative(x, 1))`, bit for bit, with one interval
    /// search where the two share it (SimmSpline, also inside a multiplier).
    pub fn value_and_slope(&self, x: f64) -> (f64, f64) {
        match self {
            Function::SimmSpline(f) => {
                let (v, d1, _) = f.eval2(x);
                (v, d1)
            }
            Function::Multiplier { scale, inner } => {
                let (v, d1) = inner.value_and_slope(x);
                (scale * v, scale * d1)
            }
            _ => (self.value(x), self.derivative(x, 1)),
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

    /// `value_and_slope` has the bits of `value` and `derivative(.., 1)` for
    /// every kind, inside and outside the data and on the knots.
    #[test]
    fn value_and_slope_is_value_and_derivative_bit_for_bit() {
        let x = [0.0, 0.2, 0.5, 0.9, 1.4, 1.5, 2.0];
        let y = [0.1, 0.4, -0.2, 0.3, 0.9, 1.0, 0.2];
        let simm = Function::SimmSpline(SimmSpline::new(&x, &y).unwrap());
        let fs = [
            simm.clone(),
            Function::Multiplier {
                scale: 0.988523,
                inner: Box::new(simm),
            },
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
            Function::Constant(0.25),
            Function::Linear {
                slope: -0.3,
                intercept: 0.1,
            },
        ];
        let ts = (0..45).map(|i| -0.5 + 0.07 * i as f64).chain(x);
        for t in ts {
            for f in &fs {
                let (v, d) = f.value_and_slope(t);
                assert_eq!(v.to_bits(), f.value(t).to_bits(), "{f:?} {t}");
                assert_eq!(d.to_bits(), f.derivative(t, 1).to_bits(), "{f:?} {t}");
            }
        }
    }
}

/// Values pinned against OpenSim 4.6 (pip package, /work/venv): each
/// function was written as an XML element (`<GCVSpline name="f">` with
/// `<half_order>`, `<error_variance>0</error_variance>`, `<x>`, `<y>`
/// printed with Python `repr`, or `<SimmSpline>`), loaded with
/// `opensim.OpenSimObject.makeObjectFromFile`, and evaluated with
/// `calcValue(Vector(1, x))` and `calcDerivative(StdVectorInt([0]*order),
/// Vector(1, x))`.
#[cfg(test)]
mod opensim_reference {
    use super::*;

    const X: [f64; 10] = [
        0.59999926, 0.61, 0.6333, 0.64, 0.6719, 0.69, 0.7001, 0.73, 0.745, 0.7712,
    ];
    const Y: [f64; 10] = [0.1, -0.4, 0.25, 0.9, 0.7, 1.3, 0.2, -0.6, -0.1, 0.35];

    type Row = (f64, [f64; 3]);

    const GCV3: [Row; 9] = [
        (0.55, [2.9953925828115686, -57.90870870512022, 0.0]),
        (0.59999926, [0.0999999999999999, -57.90870870512022, 0.0]),
        (
            0.6,
            [0.09995714755559343, -57.908708575154414, 0.3512589460772233],
        ),
        (
            0.615,
            [-0.5099611465073473, -9.501455516871816, 5120.91738382611],
        ),
        (
            0.65,
            [1.141020293808415, -15.768441734966014, -5599.468594576305],
        ),
        (
            0.7,
            [0.2115417565326688, -115.81186022153611, 7794.025569521331],
        ),
        (
            0.7205,
            [-0.774719680112878, 4.385870173641549, 3636.685584331334],
        ),
        (0.7712, [0.35000000000000003, 10.788191614873604, 0.0]),
        (0.8, [0.6606999185083603, 10.788191614873604, 0.0]),
    ];
    const GCV5: [Row; 9] = [
        (
            0.55,
            [5.436545290402731, -153.5755536199334, 1873.7504583505486],
        ),
        (
            0.59999926,
            [0.10000000000000028, -59.88941727774517, 1873.7504583505486],
        ),
        (
            0.6,
            [0.09995568234425092, -59.888030702406084, 1873.750458350973],
        ),
        (
            0.615,
            [-0.5482760743883265, -19.00020861763027, 5029.961490777906],
        ),
        (
            0.65,
            [1.1969295894960337, -20.072017189436167, -8247.510602160888],
        ),
        (
            0.7,
            [0.2130880301451078, -130.97294622271102, 1797.0560962470881],
        ),
        (
            0.7205,
            [-0.9616712881749887, 23.318937008723996, 5216.776757473171],
        ),
        (0.7712, [0.35, 15.537333922937064, -26.629291033799333]),
        (
            0.8,
            [0.7864315174030507, 14.77041034116364, -26.629291033799333],
        ),
    ];
    const SIMM: [Row; 9] = [
        (0.55, [3.6174714475079415, -70.35047013711687, 0.0]),
        (0.59999926, [0.1, -70.35047013711687, 4088.1112532547904]),
        (
            0.6,
            [0.09994794177142702, -70.34744493623349, 4088.1073511165464],
        ),
        (
            0.615,
            [-0.49576387824655127, -8.086707501896644, 4621.953011837452],
        ),
        (
            0.65,
            [1.1422125659054747, -15.7531374092339, -5615.734337059965],
        ),
        (
            0.7,
            [0.21151336298422518, -115.53271403384937, 7889.421515849801],
        ),
        (
            0.7205,
            [-0.765187057611499, 4.225265565767955, 3496.0658602750736],
        ),
        (0.7712, [0.35, -18.23146591184523, -3978.1651553947327]),
        (0.8, [-0.17506621826114355, -18.23146591184523, 0.0]),
    ];

    fn check(f: &Function, rows: &[Row], what: &str) -> f64 {
        let mut worst: f64 = 0.0;
        for (x, want) in rows {
            let got = f.eval2(*x);
            let got = [got.0, got.1, got.2];
            for o in 0..3 {
                // relative to the size of that derivative on this data
                let size = rows.iter().map(|r| r.1[o].abs()).fold(1.0, f64::max);
                let err = (got[o] - want[o]).abs() / size;
                worst = worst.max(err);
                assert!(
                    err < 1e-11,
                    "{what} order {o} at {x}: {} vs {}",
                    got[o],
                    want[o]
                );
            }
        }
        worst
    }

    #[test]
    fn gcv_and_simm_match_opensim_46() {
        let g3 = Function::GcvSpline(GcvSpline::interpolating(3, &X, &Y).unwrap());
        let g5 = Function::GcvSpline(GcvSpline::interpolating(5, &X, &Y).unwrap());
        let s = Function::SimmSpline(SimmSpline::new(&X, &Y).unwrap());
        let w = [
            check(&g3, &GCV3, "GCV cubic"),
            check(&g5, &GCV5, "GCV quintic"),
            check(&s, &SIMM, "SimmSpline"),
        ];
        eprintln!("worst relative errors vs OpenSim: {w:?}");
    }

    #[test]
    fn simm_three_points_and_piecewise_linear_match_opensim_46() {
        // SimmSpline x = (0, 0.4, 1), y = (1, -1, 2)
        let s = SimmSpline::new(&[0.0, 0.4, 1.0], &[1.0, -1.0, 2.0]).unwrap();
        for (x, v, d1, d2) in [
            (-0.5, 5.5, -9.0, 0.0),
            (0.2, -0.40000000000000013, -5.0, 20.0),
            (0.7, -0.40000000000000036, 4.999999999999998, 20.0),
            (1.5, 7.5, 11.0, 0.0),
        ] {
            let (a, b, c) = s.eval2(x);
            assert!((a - v).abs() < 1e-12 && (b - d1).abs() < 1e-12 && (c - d2).abs() < 1e-10);
        }
        // PiecewiseLinearFunction x = (0, 1, 3), y = (0, 2, 3)
        let p = PiecewiseLinear::new(&[0.0, 1.0, 3.0], &[0.0, 2.0, 3.0]).unwrap();
        for (x, v, d1) in [
            (-1.0, -2.0, 2.0),
            (0.5, 1.0, 2.0),
            (2.0, 2.5, 0.5),
            (5.0, 4.0, 0.5),
        ] {
            assert_eq!(p.eval2(x), (v, d1, 0.0));
        }
    }
}
