//! Joint-space mass matrix M(q) = Σ_b (J_ωᵀ I_b J_ω + m_b J_cᵀ J_c).

use nalgebra::{DMatrix, Vector3};

use super::{jacobian, Data};
use crate::model::Model;

/// M(q) at `data.q` (positions must be current: call
/// [`super::kinematics::positions`] first).
pub fn mass_matrix(model: &Model, data: &Data) -> DMatrix<f64> {
    let n = model.nq();
    let mut m = DMatrix::zeros(n, n);
    let mut jc = DMatrix::zeros(3, n);
    let mut jw = DMatrix::zeros(3, n);
    for b in 1..model.nbodies() {
        let body = &model.bodies[b];
        if body.mass == 0.0 {
            continue;
        }
        jc.fill(0.0);
        jw.fill(0.0);
        let c = data.station_position(b, &body.mass_center);
        jacobian::add_station_jacobian(model, data, b, &c, 1.0, &mut jc);
        angular_jacobian(model, data, b, &mut jw);
        let r = data.rotation[b];
        let i_g = r * body.inertia * r.transpose();
        m += body.mass * jc.transpose() * &jc + jw.transpose() * i_g * &jw;
    }
    m
}

/// ∂ω_b/∂u (3 × nu).
pub fn angular_jacobian(model: &Model, data: &Data, b: usize, out: &mut DMatrix<f64>) {
    let mut body = b;
    while body != 0 {
        let j = &model.joints[body];
        let m = &data.joint_motion[body];
        for k in 0..j.nq {
            let w: Vector3<f64> = data.r_gf[body] * m.h_w[k];
            for r in 0..3 {
                out[(r, j.q_start + k)] += w[r];
            }
        }
        body = j.parent_body;
    }
}
