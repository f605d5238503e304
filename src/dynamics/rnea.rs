//! Recursive Newton-Euler inverse dynamics: the generalized forces that,
//! together with gravity and the applied forces in `data.applied` /
//! `data.applied_gen`, produce the accelerations `data.udot`. Constraints are
//! ignored, as in Simbody's `calcResidualForceIgnoringConstraints` used by
//! OpenSim's InverseDynamicsTool.

use super::{kinematics, BodyForce, Data};
use crate::model::Model;

/// τ = M(q) u̇ + C(q, u) − G(q) − applied; result in `data.tau`, and the
/// spatial force each joint transmits in `data.joint_force`.
pub fn inverse_dynamics(model: &Model, data: &mut Data) {
    kinematics::full(model, data);
    inverse_dynamics_after_kinematics(model, data, true);
}

/// RNEA backward pass only (kinematics already computed). With
/// `gravity == false`, gravity is omitted (used for mass-matrix columns).
pub fn inverse_dynamics_after_kinematics(model: &Model, data: &mut Data, gravity: bool) {
    let g = if gravity {
        model.gravity
    } else {
        nalgebra::Vector3::zeros()
    };
    let nb = model.nbodies();
    // Net spatial force each body needs (about the ground origin), minus applied.
    for b in 1..nb {
        let body = &model.bodies[b];
        let r = data.rotation[b];
        let rc = r * body.mass_center;
        let c = data.position[b] + rc;
        let w = data.omega[b];
        let a_c = data.accel[b] + data.alpha[b].cross(&rc) + w.cross(&w.cross(&rc));
        let i_g = r * body.inertia * r.transpose();
        let f = body.mass * (a_c - g);
        let n_c = i_g * data.alpha[b] + w.cross(&(i_g * w));
        let ap = data.applied[b];
        data.joint_force[b] = BodyForce {
            force: f - ap.force,
            moment: n_c + c.cross(&f) - ap.moment,
        };
    }
    // Accumulate subtrees from leaves to root (tree order guarantees parents first).
    for b in (1..nb).rev() {
        let p = model.joints[b].parent_body;
        if p != 0 {
            let jf = data.joint_force[b];
            data.joint_force[p].add(&jf);
        }
    }
    for b in 1..nb {
        let j = &model.joints[b];
        let jf = data.joint_force[b];
        let p_m = data.p_gm[b];
        // Moment about M's origin, in F.
        let r_fg = data.r_gf[b].transpose();
        let n_m = r_fg * (jf.moment - p_m.cross(&jf.force));
        let f_f = r_fg * jf.force;
        let m = &data.joint_motion[b];
        for k in 0..j.nq {
            let i = j.q_start + k;
            data.tau[i] = m.h_w[k].dot(&n_m) + m.h_v[k].dot(&f_f) - data.applied_gen[i];
        }
    }
}
