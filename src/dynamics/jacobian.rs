//! Station Jacobians: ∂v/∂u of a point fixed on a body, from the per-joint
//! velocity maps computed by [`super::kinematics::positions`].

use nalgebra::{DMatrix, Vector3};

use super::Data;
use crate::model::Model;

/// Add to `out` (3 × nu) the Jacobian of the ground velocity of the point at
/// ground position `x`, fixed on body `b`, scaled by `scale`. Requires
/// positions to be current.
pub fn add_station_jacobian(
    model: &Model,
    data: &Data,
    b: usize,
    x: &Vector3<f64>,
    scale: f64,
    out: &mut DMatrix<f64>,
) {
    let mut body = b;
    while body != 0 {
        let j = &model.joints[body];
        let m = &data.joint_motion[body];
        let r_gf = data.r_gf[body];
        let arm = x - data.p_gm[body];
        for k in 0..j.nq {
            let w = r_gf * m.h_w[k];
            let v = r_gf * m.h_v[k] + w.cross(&arm);
            let col = j.q_start + k;
            for r in 0..3 {
                out[(r, col)] += scale * v[r];
            }
        }
        body = j.parent_body;
    }
}

/// Generalized force produced by a force `f` (ground) acting at ground point
/// `x` on body `b`: Jᵀ f, accumulated into `gen`.
pub fn add_point_force(
    model: &Model,
    data: &Data,
    b: usize,
    x: &Vector3<f64>,
    f: &Vector3<f64>,
    gen: &mut [f64],
) {
    add_point_force_below(model, data, b, 0, x, f, gen);
}

/// The part of [`add_point_force`] on the coordinates of the joints between
/// body `b` and its ancestor `top` (`top`'s own joint and those above it
/// excluded). With `top` the common ancestor of two bodies pulled by opposite
/// forces (a path segment), the rest is the pair's net moment on `top`
/// ([`add_body_torque`]), zero when the forces are collinear.
pub fn add_point_force_below(
    model: &Model,
    data: &Data,
    b: usize,
    top: usize,
    x: &Vector3<f64>,
    f: &Vector3<f64>,
    gen: &mut [f64],
) {
    let mut body = b;
    while body != top {
        let j = &model.joints[body];
        let m = &data.joint_motion[body];
        let r_gf = data.r_gf[body];
        let arm = x - data.p_gm[body];
        let f_f = r_gf.transpose() * f;
        let n_f = r_gf.transpose() * arm.cross(f);
        for k in 0..j.nq {
            gen[j.q_start + k] += m.h_v[k].dot(&f_f) + m.h_w[k].dot(&n_f);
        }
        body = j.parent_body;
    }
}

/// Generalized force produced by a pure torque `t` (ground) on body `b`.
pub fn add_body_torque(model: &Model, data: &Data, b: usize, t: &Vector3<f64>, gen: &mut [f64]) {
    let mut body = b;
    while body != 0 {
        let j = &model.joints[body];
        let m = &data.joint_motion[body];
        let t_f = data.r_gf[body].transpose() * t;
        for k in 0..j.nq {
            gen[j.q_start + k] += m.h_w[k].dot(&t_f);
        }
        body = j.parent_body;
    }
}
