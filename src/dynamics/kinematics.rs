//! Forward kinematics: body poses, velocities and accelerations in ground from
//! (q, u, u̇), one pass from ground outwards in tree order.

use nalgebra::Vector3;

use super::Data;
use crate::model::Model;

/// Positions only (and the per-joint motion maps H, which depend on q; the
/// velocity-dependent bias terms use `data.u`).
pub fn positions(model: &Model, data: &mut Data) {
    for b in 1..model.nbodies() {
        let j = &model.joints[b];
        let p = j.parent_body;
        let qs = &data.q[j.q_start..j.q_start + j.nq];
        let us = &data.u[j.q_start..j.q_start + j.nq];
        j.kind.motion(qs, us, &mut data.joint_motion[b]);
        let m = &data.joint_motion[b];
        let r_gp = data.rotation[p];
        let r_gf = r_gp * j.x_pf.rotation;
        let p_gf = data.position[p] + r_gp * j.x_pf.translation;
        let r_gm = r_gf * m.rotation;
        let p_gm = p_gf + r_gf * m.translation;
        let r_gb = r_gm * j.x_bm.rotation.transpose();
        data.rotation[b] = r_gb;
        data.position[b] = p_gm - r_gb * j.x_bm.translation;
        data.r_gf[b] = r_gf;
        data.p_gm[b] = p_gm;
    }
}

/// Positions, velocities and accelerations of every body.
pub fn full(model: &Model, data: &mut Data) {
    positions(model, data);
    motion(model, data);
}

/// Velocities and accelerations of every body from `data.u` and
/// `data.udot`, with the positions (and motion maps) already current for
/// `data.q` and `data.u`: after [`positions`] or [`full`] at the same state,
/// e.g. when only the accelerations changed.
pub fn motion(model: &Model, data: &mut Data) {
    for b in 1..model.nbodies() {
        let j = &model.joints[b];
        let p = j.parent_body;
        let m = &data.joint_motion[b];
        let r_gf = data.r_gf[b];
        let (mut w_fm, mut v_fm, mut a_w, mut a_v) =
            (Vector3::zeros(), Vector3::zeros(), m.c_w, m.c_v);
        for k in 0..j.nq {
            let (u, ud) = (data.u[j.q_start + k], data.udot[j.q_start + k]);
            w_fm += m.h_w[k] * u;
            v_fm += m.h_v[k] * u;
            a_w += m.h_w[k] * ud;
            a_v += m.h_v[k] * ud;
        }
        let w_rel = r_gf * w_fm;
        let v_rel = r_gf * v_fm;
        let (wp, vp, alp, ap) = (
            data.omega[p],
            data.velocity[p],
            data.alpha[p],
            data.accel[p],
        );
        let r_pm = data.p_gm[b] - data.position[p]; // parent origin → M origin
        let r_mb = data.position[b] - data.p_gm[b]; // M origin → body origin
        let w = wp + w_rel;
        let v_m = vp + wp.cross(&r_pm) + v_rel;
        data.omega[b] = w;
        data.velocity[b] = v_m + w.cross(&r_mb);
        let al = alp + r_gf * a_w + wp.cross(&w_rel);
        let a_m = ap
            + alp.cross(&r_pm)
            + wp.cross(&wp.cross(&r_pm))
            + 2.0 * wp.cross(&v_rel)
            + r_gf * a_v;
        data.alpha[b] = al;
        data.accel[b] = a_m + al.cross(&r_mb) + w.cross(&w.cross(&r_mb));
    }
}
