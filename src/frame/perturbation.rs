//! Static optimization's constraint matrix by unit perturbation through
//! forward dynamics (Krüger & Wartzack 2017 eq. 14; what OpenSim's
//! `StaticOptimizationTarget` does): for each optimisation variable i, the
//! generalized force it applies at unit control (a muscle at unit activation
//! × its force scale, a contact multiplier at 1) is added to the frame's
//! loads and the model's accelerations are solved for; column i is
//! u̇_i − u̇_0 and the right-hand side u̇_target − u̇_0, where u̇_0 is forward
//! dynamics with every variable at 0.
//!
//! Forward dynamics honours the model's constraints exactly as the analytic
//! rows do (`SoProblem::frame_problem`): with C = [C_k] the coupling vectors
//! of the free coordinates k (`paths::coupling`), u̇ = C u̇_I + ċ, ċ the
//! accelerations of the constrained coordinates when the free ones have
//! none (coupler curvature, prescribed functions, locks). Projecting the
//! equations of motion on C gives
//! M_r u̇_I = Cᵀ (τ_applied − τ_0), M_r = Cᵀ M C,
//! τ_0 = M ċ + bias − loads, the inverse dynamics at u̇ = ċ (RNEA).
//!
//! Every column is a whole forward-dynamics solve — kinematics, external and
//! passive loads, RNEA for the bias, the mass matrix, a Cholesky
//! factorisation of M_r — with no factorisation shared between columns: the
//! point of this path is to measure that method's cost
//! (`statopt-tool bench --grid`). In exact arithmetic A_pert = M_r⁻¹ A_analytic
//! and b_pert = M_r⁻¹ b_analytic, so both give the same solution.

use nalgebra::{DMatrix, DVector};

use crate::dynamics::{kinematics, rnea, Data};
use crate::frame::problem::SoProblem;
use crate::model::Model;
use crate::muscles::set::MuscleFrame;

/// One frame's forward-dynamics state: the target and zero-variable
/// accelerations and the constraint basis.
pub struct Perturbation {
    /// Target accelerations of every coordinate (constraint-consistent), as
    /// set before the perturbations; restored by [`finish`](Self::finish).
    pub target: Vec<f64>,
    /// Accelerations of the constrained coordinates with the free ones at 0.
    udot_c: Vec<f64>,
    /// C (nq × n_free), dense.
    c: DMatrix<f64>,
    /// u̇_I with every variable at 0.
    pub udot0: DVector<f64>,
    /// M_r of the zero-variable solve.
    m_r: DMatrix<f64>,
}

impl Perturbation {
    /// Save the frame's target accelerations (in `data.udot`) and solve the
    /// zero-variable forward dynamics.
    pub fn start(
        problem: &SoProblem,
        t: f64,
        data: &mut Data,
        mf: &MuscleFrame,
        couplings: &[Vec<(usize, f64)>],
    ) -> Perturbation {
        let model = &problem.model;
        let nq = model.nq();
        let target = data.udot.clone();
        let mut udot_c = vec![0.0; nq];
        crate::dynamics::forward::constrained_accelerations(
            model,
            &data.q,
            &data.u,
            t,
            &mut udot_c,
        );
        let mut c = DMatrix::zeros(nq, couplings.len());
        for (r, cv) in couplings.iter().enumerate() {
            for &(i, v) in cv {
                c[(i, r)] += v;
            }
        }
        let mut p = Perturbation {
            target,
            udot_c,
            c,
            udot0: DVector::zeros(couplings.len()),
            m_r: DMatrix::zeros(0, 0),
        };
        let (udot0, m_r) = p.forward(problem, t, data, mf, &[], 0.0);
        p.udot0 = udot0;
        p.m_r = m_r;
        p
    }

    /// Column of a variable applying `scale × gen` (generalized forces, all
    /// coordinates): u̇_I(gen) − u̇_0, by a full forward-dynamics solve.
    pub fn column(
        &self,
        problem: &SoProblem,
        t: f64,
        data: &mut Data,
        mf: &MuscleFrame,
        gen: &[f64],
        scale: f64,
    ) -> DVector<f64> {
        let (udot, _) = self.forward(problem, t, data, mf, gen, scale);
        udot - &self.udot0
    }

    /// Forward dynamics of the free coordinates with the frame's loads plus
    /// `scale × gen`; returns u̇_I and M_r.
    fn forward(
        &self,
        problem: &SoProblem,
        t: f64,
        data: &mut Data,
        mf: &MuscleFrame,
        gen: &[f64],
        scale: f64,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let model = &problem.model;
        let nq = model.nq();
        data.udot.copy_from_slice(&self.udot_c);
        kinematics::full(model, data);
        data.clear_applied();
        if let Some(l) = &problem.loads {
            l.apply(t, data);
        }
        let mut g = vec![0.0; nq];
        problem.add_passive_forces(t, data, &mut g, None);
        problem.add_passive_fiber_forces(data, mf);
        for (k, x) in gen.iter().enumerate() {
            data.applied_gen[k] += scale * x;
        }
        // τ_0 = M ċ + bias − loads − scale·gen.
        rnea::inverse_dynamics_after_kinematics(model, data, true);
        let (y, m_r) = crate::dynamics::forward::free_accelerations(model, data, &self.c);
        // Singular M_r (e.g. massless chains): NaN, so that the solver
        // reports the frame as failed.
        let udot = y.unwrap_or_else(|| DVector::from_element(self.c.ncols(), f64::NAN));
        (udot, m_r)
    }

    /// Leave `data` as the analytic path does (kinematics at the target
    /// accelerations); returns M_r.
    pub fn finish(self, model: &Model, data: &mut Data) -> DMatrix<f64> {
        data.udot.copy_from_slice(&self.target);
        kinematics::full(model, data);
        self.m_r
    }
}
