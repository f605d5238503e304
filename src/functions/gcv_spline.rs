//! `GCVSpline`: Woltring's GCVSPL natural spline, interpolating case only
//! (opensim-semantics.md §3.2; `OpenSim/Common/GCVSpline.cpp`, simbody
//! `SplineFitter`/`GCVSPLUtil`).
//!
//! With `error_variance = 0` (what OpenSim uses for coordinates, speeds and
//! external-force data) GCVSPL produces the *natural interpolating spline* of
//! degree 2m−1 (m = half order): the unique minimiser of ∫(f⁽ᵐ⁾)² through the
//! data. It is piecewise polynomial of degree 2m−1, C^(2m−2) at the knots,
//! with f⁽ʲ⁾ = 0 at both end knots for j = m…2m−2. Outside the knots it
//! continues as the degree m−1 Taylor polynomial of the end knot (quintic
//! splines extrapolate quadratically, cubic ones linearly). Derivatives of
//! order ≥ 2m are zero.
//!
//! Construction: B-spline basis of degree k = 2m−1 on the data abscissae
//! (end knots repeated k+1 times). The n interpolation conditions plus the
//! 2(m−1) natural end conditions give a square system whose rows, ordered
//! along x, form a band matrix with m−1 sub- and super-diagonals; it is
//! solved by banded Gaussian elimination with partial pivoting in O(n m²).
//! The result is converted to per-interval Taylor coefficients so that
//! evaluation is a binary search plus one Horner scheme, without allocation.

#![allow(clippy::needless_range_loop)] // index loops mirror the band-matrix math

use std::sync::{Arc, OnceLock};

use crate::error::{Error, Result};

/// Right-hand sides solved together by [`SplineFitter`]'s column methods.
const LANES: usize = 4;

/// Largest supported degree (half order 4, "heptic").
const MAX_DEGREE: usize = 7;
const MAX_COEF: usize = MAX_DEGREE + 1;

/// An interpolating natural spline of odd degree 1, 3, 5 or 7.
///
/// The B-spline coefficients are solved when the spline is built; the
/// Taylor coefficients of an interval are computed the first time the spline
/// is evaluated there (and kept), so a long series evaluated at a few points
/// costs little more than the solve.
#[derive(Debug, Clone)]
pub struct GcvSpline {
    half_order: usize,
    /// Abscissae (shared by the splines of one [`SplineFitter`]).
    x: Arc<[f64]>,
    y: Vec<f64>,
    /// B-spline coefficients on the knots [`knot_vector`] makes of x.
    coef: Vec<f64>,
    /// Taylor coefficients f⁽ʲ⁾(base)/j! of n+1 segments, made on first use
    /// ([`GcvSpline::segment`]): segment 0 is the left extrapolation (base
    /// x₀), segment s (1 ≤ s ≤ n−1) covers [x_{s−1}, x_s) with base x_{s−1},
    /// segment n is the right extrapolation (base x_{n−1}). Unused high
    /// coefficients are 0.
    /// (Boxed: a slot not yet used takes 16 bytes, not 72.)
    seg: Box<[OnceLock<Box<[f64; MAX_COEF]>>]>,
    /// The B-spline basis derivatives each segment's Taylor coefficients
    /// are made from ([`SpanBasis`]): they depend on x and the degree only,
    /// so the splines of one [`SplineFitter`] share them.
    basis: Arc<SpanBasis>,
}

/// Basis derivatives `ders` (see [`basis_derivatives`]) of each segment of
/// the splines of one degree on one set of abscissae, made on first use,
/// slot s for segment s (as [`GcvSpline::seg`]).
#[derive(Debug)]
struct SpanBasis {
    seg: Box<[OnceLock<Box<Ders>>]>,
}

type Ders = [[f64; MAX_COEF]; MAX_COEF];

/// The last segment basis [`GcvSpline::value_transient_with`] computed,
/// keyed by the splines' shared basis table and the segment: one per
/// evaluation time, on the stack.
#[derive(Debug, Clone)]
pub struct TransientBasis {
    key: Option<(usize, usize)>,
    ders: Ders,
}

impl Default for TransientBasis {
    fn default() -> Self {
        TransientBasis {
            key: None,
            ders: [[0.0; MAX_COEF]; MAX_COEF],
        }
    }
}

impl SpanBasis {
    fn new(n: usize) -> Arc<SpanBasis> {
        Arc::new(SpanBasis {
            seg: (0..=n).map(|_| OnceLock::new()).collect(),
        })
    }
}

/// Splines are equal when they interpolate the same data with the same degree.
impl PartialEq for GcvSpline {
    fn eq(&self, other: &GcvSpline) -> bool {
        self.half_order == other.half_order && self.x == other.x && self.y == other.y
    }
}

/// The checks of [`GcvSpline::interpolating`], in its order; returns m.
fn check_data(degree: usize, x: &[f64], y: &[f64]) -> Result<usize> {
    if degree % 2 == 0 || !(1..=MAX_DEGREE).contains(&degree) {
        return Err(Error::msg(format!(
            "GCVSpline degree must be 1, 3, 5 or 7, got {degree}"
        )));
    }
    let m = degree.div_ceil(2);
    if x.len() != y.len() {
        return Err(Error::msg(format!(
            "GCVSpline: {} x values but {} y values",
            x.len(),
            y.len()
        )));
    }
    let n = x.len();
    if n < 2 * m {
        return Err(Error::msg(format!(
            "GCVSpline: Too few data points: a degree {degree} spline needs at least {} points, got {n}",
            2 * m
        )));
    }
    if let Some(i) = x.iter().chain(y).position(|v| !v.is_finite()) {
        let (what, j) = if i < n { ("x", i) } else { ("y", i - n) };
        return Err(Error::msg(format!(
            "GCVSpline: {what}[{j}] is not a finite number"
        )));
    }
    if let Some(i) = (1..n).find(|&i| x[i] <= x[i - 1]) {
        return Err(Error::msg(format!(
            "GCVSpline: x values must be strictly increasing, but x[{}] = {} and x[{}] = {}",
            i - 1,
            x[i - 1],
            i,
            x[i]
        )));
    }
    Ok(m)
}

/// The checks of [`check_data`] on y, for abscissae that passed them.
fn check_y(x: &[f64], y: &[f64]) -> Result<()> {
    if x.len() != y.len() {
        return Err(Error::msg(format!(
            "GCVSpline: {} x values but {} y values",
            x.len(),
            y.len()
        )));
    }
    if let Some(j) = y.iter().position(|v| !v.is_finite()) {
        return Err(Error::msg(format!(
            "GCVSpline: y[{j}] is not a finite number"
        )));
    }
    Ok(())
}

impl GcvSpline {
    /// Interpolating natural spline of odd degree (1, 3, 5, 7) through
    /// (x, y); x strictly increasing; needs n ≥ degree+1 points.
    pub fn interpolating(degree: usize, x: &[f64], y: &[f64]) -> Result<GcvSpline> {
        let m = check_data(degree, x, y)?;
        let t = knot_vector(2 * m - 1, x);
        let mut coef = rhs(m, y);
        let mut band = system(m, x, &t, None);
        band.factor()?;
        band.apply(&mut coef);
        let basis = SpanBasis::new(x.len());
        Ok(GcvSpline::with_coefficients(m, x.into(), basis, y, coef))
    }

    fn with_coefficients(
        m: usize,
        x: Arc<[f64]>,
        basis: Arc<SpanBasis>,
        y: &[f64],
        coef: Vec<f64>,
    ) -> Self {
        GcvSpline {
            half_order: m,
            seg: (0..=x.len()).map(|_| OnceLock::new()).collect(),
            basis,
            x,
            y: y.to_vec(),
            coef,
        }
    }

    /// d/dx at every knot of the interpolating spline through (x, y):
    /// `out[i]` has the bits of `interpolating(degree, x, y)?.derivative(x[i], 1)`
    /// (same errors), without building the Taylor segments. For several
    /// columns on the same abscissae, [`SplineFitter`] shares the solve.
    pub fn knot_slopes(degree: usize, x: &[f64], y: &[f64]) -> Result<Vec<f64>> {
        let mut out = Vec::new();
        SplineFitter::new(degree, x).knot_slopes(y, &mut out)?;
        Ok(out)
    }

    pub fn degree(&self) -> usize {
        2 * self.half_order - 1
    }
    pub fn half_order(&self) -> usize {
        self.half_order
    }
    pub fn x(&self) -> &[f64] {
        &self.x
    }
    pub fn y(&self) -> &[f64] {
        &self.y
    }

    /// Segment index (0 = left extrapolation, n = right extrapolation) and
    /// its base abscissa.
    #[inline]
    fn locate(&self, x: f64) -> (usize, f64) {
        let n = self.x.len();
        if x < self.x[0] {
            return (0, self.x[0]);
        }
        if x > self.x[n - 1] {
            return (n, self.x[n - 1]);
        }
        // Largest i with x_i <= x, restricted to 0..=n-2 (x = x_{n-1} uses
        // the last interval).
        let i = self.x[..n - 1].partition_point(|&k| k <= x).max(1) - 1;
        (i + 1, self.x[i])
    }

    pub fn value(&self, x: f64) -> f64 {
        self.derivative(x, 0)
    }

    /// [`value`](Self::value) bit for bit, for arguments that seldom come
    /// back to a segment (a data series read at increasing times): a
    /// segment not made yet is made for this call only, not kept, and so is
    /// its basis when no call has kept it yet; nothing is allocated.
    pub fn value_transient(&self, x: f64) -> f64 {
        self.value_transient_with(x, &mut TransientBasis::default())
    }

    /// [`value_transient`](Self::value_transient), taking a segment's basis
    /// from `cache` when it holds that of the same abscissae and segment
    /// (the splines of one [`SplineFitter`] evaluated at one time, e.g. the
    /// columns of an external loads file) and leaving it there otherwise.
    pub fn value_transient_with(&self, x: f64, cache: &mut TransientBasis) -> f64 {
        let deg = self.degree();
        let (s, base) = self.locate(x);
        match self.seg[s].get() {
            Some(a) => horner(a, deg, x - base, 0),
            None => {
                let a = match self.basis.seg[s].get() {
                    Some(basis) => self.make_segment_from(s, basis),
                    None => {
                        let key = (Arc::as_ptr(&self.basis) as *const u8 as usize, s);
                        if cache.key != Some(key) {
                            cache.ders = self.compute_basis(s);
                            cache.key = Some(key);
                        }
                        self.make_segment_from(s, &cache.ders)
                    }
                };
                horner(&a, deg, x - base, 0)
            }
        }
    }

    /// Derivative of the given order (0 = value); orders ≥ 2m are 0.
    pub fn derivative(&self, x: f64, order: usize) -> f64 {
        let deg = self.degree();
        if order > deg {
            return 0.0;
        }
        let (s, base) = self.locate(x);
        horner(self.segment(s), deg, x - base, order)
    }

    /// Taylor coefficients of segment `s` (see [`GcvSpline::seg`]).
    #[inline]
    fn segment(&self, s: usize) -> &[f64; MAX_COEF] {
        self.seg[s].get_or_init(|| Box::new(self.make_segment(s)))
    }

    fn make_segment(&self, s: usize) -> [f64; MAX_COEF] {
        self.make_segment_from(s, self.span_basis(s))
    }

    /// Segment `s` from its basis derivatives `basis` ([`Self::span_basis`]).
    fn make_segment_from(&self, s: usize, basis: &Ders) -> [f64; MAX_COEF] {
        let (m, x, y) = (self.half_order, &self.x, &self.y);
        let k = 2 * m - 1;
        let n = x.len();
        if s == n {
            // Right extrapolation: Taylor polynomial of degree m-1 at x_{n-1}.
            let span = k + n - 2;
            let mut a = taylor_of(basis, &self.coef[span - k..], k, m - 1);
            a[0] = y[n - 1];
            return a;
        }
        let i = s.max(1) - 1;
        let mut a = taylor_of(basis, &self.coef[i..], k, k);
        a[0] = y[i]; // interpolation is exact; avoid solve round-off at knots
        if s == 0 {
            // Left extrapolation: Taylor polynomial of degree m-1 at x0.
            a[m..].iter_mut().for_each(|v| *v = 0.0);
        }
        a
    }

    /// The basis derivatives segment `s` is made from ([`basis_x`] at the
    /// segment's span, base and order), shared by the splines of one fitter.
    fn span_basis(&self, s: usize) -> &Ders {
        self.basis.seg[s].get_or_init(|| Box::new(self.compute_basis(s)))
    }

    /// [`Self::span_basis`] computed afresh (not kept).
    fn compute_basis(&self, s: usize) -> Ders {
        let (k, n) = (self.degree(), self.x.len());
        let m = self.half_order;
        if s == n {
            basis_x(&self.x, k, k + n - 2, self.x[n - 1], m - 1)
        } else {
            let i = s.max(1) - 1;
            basis_x(&self.x, k, k + i, self.x[i], k)
        }
    }

    /// (value, first, second derivative) with one interval search.
    pub fn eval2(&self, x: f64) -> (f64, f64, f64) {
        let deg = self.degree();
        let (s, base) = self.locate(x);
        let a = self.segment(s);
        let t = x - base;
        // Horner for p, p', p'' simultaneously.
        let mut p = a[deg];
        let mut d1 = 0.0;
        let mut d2 = 0.0;
        for j in (0..deg).rev() {
            d2 = d2 * t + d1;
            d1 = d1 * t + p;
            p = p * t + a[j];
        }
        (p, d1, 2.0 * d2)
    }
}

/// Σ_{j≥order} a_j j!/(j−order)! t^(j−order), by Horner: the derivative of
/// `order` at base + t of the degree-`deg` Taylor polynomial `a`.
#[inline]
fn horner(a: &[f64; MAX_COEF], deg: usize, t: f64, order: usize) -> f64 {
    let mut acc = 0.0;
    for j in (order..=deg).rev() {
        acc = acc * t + a[j] * falling(j, order);
    }
    acc
}

/// j!/(j−r)! for r ≤ j.
#[inline]
fn falling(j: usize, r: usize) -> f64 {
    let mut f = 1.0;
    for i in (j - r + 1)..=j {
        f *= i as f64;
    }
    f
}

/// Knot vector of the degree-k B-spline space on the data abscissae, with
/// the end abscissae repeated k+1 times. Length n + 2k.
fn knot_vector(k: usize, x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut t = Vec::with_capacity(n + 2 * k);
    t.extend(std::iter::repeat_n(x[0], k + 1));
    t.extend_from_slice(&x[1..n - 1]);
    t.extend(std::iter::repeat_n(x[n - 1], k + 1));
    t
}

/// Values and derivatives up to order `nd` of the k+1 B-splines of degree
/// `k` that are nonzero on knot span `span` (t[span] < t[span+1]), i.e.
/// B_{span−k} … B_span, evaluated with the polynomial piece of that span at
/// `u` (which may lie on either end of the span). `ders[d][r]` is the d-th
/// derivative of B_{span−k+r}. Cox–de Boor triangle with derivative
/// recurrences on the coefficients of the differentiated basis.
fn basis_derivatives(
    t: &[f64],
    span: usize,
    k: usize,
    u: f64,
    nd: usize,
) -> [[f64; MAX_COEF]; MAX_COEF] {
    // ndu[j][r], r < j: knot differences; ndu[r][j], r ≤ j: basis of degree j.
    let mut ndu = [[0.0; MAX_COEF]; MAX_COEF];
    let mut left = [0.0; MAX_COEF];
    let mut right = [0.0; MAX_COEF];
    ndu[0][0] = 1.0;
    for j in 1..=k {
        left[j] = u - t[span + 1 - j];
        right[j] = t[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            ndu[j][r] = right[r + 1] + left[j - r];
            let tmp = ndu[r][j - 1] / ndu[j][r];
            ndu[r][j] = saved + right[r + 1] * tmp;
            saved = left[j - r] * tmp;
        }
        ndu[j][j] = saved;
    }
    let mut ders = [[0.0; MAX_COEF]; MAX_COEF];
    for r in 0..=k {
        ders[0][r] = ndu[r][k];
    }
    let nd = nd.min(k);
    // a[s][j]: coefficients of the d-th derivative as a combination of
    // degree k−d basis functions (two alternating rows).
    for r in 0..=k {
        let mut a = [[0.0; MAX_COEF]; 2];
        let (mut s1, mut s2) = (0usize, 1usize);
        a[0][0] = 1.0;
        for d in 1..=nd {
            let mut sum = 0.0;
            let rk = r as isize - d as isize;
            let pk = k - d;
            if rk >= 0 {
                let rk = rk as usize;
                a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
                sum = a[s2][0] * ndu[rk][pk];
            }
            let j1: usize = if rk >= -1 { 1 } else { (-rk) as usize };
            let j2: usize = if r as isize - 1 <= pk as isize {
                d - 1
            } else {
                k - r
            };
            for j in j1..=j2 {
                let idx = (rk + j as isize) as usize;
                a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                sum += a[s2][j] * ndu[idx][pk];
            }
            if r <= pk {
                a[s2][d] = -a[s1][d - 1] / ndu[pk + 1][r];
                sum += a[s2][d] * ndu[r][pk];
            }
            ders[d][r] = sum;
            std::mem::swap(&mut s1, &mut s2);
        }
    }
    // Multiply by k!/(k−d)!.
    let mut f = k as f64;
    for (d, row) in ders.iter_mut().enumerate().take(nd + 1).skip(1) {
        for v in row.iter_mut().take(k + 1) {
            *v *= f;
        }
        f *= (k - d) as f64;
    }
    ders
}

/// Right-hand side of the spline system ([`system`]) for data `y`.
fn rhs(m: usize, y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let nb = n + 2 * m - 2;
    let mut rhs = vec![0.0; nb];
    rhs[0] = y[0];
    for i in 1..n - 1 {
        rhs[m - 1 + i] = y[i];
    }
    rhs[nb - 1] = y[n - 1];
    rhs
}

/// The band matrix of the natural interpolating spline's B-spline
/// coefficients on abscissae `x` (knots `t`). With `slopes`, also the first
/// derivatives of the k+1 basis functions at x_0 … x_{n−2} (spans k … k+n−2),
/// from the same basis evaluations as the interior rows.
fn system(m: usize, x: &[f64], t: &[f64], mut slopes: Option<&mut Vec<[f64; MAX_COEF]>>) -> Band {
    let n = x.len();
    let k = 2 * m - 1;
    let nb = n + k - 1; // number of basis functions = number of equations
    let bw = m - 1; // sub- and super-diagonals of the (unpivoted) matrix
    let mut a = Band::new(nb, bw, bw);

    // Left end: value row 0, then rows s = 1..m-1 for f^(m-1+s)(x0) = 0.
    // Derivative rows are scaled by h^d (h = first interval) to O(1).
    {
        let span = k;
        let ders = basis_derivatives(t, span, k, x[0], k - 1);
        let h = x[1] - x[0];
        a.set(0, 0, 1.0);
        for s in 1..m {
            let d = m - 1 + s;
            let scale = h.powi(d as i32);
            for c in 0..=d {
                a.set(s, c, ders[d][c] * scale);
            }
        }
        if let Some(out) = slopes.as_deref_mut() {
            out.clear();
            out.push(basis_derivatives(t, span, k, x[0], 1)[1]);
        }
    }
    // Interior knots x_i (i = 1..n-2): row m-1+i, columns i..i+k-1
    // (B_{i+k} vanishes at the left end of its span).
    let nd = slopes.is_some() as usize;
    for i in 1..n - 1 {
        let span = k + i;
        let ders = basis_derivatives(t, span, k, x[i], nd);
        let row = m - 1 + i;
        for r in 0..k {
            a.set(row, i + r, ders[0][r]);
        }
        if let Some(out) = slopes.as_deref_mut() {
            out.push(ders[1]);
        }
    }
    // Right end: rows nb-1-s for f^(m-1+s)(x_{n-1}) = 0, value row nb-1.
    {
        let span = k + n - 2;
        let ders = basis_derivatives(t, span, k, x[n - 1], k - 1);
        let h = x[n - 1] - x[n - 2];
        let first = span - k; // column of ders[.][0]
        a.set(nb - 1, nb - 1, 1.0);
        for s in 1..m {
            let d = m - 1 + s;
            let scale = h.powi(d as i32);
            for c in (nb - 1 - d)..nb {
                a.set(nb - 1 - s, c, ders[d][c - first] * scale);
            }
        }
    }
    a
}

/// Taylor coefficients f⁽ᵈ⁾(u)/d!, d ≤ `upto`, of the piece of knot span
/// `span` of the spline with B-spline coefficients `coef` (others 0).
fn taylor(t: &[f64], coef: &[f64], k: usize, span: usize, u: f64, upto: usize) -> [f64; MAX_COEF] {
    let ders = basis_derivatives(t, span, k, u, upto);
    taylor_of(&ders, &coef[span - k..], k, upto)
}

/// The basis derivatives [`taylor`] uses on the knots [`knot_vector`] would
/// make of `x`, from the 2k of them that the span's basis functions use
/// (t[j] = x[clamp(j − k)]), placed so that `basis_derivatives` reads the
/// same values.
fn basis_x(x: &[f64], k: usize, span: usize, u: f64, upto: usize) -> Ders {
    let n = x.len();
    // w[i] = t[span − k + i], i = 1..=2k; span k in w is span `span` in t
    let mut w = [0.0; 2 * MAX_DEGREE + 1];
    for (i, wi) in w.iter_mut().enumerate().take(2 * k + 1).skip(1) {
        *wi = x[(span - k + i).saturating_sub(k).min(n - 1)];
    }
    basis_derivatives(&w, k, k, u, upto)
}

/// Taylor coefficients from the basis derivatives `ders` of a span whose
/// first B-spline coefficient is `coef[0]`.
fn taylor_of(
    ders: &[[f64; MAX_COEF]; MAX_COEF],
    coef: &[f64],
    k: usize,
    upto: usize,
) -> [f64; MAX_COEF] {
    let mut out = [0.0; MAX_COEF];
    let mut fact = 1.0;
    for (d, o) in out.iter_mut().enumerate().take(upto + 1) {
        if d > 0 {
            fact *= d as f64;
        }
        let s: f64 = (0..=k).map(|r| coef[r] * ders[d][r]).sum();
        *o = s / fact;
    }
    out
}

/// Knots, factored system (Err: singular) and basis slopes at x_0…x_{n−2}.
type Basis = (
    Vec<f64>,
    std::result::Result<Band, ()>,
    Vec<[f64; MAX_COEF]>,
);

/// Interpolating splines of one degree on one set of abscissae: the spline
/// system is assembled and factored once (on the first column whose data
/// pass [`GcvSpline::interpolating`]'s checks) and reused for every column.
/// Results and errors are those of [`GcvSpline::interpolating`], bit for bit
/// (the elimination applies the same operations to each right-hand side).
pub struct SplineFitter<'a> {
    degree: usize,
    x: &'a [f64],
    /// Knots, factored system (Err: singular) and basis slopes at x_0…x_{n−2}.
    basis: Option<Basis>,
    shared: Option<(Arc<[f64]>, Arc<SpanBasis>)>,
}

impl<'a> SplineFitter<'a> {
    pub fn new(degree: usize, x: &'a [f64]) -> Self {
        SplineFitter {
            degree,
            x,
            basis: None,
            shared: None,
        }
    }

    pub fn x(&self) -> &'a [f64] {
        self.x
    }

    /// Checks, then the B-spline coefficients of the spline through y.
    fn coefficients(&mut self, y: &[f64]) -> Result<(usize, Vec<f64>)> {
        let m = self.check_columns(&[y]).map_err(|(_, e)| e)?;
        let Some((_, Ok(band), _)) = &self.basis else {
            unreachable!("check_columns factored the system");
        };
        let mut coef = rhs(m, y);
        band.apply(&mut coef);
        Ok((m, coef))
    }

    /// The checks of `coefficients` for every column in order, as calls
    /// one column after the other would make them: the first error, with
    /// its column.
    fn check_columns(&mut self, ys: &[&[f64]]) -> std::result::Result<usize, (usize, Error)> {
        let mut m = 0;
        for (c, y) in ys.iter().enumerate() {
            let x = self.x;
            m = if self.basis.is_some() {
                // x passed check_data already: only y's checks can fail
                check_y(x, y).map_err(|e| (c, e))?;
                self.degree.div_ceil(2)
            } else {
                check_data(self.degree, x, y).map_err(|e| (c, e))?
            };
            let (_, band, _) = self.basis.get_or_insert_with(|| {
                let t = knot_vector(2 * m - 1, x);
                let mut slopes = Vec::with_capacity(x.len());
                let mut band = system(m, x, &t, Some(&mut slopes));
                let band = band.factor().map(|_| band).map_err(|_| ());
                (t, band, slopes)
            });
            if band.is_err() {
                return Err((c, singular()));
            }
        }
        Ok(m)
    }

    /// B-spline coefficients of checked columns, [`LANES`] at a time.
    fn solve_columns(&self, m: usize, ys: &[&[f64]]) -> Vec<Vec<f64>> {
        let Some((_, Ok(band), _)) = &self.basis else {
            return Vec::new();
        };
        let mut out = Vec::with_capacity(ys.len());
        let mut rest = ys;
        while !rest.is_empty() {
            let chunk;
            if rest.len() >= 2 * LANES {
                (chunk, rest) = rest.split_at(2 * LANES);
                solve_lanes::<{ 2 * LANES }>(band, m, chunk, &mut out);
            } else {
                (chunk, rest) = rest.split_at(rest.len().min(LANES));
                solve_lanes::<LANES>(band, m, chunk, &mut out);
            }
        }
        out
    }

    /// [`SplineFitter::spline`] of every column: the splines, or the first
    /// error and its column.
    pub fn splines(
        &mut self,
        ys: &[&[f64]],
    ) -> std::result::Result<Vec<GcvSpline>, (usize, Error)> {
        let m = self.check_columns(ys)?;
        let coefs = self.solve_columns(m, ys);
        let (x, basis) = self.shared_x();
        Ok(ys
            .iter()
            .zip(coefs)
            .map(|(y, coef)| GcvSpline::with_coefficients(m, x.clone(), basis.clone(), y, coef))
            .collect())
    }

    /// [`SplineFitter::knot_slopes`] of every column into `out[c]`, or the
    /// first error and its column.
    pub fn knot_slopes_columns(
        &mut self,
        ys: &[&[f64]],
        out: &mut Vec<Vec<f64>>,
    ) -> std::result::Result<(), (usize, Error)> {
        let m = self.check_columns(ys)?;
        out.resize_with(ys.len(), Vec::new);
        self.slopes_of_columns(m, ys, out);
        Ok(())
    }

    /// The knot slopes of checked columns into `out`, the columns split
    /// in halves over the current rayon pool's threads (`-j`) while there
    /// are several threads and enough columns: each column's arithmetic is
    /// its own, so the split changes no bit.
    fn slopes_of_columns(&self, m: usize, ys: &[&[f64]], out: &mut [Vec<f64>]) {
        if ys.len() >= 4 * LANES && rayon::current_num_threads() > 1 {
            let mid = (ys.len() / 2).div_ceil(LANES) * LANES;
            let (ya, yb) = ys.split_at(mid);
            let (oa, ob) = out.split_at_mut(mid);
            rayon::join(
                || self.slopes_of_columns(m, ya, oa),
                || self.slopes_of_columns(m, yb, ob),
            );
            return;
        }
        let coefs = self.solve_columns(m, ys);
        for ((y, coef), o) in ys.iter().zip(coefs).zip(out.iter_mut()) {
            self.slopes_of(m, y, &coef, o);
        }
    }

    /// `GcvSpline::interpolating(degree, x, y)`.
    pub fn spline(&mut self, y: &[f64]) -> Result<GcvSpline> {
        let (m, coef) = self.coefficients(y)?;
        let (x, basis) = self.shared_x();
        Ok(GcvSpline::with_coefficients(m, x, basis, y, coef))
    }

    /// The abscissae and segment basis as the splines made here share them
    /// (one degree, so one basis).
    fn shared_x(&mut self) -> (Arc<[f64]>, Arc<SpanBasis>) {
        let x = self.x;
        let (x, b) = self
            .shared
            .get_or_insert_with(|| (x.into(), SpanBasis::new(x.len())));
        (x.clone(), b.clone())
    }

    /// `out[i] = GcvSpline::interpolating(degree, x, y)?.derivative(x[i], 1)`
    /// for every knot, bit for bit.
    ///
    /// At x_i, i < n−1, `derivative` evaluates the Taylor polynomial of
    /// [x_i, x_{i+1}) at t = 0: (acc·0) + a₁ with a₁ = Σ_r c_r B′_r(x_i), the
    /// same sum as here, and acc·0 = ±0 (the higher coefficients are finite),
    /// so the result is a₁ unless a₁ is 0, when the sign of the zero depends
    /// on acc: then (and at x_{n−1}, evaluated on the last interval) the
    /// whole Taylor polynomial is made and evaluated as `derivative` does.
    pub fn knot_slopes(&mut self, y: &[f64], out: &mut Vec<f64>) -> Result<()> {
        let (m, coef) = self.coefficients(y)?;
        self.slopes_of(m, y, &coef, out);
        Ok(())
    }

    fn slopes_of(&self, m: usize, y: &[f64], coef: &[f64], out: &mut Vec<f64>) {
        let (t, _, d1) = self.basis.as_ref().expect("made by coefficients");
        let x = self.x;
        let n = x.len();
        let k = 2 * m - 1;
        out.clear();
        for (i, b) in d1.iter().enumerate() {
            let a1 = (0..=k).map(|r| coef[i + r] * b[r]).sum::<f64>() / 1.0;
            if a1 != 0.0 && a1.is_finite() {
                out.push(a1);
            } else {
                let mut a = taylor(t, coef, k, k + i, x[i], k);
                a[0] = y[i];
                // t = x_i − x_i = +0
                out.push(horner(&a, k, 0.0, 1));
            }
        }
        let mut a = taylor(t, coef, k, k + n - 2, x[n - 2], k);
        a[0] = y[n - 2];
        out.push(horner(&a, k, x[n - 1] - x[n - 2], 1));
    }
}

/// Solve up to L columns together ([`Band::apply_lanes`]; unused lanes are
/// zeros) and append their coefficients to `out`.
fn solve_lanes<const L: usize>(band: &Band, m: usize, ys: &[&[f64]], out: &mut Vec<Vec<f64>>) {
    let mut b = vec![[0.0; L]; band.n];
    for (lane, y) in ys.iter().enumerate() {
        for (v, r) in b.iter_mut().zip(rhs(m, y)) {
            v[lane] = r;
        }
    }
    band.apply_lanes(&mut b);
    for lane in 0..ys.len() {
        out.push(b.iter().map(|v| v[lane]).collect());
    }
}

fn singular() -> Error {
    Error::internal("GCVSpline: singular spline system (ill-conditioned abscissae?)")
}

/// A square band matrix with room for the fill-in of partial pivoting.
/// Row r stores absolute columns r−kl … r+kl+ku.
struct Band {
    n: usize,
    kl: usize,
    ku: usize,
    w: usize,
    data: Vec<f64>,
    /// Pivot row of each column and the multipliers (kl per column).
    piv: Vec<usize>,
    mult: Vec<f64>,
}

impl Band {
    fn new(n: usize, kl: usize, ku: usize) -> Band {
        let w = 2 * kl + ku + 1;
        Band {
            n,
            kl,
            ku,
            w,
            data: vec![0.0; n * w],
            piv: Vec::new(),
            mult: Vec::new(),
        }
    }
    #[inline]
    fn idx(&self, r: usize, c: usize) -> usize {
        debug_assert!(c + self.kl >= r && c <= r + self.kl + self.ku);
        r * self.w + (c + self.kl - r)
    }
    fn set(&mut self, r: usize, c: usize, v: f64) {
        let i = self.idx(r, c);
        self.data[i] = v;
    }
    fn get(&self, r: usize, c: usize) -> f64 {
        self.data[self.idx(r, c)]
    }

    /// LU factorisation with partial pivoting (row swaps in `piv`, the
    /// multipliers in `mult`); [`Band::apply`] then solves for any
    /// right-hand side with the operations a combined elimination would do.
    fn factor(&mut self) -> Result<()> {
        let n = self.n;
        let (kl, ku) = (self.kl, self.ku);
        let scale = self.data.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        self.piv = vec![0; n];
        self.mult = vec![0.0; n * kl];
        for p in 0..n {
            let last_row = (p + kl).min(n - 1);
            let last_col = (p + kl + ku).min(n - 1);
            let (mut piv, mut big) = (p, self.get(p, p).abs());
            for r in p + 1..=last_row {
                let v = self.get(r, p).abs();
                if v > big {
                    piv = r;
                    big = v;
                }
            }
            if big <= scale * 1e-14 || !big.is_finite() {
                return Err(singular());
            }
            self.piv[p] = piv;
            if piv != p {
                for c in p..=last_col {
                    let (i, j) = (self.idx(p, c), self.idx(piv, c));
                    self.data.swap(i, j);
                }
            }
            let d = self.get(p, p);
            for r in p + 1..=last_row {
                let l = self.get(r, p) / d;
                self.mult[p * kl + (r - p - 1)] = l;
                if l == 0.0 {
                    continue;
                }
                for c in p..=last_col {
                    let v = self.get(p, c);
                    let i = self.idx(r, c);
                    self.data[i] -= l * v;
                }
            }
        }
        Ok(())
    }

    /// Solve with the factors of [`Band::factor`]; `b` is overwritten with
    /// the solution.
    fn apply(&self, b: &mut [f64]) {
        let mut one: Vec<[f64; 1]> = b.iter().map(|&v| [v]).collect();
        self.apply_lanes(&mut one);
        for (v, o) in b.iter_mut().zip(&one) {
            *v = o[0];
        }
    }

    /// [`Band::apply`] for L right-hand sides at once (`b[i][lane]`): each
    /// lane gets exactly the operations of its own solve, but the L
    /// dependency chains of the substitutions overlap in the processor.
    /// (Rows of U are contiguous: `idx(p, p + j)` = p·w + kl + j.)
    fn apply_lanes<const L: usize>(&self, b: &mut [[f64; L]]) {
        let n = self.n;
        let (kl, ku, w) = (self.kl, self.ku, self.w);
        for p in 0..n {
            let q = self.piv[p];
            if q != p {
                b.swap(p, q);
            }
            let last_row = (p + kl).min(n - 1);
            let bp = b[p];
            let mult = &self.mult[p * kl..p * kl + (last_row - p)];
            for (br, &l) in b[p + 1..=last_row].iter_mut().zip(mult) {
                if l == 0.0 {
                    continue;
                }
                for (v, vp) in br.iter_mut().zip(&bp) {
                    *v -= l * vp;
                }
            }
        }
        for p in (0..n).rev() {
            let last_col = (p + kl + ku).min(n - 1);
            let row = &self.data[p * w + kl..=p * w + kl + (last_col - p)];
            let mut s = b[p];
            for (u, bc) in row[1..].iter().zip(&b[p + 1..=last_col]) {
                for (v, vc) in s.iter_mut().zip(bc) {
                    *v -= u * vc;
                }
            }
            for (v, sv) in b[p].iter_mut().zip(&s) {
                *v = sv / row[0];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(t: f64) -> f64 {
        (2.0 * std::f64::consts::PI * t).sin() + 0.3 * t.powi(3)
    }

    /// Derivative of order `d` at `x` of the polynomial piece stored in
    /// segment `si` (segment i+1 covers [x_i, x_{i+1}]), evaluated
    /// directly from its Taylor coefficients — used to compare the two
    /// pieces meeting at a knot.
    fn piece_derivative(s: &GcvSpline, si: usize, x: f64, d: usize) -> f64 {
        let base = if si == 0 { s.x[0] } else { s.x[si - 1] };
        let t = x - base;
        (d..=s.degree())
            .map(|j| s.segment(si)[j] * falling(j, d) * t.powi((j - d) as i32))
            .sum()
    }

    /// Small xorshift generator (deterministic).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The elimination as it was before [`Band::factor`] / [`Band::apply`]
    /// were split: matrix and right-hand side in one pass.
    fn solve_combined(a: &mut Band, b: &mut [f64]) -> Result<()> {
        let n = a.n;
        let (kl, ku) = (a.kl, a.ku);
        let scale = a.data.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for p in 0..n {
            let last_row = (p + kl).min(n - 1);
            let last_col = (p + kl + ku).min(n - 1);
            let (mut piv, mut big) = (p, a.get(p, p).abs());
            for r in p + 1..=last_row {
                let v = a.get(r, p).abs();
                if v > big {
                    piv = r;
                    big = v;
                }
            }
            if big <= scale * 1e-14 || !big.is_finite() {
                return Err(singular());
            }
            if piv != p {
                for c in p..=last_col {
                    let (i, j) = (a.idx(p, c), a.idx(piv, c));
                    a.data.swap(i, j);
                }
                b.swap(p, piv);
            }
            let d = a.get(p, p);
            for r in p + 1..=last_row {
                let l = a.get(r, p) / d;
                if l == 0.0 {
                    continue;
                }
                for c in p..=last_col {
                    let v = a.get(p, c);
                    let i = a.idx(r, c);
                    a.data[i] -= l * v;
                }
                b[r] -= l * b[p];
            }
        }
        for p in (0..n).rev() {
            let last_col = (p + kl + ku).min(n - 1);
            let mut s = b[p];
            for c in p + 1..=last_col {
                s -= a.get(p, c) * b[c];
            }
            b[p] = s / a.get(p, p);
        }
        Ok(())
    }

    /// The Taylor segments as they were made before they became lazy: all of
    /// them, eagerly.
    fn eager_segments(s: &GcvSpline) -> Vec<[f64; MAX_COEF]> {
        let (m, x, y) = (s.half_order, &s.x, &s.y);
        let n = x.len();
        let k = 2 * m - 1;
        let t = knot_vector(k, x);
        let mut interior = Vec::new();
        for i in 0..n - 1 {
            let mut a = taylor(&t, &s.coef, k, k + i, x[i], k);
            a[0] = y[i];
            interior.push(a);
        }
        let mut left = interior[0];
        left[m..].iter_mut().for_each(|v| *v = 0.0);
        let mut right = taylor(&t, &s.coef, k, k + n - 2, x[n - 1], m - 1);
        right[0] = y[n - 1];
        let mut seg = vec![left];
        seg.extend(interior);
        seg.push(right);
        seg
    }

    /// Random abscissae (uniform, jittered, or storage-like time stamps) and
    /// data (smooth, noisy, constant, zero, with zero runs).
    fn random_cases() -> Vec<(usize, Vec<f64>, Vec<f64>)> {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut cases = Vec::new();
        for case in 0..240 {
            let degree: usize = [1, 3, 5, 7][case % 4];
            let n = 2 * degree.div_ceil(2) + (rng.next() * 60.0) as usize;
            let x: Vec<f64> = match case % 3 {
                0 => (0..n).map(|i| 0.59999926 + i as f64 * 0.01).collect(),
                1 => {
                    let mut t = rng.next() - 0.5;
                    (0..n)
                        .map(|_| {
                            t += 1e-3 + rng.next() * 0.05;
                            t
                        })
                        .collect()
                }
                _ => (0..n).map(|i| i as f64 / 600.0).collect(),
            };
            let y: Vec<f64> = match (case / 4) % 5 {
                0 => x.iter().map(|&t| (7.0 * t).sin() * 30.0).collect(),
                1 => (0..n).map(|_| rng.next() * 2.0 - 1.0).collect(),
                2 => vec![0.0; n],
                3 => vec![-1.25; n],
                _ => (0..n)
                    .map(|i| if i % 9 < 4 { 0.0 } else { rng.next() - 0.5 })
                    .collect(),
            };
            cases.push((degree, x, y));
        }
        cases
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    /// Factored once and applied per column = the one-pass elimination, bit
    /// for bit; lazy segments = eager ones.
    #[test]
    fn factored_solve_and_lazy_segments_are_bit_identical() {
        for (degree, x, y) in random_cases() {
            let m = degree.div_ceil(2);
            let t = knot_vector(degree, &x);
            let mut want = rhs(m, &y);
            solve_combined(&mut system(m, &x, &t, None), &mut want).unwrap();
            let s = GcvSpline::interpolating(degree, &x, &y).unwrap();
            assert_eq!(bits(&s.coef), bits(&want), "degree {degree} n {}", x.len());
            let mut f = SplineFitter::new(degree, &x);
            let s2 = f.spline(&y).unwrap();
            assert_eq!(bits(&s2.coef), bits(&want));
            let eager = eager_segments(&s);
            for (i, e) in eager.iter().enumerate() {
                assert_eq!(bits(s.segment(i)), bits(e));
            }
        }
    }

    /// The splines of one fitter share one segment basis: a segment made
    /// from a basis another column made first (in any order, including the
    /// end segments) has the bits of that column's own eager segment.
    #[test]
    fn shared_segment_basis_gives_each_columns_own_segments() {
        for (degree, x, y) in random_cases().into_iter().step_by(7) {
            let n = x.len();
            let y2: Vec<f64> = y
                .iter()
                .enumerate()
                .map(|(i, v)| v * 0.5 - i as f64)
                .collect();
            let y3: Vec<f64> = y.iter().map(|v| (v * 3.0).cos()).collect();
            let mut f = SplineFitter::new(degree, &x);
            let mut ss = f.splines(&[&y, &y2, &y3]).unwrap();
            ss.push(f.spline(&y2).unwrap());
            assert!(ss.windows(2).all(|w| Arc::ptr_eq(&w[0].basis, &w[1].basis)));
            let eager: Vec<_> = ss.iter().map(eager_segments).collect();
            // interleave columns and visit segments backwards, then forwards
            let order: Vec<usize> = (0..=n).rev().chain(0..=n).collect();
            for (j, &seg) in order.iter().enumerate() {
                let c = (j + seg) % ss.len();
                assert_eq!(bits(ss[c].segment(seg)), bits(&eager[c][seg]));
            }
            for (s, e) in ss.iter().zip(&eager) {
                for (i, ei) in e.iter().enumerate() {
                    assert_eq!(bits(s.segment(i)), bits(ei), "degree {degree} n {n}");
                }
            }
        }
    }

    /// `value_transient` = `value` bit for bit, on fresh splines (segments
    /// made for the call and dropped) and on splines whose segments are
    /// kept; it keeps none itself.
    #[test]
    fn value_transient_is_value_and_keeps_no_segment() {
        for (degree, x, y) in random_cases().into_iter().step_by(3) {
            let n = x.len();
            let (lo, hi) = (x[0] - 0.3, x[n - 1] + 0.3);
            let ts: Vec<f64> = (0..=97)
                .map(|i| lo + (hi - lo) * i as f64 / 97.0)
                .chain(x.iter().copied())
                .collect();
            let mut f = SplineFitter::new(degree, &x);
            let fresh = f.spline(&y).unwrap();
            let kept = f.spline(&y).unwrap();
            // A spline of another fitter: no basis kept either.
            let lone = SplineFitter::new(degree, &x).spline(&y).unwrap();
            for &t in &ts {
                let want = kept.value(t);
                assert_eq!(fresh.value_transient(t).to_bits(), want.to_bits(), "t {t}");
                assert_eq!(kept.value_transient(t).to_bits(), want.to_bits(), "t {t}");
                assert_eq!(lone.value_transient(t).to_bits(), want.to_bits(), "t {t}");
            }
            // Through one cache, two splines of one fitter at each time
            // (the first computes the basis, the second reuses it), and a
            // spline of another fitter (whose key differs).
            let other = SplineFitter::new(degree, &x).spline(&y).unwrap();
            let mut cache = TransientBasis::default();
            for &t in &ts {
                let want = kept.value(t).to_bits();
                for sp in [&lone, &fresh, &other, &lone] {
                    assert_eq!(
                        sp.value_transient_with(t, &mut cache).to_bits(),
                        want,
                        "t {t}"
                    );
                }
            }
            assert!(fresh.seg.iter().all(|s| s.get().is_none()));
            assert!(lone.seg.iter().all(|s| s.get().is_none()));
            assert!(lone.basis.seg.iter().all(|s| s.get().is_none()));
        }
    }

    /// `knot_slopes` = `interpolating(..).derivative(x_i, 1)` bit for bit,
    /// with one fitter shared by several columns, and the same errors.
    #[test]
    fn knot_slopes_are_bit_identical() {
        let mut zeros = 0;
        for (degree, x, y) in random_cases() {
            let s = GcvSpline::interpolating(degree, &x, &y).unwrap();
            let want: Vec<f64> = x.iter().map(|&xi| s.derivative(xi, 1)).collect();
            zeros += want.iter().filter(|v| **v == 0.0).count();
            let got = GcvSpline::knot_slopes(degree, &x, &y).unwrap();
            assert_eq!(bits(&got), bits(&want), "degree {degree} n {}", x.len());
            let mut f = SplineFitter::new(degree, &x);
            let mut out = Vec::new();
            for scale in [1.0, -3.0, 0.0] {
                let ys: Vec<f64> = y.iter().map(|v| v * scale).collect();
                let s = GcvSpline::interpolating(degree, &x, &ys).unwrap();
                let want: Vec<f64> = x.iter().map(|&xi| s.derivative(xi, 1)).collect();
                f.knot_slopes(&ys, &mut out).unwrap();
                assert_eq!(bits(&out), bits(&want));
            }
        }
        assert!(zeros > 0, "the zero-slope path was not exercised");
        // several columns at once (8, then 4 at a time, a partial last
        // group), on one thread and split over a pool of three (19 and 37
        // columns: halves of 12 + 7, and 20 + 17 split again)
        let pools: Vec<rayon::ThreadPool> = [1, 3]
            .iter()
            .map(|&n| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .unwrap()
            })
            .collect();
        for (case, (degree, x, y)) in random_cases().into_iter().take(40).enumerate() {
            let ncol = if case % 2 == 0 { 19 } else { 37 };
            let cols: Vec<Vec<f64>> = (0..ncol)
                .map(|c| y.iter().map(|v| v * (c as f64 - 2.5)).collect())
                .collect();
            let ys: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
            let outs: Vec<Vec<Vec<f64>>> = pools
                .iter()
                .map(|pool| {
                    pool.install(|| {
                        let mut f = SplineFitter::new(degree, &x);
                        let mut out = Vec::new();
                        f.knot_slopes_columns(&ys, &mut out).unwrap();
                        out
                    })
                })
                .collect();
            let splines = SplineFitter::new(degree, &x).splines(&ys).unwrap();
            for (c, y) in ys.iter().enumerate() {
                let s = GcvSpline::interpolating(degree, &x, y).unwrap();
                let want: Vec<f64> = x.iter().map(|&xi| s.derivative(xi, 1)).collect();
                for out in &outs {
                    assert_eq!(bits(&out[c]), bits(&want), "column {c} of {ncol}");
                }
                assert_eq!(bits(&splines[c].coef), bits(&s.coef));
            }
        }
        // errors: the data checks per column, then the singular system
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let mut f = SplineFitter::new(5, &x);
        let mut out = Vec::new();
        for y in [&[1.0; 5][..], &[0.0, 1.0, f64::NAN, 0.0, 0.0, 0.0]] {
            let want = GcvSpline::interpolating(5, &x, y).unwrap_err().to_string();
            let got = f.knot_slopes(y, &mut out).unwrap_err().to_string();
            assert_eq!(got, want);
        }
        let ok = [0.0; 6];
        let nan = [0.0, 1.0, f64::NAN, 0.0, 0.0, 0.0];
        // after a good column (x checked), the y checks alone
        let mut f = SplineFitter::new(5, &x);
        f.knot_slopes(&ok, &mut out).unwrap();
        for y in [&[1.0; 5][..], &[1.0; 7], &nan, &[f64::INFINITY; 6]] {
            let want = GcvSpline::interpolating(5, &x, y).unwrap_err().to_string();
            assert_eq!(f.knot_slopes(y, &mut out).unwrap_err().to_string(), want);
            assert_eq!(f.spline(y).unwrap_err().to_string(), want);
        }
        let e = SplineFitter::new(5, &x)
            .knot_slopes_columns(&[&ok, &ok, &nan, &[1.0; 5]], &mut Vec::new())
            .unwrap_err();
        assert_eq!(e.0, 2);
        assert!(e.1.to_string().contains("y[2] is not a finite"), "{}", e.1);
        let bad = [0.0, 1.0, 1.0, 2.0, 3.0, 4.0];
        let want = GcvSpline::interpolating(5, &bad, &[0.0; 6])
            .unwrap_err()
            .to_string();
        let got = GcvSpline::knot_slopes(5, &bad, &[0.0; 6])
            .unwrap_err()
            .to_string();
        assert_eq!(got, want);
    }

    #[test]
    fn opensim_46_double_splining_example() {
        // opensim-semantics.md §6.3 (OpenSim 4.6): q = sin 2πt + 0.3t³ at
        // t = k/20. Also reproduced with the 4.6 venv: GCVSpline XML with
        // half_order 3, error_variance 0 loaded by
        // opensim.OpenSimObject.makeObjectFromFile, calcDerivative([0,0], t):
        // S_q''(0) = -8.097650734633703, S_u'(0) = -5.75735504217664,
        // S_q''(0.05) = -10.95737007403919, S_u'(0.05) = -12.121769565770084,
        // S_q''(1) = 9.897650734633043, S_u'(1) = 7.557355042175499.
        let t: Vec<f64> = (0..21).map(|k| k as f64 / 20.0).collect();
        let y: Vec<f64> = t.iter().map(|&t| q(t)).collect();
        let sq = GcvSpline::interpolating(5, &t, &y).unwrap();
        let u: Vec<f64> = t.iter().map(|&t| sq.derivative(t, 1)).collect();
        let su = GcvSpline::interpolating(5, &t, &u).unwrap();
        let cases = [
            (sq.derivative(0.0, 2), -8.097650734633703),
            (su.derivative(0.0, 1), -5.75735504217664),
            (sq.derivative(0.05, 2), -10.95737007403919),
            (su.derivative(0.05, 1), -12.121769565770084),
            (sq.derivative(1.0, 2), 9.897650734633043),
            (su.derivative(1.0, 1), 7.557355042175499),
        ];
        for (i, (got, want)) in cases.iter().enumerate() {
            assert!((got - want).abs() < 1e-8, "case {i}: {got} vs {want}");
        }
        // printed digits of the doc
        assert_eq!(format!("{:.3}", su.derivative(0.0, 1)), "-5.757");
        assert_eq!(format!("{:.3}", sq.derivative(0.0, 2)), "-8.098");
    }

    #[test]
    fn interpolates_and_natural_end_conditions() {
        // non-uniform abscissae shaped like storage time stamps
        let x: Vec<f64> = (0..40)
            .map(|i| 0.59999926 + 0.01 * i as f64 + 0.0031 * ((i * 7 % 5) as f64))
            .collect();
        let y: Vec<f64> = x.iter().map(|&t| (3.0 * t).cos() + t * t).collect();
        for deg in [1usize, 3, 5, 7] {
            let s = GcvSpline::interpolating(deg, &x, &y).unwrap();
            let m = deg.div_ceil(2);
            for (xi, yi) in x.iter().zip(&y) {
                assert!((s.value(*xi) - yi).abs() < 1e-12, "deg {deg}");
            }
            let n = x.len();
            // High derivatives are compared in units of the mean spacing
            // (f^(j)·h̄^j): their round-off grows like h^-j and with the
            // spacing ratio (~23 here), so absolute zeros are not expected.
            let hbar = (x[n - 1] - x[0]) / (n - 1) as f64;
            let scaled = |v: f64, j: usize| v * hbar.powi(j as i32);
            for j in m..=(2 * m).saturating_sub(2) {
                for &xe in &[x[0], x[n - 1]] {
                    let v = scaled(s.derivative(xe, j), j);
                    assert!(v.abs() < 1e-10, "deg {deg} j {j} at {xe}: {v}");
                }
            }
            // C^(2m-2) at interior knots: the pieces of [x_{i-1}, x_i]
            // (segment i) and [x_i, x_{i+1}] (segment i+1) agree at x_i
            for i in 1..n - 1 {
                for j in 0..=(2 * m - 2) {
                    let l = scaled(piece_derivative(&s, i, x[i], j), j);
                    let r = scaled(piece_derivative(&s, i + 1, x[i], j), j);
                    assert!(
                        (l - r).abs() < 1e-10,
                        "deg {deg} j {j} at {}: {l} vs {r}",
                        x[i]
                    );
                }
            }
            // derivatives of order >= 2m are 0
            assert_eq!(s.derivative(x[3] + 0.001, 2 * m), 0.0);
        }
    }

    #[test]
    fn reproduces_polynomials_below_m() {
        let x: Vec<f64> = (0..12).map(|i| (i as f64).powf(1.3) * 0.1).collect();
        // quadratic is reproduced by the quintic (m = 3) and septic (m = 4)
        let p = |t: f64| 2.0 - 1.5 * t + 0.7 * t * t;
        let y: Vec<f64> = x.iter().map(|&t| p(t)).collect();
        for deg in [5usize, 7] {
            let s = GcvSpline::interpolating(deg, &x, &y).unwrap();
            for i in 0..50 {
                let t = -0.5 + i as f64 * 0.05;
                assert!((s.value(t) - p(t)).abs() < 1e-11);
                assert!((s.derivative(t, 1) - (-1.5 + 1.4 * t)).abs() < 1e-10);
                assert!((s.derivative(t, 2) - 1.4).abs() < 1e-9);
            }
        }
        // cubic: lines are reproduced
        let y: Vec<f64> = x.iter().map(|&t| 3.0 * t - 1.0).collect();
        let s = GcvSpline::interpolating(3, &x, &y).unwrap();
        assert!((s.value(0.123) - (3.0 * 0.123 - 1.0)).abs() < 1e-12);
    }

    #[test]
    fn extrapolation_is_degree_m_minus_1_taylor() {
        let x: Vec<f64> = (0..10).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = x.iter().map(|&t| (5.0 * t).sin()).collect();
        let s = GcvSpline::interpolating(5, &x, &y).unwrap();
        let (f0, d0, dd0) = s.eval2(0.0);
        for dx in [-0.3, -0.05] {
            let want = f0 + d0 * dx + 0.5 * dd0 * dx * dx;
            assert!((s.value(dx) - want).abs() < 1e-12);
            assert!((s.derivative(dx, 2) - dd0).abs() < 1e-12);
            assert_eq!(s.derivative(dx, 3), 0.0);
        }
        let xe = 0.9;
        let (f1, d1, dd1) = s.eval2(xe);
        let dx = 0.2;
        let want = f1 + d1 * dx + 0.5 * dd1 * dx * dx;
        assert!((s.value(xe + dx) - want).abs() < 1e-12);
        // cubic extrapolates linearly
        let c = GcvSpline::interpolating(3, &x, &y).unwrap();
        assert_eq!(c.derivative(-1.0, 2), 0.0);
        assert!((c.derivative(-1.0, 1) - c.derivative(0.0, 1)).abs() < 1e-12);
    }

    #[test]
    fn eval2_matches_derivative() {
        let x: Vec<f64> = (0..15)
            .map(|i| i as f64 * 0.07 + 0.01 * (i % 3) as f64)
            .collect();
        let y: Vec<f64> = x.iter().map(|&t| t.exp().sin()).collect();
        let s = GcvSpline::interpolating(5, &x, &y).unwrap();
        for i in 0..60 {
            let t = -0.2 + i as f64 * 0.02;
            let (a, b, c) = s.eval2(t);
            assert!((a - s.value(t)).abs() < 1e-13);
            assert!((b - s.derivative(t, 1)).abs() < 1e-11);
            assert!((c - s.derivative(t, 2)).abs() < 1e-9);
        }
    }

    #[test]
    fn errors() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0];
        let y = [0.0; 5];
        let e = GcvSpline::interpolating(5, &x, &y).unwrap_err();
        assert!(e.to_string().contains("Too few data points"), "{e}");
        assert!(GcvSpline::interpolating(3, &[0.0, 1.0, 1.0, 2.0], &[0.0; 4]).is_err());
        assert!(GcvSpline::interpolating(4, &x, &y).is_err());
        assert!(GcvSpline::interpolating(3, &x, &y[..4]).is_err());
        assert!(GcvSpline::interpolating(1, &[0.0, f64::NAN], &[0.0, 1.0]).is_err());
        // minimum sizes work
        assert!(GcvSpline::interpolating(5, &[0., 1., 2., 3., 4., 5.], &[1.; 6]).is_ok());
        assert!(GcvSpline::interpolating(1, &[0., 1.], &[1., 3.]).is_ok());
    }

    #[test]
    fn large_series_is_fast_and_accurate() {
        let n = 2000;
        let x: Vec<f64> = (0..n).map(|i| 0.59999926 + i as f64 / 120.0).collect();
        let y: Vec<f64> = x.iter().map(|&t| q(t)).collect();
        let start = std::time::Instant::now();
        let s = GcvSpline::interpolating(5, &x, &y).unwrap();
        let el = start.elapsed();
        eprintln!("n = {n} quintic build: {el:?}");
        // generous bound: opt-level 1 test profile, shared CPUs
        assert!(el.as_millis() < 200, "took {el:?}");
        for i in (0..n).step_by(97) {
            assert!((s.value(x[i]) - y[i]).abs() < 1e-12);
        }
        // interior derivative close to the true one
        let tm = x[n / 2] + 0.003;
        let dq =
            2.0 * std::f64::consts::PI * (2.0 * std::f64::consts::PI * tm).cos() + 0.9 * tm * tm;
        assert!((s.derivative(tm, 1) - dq).abs() < 1e-6);
    }
}
