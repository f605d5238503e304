//! Joint reactions of a frame (opensim-semantics.md §7; OpenSim's
//! JointReaction analysis, Simbody's `calcMobilizerReactionForces`): every
//! force applied as body and mobility forces, accelerations from
//! **forward dynamics** under the model's constraints, and each joint's
//! reaction as the RNEA's transmitted spatial force, referred to the child
//! joint frame origin M_o (or, on the parent, −F shifted to F_o), expressed
//! in a chosen frame. The JointReaction tool (`tools::joint_reaction`) reads
//! the forces from a file; static optimization passes each frame's solution
//! ([`static_optimization_reactions`]).

use nalgebra::{DMatrix, Vector3};

use crate::dynamics::{forward, kinematics, rnea, BodyForce, Data};
use crate::error::{Error, Result};
use crate::forces::external_loads::ExternalLoads;
use crate::forces::passive::PassiveForce;
use crate::frame::problem::{Control, FrameResult, SoProblem};
use crate::frame::workspace::Workspace;
use crate::model::{Model, Transform};
use crate::muscles::set::{MuscleFrame, MuscleSet};
use crate::paths::{coupling, geometry};

/// One reported reaction.
#[derive(Debug, Clone)]
pub struct ReactionSpec {
    /// The joint, by the index of its child body (`model.joints[joint]`).
    pub joint: usize,
    /// Reaction on the child body at M_o (true) or on the parent at F_o.
    pub on_child: bool,
    /// The expressed-in frame E: its body and its pose in that body.
    pub frame_body: usize,
    pub frame: Transform,
    /// `<joint>_on_<body>_in_<frame>`.
    pub label_root: String,
}

/// Column labels (without `time`) for `specs`.
pub fn column_labels(specs: &[ReactionSpec]) -> Vec<String> {
    let mut v = Vec::with_capacity(9 * specs.len());
    for s in specs {
        for suffix in ["fx", "fy", "fz", "mx", "my", "mz", "px", "py", "pz"] {
            v.push(format!("{}_{suffix}", s.label_root));
        }
    }
    v
}

/// Forward dynamics (§7.2 "Dynamics"): set `data.udot` to the accelerations
/// that the applied forces in `data.applied` / `data.applied_gen`, gravity and
/// velocity terms produce under the model's constraints. q and u must
/// satisfy the constraints ([`crate::motion::states::assemble`]). Locked coordinates get u̇ = 0,
/// prescribed ones their function's second derivative at `t`, coupler
/// dependents follow their independent coordinate.
pub fn forward_dynamics(model: &Model, data: &mut Data, t: f64) -> Result<()> {
    let nq = model.nq();
    // d: accelerations with every independent acceleration zero.
    forward::constrained_accelerations(model, &data.q, &data.u, t, &mut data.udot);
    kinematics::full(model, data);
    rnea::inverse_dynamics_after_kinematics(model, data, true);
    // The buffers (data.forward) are taken out for the call and put back.
    let mut buf = std::mem::take(&mut data.forward);
    let mut cm = std::mem::replace(&mut buf.coupling, DMatrix::zeros(0, 0));
    buf.free.clear();
    buf.free
        .extend((0..nq).filter(|&c| !model.coordinates[c].is_constrained()));
    let nr = buf.free.len();
    let mut solved = true;
    if nr > 0 {
        forward::shaped(&mut cm, nq, nr);
        cm.fill(0.0);
        for (r, &k) in buf.free.iter().enumerate() {
            coupling::coupling_vector_into(model, &data.q, k, &mut buf.coupling_vector);
            for &(i, c) in buf.coupling_vector.iter() {
                cm[(i, r)] += c;
            }
        }
        solved = forward::free_accelerations_in(model, data, &cm, &mut buf);
        if solved {
            for (r, yr) in buf.y.iter().enumerate() {
                for (k, ckr) in cm.column(r).iter().enumerate() {
                    if *ckr != 0.0 {
                        data.udot[k] += ckr * yr;
                    }
                }
            }
        }
    }
    buf.coupling = cm;
    data.forward = buf;
    if !solved {
        return Err(Error::msg(format!(
            "forward dynamics at t = {t}: the mass matrix is singular (a body chain without mass or inertia?)"
        )));
    }
    Ok(())
}

/// The reactions of `specs` at the accelerations already in `data.udot`
/// (applied forces set), written to `out` (9 values per spec, see
/// [`column_labels`]). The positions in `data` must be current (as
/// [`forward_dynamics`] leaves them): only velocities and accelerations are
/// recomputed.
pub fn reactions_at_accelerations(
    model: &Model,
    data: &mut Data,
    specs: &[ReactionSpec],
    out: &mut [f64],
) {
    kinematics::motion(model, data);
    rnea::inverse_dynamics_after_kinematics(model, data, true);
    for (s, o) in specs.iter().zip(out.chunks_mut(9)) {
        let b = s.joint;
        let jf: BodyForce = data.joint_force[b];
        let (force, moment, point) = if s.on_child {
            let p_m = data.p_gm[b];
            (jf.force, jf.moment - p_m.cross(&jf.force), p_m)
        } else {
            let j = &model.joints[b];
            let p = j.parent_body;
            let p_f = data.station_position(p, &j.x_pf.translation);
            (-jf.force, p_f.cross(&jf.force) - jf.moment, p_f)
        };
        let r_eg = (data.rotation[s.frame_body] * s.frame.rotation).transpose();
        let o_e = data.station_position(s.frame_body, &s.frame.translation);
        let vals: [Vector3<f64>; 3] = [r_eg * force, r_eg * moment, r_eg * (point - o_e)];
        for (k, v) in vals.iter().enumerate() {
            o[3 * k..3 * k + 3].copy_from_slice(v.as_slice());
        }
    }
}

/// The per-frame entry point: forward dynamics with the forces already
/// applied in `data` (q, u assembled; `data.applied` and `data.applied_gen`
/// hold every actuator, passive force and external load, e.g. from
/// [`apply_forces`]), then the reactions into `out`.
pub fn reactions(
    model: &Model,
    data: &mut Data,
    t: f64,
    specs: &[ReactionSpec],
    out: &mut [f64],
) -> Result<()> {
    forward_dynamics(model, data, t)?;
    reactions_at_accelerations(model, data, specs, out);
    Ok(())
}

/// Apply every force at the state (q, u) in `data`: external loads, passive
/// forces, and each control with its force `values[i]` (a muscle's tension
/// along its path, an actuator's actuation). Recomputes kinematics (with
/// u̇ = 0) and the muscle geometry in `mf`.
#[allow(clippy::too_many_arguments)]
pub fn apply_forces(
    model: &Model,
    data: &mut Data,
    mf: &mut MuscleFrame,
    muscles: &MuscleSet,
    controls: &[Control],
    values: &[f64],
    passive: &[PassiveForce],
    loads: Option<&ExternalLoads>,
    t: f64,
) {
    data.udot.iter_mut().for_each(|x| *x = 0.0);
    kinematics::full(model, data);
    if controls.iter().any(|c| matches!(c, Control::Muscle(_))) {
        mf.evaluate(muscles, model, data);
    }
    apply_forces_at_state(data, mf, controls, values, passive, loads, t);
}

/// [`apply_forces`] when `data`'s positions and velocities and the muscle
/// paths in `mf` are already those of the state (nothing recomputed).
#[allow(clippy::too_many_arguments)]
pub(crate) fn apply_forces_at_state(
    data: &mut Data,
    mf: &MuscleFrame,
    controls: &[Control],
    values: &[f64],
    passive: &[PassiveForce],
    loads: Option<&ExternalLoads>,
    t: f64,
) {
    data.clear_applied();
    if let Some(l) = loads {
        l.apply(t, data);
    }
    let mut applied = std::mem::take(&mut data.applied);
    let mut gen = std::mem::take(&mut data.applied_gen);
    for p in passive {
        p.apply(data, &mut applied, &mut gen);
    }
    for (c, &v) in controls.iter().zip(values) {
        match c {
            Control::Muscle(m) => {
                geometry::add_tension_forces(mf.path_state(*m), v, &mut applied, &mut gen)
            }
            Control::Actuator(a) => a.apply(data, v, &mut applied, &mut gen),
        }
    }
    data.applied = applied;
    data.applied_gen = gen;
}

/// Joint reactions of one static-optimization frame, from that frame's
/// solution: the actuator forces (`result.forces`, x_i·f_i in control
/// order) and the contact forces (`result.contacts.loads`: on the point body
/// at p, on the plane body at p*), as body forces. For the actuators this is
/// what a JointReaction run on the SO force file computes, without the file.
///
/// The frame's kinematics and muscle paths are reused from the workspace it
/// was solved in (`SoProblem::solve_frame*` leaves them there, and so does
/// this function, for the next weight of a sweep): they are recomputed only
/// when `ws` holds another state than `result`'s.
/// Every muscle's passive fiber force along its path, added to the forces
/// applied in `data` (static optimization's `passive_fiber_forces`).
pub(crate) fn add_passive_fiber_forces(problem: &SoProblem, mf: &MuscleFrame, data: &mut Data) {
    let mut applied = std::mem::take(&mut data.applied);
    let mut gen = std::mem::take(&mut data.applied_gen);
    for m in 0..problem.muscles.len() {
        geometry::add_tension_forces(
            mf.path_state(m),
            mf.passive_force[m],
            &mut applied,
            &mut gen,
        );
    }
    data.applied = applied;
    data.applied_gen = gen;
}

pub fn static_optimization_reactions(
    problem: &SoProblem,
    t: f64,
    result: &FrameResult,
    ws: &mut Workspace,
    specs: &[ReactionSpec],
    out: &mut [f64],
) -> Result<()> {
    let model = &problem.model;
    let (data, mf) = (&mut ws.data, &mut ws.muscles);
    if data.q != result.q || data.u != result.u {
        data.q.copy_from_slice(&result.q);
        data.u.copy_from_slice(&result.u);
        data.udot.iter_mut().for_each(|x| *x = 0.0);
        kinematics::full(model, data);
        mf.evaluate(&problem.muscles, model, data);
    }
    apply_forces_at_state(
        data,
        mf,
        &problem.controls,
        &result.forces,
        &problem.passive,
        problem.loads.as_ref(),
        t,
    );
    // Contact forces: per contact, force and point on the point body, then
    // (plane body not ground) force and point on the plane body.
    let loads = &result.contacts.loads;
    let mut k = 0;
    for c in &problem.contacts {
        let v = |i: usize| Vector3::new(loads[i], loads[i + 1], loads[i + 2]);
        if loads.len() < k + 6 {
            return Err(Error::internal("contact rows shorter than the contacts"));
        }
        data.applied[c.point_body].add(&BodyForce::at_point(v(k), v(k + 3)));
        k += 6;
        if c.plane_body != 0 {
            if loads.len() < k + 6 {
                return Err(Error::internal("contact rows shorter than the contacts"));
            }
            data.applied[c.plane_body].add(&BodyForce::at_point(v(k), v(k + 3)));
            k += 6;
        }
    }
    if problem.options.passive_fiber_forces {
        add_passive_fiber_forces(problem, mf, data);
    }
    reactions(model, data, t, specs, out)
}
