//! Joint (mobilizer) kinematics: for each joint type, the transform X_FM(q)
//! of the child frame M in the parent frame F, the velocity map H(q) with
//! `[ω_FM; v_FM] = H u` (both expressed in F, v of M's origin), and the bias
//! `Ḣ u` (opensim-semantics.md §2.6, §2.7).

use nalgebra::{Matrix3, Vector3};

use super::{rot_x, rot_y, rot_z};
use crate::functions::Function;

/// One TransformAxis of a CustomJoint: θ = f(q_coordinate) along `axis`.
#[derive(Debug, Clone)]
pub struct TransformAxis {
    /// Unit axis in F.
    pub axis: Vector3<f64>,
    /// Local index (within the joint) of the coordinate driving this axis, if
    /// any. Axes listing several coordinates must have a Constant function.
    pub coordinate: Option<usize>,
    /// Constant(0) when the XML element had no function (OpenSim's default).
    pub function: Function,
}

#[derive(Debug, Clone)]
pub enum JointKind {
    Weld,
    /// Rotation about the common z axis.
    Pin,
    /// Translation along the common x axis.
    Slider,
    /// Rx(q1)·Ry(q2).
    Universal,
    /// Body-fixed XYZ with u = q̇.
    Gimbal,
    /// Body-fixed XYZ Euler angles; u = ω_FM in F.
    Ball,
    /// Ball rotation plus translation in F; u = (ω_FM in F, v_FM in F).
    Free,
    /// Rz(q1), translation (q2, q3, 0).
    Planar,
    /// rotation1..3, translation1..3.
    Custom(Box<[TransformAxis; 6]>),
}

/// Motion of a joint at one (q, u): all vectors in F.
#[derive(Debug, Clone, Copy)]
pub struct JointMotion {
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
    /// Columns of H: angular part per local speed.
    pub h_w: [Vector3<f64>; 6],
    /// Columns of H: linear part per local speed.
    pub h_v: [Vector3<f64>; 6],
    /// Ḣ u, angular and linear.
    pub c_w: Vector3<f64>,
    pub c_v: Vector3<f64>,
}

impl Default for JointMotion {
    fn default() -> Self {
        JointMotion {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            h_w: [Vector3::zeros(); 6],
            h_v: [Vector3::zeros(); 6],
            c_w: Vector3::zeros(),
            c_v: Vector3::zeros(),
        }
    }
}

/// Right-handed rotation by `angle` about unit vector `a`.
pub fn axis_angle(a: &Vector3<f64>, angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    let t = 1.0 - c;
    let (x, y, z) = (a[0], a[1], a[2]);
    Matrix3::new(
        t * x * x + c,
        t * x * y - s * z,
        t * x * z + s * y,
        t * x * y + s * z,
        t * y * y + c,
        t * y * z - s * x,
        t * x * z - s * y,
        t * y * z + s * x,
        t * z * z + c,
    )
}

impl JointKind {
    /// Number of generalized coordinates (= speeds) of this joint type;
    /// for CustomJoint, the number of distinct coordinates.
    pub fn fixed_nq(&self) -> Option<usize> {
        match self {
            JointKind::Weld => Some(0),
            JointKind::Pin | JointKind::Slider => Some(1),
            JointKind::Universal => Some(2),
            JointKind::Gimbal | JointKind::Ball | JointKind::Planar => Some(3),
            JointKind::Free => Some(6),
            JointKind::Custom(_) => None,
        }
    }

    /// Evaluate X_FM, H and Ḣu at local (q, u).
    pub fn motion(&self, q: &[f64], u: &[f64], m: &mut JointMotion) {
        let x = Vector3::x();
        let y = Vector3::y();
        let z = Vector3::z();
        m.c_w = Vector3::zeros();
        m.c_v = Vector3::zeros();
        m.translation = Vector3::zeros();
        match self {
            JointKind::Weld => {
                m.rotation = Matrix3::identity();
            }
            JointKind::Pin => {
                m.rotation = rot_z(q[0]);
                m.h_w[0] = z;
                m.h_v[0] = Vector3::zeros();
            }
            JointKind::Slider => {
                m.rotation = Matrix3::identity();
                m.translation = Vector3::new(q[0], 0.0, 0.0);
                m.h_w[0] = Vector3::zeros();
                m.h_v[0] = x;
            }
            JointKind::Universal => {
                let r1 = rot_x(q[0]);
                m.rotation = r1 * rot_y(q[1]);
                m.h_w[0] = x;
                m.h_w[1] = r1 * y;
                m.h_v[0] = Vector3::zeros();
                m.h_v[1] = Vector3::zeros();
                m.c_w = (x * u[0]).cross(&m.h_w[1]) * u[1];
            }
            JointKind::Gimbal => {
                let r1 = rot_x(q[0]);
                let r12 = r1 * rot_y(q[1]);
                m.rotation = r12 * rot_z(q[2]);
                m.h_w[0] = x;
                m.h_w[1] = r1 * y;
                m.h_w[2] = r12 * z;
                for k in 0..3 {
                    m.h_v[k] = Vector3::zeros();
                }
                let w1 = x * u[0];
                let w2 = w1 + m.h_w[1] * u[1];
                m.c_w = w1.cross(&m.h_w[1]) * u[1] + w2.cross(&m.h_w[2]) * u[2];
            }
            JointKind::Ball => {
                m.rotation = rot_x(q[0]) * rot_y(q[1]) * rot_z(q[2]);
                m.h_w[0] = x;
                m.h_w[1] = y;
                m.h_w[2] = z;
                for k in 0..3 {
                    m.h_v[k] = Vector3::zeros();
                }
            }
            JointKind::Free => {
                m.rotation = rot_x(q[0]) * rot_y(q[1]) * rot_z(q[2]);
                m.translation = Vector3::new(q[3], q[4], q[5]);
                let e = [x, y, z];
                for k in 0..3 {
                    m.h_w[k] = e[k];
                    m.h_v[k] = Vector3::zeros();
                    m.h_w[k + 3] = Vector3::zeros();
                    m.h_v[k + 3] = e[k];
                }
            }
            JointKind::Planar => {
                m.rotation = rot_z(q[0]);
                m.translation = Vector3::new(q[1], q[2], 0.0);
                m.h_w = [
                    z,
                    Vector3::zeros(),
                    Vector3::zeros(),
                    Vector3::zeros(),
                    Vector3::zeros(),
                    Vector3::zeros(),
                ];
                m.h_v = [
                    Vector3::zeros(),
                    x,
                    y,
                    Vector3::zeros(),
                    Vector3::zeros(),
                    Vector3::zeros(),
                ];
            }
            JointKind::Custom(axes) => custom_motion(axes, q, u, m),
        }
    }
}

/// FunctionBased mobilizer (opensim-semantics.md §2.6): θ_i = f_i(q_ci),
/// R = R(θ0,a0)·R(θ1,a1)·R(θ2,a2) (body-fixed), p = Σ θ_{3+k} a_{3+k} in F.
fn custom_motion(axes: &[TransformAxis; 6], q: &[f64], u: &[f64], m: &mut JointMotion) {
    let n = q.len();
    for k in 0..n {
        m.h_w[k] = Vector3::zeros();
        m.h_v[k] = Vector3::zeros();
    }
    // θ, dθ/dq (single coordinate), d²θ/dq²
    let mut theta = [0.0; 6];
    let mut dtheta = [0.0; 6]; // θ̇
    let mut bias = [0.0; 6]; // f'' q̇²
    let mut slope = [0.0; 6];
    for (i, ax) in axes.iter().enumerate() {
        match ax.coordinate {
            Some(c) => {
                let (v, d1, d2) = ax.function.eval2(q[c]);
                theta[i] = v;
                slope[i] = d1;
                dtheta[i] = d1 * u[c];
                bias[i] = d2 * u[c] * u[c];
            }
            None => theta[i] = ax.function.value(0.0),
        }
    }
    let r0 = axis_angle(&axes[0].axis, theta[0]);
    let r01 = r0 * axis_angle(&axes[1].axis, theta[1]);
    m.rotation = r01 * axis_angle(&axes[2].axis, theta[2]);
    let w = [axes[0].axis, r0 * axes[1].axis, r01 * axes[2].axis];
    let mut omega_partial = Vector3::zeros();
    for i in 0..3 {
        if let Some(c) = axes[i].coordinate {
            m.h_w[c] += w[i] * slope[i];
        }
        // ẇ_i = (ω accumulated before axis i) × w_i
        m.c_w += w[i] * bias[i] + omega_partial.cross(&w[i]) * dtheta[i];
        omega_partial += w[i] * dtheta[i];
    }
    for i in 3..6 {
        m.translation += axes[i].axis * theta[i];
        if let Some(c) = axes[i].coordinate {
            m.h_v[c] += axes[i].axis * slope[i];
        }
        m.c_v += axes[i].axis * bias[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_angle_matches_elementary_rotations() {
        for a in [-2.0, 0.3, 1.7] {
            assert!((axis_angle(&Vector3::x(), a) - rot_x(a)).norm() < 1e-15);
            assert!((axis_angle(&Vector3::y(), a) - rot_y(a)).norm() < 1e-15);
            assert!((axis_angle(&Vector3::z(), a) - rot_z(a)).norm() < 1e-15);
        }
    }

    /// H and Ḣu agree with finite differences of X_FM along a trajectory.
    #[test]
    fn velocity_maps_match_finite_differences() {
        let kinds = vec![JointKind::Universal, JointKind::Gimbal, JointKind::Planar];
        for kind in kinds {
            let n = kind.fixed_nq().unwrap();
            let q0: Vec<f64> = (0..n).map(|i| 0.3 + 0.4 * i as f64).collect();
            let u: Vec<f64> = (0..n).map(|i| 0.7 - 0.5 * i as f64).collect();
            let h = 1e-6;
            let qp: Vec<f64> = q0.iter().zip(&u).map(|(q, u)| q + h * u).collect();
            let qm: Vec<f64> = q0.iter().zip(&u).map(|(q, u)| q - h * u).collect();
            let (mut m0, mut mp, mut mm) = (
                JointMotion::default(),
                JointMotion::default(),
                JointMotion::default(),
            );
            kind.motion(&q0, &u, &mut m0);
            kind.motion(&qp, &u, &mut mp);
            kind.motion(&qm, &u, &mut mm);
            // ω from Ṙ Rᵀ
            let rdot = (mp.rotation - mm.rotation) / (2.0 * h);
            let wx = rdot * m0.rotation.transpose();
            let w_fd = Vector3::new(wx[(2, 1)], wx[(0, 2)], wx[(1, 0)]);
            let w: Vector3<f64> = (0..n).map(|k| m0.h_w[k] * u[k]).sum();
            assert!((w - w_fd).norm() < 1e-8, "{kind:?}: {w} vs {w_fd}");
            // Ḣu from d/dt (H u) at constant u
            let wp: Vector3<f64> = (0..n).map(|k| mp.h_w[k] * u[k]).sum();
            let wm: Vector3<f64> = (0..n).map(|k| mm.h_w[k] * u[k]).sum();
            assert!(((wp - wm) / (2.0 * h) - m0.c_w).norm() < 1e-7, "{kind:?}");
        }
    }
}
