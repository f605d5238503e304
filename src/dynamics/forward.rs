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

use super::{mass_matrix, Data};
use crate::model::Model;

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
    let m = mass_matrix::mass_matrix(model, data);
    let m_r = c.transpose() * m * c;
    let rhs = -(c.transpose() * DVector::from_column_slice(&data.tau));
    let y = match m_r.clone().cholesky() {
        Some(ch) => Some(ch.solve(&rhs)),
        None => m_r.clone().lu().solve(&rhs),
    };
    (y, m_r)
}
