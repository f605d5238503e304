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
//!   column of A and of its force x_i f_i;
//! - **an external load's scale** s (an `ExternalForce` of the setup's
//!   ExternalLoads, its force and torque data times s): its generalized
//!   force g_e = Jᵀ F_e enters b as a passive force's does, b_c = b −
//!   Cᵀ (s − 1) g_e, and the knee contact method's rows (affine in the loads
//!   on the bodies distal to the knee, `frame::knee_contact`) by the same
//!   (s − 1) times that load's share, precomputed once per frame; its
//!   force-table values (force and torque) scale by s.
//!
//! Everything else (the motion and its contact closure, kinematics, muscle
//! geometry and strength, moment arms, contact states, A) is the frame's,
//! shared by every candidate. The answers are those of a run of the
//! candidate's own setup up to rounding (b is formed as a difference, A's
//! column rescaled), whatever warm start the caller gives
//! (`optimize::solve_into`).

use nalgebra::DVector;

use crate::forces::passive::PassiveForce;
use crate::frame::problem::{Control, FrameResult, Outputs, SoProblem};
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
    /// Per ExternalForce of the problem's loads (in their order): the
    /// factor its force and torque data are scaled by; empty: all 1.
    pub external: Vec<f64>,
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
    /// The external loads' force-table values as assembled, and where each
    /// load's start.
    external0: Vec<f64>,
    external_start: Vec<usize>,
    /// Per external load: its generalized force Jᵀ F_e at the frame (nq).
    external_gen: Vec<Vec<f64>>,
    /// Per knee of the knee contact method and external load (knee-major):
    /// the load's part of the knee rows' right-hand sides (axial, frontal).
    knee_external: Vec<[f64; 2]>,
    /// Per external load: its spatial force and body at the frame (for the
    /// reaction bases).
    pub external_forces: Vec<(usize, crate::dynamics::BodyForce)>,
    /// Whether every entry of the frame's A is finite (checked once).
    a_finite: bool,
    /// Whether the frame's program is valid but for A's entries and b
    /// (checked once: a candidate changes b, A's scaled columns, which are
    /// checked with each, and the contact weights, 1/w0 with w0 in
    /// `CONTACT_WEIGHT_RANGE`).
    valid_but_a_b: bool,
    /// Per passive force of the problem: its generalized force at the
    /// frame, once a candidate replaced it (empty until then).
    passive_g0: Vec<Vec<f64>>,
    /// The frame's A as assembled, named for the solver
    /// (`optimize::solve_into_valid_keyed`): a candidate that scales no
    /// column solves this A.
    a_key: u64,
}

impl SoProblem {
    /// Keep the frame at time `t` just assembled in `ws` (by
    /// [`SoProblem::assemble`]) as the base every candidate of the frame
    /// starts from. Fails only as the external loads' evaluation does.
    pub fn begin_candidates(
        &self,
        t: f64,
        ws: &Workspace,
        scratch: &mut CandidateScratch,
    ) -> crate::error::Result<()> {
        let asm = &ws.assembly;
        scratch.a_key = optimize::fresh_a_key();
        scratch.a_finite = asm.problem.a.iter().all(|v| v.is_finite());
        scratch.valid_but_a_b = asm.problem.validate_but_a_entries_and_b().is_ok();
        scratch.passive_g0.resize_with(self.passive.len(), Vec::new);
        scratch.passive_g0.iter_mut().for_each(Vec::clear);
        scratch.b0.clone_from(&asm.problem.b);
        scratch.passive0.clone_from(&asm.passive);
        scratch.external0.clone_from(&asm.external);
        scratch.record_start.clear();
        let mut k = 0;
        for p in &self.passive {
            scratch.record_start.push(k);
            k += p.record_size();
        }
        let nq = self.model.nq();
        scratch.dg.resize(nq, 0.0);
        scratch.g.resize(nq, 0.0);
        scratch.external_start.clear();
        scratch.external_forces.clear();
        scratch.knee_external.clear();
        let Some(loads) = &self.loads else {
            scratch.external_gen.clear();
            return Ok(());
        };
        let data = &ws.data;
        let ne = loads.forces.len();
        scratch.external_gen.resize_with(ne, Vec::new);
        let mut k = 0;
        for (ef, gen) in loads.forces.iter().zip(scratch.external_gen.iter_mut()) {
            scratch.external_start.push(k);
            k += ef.record_size();
            let bf = ef.body_force(t, data)?;
            let b = ef.applied_to_body;
            gen.clear();
            gen.resize(nq, 0.0);
            // Jᵀ of the spatial force: its force at the ground origin, fixed
            // on the body, and its moment about the ground origin.
            let origin = nalgebra::Vector3::zeros();
            crate::dynamics::jacobian::add_point_force(
                &self.model,
                data,
                b,
                &origin,
                &bf.force,
                gen,
            );
            crate::dynamics::jacobian::add_body_torque(&self.model, data, b, &bf.moment, gen);
            scratch.external_forces.push((b, bf));
        }
        for knee in &self.knees {
            for (b, bf) in &scratch.external_forces {
                // The knee's reaction r₀ holds −(the loads on its distal
                // bodies): b_axial = −F0_y, b_frontal = M0_x.
                let share = if knee.distal[*b] {
                    let (f, m) = crate::frame::knee_contact::in_tibia(data, knee.tibia, bf);
                    [f.y, if knee.frontal { -m.x } else { 0.0 }]
                } else {
                    [0.0, 0.0]
                };
                scratch.knee_external.push(share);
            }
        }
        Ok(())
    }

    /// Solve the frame kept by [`begin_candidates`](Self::begin_candidates)
    /// for `cand`, from the multipliers `y0` when given, into `out` (the
    /// frame's outputs as [`SoProblem::solve_frame_into`] makes them for a
    /// run of the candidate's setup; of those [`Outputs`] can leave out,
    /// only `want`'s). Leaves the candidate's generalized
    /// force change in `scratch.dg` (for its joint reactions); the frame in
    /// `ws` is left as it was assembled.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_candidate_into(
        &self,
        t: f64,
        ws: &mut Workspace,
        cand: &ForceCandidate,
        y0: Option<&[f64]>,
        want: Outputs,
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
            // The replaced force's, once per frame.
            let g0 = &mut scratch.passive_g0[*j];
            if g0.is_empty() {
                g0.resize(g.len(), 0.0);
                self.passive[*j].add_generalized_force(model, data, t, g0);
            }
            for (d, x) in scratch.dg.iter_mut().zip(g0.iter()) {
                *d -= x;
            }
            if !want.force_row {
                // Its record values are the force table's only.
                continue;
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
        // External loads scaled: their generalized forces (with the
        // passive forces' in Δg for the rows, apart for the reactions) and
        // their force-table values.
        let scaled = cand.external.iter().any(|&s| s != 1.0);
        let g = &mut scratch.g;
        g.iter_mut().for_each(|x| *x = 0.0);
        asm.external.clone_from(&scratch.external0);
        if scaled {
            let forces = self.loads.as_ref().map_or(&[][..], |l| &l.forces[..]);
            for (e, &s) in cand.external.iter().enumerate() {
                if s == 1.0 {
                    continue;
                }
                for (x, ge) in g.iter_mut().zip(&scratch.external_gen[e]) {
                    *x += (s - 1.0) * ge;
                }
                let k = scratch.external_start[e];
                let ef = &forces[e];
                ef.scale_record(&mut asm.external[k..k + ef.record_size()], s);
            }
        }
        asm.problem.b.copy_from(&scratch.b0);
        if !cand.passive.is_empty() || scaled {
            for (r, cv) in asm.couplings.iter().enumerate() {
                let d: f64 = cv
                    .iter()
                    .map(|(i, c)| c * (scratch.dg[*i] + scratch.g[*i]))
                    .sum();
                asm.problem.b[r] -= d;
            }
        }
        if scaled && !self.knees.is_empty() {
            let (nr, ne) = (self.rows.len(), cand.external.len());
            for ki in 0..self.knees.len() {
                for (e, &s) in cand.external.iter().enumerate() {
                    let [fa, fm] = scratch.knee_external[ki * ne + e];
                    asm.problem.b[nr + 2 * ki] += (s - 1.0) * fa;
                    asm.problem.b[nr + 2 * ki + 1] += (s - 1.0) * fm;
                }
            }
        }
        // Weights: the contact multipliers follow the controls (the knee
        // compartments after them are weighted by their capacity, not w0:
        // the frame's, every candidate's).
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
        // A was checked with the frame; of its columns only those just
        // scaled need a look.
        let a_finite = scratch.a_finite
            && scratch
                .saved
                .iter()
                .all(|(v, _, _)| asm.problem.a.column(*v).iter().all(|x| x.is_finite()));
        let valid =
            scratch.valid_but_a_b && a_finite && asm.problem.b.iter().all(|v| v.is_finite());
        if scratch.saved.is_empty() {
            let key = scratch.a_key;
            optimize::solve_into_valid_keyed(&asm.problem, y0, &mut out.solution, valid, key);
        } else {
            optimize::solve_into_valid(&asm.problem, y0, &mut out.solution, valid);
        }
        self.frame_outputs_into(t, asm, None, data, mf, want, out);
        for (v, col, f0) in scratch.saved.drain(..) {
            asm.problem.a.column_mut(v).copy_from_slice(&col);
            asm.scale[v] = f0;
        }
        asm.passive.clone_from(&scratch.passive0);
        asm.external.clone_from(&scratch.external0);
        asm.problem.b.copy_from(&scratch.b0);
    }
}
