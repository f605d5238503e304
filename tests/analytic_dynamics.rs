//! Inverse dynamics and mass matrix against closed-form expressions.

use std::path::Path;

use statopt::dynamics::{kinematics, mass_matrix::mass_matrix, rnea, Data};
use statopt::model::{compile, Model};
use statopt::parse::osim::ModelSpec;
use statopt::xml;

fn model_from(text: &str) -> Model {
    let root = xml::parse_str(text, Path::new("test.osim")).unwrap();
    compile(&ModelSpec::from_document(&root, Path::new("test.osim")).unwrap()).unwrap()
}

const G: f64 = 9.80665;
const M1: f64 = 2.3;
const M2: f64 = 1.7;
const L1: f64 = 0.9;
const A1: f64 = 0.4;
const A2: f64 = 0.35;
const I1: f64 = 0.11;
const I2: f64 = 0.07;

fn pin(name: &str, parent: &str, child: &str, loc: f64, coord: &str) -> String {
    format!(
        r#"<PinJoint name="{name}">
  <socket_parent_frame>{parent}_offset</socket_parent_frame>
  <socket_child_frame>{child}_offset</socket_child_frame>
  <coordinates><Coordinate name="{coord}"/></coordinates>
  <frames>
    <PhysicalOffsetFrame name="{parent}_offset"><socket_parent>{ppath}</socket_parent><translation>0 {loc} 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
    <PhysicalOffsetFrame name="{child}_offset"><socket_parent>/bodyset/{child}</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
  </frames>
</PinJoint>"#,
        ppath = if parent == "ground" {
            "/ground".to_string()
        } else {
            format!("/bodyset/{parent}")
        }
    )
}

/// The same rotation as a PinJoint, written as a CustomJoint (rotation1 about z,
/// the other axes Constant 0 / without function).
fn custom_pin(name: &str, parent: &str, child: &str, loc: f64, coord: &str) -> String {
    format!(
        r#"<CustomJoint name="{name}">
  <socket_parent_frame>{parent}_offset</socket_parent_frame>
  <socket_child_frame>{child}_offset</socket_child_frame>
  <coordinates><Coordinate name="{coord}"/></coordinates>
  <frames>
    <PhysicalOffsetFrame name="{parent}_offset"><socket_parent>{ppath}</socket_parent><translation>0 {loc} 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
    <PhysicalOffsetFrame name="{child}_offset"><socket_parent>/bodyset/{child}</socket_parent><translation>0 0 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame>
  </frames>
  <SpatialTransform>
    <TransformAxis name="rotation1"><coordinates>{coord}</coordinates><axis>0 0 1</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
    <TransformAxis name="rotation2"><coordinates/><axis>1 0 0</axis></TransformAxis>
    <TransformAxis name="rotation3"><coordinates/><axis>0 1 0</axis><Constant name="function"><value>0</value></Constant></TransformAxis>
    <TransformAxis name="translation1"><coordinates/><axis>1 0 0</axis></TransformAxis>
    <TransformAxis name="translation2"><coordinates/><axis>0 1 0</axis></TransformAxis>
    <TransformAxis name="translation3"><coordinates/><axis>0 0 1</axis></TransformAxis>
  </SpatialTransform>
</CustomJoint>"#,
        ppath = if parent == "ground" {
            "/ground".to_string()
        } else {
            format!("/bodyset/{parent}")
        }
    )
}

fn body(name: &str, m: f64, a: f64, i: f64) -> String {
    format!(
        r#"<Body name="{name}"><mass>{m}</mass><mass_center>0 {} 0</mass_center><inertia>{i} {i} {i} 0 0 0</inertia></Body>"#,
        -a
    )
}

fn double_pendulum(joint: fn(&str, &str, &str, f64, &str) -> String) -> Model {
    let text = format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="dp">
<gravity>0 -{G} 0</gravity>
<BodySet name="bodyset"><objects>{}{}</objects></BodySet>
<JointSet name="jointset"><objects>{}{}</objects></JointSet>
</Model></OpenSimDocument>"#,
        body("link1", M1, A1, I1),
        body("link2", M2, A2, I2),
        joint("j1", "ground", "link1", 0.0, "q1"),
        joint("j2", "link1", "link2", -L1, "q2"),
    );
    model_from(&text)
}

fn closed_form(q: [f64; 2], u: [f64; 2], ud: [f64; 2]) -> ([[f64; 2]; 2], [f64; 2]) {
    let (c2, s2) = (q[1].cos(), q[1].sin());
    let m11 = I1 + I2 + M1 * A1 * A1 + M2 * (L1 * L1 + A2 * A2 + 2.0 * L1 * A2 * c2);
    let m12 = I2 + M2 * (A2 * A2 + L1 * A2 * c2);
    let m22 = I2 + M2 * A2 * A2;
    let h = M2 * L1 * A2 * s2;
    let g1 = M1 * G * A1 * q[0].sin() + M2 * G * (L1 * q[0].sin() + A2 * (q[0] + q[1]).sin());
    let g2 = M2 * G * A2 * (q[0] + q[1]).sin();
    let tau1 = m11 * ud[0] + m12 * ud[1] - h * (2.0 * u[0] * u[1] + u[1] * u[1]) + g1;
    let tau2 = m12 * ud[0] + m22 * ud[1] + h * u[0] * u[0] + g2;
    ([[m11, m12], [m12, m22]], [tau1, tau2])
}

fn check(model: &Model) {
    let mut data = Data::new(model);
    for (q, u, ud) in [
        ([0.3, -0.7], [1.1, -0.4], [2.0, 0.5]),
        ([-1.2, 2.1], [0.0, 3.0], [-1.0, 4.0]),
        ([2.9, 0.01], [-2.5, 0.7], [0.3, -0.2]),
    ] {
        data.q.copy_from_slice(&q);
        data.u.copy_from_slice(&u);
        data.udot.copy_from_slice(&ud);
        rnea::inverse_dynamics(model, &mut data);
        let (m, tau) = closed_form(q, u, ud);
        for i in 0..2 {
            assert!(
                (data.tau[i] - tau[i]).abs() < 1e-9,
                "tau[{i}] = {} vs closed form {}",
                data.tau[i],
                tau[i]
            );
        }
        kinematics::positions(model, &mut data);
        let mm = mass_matrix(model, &data);
        for i in 0..2 {
            for j in 0..2 {
                assert!(
                    (mm[(i, j)] - m[i][j]).abs() < 1e-9,
                    "M[{i}{j}] = {} vs {}",
                    mm[(i, j)],
                    m[i][j]
                );
            }
        }
    }
}

#[test]
fn pendulum_inverse_dynamics_closed_form() {
    let text = format!(
        r#"<OpenSimDocument Version="40000"><Model name="p"><gravity>0 -{G} 0</gravity>
<BodySet name="b"><objects>{}</objects></BodySet><JointSet name="j"><objects>{}</objects></JointSet></Model></OpenSimDocument>"#,
        body("link1", M1, A1, I1),
        pin("j1", "ground", "link1", 0.0, "q1")
    );
    let model = model_from(&text);
    let mut data = Data::new(&model);
    for (q, u, ud) in [(0.4, 1.3, -0.8), (-2.0, 0.0, 3.0)] {
        data.q[0] = q;
        data.u[0] = u;
        data.udot[0] = ud;
        rnea::inverse_dynamics(&model, &mut data);
        let expect = (I1 + M1 * A1 * A1) * ud + M1 * G * A1 * f64::sin(q);
        assert!(
            (data.tau[0] - expect).abs() < 1e-9,
            "{} vs {}",
            data.tau[0],
            expect
        );
    }
}

#[test]
fn double_pendulum_pin_joints_closed_form() {
    check(&double_pendulum(pin));
}

#[test]
fn double_pendulum_custom_joints_closed_form() {
    check(&double_pendulum(custom_pin));
}

#[test]
fn custom_joint_reproducing_pin_joint_gives_identical_results() {
    let a = double_pendulum(pin);
    let b = double_pendulum(custom_pin);
    let (mut da, mut db) = (Data::new(&a), Data::new(&b));
    for d in [&mut da, &mut db] {
        d.q.copy_from_slice(&[0.8, -1.9]);
        d.u.copy_from_slice(&[-0.6, 2.2]);
        d.udot.copy_from_slice(&[1.4, -3.1]);
    }
    rnea::inverse_dynamics(&a, &mut da);
    rnea::inverse_dynamics(&b, &mut db);
    for i in 0..2 {
        assert!(
            (da.tau[i] - db.tau[i]).abs() < 1e-12,
            "{} vs {}",
            da.tau[i],
            db.tau[i]
        );
        assert!((da.position[2] - db.position[2]).norm() < 1e-14);
    }
}

/// On a model with CustomJoints whose transforms are splines of the
/// coordinates (gait2392's knees), the velocity terms of RNEA must satisfy
/// Lagrange's equations: τ(q, u, u̇=0, g=0) = Ṁ u − ∂T/∂q, with
/// Ṁ = Σ_k ∂M/∂q_k u_k and T = ½ uᵀ M u (q̇ = u for these joints).
#[test]
fn rnea_velocity_terms_satisfy_lagrange_on_spline_custom_joints() {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/models/gait2392/gait2392_thelen2003muscle.osim");
    if !path.is_file() {
        eprintln!("SKIP rnea_velocity_terms_satisfy_lagrange_on_spline_custom_joints: ../shared/models is absent");
        return;
    }
    let mut model = compile(&ModelSpec::read(&path).unwrap()).unwrap();
    model.gravity = nalgebra::Vector3::zeros();
    let n = model.nq();
    let mut data = Data::new(&model);
    let q0: Vec<f64> = (0..n)
        .map(|i| 0.3 * ((i as f64) * 1.7).sin() - 0.4 * (i % 3 == 0) as i32 as f64)
        .collect();
    let u: Vec<f64> = (0..n).map(|i| 0.8 * ((i as f64) * 0.9).cos()).collect();
    let mass_at = |q: &[f64], data: &mut Data| {
        data.q.copy_from_slice(q);
        kinematics::positions(&model, data);
        mass_matrix(&model, data)
    };
    let h = 1e-6;
    let mut mdot = nalgebra::DMatrix::zeros(n, n);
    let mut dtdq = vec![0.0; n];
    let uv = nalgebra::DVector::from_column_slice(&u);
    for k in 0..n {
        let mut qp = q0.clone();
        qp[k] += h;
        let mut qm = q0.clone();
        qm[k] -= h;
        let dm = (mass_at(&qp, &mut data) - mass_at(&qm, &mut data)) / (2.0 * h);
        dtdq[k] = 0.5 * (uv.transpose() * &dm * &uv)[(0, 0)];
        mdot += dm * u[k];
    }
    let expect = &mdot * &uv;
    data.q.copy_from_slice(&q0);
    data.u.copy_from_slice(&u);
    data.udot.iter_mut().for_each(|x| *x = 0.0);
    data.clear_applied();
    rnea::inverse_dynamics(&model, &mut data);
    let scale = expect.amax().max(1.0);
    for i in 0..n {
        let lagrange = expect[i] - dtdq[i];
        assert!(
            (data.tau[i] - lagrange).abs() < 1e-6 * scale,
            "{}: RNEA {} vs Lagrange {}",
            model.coordinates[i].name,
            data.tau[i],
            lagrange
        );
    }
    // And the mass matrix equals RNEA's response to unit accelerations.
    data.u.iter_mut().for_each(|x| *x = 0.0);
    let m = mass_at(&q0, &mut data);
    for j in 0..n {
        data.q.copy_from_slice(&q0);
        data.udot
            .iter_mut()
            .enumerate()
            .for_each(|(i, x)| *x = (i == j) as i32 as f64);
        rnea::inverse_dynamics(&model, &mut data);
        for i in 0..n {
            assert!((data.tau[i] - m[(i, j)]).abs() < 1e-10, "M[{i},{j}]");
        }
    }
}

/// The 3.x layout (joints inside bodies, location_in_parent, inertia_xx...)
/// gives the same model as the 4.0 layout, with OpenSim's 6-significant-digit
/// rounding of joint offsets and inertias applied on upgrade.
#[test]
fn opensim_3x_layout_matches_40_layout() {
    let body3 = |name: &str, m: f64, a: f64, i: f64, joint: &str| {
        format!(
            r#"<Body name="{name}"><mass>{m}</mass><mass_center>0 {} 0</mass_center>
<inertia_xx>{i}</inertia_xx><inertia_yy>{i}</inertia_yy><inertia_zz>{i}</inertia_zz>
<inertia_xy>0</inertia_xy><inertia_xz>0</inertia_xz><inertia_yz>0</inertia_yz><Joint>{joint}</Joint></Body>"#,
            -a
        )
    };
    let pin3 = |name: &str, parent: &str, loc: f64, coord: &str| {
        format!(
            r#"<PinJoint name="{name}"><parent_body>{parent}</parent_body><location_in_parent>0 {loc} 0</location_in_parent>
<orientation_in_parent>0 0 0</orientation_in_parent><location>0 0 0</location><orientation>0 0 0</orientation>
<CoordinateSet><objects><Coordinate name="{coord}"><default_value>0</default_value></Coordinate></objects></CoordinateSet></PinJoint>"#
        )
    };
    let text = format!(
        r#"<OpenSimDocument Version="30000"><Model name="dp3"><gravity>0 -{G} 0</gravity>
<BodySet><objects><Body name="ground"><mass>0</mass><Joint/></Body>{}{}</objects></BodySet></Model></OpenSimDocument>"#,
        body3("link1", M1, A1, I1, &pin3("j1", "ground", 0.0, "q1")),
        body3("link2", M2, A2, I2, &pin3("j2", "link1", -L1, "q2")),
    );
    let m3 = model_from(&text);
    let m4 = double_pendulum(pin);
    assert_eq!(m3.nq(), 2);
    let (mut d3, mut d4) = (Data::new(&m3), Data::new(&m4));
    for d in [&mut d3, &mut d4] {
        d.q.copy_from_slice(&[0.4, -0.9]);
        d.u.copy_from_slice(&[1.0, 0.3]);
        d.udot.copy_from_slice(&[-0.5, 2.0]);
    }
    rnea::inverse_dynamics(&m3, &mut d3);
    rnea::inverse_dynamics(&m4, &mut d4);
    for i in 0..2 {
        assert!(
            (d3.tau[i] - d4.tau[i]).abs() < 1e-12,
            "{} vs {}",
            d3.tau[i],
            d4.tau[i]
        );
    }
    // 6 significant digits on upgrade: 0.123456789 -> 0.123457
    let text = text.replacen(
        "<location_in_parent>0 0 0</location_in_parent>",
        "<location_in_parent>0.123456789 0 0</location_in_parent>",
        1,
    );
    let m = model_from(&text);
    let x = m.joints[1].x_pf.translation.x;
    assert_eq!(
        x, 0.123457,
        "offset {x} was not rounded as OpenSim's 3.x upgrade rounds it"
    );
}

/// The mass matrix, assembled body by body on each body's chain columns,
/// against its definition through inverse dynamics: column k is
/// τ(q, u = 0, u̇ = e_k) with gravity off. Whole-body models with many
/// chains (gait2392: 23 coordinates, Rajagopal: 39).
#[test]
fn mass_matrix_columns_are_inverse_dynamics_of_unit_accelerations() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    for file in [
        "gait2392/gait2392_thelen2003muscle.osim",
        "rajagopal2016/RajagopalLaiUhlrich2023.osim",
    ] {
        let path = root.join(file);
        if !path.is_file() {
            eprintln!(
                "SKIP mass_matrix_columns_are_inverse_dynamics_of_unit_accelerations: {} is absent",
                path.display()
            );
            continue;
        }
        let model = compile(&ModelSpec::read(&path).unwrap()).unwrap();
        let n = model.nq();
        let mut data = Data::new(&model);
        for (i, q) in data.q.iter_mut().enumerate() {
            *q = 0.3 * ((i as f64) * 1.3).sin();
        }
        kinematics::positions(&model, &mut data);
        let m = mass_matrix(&model, &data);
        let scale = m.amax();
        let mut worst = 0.0f64;
        for k in 0..n {
            data.u.iter_mut().for_each(|x| *x = 0.0);
            data.udot.iter_mut().for_each(|x| *x = 0.0);
            data.udot[k] = 1.0;
            data.clear_applied();
            kinematics::full(&model, &mut data);
            rnea::inverse_dynamics_after_kinematics(&model, &mut data, false);
            for i in 0..n {
                worst = worst.max((m[(i, k)] - data.tau[i]).abs());
                assert!(
                    (m[(i, k)] - m[(k, i)]).abs() <= 1e-12 * scale,
                    "{file}: M is not symmetric at ({i}, {k})"
                );
            }
        }
        assert!(
            worst <= 1e-12 * scale,
            "{file}: M differs from inverse dynamics by {worst:e} (largest entry {scale:e})"
        );
    }
}
