//! Joint-space mass matrix M(q) = Σ_b (J_ωᵀ I_b J_ω + m_b J_cᵀ J_c).

use nalgebra::{DMatrix, Vector3};

use super::{jacobian, Data};
use crate::model::Model;

/// M(q) at `data.q` (positions must be current: call
/// [`super::kinematics::positions`] first).
///
/// A body's Jacobians are nonzero only in the columns of the joints between
/// it and ground, so each body adds m J_cᵀ J_c + J_ωᵀ I J_ω on those columns
/// alone: O(Σ_b k_b²) for k_b such columns, instead of O(bodies × n²).
pub fn mass_matrix(model: &Model, data: &Data) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(0, 0);
    mass_matrix_into(model, data, &mut m, &mut MassMatrixBuffers::default());
    m
}

/// The working buffers of [`mass_matrix_into`].
#[derive(Debug, Clone)]
pub struct MassMatrixBuffers {
    jc: DMatrix<f64>,
    jw: DMatrix<f64>,
    cols: Vec<usize>,
    /// Per chain column: m J_c and I J_ω.
    mjc: Vec<Vector3<f64>>,
    ijw: Vec<Vector3<f64>>,
}

impl Default for MassMatrixBuffers {
    fn default() -> Self {
        MassMatrixBuffers {
            jc: DMatrix::zeros(0, 0),
            jw: DMatrix::zeros(0, 0),
            cols: Vec::new(),
            mjc: Vec::new(),
            ijw: Vec::new(),
        }
    }
}

/// [`mass_matrix`] into `m`, with the buffers `buf` (no allocation once
/// they have the model's sizes).
pub fn mass_matrix_into(
    model: &Model,
    data: &Data,
    m: &mut DMatrix<f64>,
    buf: &mut MassMatrixBuffers,
) {
    let n = model.nq();
    if m.shape() != (n, n) {
        *m = DMatrix::zeros(n, n);
    } else {
        m.fill(0.0);
    }
    let MassMatrixBuffers {
        jc,
        jw,
        cols,
        mjc,
        ijw,
    } = buf;
    if jc.shape() != (3, n) {
        *jc = DMatrix::zeros(3, n);
        *jw = DMatrix::zeros(3, n);
    }
    for b in 1..model.nbodies() {
        let body = &model.bodies[b];
        if body.mass == 0.0 {
            continue;
        }
        cols.clear();
        let mut up = b;
        while up != 0 {
            let j = &model.joints[up];
            cols.extend(j.q_start..j.q_start + j.nq);
            up = j.parent_body;
        }
        for &c in cols.iter() {
            for r in 0..3 {
                jc[(r, c)] = 0.0;
                jw[(r, c)] = 0.0;
            }
        }
        let c = data.station_position(b, &body.mass_center);
        jacobian::add_station_jacobian(model, data, b, &c, 1.0, jc);
        angular_jacobian(model, data, b, jw);
        let r = data.rotation[b];
        let i_g = r * body.inertia * r.transpose();
        let col3 =
            |mat: &DMatrix<f64>, c: usize| Vector3::new(mat[(0, c)], mat[(1, c)], mat[(2, c)]);
        mjc.clear();
        ijw.clear();
        for &c in cols.iter() {
            mjc.push(body.mass * col3(jc, c));
            ijw.push(i_g * col3(jw, c));
        }
        for &ca in cols.iter() {
            let (jca, jwa) = (col3(jc, ca), col3(jw, ca));
            for (k, &ck) in cols.iter().enumerate() {
                m[(ca, ck)] += mjc[k].dot(&jca) + ijw[k].dot(&jwa);
            }
        }
    }
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
