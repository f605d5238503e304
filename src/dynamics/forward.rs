//! Constrained forward dynamics, the one implementation joint reactions and
//! the perturbation constraint matrix share: the accelerations the applied
//! forces, gravity and velocity terms produce under the model's constraints
//! (locked and prescribed coordinates, coordinate couplers).
//!
//! With the free (unconstrained) coordinates' accelerations y, the
//! accelerations of every coordinate are u̇ = u̇_c + C y: u̇_c holds the
//! constrained coordinates' own accelerations with y = 0
//! ([`constrained_accelerations`]) and C (nq × n_free) the coupling vectors
//! of the free coordinates. Inverse dynamics at u̇_c gives the generalized
//! forces τ_c still to be supplied; y solves M_r y = −Cᵀ τ_c with the
//! reduced mass matrix M_r = Cᵀ M C ([`free_accelerations`]).
use nalgebra::{DMatrix, DVector};

use super::mass_matrix::{self, MassMatrixBuffers};
use super::Data;
use crate::model::Model;

/// The buffers of [`free_accelerations_in`] (kept in [`Data::forward`]):
/// a frame's forward dynamics allocates nothing once they have the model's
/// sizes.
#[derive(Debug, Clone)]
pub struct ForwardBuffers {
    /// M, and its buffers.
    m: DMatrix<f64>,
    mass: MassMatrixBuffers,
    /// Cᵀ M, and M_r = Cᵀ M C.
    ctm: DMatrix<f64>,
    pub m_r: DMatrix<f64>,
    /// M_r's Cholesky factor.
    factor: DMatrix<f64>,
    /// The free accelerations y.
    pub y: DVector<f64>,
    /// For callers (joint reactions): the free coordinates, their coupling
    /// vectors as the columns of C.
    pub free: Vec<usize>,
    pub coupling: DMatrix<f64>,
    pub coupling_vector: Vec<(usize, f64)>,
    /// What `m`, `ctm`, `m_r` and `factor` were computed for: the model (its
    /// address), the positions q and C. A call at the same key (a w0 sweep's
    /// joint reactions: one state, forces that differ) reuses them and only
    /// solves for y, bit for bit as rebuilding them would.
    key_model: usize,
    key_q: Vec<f64>,
    /// C's nonzeros (row, value), column by column, and where each column
    /// starts in that list.
    nonzeros: Vec<(usize, f64)>,
    column_start: Vec<usize>,
    key_c: DMatrix<f64>,
    /// `factor` holds M_r's Cholesky factor for the key.
    factored: bool,
}

impl Default for ForwardBuffers {
    fn default() -> Self {
        let empty = || DMatrix::zeros(0, 0);
        ForwardBuffers {
            m: empty(),
            mass: MassMatrixBuffers::default(),
            ctm: empty(),
            m_r: empty(),
            factor: empty(),
            y: DVector::zeros(0),
            free: Vec::new(),
            coupling: empty(),
            coupling_vector: Vec::new(),
            key_model: 0,
            key_q: Vec::new(),
            nonzeros: Vec::new(),
            column_start: Vec::new(),
            key_c: empty(),
            factored: false,
        }
    }
}

/// A buffer of `rows` × `cols` (reallocated only when its shape changes).
pub fn shaped(a: &mut DMatrix<f64>, rows: usize, cols: usize) {
    if a.shape() != (rows, cols) {
        *a = DMatrix::zeros(rows, cols);
    }
}

/// Accelerations of the constrained coordinates with every free
/// coordinate's acceleration 0, written into `udot` (which is zeroed first;
/// see [`complete_accelerations`]).
pub fn constrained_accelerations(model: &Model, q: &[f64], u: &[f64], t: f64, udot: &mut [f64]) {
    udot.iter_mut().for_each(|x| *x = 0.0);
    complete_accelerations(model, q, u, t, udot);
}

/// Given the free coordinates' accelerations in `udot`, set every
/// constrained coordinate's: a locked coordinate 0; a prescribed one its
/// function's second derivative at `t`; a coupler's dependent coordinate the
/// second time derivative of its coupler, f''(q_i) u_i² + f'(q_i) u̇_i, times
/// the coupler's scale (after the prescribed ones, so that a coupler driven
/// by a prescribed coordinate follows it).
pub fn complete_accelerations(model: &Model, q: &[f64], u: &[f64], t: f64, udot: &mut [f64]) {
    for (c, coord) in model.coordinates.iter().enumerate() {
        if coord.is_constrained() {
            udot[c] = match &coord.prescribed {
                Some(f) => f.derivative(t, 2),
                None => 0.0,
            };
        }
    }
    for cp in &model.couplers {
        if let Some(&i) = cp.independent.first() {
            let (_, d1, d2) = cp.function.eval2(q[i]);
            udot[cp.dependent] = cp.scale * (d2 * u[i] * u[i] + d1 * udot[i]);
        }
    }
}

/// The reduced mass matrix M_r = Cᵀ M C at the positions in `data`, and the
/// free accelerations y solving M_r y = −Cᵀ τ with τ = `data.tau` (the
/// generalized forces inverse dynamics left at the constrained-only
/// accelerations, applied forces included). y is None when M_r is singular
/// (a chain without mass or inertia): Cholesky first, LU when M_r is not
/// positive definite.
pub fn free_accelerations(
    model: &Model,
    data: &Data,
    c: &DMatrix<f64>,
) -> (Option<DVector<f64>>, DMatrix<f64>) {
    let mut buf = ForwardBuffers::default();
    let solved = free_accelerations_in(model, data, c, &mut buf);
    (solved.then_some(buf.y), buf.m_r)
}

/// [`free_accelerations`] into `buf.m_r` and `buf.y`; false when M_r is
/// singular. No allocation once the buffers have their sizes, except where
/// M_r is not positive definite (LU).
pub fn free_accelerations_in(
    model: &Model,
    data: &Data,
    c: &DMatrix<f64>,
    buf: &mut ForwardBuffers,
) -> bool {
    let (nq, nr) = c.shape();
    let model_key = model as *const Model as usize;
    if buf.factored
        && buf.key_model == model_key
        && same_bits(&buf.key_q, &data.q)
        && buf.key_c.shape() == c.shape()
        && same_bits(buf.key_c.as_slice(), c.as_slice())
    {
        // M, M_r and its factor depend on q (and C) alone: solve for y only.
        minus_ct_tau(c, data, &mut buf.y);
        let factor = std::mem::replace(&mut buf.factor, DMatrix::zeros(0, 0));
        let ch = nalgebra::Cholesky::pack_dirty(factor);
        ch.solve_mut(&mut buf.y);
        buf.factor = ch.unpack_dirty();
        return true;
    }
    buf.factored = false;
    mass_matrix::mass_matrix_into(model, data, &mut buf.m, &mut buf.mass);
    // The products by C skip its zeros (C holds one coupling vector per
    // column, mostly a single 1): each column's nonzeros listed once, in
    // ascending row order, so every sum adds the same terms in the same
    // order as a dense loop that skips zeros.
    buf.nonzeros.clear();
    buf.column_start.clear();
    for r in 0..nr {
        buf.column_start.push(buf.nonzeros.len());
        for k in 0..nq {
            let ckr = c[(k, r)];
            if ckr != 0.0 {
                buf.nonzeros.push((k, ckr));
            }
        }
    }
    buf.column_start.push(buf.nonzeros.len());
    let (nonzeros, starts) = (&buf.nonzeros, &buf.column_start);
    let column = |r: usize| &nonzeros[starts[r]..starts[r + 1]];
    shaped(&mut buf.ctm, nr, nq);
    for j in 0..nq {
        for r in 0..nr {
            let mut sum = 0.0;
            for &(k, ckr) in column(r) {
                sum += ckr * buf.m[(k, j)];
            }
            buf.ctm[(r, j)] = sum;
        }
    }
    shaped(&mut buf.m_r, nr, nr);
    for s in 0..nr {
        for r in 0..nr {
            let mut sum = 0.0;
            for &(k, cks) in column(s) {
                sum += buf.ctm[(r, k)] * cks;
            }
            buf.m_r[(r, s)] = sum;
        }
    }
    minus_ct_tau(c, data, &mut buf.y);
    shaped(&mut buf.factor, nr, nr);
    buf.factor.copy_from(&buf.m_r);
    let factor = std::mem::replace(&mut buf.factor, DMatrix::zeros(0, 0));
    match factor.cholesky() {
        Some(ch) => {
            ch.solve_mut(&mut buf.y);
            buf.factor = ch.unpack_dirty();
            buf.key_model = model_key;
            buf.key_q.clear();
            buf.key_q.extend_from_slice(&data.q);
            shaped(&mut buf.key_c, nq, nr);
            buf.key_c.copy_from(c);
            buf.factored = true;
            true
        }
        None => match buf.m_r.clone().lu().solve(&buf.y) {
            Some(y) => {
                buf.y = y;
                true
            }
            None => false,
        },
    }
}

/// y = −Cᵀ τ (τ = `data.tau`), skipping C's zeros.
pub(crate) fn minus_ct_tau(c: &DMatrix<f64>, data: &Data, y: &mut DVector<f64>) {
    let (nq, nr) = c.shape();
    if y.len() != nr {
        *y = DVector::zeros(nr);
    }
    for r in 0..nr {
        let mut sum = 0.0;
        for k in 0..nq {
            let ckr = c[(k, r)];
            if ckr != 0.0 {
                sum += ckr * data.tau[k];
            }
        }
        y[r] = -sum;
    }
}

/// `a` and `b` hold the same values bit for bit (−0 ≠ 0, a NaN never equal).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.to_bits() == y.to_bits() && !x.is_nan())
}
