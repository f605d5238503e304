//! Candidates that differ from a compiled problem only in forces: one
//! frame assembled once ([`SoProblem::assemble`]: kinematics, muscle paths
//! and strength, contacts, the equations A x = b), then solved for every
//! candidate ([`SoProblem::solve_candidate_into`]).
//!
//! What a candidate may change, and where it enters the frame's program:
//! - **w0**: the contact multipliers' objective weights 1/w0;
//! - **a passive force** (an `ExpressionBasedCoordinateForce`'s expression,
//!   any passive force element replaced by another of the same record
//!   size): its generalized force Δg changes the right-hand side,
//!   b = Cᵀ(τ_ID − g_applied), so b_c = b − Cᵀ Δg; its record values
//!   change the force table's row;
//! - **an actuator's optimal force** (not a muscle's): the scale f_i of its
//!   column of A and of its force x_i f_i.
//!
//! Everything else (the motion and its contact closure, kinematics, muscle
//! geometry and strength, moment arms, contact states, A) is the frame's,
//! shared by every candidate. The answers are those of a run of the
//! candidate's own setup up to rounding (b is formed as a difference, A's
//! column rescaled), whatever warm start the caller gives
//! (`optimize::solve_into`).

use nalgebra::DVector;

use crate::forces::passive::PassiveForce;
use crate::frame::problem::{Control, FrameResult, SoProblem};
use crate::frame::workspace::Workspace;
use crate::optimize;

/// One candidate: what differs from the compiled problem.
#[derive(Debug, Clone, Default)]
pub struct ForceCandidate {
    /// The contact weight.
    pub w0: f64,
    /// Passive forces replaced: (index into `SoProblem::passive`, the
    /// replacement, with the same record size).
    pub passive: Vec<(usize, PassiveForce)>,
    /// Actuators' optimal forces: (control index, optimal force); muscles
    /// are not allowed.
    pub optimal_force: Vec<(usize, f64)>,
}

/// A frame's shared part and per-candidate buffers (per thread).
#[derive(Debug, Clone, Default)]
pub struct CandidateScratch {
    /// The frame's right-hand side and passive record values as assembled.
    b0: DVector<f64>,
    passive0: Vec<f64>,
    /// Where each passive force's record values start in `passive0`.
    record_start: Vec<usize>,
    /// The candidate's change of generalized forces (nq), and a scratch.
    pub dg: Vec<f64>,
    g: Vec<f64>,
    record: Vec<f64>,
    /// Columns of A saved while an optimal force is changed.
    saved: Vec<(usize, Vec<f64>, f64)>,
}

impl SoProblem {
    /// Keep the frame just assembled in `ws` (by [`SoProblem::assemble`])
    /// as the base every candidate of the frame starts from.
    pub fn begin_candidates(&self, ws: &Workspace, scratch: &mut CandidateScratch) {
        let asm = &ws.assembly;
        scratch.b0.clone_from(&asm.problem.b);
        scratch.passive0.clone_from(&asm.passive);
        scratch.record_start.clear();
        let mut k = 0;
        for p in &self.passive {
            scratch.record_start.push(k);
            k += p.record_size();
        }
        let nq = self.model.nq();
        scratch.dg.resize(nq, 0.0);
        scratch.g.resize(nq, 0.0);
    }

    /// Solve the frame kept by [`begin_candidates`](Self::begin_candidates)
    /// for `cand`, from the multipliers `y0` when given, into `out` (the
    /// frame's outputs as [`SoProblem::solve_frame_into`] makes them for a
    /// run of the candidate's setup). Leaves the candidate's generalized
    /// force change in `scratch.dg` (for its joint reactions); the frame in
    /// `ws` is left as it was assembled.
    pub fn solve_candidate_into(
        &self,
        t: f64,
        ws: &mut Workspace,
        cand: &ForceCandidate,
        y0: Option<&[f64]>,
        scratch: &mut CandidateScratch,
        out: &mut FrameResult,
    ) {
        let Workspace {
            data,
            muscles: mf,
            assembly: asm,
            ..
        } = ws;
        let model = &self.model;
        let nv = self.controls.len();
        // Right-hand side: b − Cᵀ Δg.
        scratch.dg.iter_mut().for_each(|x| *x = 0.0);
        asm.passive.clone_from(&scratch.passive0);
        for (j, pf) in &cand.passive {
            let g = &mut scratch.g;
            g.iter_mut().for_each(|x| *x = 0.0);
            pf.add_generalized_force(model, data, t, g);
            for (d, x) in scratch.dg.iter_mut().zip(g.iter()) {
                *d += x;
            }
            g.iter_mut().for_each(|x| *x = 0.0);
            self.passive[*j].add_generalized_force(model, data, t, g);
            for (d, x) in scratch.dg.iter_mut().zip(g.iter()) {
                *d -= x;
            }
            scratch.record.clear();
            pf.record_values_into(data, t, &mut scratch.record);
            let k = scratch.record_start[*j];
            let n = scratch
                .record
                .len()
                .min(asm.passive.len().saturating_sub(k));
            asm.passive[k..k + n].copy_from_slice(&scratch.record[..n]);
        }
        asm.problem.b.copy_from(&scratch.b0);
        if !cand.passive.is_empty() {
            for (r, cv) in asm.couplings.iter().enumerate() {
                let d: f64 = cv.iter().map(|(i, c)| c * scratch.dg[*i]).sum();
                asm.problem.b[r] -= d;
            }
        }
        // Weights: the contact multipliers follow the controls (knee
        // compartments, refused in sweeps today, would keep weight 1).
        let nc3 = 3 * self.contacts.len();
        asm.problem.weights[nv..nv + nc3]
            .iter_mut()
            .for_each(|w| *w = 1.0 / cand.w0);
        // Optimal forces: the column and the scale.
        scratch.saved.clear();
        for &(v, f) in &cand.optimal_force {
            if !matches!(self.controls.get(v), Some(Control::Actuator(_))) {
                continue;
            }
            let f0 = asm.scale[v];
            let mut col = asm.problem.a.column_mut(v);
            scratch.saved.push((v, col.iter().copied().collect(), f0));
            if f0 != 0.0 {
                col.iter_mut().for_each(|x| *x = *x / f0 * f);
            }
            asm.scale[v] = f;
        }
        optimize::solve_into(&asm.problem, y0, &mut out.solution);
        self.frame_result_into(t, asm, None, data, mf, out);
        for (v, col, f0) in scratch.saved.drain(..) {
            asm.problem.a.column_mut(v).copy_from_slice(&col);
            asm.scale[v] = f0;
        }
        asm.passive.clone_from(&scratch.passive0);
        asm.problem.b.copy_from(&scratch.b0);
    }
}
