//! Coupling vectors: how all generalized speeds move when one coordinate
//! moves, under the model's coupler constraints (OpenSim's MomentArmSolver,
//! opensim-semantics.md §5.3). The moment arm of a path about coordinate k
//! is `C_kᵀ f`, f the generalized force of a unit tension; the same vectors
//! reduce the equations of motion to the independent coordinates.

use crate::model::Model;

/// For coordinate `k`, the sparse coupling vector C (pairs of speed index
/// and coefficient) at the coordinate values `q`.
///
/// - k independent: C = e_k + Σ over its dependents d of s_d f_d'(q_k) e_d;
/// - k dependent on i: the constraint-consistent velocity direction w of i,
///   scaled so that its k-th entry is 1 (w / w_k), which is what projecting
///   a unit speed of k onto the constraints gives.
///
/// Locked or prescribed coordinates other than k get no entry (their speed is
/// held at zero).
pub fn coupling_vector(model: &Model, q: &[f64], k: usize) -> Vec<(usize, f64)> {
    let mut w = Vec::new();
    coupling_vector_into(model, q, k, &mut w);
    w
}

/// [`coupling_vector`] into `w` (cleared first), reusing its allocation.
pub fn coupling_vector_into(model: &Model, q: &[f64], k: usize, w: &mut Vec<(usize, f64)>) {
    w.clear();
    let independent_of = |c: usize| {
        model
            .couplers
            .iter()
            .find(|cp| cp.dependent == c)
            .map(|cp| cp.independent[0])
    };
    let root = independent_of(k).unwrap_or(k);
    w.push((root, 1.0));
    for cp in &model.couplers {
        if cp.independent.first() == Some(&root) {
            let slope = cp.scale * cp.function.derivative(q[root], 1);
            w.push((cp.dependent, slope));
        }
    }
    if root != k {
        let wk = w
            .iter()
            .find(|(i, _)| *i == k)
            .map(|(_, v)| *v)
            .unwrap_or(0.0);
        if wk == 0.0 {
            // The dependent coordinate cannot move alone: no finite coupling.
            w.clear();
            w.push((k, 1.0));
            return;
        }
        for e in w.iter_mut() {
            e.1 /= wk;
        }
    }
}

/// `C_kᵀ f` for a dense generalized force `f`.
pub fn project(model: &Model, q: &[f64], k: usize, f: &[f64]) -> f64 {
    coupling_vector(model, q, k)
        .iter()
        .map(|(i, c)| c * f[*i])
        .sum()
}
