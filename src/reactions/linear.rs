//! Joint reactions of a static-optimization frame as an affine function of
//! its forces ([`ReactionBasis`]), for many solutions of one frame (the
//! candidates of a force sweep, `frame::candidates`).
//!
//! At a fixed state the reactions are affine in the applied forces: forward
//! dynamics under the constraints and the RNEA's transmitted forces are
//! linear in them, gravity and the velocity terms are the constant part.
//! So, with r₀ the reactions when every actuator force and contact
//! multiplier is zero (passive forces, external loads, passive fiber forces,
//! gravity and velocities only),
//!
//! ```text
//! r = r₀ + Σ_i R_i F_i + Σ_j L_j λ_j + Σ_k M_k Δg_k + Σ_e E_e (s_e − 1)
//! ```
//!
//! F_i the actuator forces (x_i f_i), λ_j the contact multipliers (each
//! contact's force is linear in its three, at its state), Δg_k a change
//! of the generalized force on coordinate k (a passive force of a
//! candidate) and s_e the factor an external load's force and torque are
//! scaled by (E_e: the response to that load as the frame applies it). Each column is one evaluation of
//! [`static_optimization_reactions`](super::static_optimization_reactions)'s
//! forces with one force probed, less r₀: 1 + n_controls + 3 n_contacts
//! (+ the coordinates probed) forward-dynamics evaluations per frame,
//! however many solutions use them. The result equals the direct
//! evaluation up to rounding (tests/force_sweep.rs compares candidates'
//! reactions with their own runs).

use nalgebra::DMatrix;

use crate::contacts::{ContactState, Regime};
use crate::dynamics::{forward, kinematics, rnea, BodyForce};
use crate::error::Result;
use crate::frame::problem::{Control, SoProblem};
use crate::frame::workspace::Workspace;
use crate::paths::geometry;
use crate::reactions::joint::{
    add_passive_fiber_forces, apply_forces_at_state, reactions, ReactionSpec,
};

/// One frame's reactions as r₀ + columns · (forces, multipliers) + mobility
/// responses (see the module documentation).
#[derive(Debug, Clone, Default)]
pub struct ReactionBasis {
    /// Reactions with every actuator force and multiplier zero (9 per spec).
    pub r0: Vec<f64>,
    /// Per actuator force (N or N m), then per contact multiplier: the
    /// change of the reactions per unit (9 n_specs × (n_controls + 3 n_contacts)).
    pub columns: DMatrix<f64>,
    /// Per probed coordinate: the change per unit generalized force on it.
    pub mobility: Vec<(usize, Vec<f64>)>,
    /// Per external load given to [`build`](Self::build): the change its
    /// spatial force makes.
    pub external: Vec<Vec<f64>>,
    forces: Vec<f64>,
    row: Vec<f64>,
}

/// The reactions of `specs` with actuator forces `forces`, the one contact
/// multiplier `(contact, k, value)` and the generalized force
/// `(coordinate, value)` applied, at the frame's state in `ws` (positions,
/// velocities and muscle paths current).
#[allow(clippy::too_many_arguments)]
fn evaluate(
    problem: &SoProblem,
    t: f64,
    ws: &mut Workspace,
    states: &[ContactState],
    specs: &[ReactionSpec],
    forces: &[f64],
    multiplier: Option<(usize, usize, f64)>,
    mobility: Option<(usize, f64)>,
    out: &mut [f64],
) -> Result<()> {
    let (data, mf) = (&mut ws.data, &mut ws.muscles);
    apply_forces_at_state(
        data,
        mf,
        &problem.controls,
        forces,
        &problem.passive,
        problem.loads.as_ref(),
        t,
    );
    if let Some((ci, k, value)) = multiplier {
        let c = &problem.contacts[ci];
        let st = &states[ci];
        let mut l = [0.0; 3];
        l[k] = value;
        let (f_point, p, f_plane) = c.forces(st, l, st.regime == Regime::Kinetic);
        data.applied[c.point_body].add(&BodyForce::at_point(f_point, p));
        if c.plane_body != 0 {
            data.applied[c.plane_body].add(&BodyForce::at_point(f_plane, st.projection_ground));
        }
    }
    if problem.options.passive_fiber_forces {
        add_passive_fiber_forces(problem, mf, data);
    }
    if let Some((k, value)) = mobility {
        data.applied_gen[k] += value;
    }
    reactions(&problem.model, data, t, specs, out)
}

/// What one column of the basis applies: an actuator's force, a contact
/// multiplier, or a generalized force on a coordinate (each of size `1.0`
/// times the given value).
#[derive(Clone, Copy)]
enum Probe {
    Control(usize, f64),
    Multiplier(usize, usize),
    Mobility(usize),
    /// A spatial force (about the ground origin) on a body.
    Body(usize, BodyForce),
}

/// The linear part of the reactions for the forces of `probe` alone, at
/// the positions in `ws` with zero velocities (the bias terms already
/// zeroed in `ws.data`), no gravity and no prescribed accelerations:
/// generalized forces Jᵀ F (the RNEA at rest), free accelerations
/// y = M_r⁻¹ Cᵀ Jᵀ F (`factor`: M_r's Cholesky factor, `c`: C), u̇ = C y,
/// and the RNEA's transmitted forces, expressed as
/// [`reactions_at_accelerations`](super::reactions_at_accelerations)
/// expresses them (the points' entries 0: they do not move with forces).
#[allow(clippy::too_many_arguments)]
fn linear_response(
    problem: &SoProblem,
    ws: &mut Workspace,
    states: &[ContactState],
    specs: &[ReactionSpec],
    factor: &nalgebra::Cholesky<f64, nalgebra::Dyn>,
    c: &DMatrix<f64>,
    probe: Probe,
    y: &mut nalgebra::DVector<f64>,
    out: &mut [f64],
) {
    let model = &problem.model;
    let (data, mf) = (&mut ws.data, &ws.muscles);
    data.clear_applied();
    let mut applied = std::mem::take(&mut data.applied);
    let mut gen = std::mem::take(&mut data.applied_gen);
    match probe {
        Probe::Control(v, value) => match &problem.controls[v] {
            Control::Muscle(m) => {
                geometry::add_tension_forces(mf.path_state(*m), value, &mut applied, &mut gen)
            }
            Control::Actuator(a) => a.apply(data, value, &mut applied, &mut gen),
        },
        Probe::Multiplier(ci, k) => {
            let cn = &problem.contacts[ci];
            let st = &states[ci];
            let mut l = [0.0; 3];
            l[k] = 1.0;
            let (f_point, p, f_plane) = cn.forces(st, l, st.regime == Regime::Kinetic);
            applied[cn.point_body].add(&BodyForce::at_point(f_point, p));
            if cn.plane_body != 0 {
                applied[cn.plane_body].add(&BodyForce::at_point(f_plane, st.projection_ground));
            }
        }
        Probe::Mobility(k) => gen[k] += 1.0,
        Probe::Body(b, f) => applied[b].add(&f),
    }
    data.applied = applied;
    data.applied_gen = gen;
    // At rest: τ = −Jᵀ F − g.
    data.udot.iter_mut().for_each(|x| *x = 0.0);
    kinematics::motion(model, data);
    rnea::inverse_dynamics_after_kinematics(model, data, false);
    let (nq, nr) = c.shape();
    forward::minus_ct_tau(c, data, y);
    factor.solve_mut(y);
    for k in 0..nq {
        let mut sum = 0.0;
        for r in 0..nr {
            let ckr = c[(k, r)];
            if ckr != 0.0 {
                sum += ckr * y[r];
            }
        }
        data.udot[k] = sum;
    }
    kinematics::motion(model, data);
    rnea::inverse_dynamics_after_kinematics(model, data, false);
    for (s, o) in specs.iter().zip(out.chunks_mut(9)) {
        let b = s.joint;
        let jf: BodyForce = data.joint_force[b];
        let (force, moment) = if s.on_child {
            let p_m = data.p_gm[b];
            (jf.force, jf.moment - p_m.cross(&jf.force))
        } else {
            let j = &model.joints[b];
            let p_f = data.station_position(j.parent_body, &j.x_pf.translation);
            (-jf.force, p_f.cross(&jf.force) - jf.moment)
        };
        let r_eg = (data.rotation[s.frame_body] * s.frame.rotation).transpose();
        o[0..3].copy_from_slice((r_eg * force).as_slice());
        o[3..6].copy_from_slice((r_eg * moment).as_slice());
        o[6..9].iter_mut().for_each(|x| *x = 0.0);
    }
}

impl ReactionBasis {
    /// The basis of the frame whose state, muscle paths and contact states
    /// `ws` holds (as [`SoProblem::assemble`] leaves them), probing the
    /// generalized forces of `coordinates` and the spatial forces
    /// `external` (body, force) too: r₀ by one full evaluation,
    /// each column by [`linear_response`] with M_r factored once. `ws`'s
    /// kinematics and `data.udot` are restored.
    pub fn build(
        &mut self,
        problem: &SoProblem,
        t: f64,
        ws: &mut Workspace,
        specs: &[ReactionSpec],
        coordinates: &[usize],
        external: &[(usize, BodyForce)],
    ) -> Result<()> {
        let n = 9 * specs.len();
        let nv = problem.controls.len();
        let nc = problem.contacts.len();
        let udot = ws.data.udot.clone();
        let u = ws.data.u.clone();
        let states = std::mem::take(&mut ws.assembly.states);
        let scale = std::mem::take(&mut ws.assembly.scale);
        let result = (|| -> Result<()> {
            self.forces.clear();
            self.forces.resize(nv, 0.0);
            self.r0.clear();
            self.r0.resize(n, 0.0);
            self.row.resize(n, 0.0);
            if self.columns.shape() != (n, nv + 3 * nc) {
                self.columns = DMatrix::zeros(n, nv + 3 * nc);
            }
            let mut r0 = std::mem::take(&mut self.r0);
            evaluate(
                problem,
                t,
                ws,
                &states,
                specs,
                &self.forces,
                None,
                None,
                &mut r0,
            )?;
            self.r0 = r0;
            // The forward dynamics of r₀ left M_r and C in data.forward.
            let c = ws.data.forward.coupling.clone();
            let factor = ws.data.forward.m_r.clone().cholesky().ok_or_else(|| {
                crate::error::Error::msg(format!(
                    "joint reactions at t = {t}: the reduced mass matrix is not positive definite"
                ))
            })?;
            let mut y = nalgebra::DVector::zeros(c.ncols());
            // At rest: the velocity bias terms of the joints zeroed.
            ws.data.u.iter_mut().for_each(|x| *x = 0.0);
            kinematics::positions(&problem.model, &mut ws.data);
            let mut probes: Vec<(usize, Probe)> = Vec::with_capacity(nv + 3 * nc);
            for v in 0..nv {
                // A probe of the size of the actuator's forces.
                let probe = scale.get(v).map_or(1.0, |s| s.abs().max(1.0));
                probes.push((v, Probe::Control(v, probe)));
            }
            for ci in 0..nc {
                for k in 0..3 {
                    probes.push((nv + 3 * ci + k, Probe::Multiplier(ci, k)));
                }
            }
            for (col, probe) in probes {
                linear_response(
                    problem,
                    ws,
                    &states,
                    specs,
                    &factor,
                    &c,
                    probe,
                    &mut y,
                    &mut self.row,
                );
                let size = match probe {
                    Probe::Control(_, p) => p,
                    _ => 1.0,
                };
                for (i, r) in self.row.iter().enumerate() {
                    self.columns[(i, col)] = r / size;
                }
            }
            self.mobility
                .resize_with(coordinates.len(), Default::default);
            for (m, &k) in self.mobility.iter_mut().zip(coordinates) {
                linear_response(
                    problem,
                    ws,
                    &states,
                    specs,
                    &factor,
                    &c,
                    Probe::Mobility(k),
                    &mut y,
                    &mut self.row,
                );
                m.0 = k;
                m.1.clone_from(&self.row);
            }
            self.external.resize_with(external.len(), Default::default);
            for (e, &(b, f)) in self.external.iter_mut().zip(external) {
                linear_response(
                    problem,
                    ws,
                    &states,
                    specs,
                    &factor,
                    &c,
                    Probe::Body(b, f),
                    &mut y,
                    &mut self.row,
                );
                e.clone_from(&self.row);
            }
            Ok(())
        })();
        ws.assembly.states = states;
        ws.assembly.scale = scale;
        ws.data.u.copy_from_slice(&u);
        ws.data.udot.copy_from_slice(&udot);
        kinematics::full(&problem.model, &mut ws.data);
        result
    }

    /// The reactions of a solution: actuator forces `forces`, contact
    /// multipliers `lambda`, generalized-force changes `dg` (nq; only
    /// the probed coordinates count) and the external loads' factors
    /// `external` (empty: all 1) into `out`.
    pub fn reactions_into(
        &self,
        forces: &[f64],
        lambda: &[f64],
        dg: &[f64],
        external: &[f64],
        out: &mut [f64],
    ) {
        out.copy_from_slice(&self.r0);
        let n = out.len();
        if n == 0 {
            return;
        }
        // Column by column over the matrix's storage (column-major).
        let columns = self.columns.as_slice().chunks_exact(n);
        for (x, col) in forces.iter().chain(lambda).zip(columns) {
            if *x != 0.0 {
                for (o, c) in out.iter_mut().zip(col) {
                    *o += c * x;
                }
            }
        }
        for (k, col) in &self.mobility {
            let d = dg.get(*k).copied().unwrap_or(0.0);
            if d != 0.0 {
                for (o, c) in out.iter_mut().zip(col) {
                    *o += c * d;
                }
            }
        }
        for (s, col) in external.iter().zip(&self.external) {
            let d = s - 1.0;
            if d != 0.0 {
                for (o, c) in out.iter_mut().zip(col) {
                    *o += c * d;
                }
            }
        }
    }
}
