//! Tests of the actuator and passive-force elements.

use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, Vector3};

use super::*;
use crate::dynamics::{kinematics, Data};
use crate::model::{compile, Model};
use crate::parse::osim::ModelSpec;
use crate::xml;

const L1: f64 = 0.9;
const L2: f64 = 0.7;

fn frame(name: &str, parent: &str, t: [f64; 3], o: [f64; 3]) -> String {
    format!(
        r#"<PhysicalOffsetFrame name="{name}"><socket_parent>{parent}</socket_parent><translation>{} {} {}</translation><orientation>{} {} {}</orientation></PhysicalOffsetFrame>"#,
        t[0], t[1], t[2], o[0], o[1], o[2]
    )
}

fn joint(
    kind: &str,
    name: &str,
    parent: &str,
    child: &str,
    loc: [f64; 3],
    ori: [f64; 3],
    coord: &str,
) -> String {
    let ppath = if parent == "ground" {
        "/ground".to_string()
    } else {
        format!("/bodyset/{parent}")
    };
    format!(
        r#"<{kind} name="{name}">
  <socket_parent_frame>{parent}_offset</socket_parent_frame>
  <socket_child_frame>{child}_offset</socket_child_frame>
  <coordinates><Coordinate name="{coord}"/></coordinates>
  <frames>{}{}</frames>
</{kind}>"#,
        frame(&format!("{parent}_offset"), &ppath, loc, [0.0; 3]),
        frame(
            &format!("{child}_offset"),
            &format!("/bodyset/{child}"),
            [0.0; 3],
            ori
        ),
    )
}

fn body(name: &str) -> String {
    format!(
        r#"<Body name="{name}"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>"#
    )
}

/// Double pendulum in the x-y plane (pins about z at the ground origin and at
/// (0, −L1, 0) on link1), and a cart sliding on link2. link2's child frame is
/// tilted about x so that link2's body axes differ from the joint's, and the
/// slider's parent frame is at (0, −L2, 0) on link2; the slider axis is the
/// x axis of link2 (the joint frames are not rotated in link2).
fn test_model() -> Model {
    let text = format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="t">
<BodySet name="bodyset"><objects>{}{}{}</objects></BodySet>
<JointSet name="jointset"><objects>{}{}{}</objects></JointSet>
</Model></OpenSimDocument>"#,
        body("link1"),
        body("link2"),
        body("cart"),
        joint("PinJoint", "j1", "ground", "link1", [0.0; 3], [0.0; 3], "q1"),
        joint(
            "PinJoint",
            "j2",
            "link1",
            "link2",
            [0.0, -L1, 0.0],
            [0.5, 0.0, 0.0],
            "q2"
        ),
        joint(
            "SliderJoint",
            "j3",
            "link2",
            "cart",
            [0.0, -L2, 0.0],
            [0.0; 3],
            "q3"
        ),
    );
    let root = xml::parse_str(&text, Path::new("test.osim")).unwrap();
    compile(&ModelSpec::from_document(&root, Path::new("test.osim")).unwrap()).unwrap()
}

fn el(text: &str) -> xml::Element {
    xml::parse_str(text, Path::new("forces.xml")).unwrap()
}

fn actuator(model: &Model, text: &str) -> Actuator {
    Actuator::from_xml(&el(text), model)
        .unwrap()
        .expect("an actuator")
}

fn passive(model: &Model, text: &str) -> PassiveForce {
    PassiveForce::from_xml(&el(text), model)
        .unwrap()
        .expect("a passive force")
}

fn data_at(model: &Model, q: &[f64], u: &[f64]) -> Data {
    let mut d = Data::new(model);
    d.q.copy_from_slice(q);
    d.u.copy_from_slice(u);
    kinematics::positions(model, &mut d);
    d
}

fn unit_gen(model: &Model, a: &Actuator, d: &Data) -> Vec<f64> {
    let mut g = vec![0.0; model.nq()];
    a.add_unit_generalized_force(model, d, &mut g);
    g
}

fn rz(a: f64) -> Matrix3<f64> {
    crate::model::rot_z(a)
}

fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tol * (1.0 + y.abs()),
            "{what}: {a:?} vs {b:?}"
        );
    }
}

const Q: [f64; 3] = [0.4, -0.9, 0.25];

#[test]
fn coordinate_actuator_is_unit_vector() {
    let m = test_model();
    let a = actuator(
        &m,
        r#"<CoordinateActuator name="r2"><coordinate>q2</coordinate><optimal_force>50</optimal_force>
           <min_control>-2</min_control><max_control>3</max_control></CoordinateActuator>"#,
    );
    assert_eq!(
        (
            a.optimal_force,
            a.min_control,
            a.max_control,
            a.applies_force
        ),
        (50.0, -2.0, 3.0, true)
    );
    let d = data_at(&m, &Q, &[0.0; 3]);
    let k = m.coordinate_index("q2").unwrap();
    let mut want = vec![0.0; 3];
    want[k] = 1.0;
    assert_eq!(unit_gen(&m, &a, &d), want);
    assert_eq!(a.record_labels(), vec!["r2".to_string()]);
    // Defaults: optimal_force 1, controls unbounded.
    let a = actuator(
        &m,
        r#"<CoordinateActuator name="r"><coordinate>q1</coordinate></CoordinateActuator>"#,
    );
    assert_eq!(
        (a.optimal_force, a.min_control, a.max_control),
        (1.0, f64::NEG_INFINITY, f64::INFINITY)
    );
}

/// Hand computation: x = R(q1)(0,−L1,0) + R(q1+q2)·R_x(0.5)·p, τ1 = (x × F)_z,
/// τ2 = ((x − p_j2) × F)_z; the slider coordinate is outboard, so τ3 = 0.
#[test]
fn point_actuator_on_pendulum_matches_r_cross_f() {
    let m = test_model();
    let d = data_at(&m, &Q, &[0.0; 3]);
    let (q1, q2) = (Q[0], Q[1]);
    let p = Vector3::new(0.1, -0.3, 0.2);
    let dir = Vector3::new(0.6, 0.0, 0.8);
    let p_j2 = rz(q1) * Vector3::new(0.0, -L1, 0.0);
    // The child frame is rotated by R_x(0.5) in link2: R_link2 = R_z(q1+q2) R_x(0.5)ᵀ.
    let r2 = rz(q1 + q2) * crate::model::rot_x(0.5).transpose();
    let idx = |n: &str| m.coordinate_index(n).unwrap();
    let expect = |x: Vector3<f64>, f: Vector3<f64>| {
        let mut t = vec![0.0; 3];
        t[idx("q1")] = x.cross(&f).z;
        t[idx("q2")] = (x - p_j2).cross(&f).z;
        t
    };
    let xml = |pg: bool, fg: bool| {
        format!(
            r#"<PointActuator name="F"><body>link2</body><point>0.1 -0.3 0.2</point><point_is_global>{pg}</point_is_global>
               <direction>3 0 4</direction><force_is_global>{fg}</force_is_global></PointActuator>"#
        )
    };
    // Body point, body direction.
    let a = actuator(&m, &xml(false, false));
    assert_close(
        &unit_gen(&m, &a, &d),
        &expect(p_j2 + r2 * p, r2 * dir),
        1e-12,
        "local/local",
    );
    // Body point, global direction.
    let a = actuator(&m, &xml(false, true));
    assert_close(
        &unit_gen(&m, &a, &d),
        &expect(p_j2 + r2 * p, dir),
        1e-12,
        "local/global",
    );
    // Global point, body direction.
    let a = actuator(&m, &xml(true, false));
    assert_close(
        &unit_gen(&m, &a, &d),
        &expect(p, r2 * dir),
        1e-12,
        "global/local",
    );
    // Global point, global direction.
    let a = actuator(&m, &xml(true, true));
    assert_close(
        &unit_gen(&m, &a, &d),
        &expect(p, dir),
        1e-12,
        "global/global",
    );
}

/// Generalized force of a point force by virtual work: τ_k = F · ∂x/∂q_k
/// (u = q̇ for pins and sliders), by central differences.
#[test]
fn point_actuator_on_slider_body_by_virtual_work() {
    let m = test_model();
    let a = actuator(
        &m,
        r#"<PointActuator name="F"><body>cart</body><point>0.2 0.1 -0.3</point>
           <direction>1 2 -0.5</direction></PointActuator>"#,
    );
    let cart = m.body_index("cart").unwrap();
    let p = Vector3::new(0.2, 0.1, -0.3);
    let d = data_at(&m, &Q, &[0.0; 3]);
    let f = d.rotation[cart] * Vector3::new(1.0, 2.0, -0.5).normalize();
    let h = 1e-6;
    let mut want = vec![0.0; 3];
    for k in 0..3 {
        let (mut qp, mut qm) = (Q, Q);
        qp[k] += h;
        qm[k] -= h;
        let xp = data_at(&m, &qp, &[0.0; 3]).station_position(cart, &p);
        let xm = data_at(&m, &qm, &[0.0; 3]).station_position(cart, &p);
        want[k] = f.dot(&((xp - xm) / (2.0 * h)));
    }
    assert!(
        want[m.coordinate_index("q3").unwrap()].abs() > 0.1,
        "slider must feel the force"
    );
    assert_close(&unit_gen(&m, &a, &d), &want, 1e-8, "virtual work");
}

/// OpenSim applies +axis on bodyA and −axis on bodyB (TorqueActuator.cpp,
/// `implProduceForces`). On link2 (A) against link1 (B) about global z:
/// τ1 = +1 − 1 = 0 (both outboard of j1), τ2 = +1 (only A is outboard of j2).
#[test]
fn torque_actuator_between_bodies() {
    let m = test_model();
    let d = data_at(&m, &Q, &[0.0; 3]);
    let idx = |n: &str| m.coordinate_index(n).unwrap();
    let xml = |a: &str, b: &str, axis: &str, global: bool| {
        format!(
            r#"<TorqueActuator name="T"><bodyA>{a}</bodyA><bodyB>{b}</bodyB><axis>{axis}</axis>
               <torque_is_global>{global}</torque_is_global></TorqueActuator>"#
        )
    };
    let mut want = vec![0.0; 3];
    want[idx("q2")] = 1.0;
    let a = actuator(&m, &xml("link2", "link1", "0 0 2", true));
    assert_close(&unit_gen(&m, &a, &d), &want, 1e-14, "A=link2, B=link1");
    // Swapped bodies: the sign flips.
    let a = actuator(&m, &xml("link1", "link2", "0 0 1", true));
    want[idx("q2")] = -1.0;
    assert_close(&unit_gen(&m, &a, &d), &want, 1e-14, "A=link1, B=link2");
    // Against ground (residual moment): τ1 = τ2 = 1; the slider feels nothing.
    let a = actuator(&m, &xml("./bodyset/link2", "ground", "0 0 1", true));
    want = vec![0.0; 3];
    want[idx("q1")] = 1.0;
    want[idx("q2")] = 1.0;
    assert_close(&unit_gen(&m, &a, &d), &want, 1e-14, "A=link2, B=ground");
    // Axis fixed in body A: only its ground z component drives the pins.
    let axis_b = Vector3::new(0.0, 0.6, 0.8);
    let link2 = m.body_index("link2").unwrap();
    let tz = (d.rotation[link2] * axis_b).z;
    // R_link2 = R_z(q1+q2)·R_x(0.5)ᵀ, and R_z keeps z components.
    assert!(
        (tz - (0.8 * 0.5f64.cos() - 0.6 * 0.5f64.sin())).abs() < 1e-14,
        "{tz}"
    );
    let a = actuator(&m, &xml("link2", "ground", "0 0.6 0.8", false));
    want[idx("q1")] = tz;
    want[idx("q2")] = tz;
    assert_close(&unit_gen(&m, &a, &d), &want, 1e-14, "body-fixed axis");
}

#[test]
fn legacy_spelling_and_disabled() {
    let m = test_model();
    let a = actuator(
        &m,
        r#"<CoordinateActuator name="r"><isDisabled> true </isDisabled><min_control> -infinity </min_control>
           <max_control> infinity </max_control><coordinate> q3 </coordinate><optimal_force> 2.5 </optimal_force></CoordinateActuator>"#,
    );
    assert!(!a.applies_force);
    assert_eq!(a.optimal_force, 2.5);
    assert_eq!(a.min_control, f64::NEG_INFINITY);
    let a = actuator(
        &m,
        r#"<CoordinateActuator name="r"><appliesForce>false</appliesForce><coordinate>q3</coordinate></CoordinateActuator>"#,
    );
    assert!(!a.applies_force);
    // Non-actuators are not ours.
    assert!(
        Actuator::from_xml(&el(r#"<Thelen2003Muscle name="m"/>"#), &m)
            .unwrap()
            .is_none()
    );
    assert!(
        Actuator::from_xml(&el(r#"<CoordinateLimitForce name="m"/>"#), &m)
            .unwrap()
            .is_none()
    );
}

#[test]
fn bad_actuators_are_located_errors() {
    let m = test_model();
    for (text, want) in [
        ("<CoordinateActuator name=\"r\">\n<coordinate>nope</coordinate></CoordinateActuator>", "unknown coordinate 'nope'"),
        ("<CoordinateActuator name=\"r\">\n</CoordinateActuator>", "missing property <coordinate>"),
        ("<PointActuator name=\"r\">\n<body>nobody</body></PointActuator>", "unknown body 'nobody'"),
        ("<PointActuator name=\"r\">\n<body>ground</body></PointActuator>", "unknown body 'ground'"),
        ("<PointActuator name=\"r\">\n<body>link1</body><direction>0 0 0</direction></PointActuator>", "non-zero"),
        ("<TorqueActuator name=\"r\">\n<bodyA>link1</bodyA></TorqueActuator>", "missing property <bodyB>"),
        ("<TorqueActuator name=\"r\">\n<bodyA>link1</bodyA><bodyB>x</bodyB></TorqueActuator>", "unknown body or frame 'x'"),
        ("<CoordinateActuator name=\"r\">\n<coordinate>q1</coordinate><optimal_force>abc</optimal_force></CoordinateActuator>", "abc"),
        ("<CoordinateActuator name=\"r\">\n<coordinate>q1</coordinate><optimal_force>0</optimal_force></CoordinateActuator>", "optimal_force"),
        ("<CoordinateActuator name=\"r\">\n<coordinate>q1</coordinate><min_control>2</min_control><max_control>1</max_control></CoordinateActuator>", "min_control"),
        ("<PointToPointActuator name=\"r\">\n</PointToPointActuator>", "not supported"),
    ] {
        let e = Actuator::from_xml(&el(text), &m).unwrap_err().to_string();
        assert!(e.contains(want) && e.contains("forces.xml") && e.contains("line "), "{text}: {e}");
    }
}

// --------------------------------------------------------------------------
// Passive forces

/// Reference numbers from OpenSim 4.6 (venv): a one-body model with a PinJoint
/// (then a SliderJoint) and `CoordinateLimitForce("q", 30, 10, -20, 20, 0.05, 5)`
/// (upper limit, upper stiffness, lower limit, lower stiffness, damping,
/// transition); values are `calcLimitForce(s)`, `computePotentialEnergy(s)`
/// after `setValue`, `setSpeedValue`, `realizeDynamics`.
const CLF_ROT: &[(f64, f64, f64, f64)] = &[
    (0.0, 0.0, 0.0, 0.0),
    (0.52, 1.0, 0.0, 0.0),
    (0.54, -0.5, -0.39090379667288877, 0.0015966229851303478),
    (0.56, 0.3, -7.544852332901922, 0.06095950395504519),
    (0.7, 2.0, -106.80003454288449, 8.291144271084258),
    (-0.33, 0.4, 0.0, 0.0),
    (-0.36, -1.0, 0.24875408910708582, 0.00045818375637711293),
    (-0.5, 0.0, 172.95779513082323, 11.80595511105447),
    (0.6, 0.1, -43.361653418157836, 1.050911342528692),
    (-0.3, 0.2, 0.0, 0.0),
];
const CLF_SLIDER: &[(f64, f64, f64, f64)] = &[
    (0.0, 0.0, 0.0, 0.0),
    (0.7, 2.0, 0.0, 0.0),
    (35.0, 0.1, -50.005, 89.28571428571429),
    (-22.0, 0.2, 12.694425599999986, 5.82217142857143),
    (31.0, 0.5, -0.5806480000000002, 0.12274285714285717),
    (34.9, -1.0, -48.946200540160035, 84.33581034143997),
    (-24.0, 0.0, 75.3664, 89.87794285714288),
    (-26.0, 3.0, 119.85, 288.57142857142856),
];

const CLF_XML: &str = r#"<CoordinateLimitForce name="lim"><coordinate>COORD</coordinate>
  <upper_stiffness>10</upper_stiffness><upper_limit>30</upper_limit><lower_stiffness>20</lower_stiffness>
  <lower_limit>-20</lower_limit><damping>0.05</damping><transition>5</transition></CoordinateLimitForce>"#;

#[test]
fn coordinate_limit_force_matches_opensim() {
    let m = test_model();
    for (coord, table) in [("q2", CLF_ROT), ("q3", CLF_SLIDER)] {
        let f = passive(&m, &CLF_XML.replace("COORD", coord));
        assert_eq!(
            f.record_labels(),
            vec!["lim".to_string(), "PotentialEnergy".into()]
        );
        let k = m.coordinate_index(coord).unwrap();
        for &(q, u, tau, pe) in table {
            let (mut qs, mut us) = ([0.1; 3], [0.0; 3]);
            qs[k] = q;
            us[k] = u;
            let d = data_at(&m, &qs, &us);
            let mut g = vec![0.0; 3];
            let v = f.add_generalized_force(&m, &d, 0.0, &mut g);
            let mut want = vec![0.0; 3];
            want[k] = tau;
            assert_close(&g, &want, 1e-12, &format!("{coord} q={q} u={u}"));
            assert_eq!(v, g[k]);
            assert_close(
                &f.record_values(&d, 0.0),
                &[tau, pe],
                1e-12,
                &format!("{coord} record q={q}"),
            );
        }
    }
}

/// The formula of §8.4 written out directly, in the transition band and
/// beyond, for a rotational coordinate (degrees in the XML).
#[test]
fn coordinate_limit_force_formula() {
    let m = test_model();
    let f = passive(&m, &CLF_XML.replace("COORD", "q1"));
    let w = std::f64::consts::PI / 180.0;
    let (qu, ql, ku, kl, damp, tr) = (30.0 * w, -20.0 * w, 10.0 / w, 20.0 / w, 0.05 / w, 5.0 * w);
    let s = |t: f64| t * t * t * (10.0 - 15.0 * t + 6.0 * t * t);
    for (q, u) in [
        (31.0 * w, 0.3),
        (33.5 * w, -1.0),
        (40.0 * w, 0.5),
        (-21.0 * w, 0.7),
        (-24.9 * w, 0.0),
        (-30.0 * w, -2.0),
        (0.0, 5.0),
    ] {
        let kup = if q <= qu {
            0.0
        } else if q >= qu + tr {
            ku
        } else {
            ku * s((q - qu) / tr)
        };
        let klo = if q >= ql {
            0.0
        } else if q <= ql - tr {
            kl
        } else {
            kl * (1.0 - s((q - (ql - tr)) / tr))
        };
        let want = -kup * (q - qu) + klo * (ql - q) - damp * (kup / ku + klo / kl) * u;
        let d = data_at(&m, &[q, 0.0, 0.0], &[u, 0.0, 0.0]);
        let mut g = vec![0.0; 3];
        let v = f.add_generalized_force(&m, &d, 0.0, &mut g);
        assert!(
            (v - want).abs() <= 1e-12 * (1.0 + want.abs()),
            "q={q}: {v} vs {want}"
        );
    }
    // Continuity at the band edges.
    let at = |q: f64| {
        let d = data_at(&m, &[q, 0.0, 0.0], &[0.0; 3]);
        f.add_generalized_force(&m, &d, 0.0, &mut [0.0; 3])
    };
    assert_eq!(at(qu), 0.0);
    assert!((at(qu + tr) - at(qu + tr - 1e-9)).abs() < 1e-6);
}

/// Reference numbers from OpenSim 4.6 (venv): one PinJoint coordinate "q",
/// `ExpressionBasedCoordinateForce("q", expr)`, `calcExpressionForce(s)` at
/// (q, q̇) = (0.7, −1.3) and (0.05, 0.4).
const EBCF: &[(&str, f64, f64, f64)] = &[
    ("-q^2", 0.7, -1.3, -0.48999999999999994),
    ("2^3^2", 0.7, -1.3, 512.0),
    ("step(q-0.1)*(-50)", 0.7, -1.3, -50.0),
    ("-q*2^-qdot", 0.7, -1.3, -1.7236021786828828),
    ("a+b; a=2*b; b=q^2", 0.7, -1.3, 1.4699999999999998),
    (
        "k*(q-q0)-c*qdot; k=-10; q0=0.5; c = 0.3",
        0.7,
        -1.3,
        -1.6099999999999994,
    ),
    (
        "erf(q)*erfc(qdot)+sec(q)-csc(q)+cot(q)",
        0.7,
        -1.3,
        2.2533036588749953,
    ),
    (
        "min(q,qdot)-max(q,qdot)+abs(qdot)+recip(q)+square(qdot)+cube(q)+delta(q-0.7)",
        0.7,
        -1.3,
        3.761571428571429,
    ),
    (
        "-1.5*exp(-10*(q-0.5))+1.5*exp(10*(-q-0.5)) - 0.1*qdot",
        0.7,
        -1.3,
        -0.07299370853638915,
    ),
    ("1/2*q", 0.7, -1.3, 0.35),
    ("-q^2", 0.05, 0.4, -0.0025000000000000005),
    ("2^3^2", 0.05, 0.4, 512.0),
    ("step(q-0.1)*(-50)", 0.05, 0.4, -0.0),
    ("-q*2^-qdot", 0.05, 0.4, -0.03789291416275995),
    ("a+b; a=2*b; b=q^2", 0.05, 0.4, 0.0075000000000000015),
    ("k*(q-q0)-c*qdot; k=-10; q0=0.5; c = 0.3", 0.05, 0.4, 4.38),
    (
        "erf(q)*erfc(qdot)+sec(q)-csc(q)+cot(q)",
        0.05,
        0.4,
        1.0084687472426275,
    ),
    (
        "min(q,qdot)-max(q,qdot)+abs(qdot)+recip(q)+square(qdot)+cube(q)+delta(q-0.7)",
        0.05,
        0.4,
        20.210125,
    ),
    (
        "-1.5*exp(-10*(q-0.5))+1.5*exp(10*(-q-0.5)) - 0.1*qdot",
        0.05,
        0.4,
        -135.05956679362504,
    ),
    ("1/2*q", 0.05, 0.4, 0.025),
    ("-qdot^2^0.5", 0.05, 0.4, -0.27367040993356445),
];

#[test]
fn expression_based_coordinate_force_matches_opensim() {
    let m = test_model();
    let k = m.coordinate_index("q2").unwrap();
    for &(expr, q, u, want) in EBCF {
        let f = passive(
            &m,
            &format!(
                "<ExpressionBasedCoordinateForce name=\"e\"><coordinate>q2</coordinate><expression> {} </expression></ExpressionBasedCoordinateForce>",
                expr.replace('<', "&lt;")
            ),
        );
        let (mut qs, mut us) = ([0.0; 3], [0.0; 3]);
        qs[k] = q;
        us[k] = u;
        let d = data_at(&m, &qs, &us);
        let mut g = vec![0.0; 3];
        let v = f.add_generalized_force(&m, &d, 0.0, &mut g);
        assert!(
            (v - want).abs() <= 1e-13 * (1.0 + want.abs()),
            "{expr} at q={q}: {v} vs OpenSim {want}"
        );
        assert_eq!(g[k], v);
        assert_eq!(f.record_labels(), vec!["e".to_string()]);
    }
    // Lepton gives NaN for a negative base to a non-integer power; so do we.
    let f = passive(&m, "<ExpressionBasedCoordinateForce name=\"e\"><coordinate>q2</coordinate><expression>-qdot^2^0.5</expression></ExpressionBasedCoordinateForce>");
    let d = data_at(&m, &[0.0, 0.7, 0.0], &[0.0, -1.3, 0.0]);
    assert!(f.add_generalized_force(&m, &d, 0.0, &mut [0.0; 3]).is_nan());
    // Defaults: expression "0.0"; unnamed force gets OpenSim's default name.
    let f = passive(&m, "<ExpressionBasedCoordinateForce><coordinate>q1</coordinate></ExpressionBasedCoordinateForce>");
    assert_eq!(
        f.record_labels(),
        vec!["expressionCoordForce_q1".to_string()]
    );
    assert_eq!(f.add_generalized_force(&m, &d, 0.0, &mut [0.0; 3]), 0.0);
}

#[test]
fn bad_expression_names_element_and_line() {
    let m = test_model();
    let text = "<ForceSet>\n<ExpressionBasedCoordinateForce name=\"e\">\n<coordinate>q1</coordinate>\n<expression>k*theta</expression>\n</ExpressionBasedCoordinateForce></ForceSet>";
    let root = el(text);
    let e = PassiveForce::from_xml(&root.children[0], &m)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 4")
            && e.contains("forces.xml")
            && e.contains("unknown variable 'k'")
            && e.contains("'e'"),
        "{e}"
    );
    let e = PassiveForce::from_xml(
        &el("<ExpressionBasedCoordinateForce name=\"e\"><coordinate>qq</coordinate></ExpressionBasedCoordinateForce>"),
        &m,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("unknown coordinate 'qq'"), "{e}");
}

#[test]
fn spring_generalized_force() {
    let m = test_model();
    let f = passive(
        &m,
        "<SpringGeneralizedForce name=\"s\"><coordinate>q3</coordinate><stiffness>40</stiffness><rest_length>0.1</rest_length><viscosity>2</viscosity></SpringGeneralizedForce>",
    );
    assert_eq!(f.record_labels(), vec!["s_Force".to_string()]);
    let d = data_at(&m, &[0.0, 0.0, 0.35], &[0.0, 0.0, -0.5]);
    let mut g = vec![0.0; 3];
    let v = f.add_generalized_force(&m, &d, 0.0, &mut g);
    let want = -40.0 * (0.35 - 0.1) - 2.0 * (-0.5);
    assert_eq!(v, want);
    assert_eq!(g[m.coordinate_index("q3").unwrap()], want);
}

/// PointToPointSpring between ground and link1: tension k(d − L0) along the
/// line; τ1 = (x₁ × F₁)_z with F₁ = tension·(p_ground − x₁)/d on link1.
#[test]
fn point_to_point_spring() {
    let m = test_model();
    let f = passive(
        &m,
        r#"<PointToPointSpring name="p"><socket_body1>/bodyset/link1</socket_body1><socket_body2>/ground</socket_body2>
           <point1>0.2 -0.5 0</point1><point2>1 0.5 0</point2><stiffness>100</stiffness><rest_length>0.3</rest_length></PointToPointSpring>"#,
    );
    let q1 = 0.3;
    let d = data_at(&m, &[q1, 0.0, 0.0], &[0.0; 3]);
    let x1 = rz(q1) * Vector3::new(0.2, -0.5, 0.0);
    let x2 = Vector3::new(1.0, 0.5, 0.0);
    let dist = (x2 - x1).norm();
    let tension = 100.0 * (dist - 0.3);
    let f1 = (x2 - x1) * (tension / dist);
    let mut g = vec![0.0; 3];
    let v = f.add_generalized_force(&m, &d, 0.0, &mut g);
    assert!((v - tension).abs() < 1e-12);
    assert!((g[m.coordinate_index("q1").unwrap()] - x1.cross(&f1).z).abs() < 1e-12);
    let labels = f.record_labels();
    assert_eq!(labels.len(), 12);
    assert_eq!(labels[0], "p.link1.force.X");
    assert_eq!(labels[11], "p.ground.point.Z");
    let r = f.record_values(&d, 0.0);
    assert_close(&r[0..3], f1.as_slice(), 1e-12, "force on body1");
    assert_close(&r[9..12], x2.as_slice(), 1e-12, "point2");
}

#[test]
fn disabled_and_foreign_passive_forces() {
    let m = test_model();
    let off = "<CoordinateLimitForce name=\"l\"><appliesForce>false</appliesForce><coordinate>q1</coordinate></CoordinateLimitForce>";
    assert!(PassiveForce::from_xml(&el(off), &m).unwrap().is_none());
    let off3 = "<SpringGeneralizedForce name=\"l\"><isDisabled>true</isDisabled><coordinate>q1</coordinate></SpringGeneralizedForce>";
    assert!(PassiveForce::from_xml(&el(off3), &m).unwrap().is_none());
    // A disabled force is still checked.
    let bad = "<CoordinateLimitForce name=\"l\"><appliesForce>false</appliesForce><coordinate>zz</coordinate></CoordinateLimitForce>";
    assert!(PassiveForce::from_xml(&el(bad), &m).is_err());
    for other in [
        "<Thelen2003Muscle name=\"m\"/>",
        "<CoordinateActuator name=\"a\"/>",
        "<HuntCrossleyForce name=\"c\"/>",
    ] {
        assert!(
            PassiveForce::from_xml(&el(other), &m).unwrap().is_none(),
            "{other}"
        );
    }
    let e = PassiveForce::from_xml(&el("<BushingForce name=\"b\"/>"), &m)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not supported"), "{e}");
    let e = PassiveForce::from_xml(
        &el("<CoordinateLimitForce name=\"l\">\n<coordinate>q1</coordinate><transition>0</transition></CoordinateLimitForce>"),
        &m,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("transition") && e.contains("line 2"), "{e}");
}

// --------------------------------------------------------------------------
// Force-set files

#[test]
fn force_set_file_layouts() {
    let tmp = crate::test_dir::TempDir::new("statopt_forces");
    let dir = tmp.path().to_path_buf();
    let doc = dir.join("doc.xml");
    std::fs::write(&doc, "<OpenSimDocument Version=\"40000\"><ForceSet name=\"r\"><objects><CoordinateActuator name=\"a\"/><PointActuator name=\"b\"/></objects></ForceSet></OpenSimDocument>").unwrap();
    let names: Vec<String> = read_force_set_file(&doc)
        .unwrap()
        .iter()
        .map(|e| e.name_attr().to_string())
        .collect();
    assert_eq!(names, ["a", "b"]);
    let bare = dir.join("bare.xml");
    std::fs::write(
        &bare,
        "<ForceSet name=\"r\">\n<objects><TorqueActuator name=\"t\"/></objects></ForceSet>",
    )
    .unwrap();
    assert_eq!(read_force_set_file(&bare).unwrap().len(), 1);
    let wrong = dir.join("wrong.xml");
    std::fs::write(
        &wrong,
        "<OpenSimDocument Version=\"40000\">\n<Model name=\"x\"/></OpenSimDocument>",
    )
    .unwrap();
    let e = read_force_set_file(&wrong).unwrap_err().to_string();
    assert!(
        e.contains("wrong.xml") && e.contains("no <ForceSet>"),
        "{e}"
    );
    assert!(read_force_set_file(&dir.join("missing.xml")).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

fn validation_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/validation")
}

/// Every ForceSet file among the validation cases' inputs loads against the
/// case's model, and so does every non-muscle element of every case model.
#[test]
fn validation_force_sets_load() {
    let root = validation_dir();
    if !root.is_dir() {
        eprintln!("SKIP: {} absent", root.display());
        return;
    }
    let mut n_files = 0;
    let mut n_actuators = 0;
    for case in std::fs::read_dir(&root)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
    {
        let inputs = case.join("inputs");
        let Ok(entries) = std::fs::read_dir(&inputs) else {
            continue;
        };
        let files: Vec<PathBuf> = entries.filter_map(|e| e.ok()).map(|e| e.path()).collect();
        let Some(osim) = files
            .iter()
            .find(|p| p.extension().is_some_and(|x| x == "osim"))
        else {
            continue;
        };
        let spec = ModelSpec::read(osim).unwrap_or_else(|e| panic!("{e}"));
        let model = compile(&spec).unwrap_or_else(|e| panic!("{e}"));
        let mut d = Data::new(&model);
        for (i, c) in model.coordinates.iter().enumerate() {
            d.q[i] = c.default_value;
        }
        kinematics::positions(&model, &mut d);
        for f in &spec.forces {
            Actuator::from_xml(f, &model).unwrap_or_else(|e| panic!("{e}"));
            PassiveForce::from_xml(f, &model).unwrap_or_else(|e| panic!("{e}"));
        }
        for file in files
            .iter()
            .filter(|p| p.extension().is_some_and(|x| x == "xml"))
        {
            let doc = xml::parse_file(file).unwrap();
            if doc.name != "ForceSet" && doc.child("ForceSet").is_none() {
                continue;
            }
            n_files += 1;
            let members = read_force_set_file(file).unwrap();
            assert!(!members.is_empty(), "{}", file.display());
            for m in &members {
                let a = Actuator::from_xml(m, &model)
                    .unwrap_or_else(|e| panic!("{e}"))
                    .unwrap_or_else(|| {
                        panic!("{}: {} is not an actuator", file.display(), m.describe())
                    });
                assert!(a.applies_force);
                assert!(a.min_control.is_infinite() && a.max_control.is_infinite());
                let mut g = vec![0.0; model.nq()];
                a.add_unit_generalized_force(&model, &d, &mut g);
                assert!(
                    g.iter().all(|x| x.is_finite()) && g.iter().any(|x| *x != 0.0),
                    "{}: {g:?}",
                    a.name
                );
                if let ActuatorKind::Coordinate { coordinate } = a.kind {
                    assert_eq!(g.iter().filter(|x| **x != 0.0).count(), 1);
                    assert_eq!(g[coordinate], 1.0);
                }
                n_actuators += 1;
            }
            eprintln!(
                "{}: {} actuators load against {}",
                file.display(),
                members.len(),
                osim.display()
            );
        }
    }
    if n_files == 0 {
        eprintln!("SKIP: no ForceSet files under {}", root.display());
    }
    eprintln!("{n_files} force-set files, {n_actuators} actuators");
}

/// Unit generalized forces of the validation cases' residual and reserve
/// actuators against OpenSim 4.6 (venv): the model plus the `_40` force-set
/// file, gravity 0, other forces disabled, coordinates (tree order) set to
/// `Q` with `setValue(s, v, False)`, u = 0, every actuator overridden (1 for
/// the one under test, 0 for the rest); the generalized force is
/// −`InverseDynamicsSolver(m).solve(s, zeros)`.
#[test]
fn validation_actuators_match_opensim() {
    type Case<'a> = (
        &'a str,
        &'a str,
        &'a [f64],
        &'a [&'a str],
        &'a [(&'a str, &'a [f64])],
    );
    let leg: Case = (
        "leg6dof9musc_stance/inputs/leg6dof9musc.osim",
        "leg6dof9musc_stance/inputs/leg69_CMC_residuals_motors_40.xml",
        &[0.1, 0.06, 0.09, 0.31000000000000005, 0.38, 0.18, 0.52],
        &[
            "pelvis_tilt",
            "pelvis_tx",
            "pelvis_ty",
            "hip_flexion_r",
            "knee_angle_r",
            "knee_angle_pat_r",
            "ankle_angle_r",
        ],
        &[
            ("MZ", &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            ("FX", &[0.006439839968159088, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            ("FY", &[-0.06418359510533472, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]),
            ("hip_flexion_r_moment", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]),
            ("knee_angle_r_moment", &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]),
            ("ankle_angle_r_moment", &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
        ],
    );
    let gait: Case = (
        "gait10dof18musc_walk/inputs/subject01.osim",
        "gait10dof18musc_walk/inputs/gait10dof_Reserve_Actuators_40.xml",
        &[
            0.1,
            0.06,
            0.09,
            0.31000000000000005,
            0.38,
            0.45000000000000007,
            0.52,
            0.5900000000000001,
            0.66,
            0.7300000000000001,
        ],
        &[
            "pelvis_tilt",
            "pelvis_tx",
            "pelvis_ty",
            "hip_flexion_r",
            "hip_flexion_l",
            "lumbar_extension",
            "knee_angle_r",
            "knee_angle_l",
            "ankle_angle_r",
            "ankle_angle_l",
        ],
        &[
            (
                "FX",
                &[
                    0.0033943361659921575,
                    1.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
            (
                "FY",
                &[
                    -0.03383014161945288,
                    0.0,
                    1.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
            ("MZ", &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            (
                "hip_flexion_r_reserve",
                &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ),
            (
                "knee_angle_r_reserve",
                &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            ),
            (
                "ankle_angle_r_reserve",
                &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            ),
            (
                "hip_flexion_l_reserve",
                &[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ),
            (
                "knee_angle_l_reserve",
                &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            ),
            (
                "ankle_angle_l_reserve",
                &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            ),
            (
                "lumbar_extension_reserve",
                &[0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            ),
        ],
    );
    let root = validation_dir();
    for (osim, fs, q, names, want) in [leg, gait] {
        let (osim, fs) = (root.join(osim), root.join(fs));
        if !osim.is_file() || !fs.is_file() {
            eprintln!("SKIP: {} or {} absent", osim.display(), fs.display());
            continue;
        }
        let model = compile(&ModelSpec::read(&osim).unwrap()).unwrap();
        let ours: Vec<&str> = model.coordinates.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(ours, names, "tree order");
        let d = data_at(&model, q, &vec![0.0; q.len()]);
        let members = read_force_set_file(&fs).unwrap();
        assert_eq!(members.len(), want.len());
        // The 3.x spelling of the same file gives the same actuators.
        let legacy = fs.with_file_name(
            fs.file_name()
                .unwrap()
                .to_string_lossy()
                .replace("_40.xml", ".xml"),
        );
        let legacy = read_force_set_file(&legacy).unwrap();
        for (m, (name, g_want)) in members.iter().zip(want) {
            let a = Actuator::from_xml(m, &model).unwrap().unwrap();
            assert_eq!(a.name, *name);
            let b = legacy.iter().find(|e| e.name_attr() == *name).unwrap();
            assert_eq!(
                Actuator::from_xml(b, &model).unwrap().unwrap(),
                a,
                "3.x vs 4.0 spelling of {name}"
            );
            assert_close(&unit_gen(&model, &a, &d), g_want, 1e-12, name);
        }
    }
}

/// `apply_recording` adds what `apply` adds and records what
/// `evaluate` + `record` give, bit for bit, at times in and out of the data
/// (spline and linear series, repeated and out-of-order times).
#[test]
fn external_loads_apply_recording_matches_apply_and_record() {
    use crate::forces::external_loads::ExternalLoads;
    let model = test_model();
    let tmp = crate::test_dir::TempDir::new("statopt_extload");
    let dir = tmp.path().to_path_buf();
    for rows in [7usize, 3] {
        let mut mot = format!(
            "grf.mot\nversion=1\nnRows={rows}\nnColumns=10\ninDegrees=no\nendheader\n\
             time\tf_vx\tf_vy\tf_vz\tf_px\tf_py\tf_pz\tt_x\tt_y\tt_z\n"
        );
        for i in 0..rows {
            let t = 0.013 * i as f64 + 0.001 * (i * i) as f64;
            let v: Vec<String> = (0..9)
                .map(|c| format!("{}", ((c + 1) as f64 * 1.7 * t + c as f64).sin() * 50.0))
                .collect();
            mot.push_str(&format!("{t}\t{}\n", v.join("\t")));
        }
        std::fs::write(dir.join("grf.mot"), mot).unwrap();
        let xpath = two_forces_xml(&dir);
        let loads = ExternalLoads::load(&xpath, &dir, &model).unwrap();
        assert_eq!(loads.forces.len(), 2);
        for (i, t) in [0.02, 0.05, -0.1, 0.05, 0.0, 0.3, 0.013, 0.0271]
            .into_iter()
            .enumerate()
        {
            let q = [0.3 + 0.1 * i as f64, -0.7, 0.2];
            let mut d1 = data_at(&model, &q, &[0.0; 3]);
            let mut d2 = d1.clone();
            loads.apply(t, &mut d1);
            let mut record = vec![1.5];
            loads.apply_recording(t, &mut d2, &mut record);
            let mut want = vec![1.5];
            for ef in &loads.forces {
                let (f, p, tq) = ef.evaluate(t, &d1).unwrap();
                want.extend(ef.record(&f, &p, &tq, &d1));
            }
            assert_eq!(want.len(), 1 + 9 + 3);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&record), bits(&want), "rows {rows} t {t}");
            assert_eq!(d1.applied, d2.applied);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The first error of an ExternalLoads file is the one reading it force by
/// force would meet: a force's disabled flag, then its body, then its
/// force, point and torque identifiers, and a later force's error only
/// after every earlier force is fine (the files are read before the model
/// is known, the bodies bound after).
#[test]
fn external_loads_report_the_first_error_in_reading_order() {
    use crate::forces::external_loads::ExternalLoads;
    let model = test_model();
    let tmp = crate::test_dir::TempDir::new("statopt_extload_err");
    let dir = tmp.path().to_path_buf();
    let mut mot = "grf.mot\nversion=1\nnRows=5\nnColumns=4\ninDegrees=no\nendheader\ntime\tf_vx\tf_vy\tf_vz\n".to_string();
    for i in 0..5 {
        mot.push_str(&format!("{}\t1\t2\t3\n", 0.01 * i as f64));
    }
    std::fs::write(dir.join("grf.mot"), mot).unwrap();
    let force = |name: &str, body: &str, f: &str, p: &str| {
        format!("<ExternalForce name=\"{name}\"><applied_to_body>{body}</applied_to_body><force_identifier>{f}</force_identifier><point_identifier>{p}</point_identifier></ExternalForce>")
    };
    let cases = [
        // bad body and bad force identifier: the body
        (vec![force("a", "nobody", "zz", "")], "applied_to_body 'nobody'"),
        // bad force identifier and bad point identifier: the force's
        (vec![force("a", "link2", "zz", "yy")], "identifier 'zz'"),
        // the first force's identifier before the second force's body
        (
            vec![force("a", "link2", "f_v", "yy"), force("b", "nobody", "f_v", "")],
            "identifier 'yy'",
        ),
        (
            vec![force("a", "nobody", "f_v", ""), force("b", "link2", "zz", "")],
            "applied_to_body 'nobody'",
        ),
        // disabled forces are not read
        (
            vec![
                "<ExternalForce name=\"a\"><appliesForce>false</appliesForce><applied_to_body>nobody</applied_to_body><force_identifier>zz</force_identifier></ExternalForce>".to_string(),
                force("b", "link2", "f_v", "qq"),
            ],
            "identifier 'qq'",
        ),
    ];
    for (forces, want) in cases {
        let xml = format!(
            r#"<?xml version="1.0"?><OpenSimDocument Version="40000"><ExternalLoads name="x"><objects>{}</objects><datafile>grf.mot</datafile></ExternalLoads></OpenSimDocument>"#,
            forces.join("")
        );
        let xpath = dir.join("grf.xml");
        std::fs::write(&xpath, xml).unwrap();
        let e = ExternalLoads::load(&xpath, &dir, &model)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "want '{want}', got: {e}");
    }
}

/// A data file of `rows` rows with uneven times and a NaN at `nan` (row,
/// column) if given, and the ExternalLoads XML of two forces on it
/// ([`two_forces_xml`]).
fn long_grf(dir: &std::path::Path, rows: usize, nan: Option<(usize, usize)>) -> std::path::PathBuf {
    let mut mot = format!(
        "grf.mot\nversion=1\nnRows={rows}\nnColumns=10\ninDegrees=no\nendheader\n\
         time\tf_vx\tf_vy\tf_vz\tf_px\tf_py\tf_pz\tt_x\tt_y\tt_z\n"
    );
    let mut t = 0.0;
    for i in 0..rows {
        t += 0.001 * (1.0 + 0.3 * ((i * 7919) % 13) as f64 / 13.0);
        let v: Vec<String> = (0..9)
            .map(|c| {
                if nan == Some((i, c)) {
                    return "nan".to_string();
                }
                let x = ((c + 1) as f64 * 3.1 * t + c as f64).sin() * 400.0
                    + (((i * 31 + c * 17) % 23) as f64 - 11.0);
                format!("{x}")
            })
            .collect();
        mot.push_str(&format!("{t}\t{}\n", v.join("\t")));
    }
    std::fs::write(dir.join("grf.mot"), mot).unwrap();
    two_forces_xml(dir)
}

/// The ExternalLoads file of two forces on `grf.mot` (columns f_v*, f_p*,
/// t_*) in `dir`: one with force, point and torque on link2, one with a
/// force on the cart.
fn two_forces_xml(dir: &std::path::Path) -> std::path::PathBuf {
    let xml = r#"<?xml version="1.0"?><OpenSimDocument Version="40000"><ExternalLoads name="x"><objects>
<ExternalForce name="a"><applied_to_body>link2</applied_to_body><force_expressed_in_body>link1</force_expressed_in_body><point_expressed_in_body>ground</point_expressed_in_body><force_identifier>f_v</force_identifier><point_identifier>f_p</point_identifier><torque_identifier>t_</torque_identifier></ExternalForce>
<ExternalForce name="b"><applied_to_body>cart</applied_to_body><force_expressed_in_body>ground</force_expressed_in_body><force_identifier>f_p</force_identifier></ExternalForce>
</objects><datafile>grf.mot</datafile></ExternalLoads></OpenSimDocument>"#;
    let xpath = dir.join("grf.xml");
    std::fs::write(&xpath, xml).unwrap();
    xpath
}

/// A data file splined window by window (64-row windows, so 1,000 rows
/// make 16) gives the loads of the spline through the whole file to
/// rounding, at times before, in and after the data, at knots and window
/// starts, in order, out of order (windows fitted and let go on demand)
/// and after `prepare`; the recorded values too.
#[test]
fn external_loads_windowed_equal_the_whole_file() {
    use crate::forces::external_loads::{ExternalLoads, ExternalLoadsFiles};
    let model = test_model();
    let tmp = crate::test_dir::TempDir::new("statopt_extload_win");
    let dir = tmp.path().to_path_buf();
    let xpath = long_grf(&dir, 1000, None);
    let whole = ExternalLoads::load(&xpath, &dir, &model).unwrap();
    assert!(!whole.windowed());
    let windowed = ExternalLoadsFiles::read_with_window(&xpath, &dir, 64)
        .unwrap()
        .bind(&model)
        .unwrap();
    assert!(windowed.windowed());
    let table = crate::storage::read(&dir.join("grf.mot")).unwrap();
    let (t0, t1) = (table.time[0], table.time[999]);
    let mut times: Vec<f64> = (0..400)
        .map(|i| t0 - 0.05 + (t1 - t0 + 0.1) * i as f64 / 399.0)
        .collect();
    // knots, window starts and the rows next to them
    for r in [0, 1, 63, 64, 65, 127, 128, 500, 511, 512, 960, 998, 999] {
        times.push(table.time[r]);
    }
    // out of order: far back and forth
    times.extend([
        table.time[900],
        table.time[3] + 1e-4,
        table.time[700] - 1e-5,
        t0 - 1.0,
        t1 + 1.0,
    ]);
    let mut worst = 0.0f64;
    let mut check = |t: f64, i: usize| {
        let q = [0.3 + 0.01 * (i % 17) as f64, -0.7, 0.2];
        let mut d1 = data_at(&model, &q, &[0.0; 3]);
        let mut d2 = d1.clone();
        let (mut r1, mut r2) = (Vec::new(), Vec::new());
        whole.apply_recording(t, &mut d1, &mut r1);
        windowed.apply_recording(t, &mut d2, &mut r2);
        assert_eq!(r1.len(), r2.len());
        for (a, b) in r1.iter().zip(&r2) {
            let d = (a - b).abs() / a.abs().max(1.0);
            assert!(d <= 1e-11, "t {t}: whole {a}, windowed {b}");
            worst = worst.max(d);
        }
    };
    for (i, &t) in times.iter().enumerate() {
        check(t, i);
    }
    // prepared block by block, as the frame drivers do
    for k in 0..10 {
        let (a, b) = (table.time[100 * k], table.time[(100 * k + 99).min(999)]);
        windowed.prepare(a).unwrap();
        for i in 0..25 {
            check(a + (b - a) * i as f64 / 24.0, i);
        }
    }
    windowed.check().unwrap();
    // One block over the whole file: its 16 windows fitted as the frames
    // reach them, never more than three held.
    windowed.prepare(t0).unwrap();
    let mut most = 0;
    for i in 0..1000 {
        check(table.time[i] + 1e-5, i);
        most = most.max(windowed.windows_held());
    }
    assert!((1..=3).contains(&most), "{most} windows held");
    eprintln!("windowed external loads: worst relative difference {worst:e}");
    // Windows are read when needed: with the file gone, a time whose window
    // is not held gets NaN loads and the error is said by the next check
    // (once), and by prepare.
    std::fs::remove_file(dir.join("grf.mot")).unwrap();
    let mut d = data_at(&model, &[0.3, -0.7, 0.2], &[0.0; 3]);
    let mut rec = Vec::new();
    windowed.apply_recording(table.time[300], &mut d, &mut rec);
    assert!(rec[..3].iter().all(|v| v.is_nan()), "{rec:?}");
    let e = windowed.check().unwrap_err().to_string();
    assert!(e.contains("grf.mot"), "{e}");
    windowed.check().unwrap();
    assert!(windowed.prepare(table.time[10]).is_err());
    std::fs::remove_dir_all(&dir).ok();
}

/// A long data file's bad value is said when it is read, in the same words
/// as when the file is splined whole (the file, its line and column).
#[test]
fn external_loads_windowed_report_bad_data_as_the_whole_file() {
    use crate::forces::external_loads::ExternalLoadsFiles;
    let model = test_model();
    let tmp = crate::test_dir::TempDir::new("statopt_extload_nan");
    let dir = tmp.path().to_path_buf();
    for nan in [(700, 1), (5, 4), (999, 8)] {
        let xpath = long_grf(&dir, 1000, Some(nan));
        let err = |window: usize| {
            ExternalLoadsFiles::read_with_window(&xpath, &dir, window)
                .and_then(|f| f.bind(&model))
                .unwrap_err()
                .to_string()
        };
        let (whole, windowed) = (err(100_000), err(64));
        assert!(whole.contains(&format!("line {}", nan.0 + 8)), "{whole}");
        assert_eq!(whole, windowed);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Scaled loads (`ExternalLoads::scale`, the Python package's
/// `external_load_scale`) equal the loads of a data file whose force and
/// torque columns are scaled (what the package used to write), to
/// rounding; the point stays; an unknown ExternalForce is an error naming
/// the loads there are.
#[test]
fn external_loads_scaled_equal_a_scaled_data_file() {
    use crate::forces::external_loads::ExternalLoads;
    let model = test_model();
    let tmp = crate::test_dir::TempDir::new("statopt_extload_scale");
    let dir = tmp.path().to_path_buf();
    let xpath = long_grf(&dir, 200, None);
    let mut scaled = ExternalLoads::load(&xpath, &dir, &model).unwrap();
    scaled.scale(&[("a".into(), 1.5)]).unwrap();
    // The reference: force 'a's force (f_v*) and torque (t_*) columns
    // times 1.5 in the file; 'b' reads f_p* (a's point), unscaled.
    let mut table = crate::storage::read(&dir.join("grf.mot")).unwrap();
    let cols: Vec<usize> = (0..table.labels.len())
        .filter(|&j| table.labels[j].starts_with("f_v") || table.labels[j].starts_with("t_"))
        .collect();
    assert_eq!(cols.len(), 6);
    for row in &mut table.rows {
        cols.iter().for_each(|&j| row[j] *= 1.5);
    }
    let ref_dir = dir.join("reference");
    std::fs::create_dir_all(&ref_dir).unwrap();
    crate::storage::write(&ref_dir.join("grf.mot"), &table, 20).unwrap();
    let reference = ExternalLoads::load(&two_forces_xml(&ref_dir), &ref_dir, &model).unwrap();
    let plain = ExternalLoads::load(&xpath, &dir, &model).unwrap();
    for t in [table.time[3], 0.05, 0.1234, table.time[150]] {
        let d = data_at(&model, &[0.3, -0.7, 0.2], &[0.0; 3]);
        for k in 0..2 {
            let (f, p, tq) = scaled.forces[k].evaluate(t, &d).unwrap();
            let (rf, rp, rtq) = reference.forces[k].evaluate(t, &d).unwrap();
            let (_, pp, _) = plain.forces[k].evaluate(t, &d).unwrap();
            for (a, b) in [(f, rf), (p, rp), (tq, rtq)] {
                assert!(
                    (a - b).norm() <= 1e-9 * (1.0 + b.norm()),
                    "t {t} load {k}: {a} vs {b}"
                );
            }
            assert_eq!(p, pp, "the point is not scaled");
        }
        let (f, _, _) = plain.forces[0].evaluate(t, &d).unwrap();
        let (sf, _, _) = scaled.forces[0].evaluate(t, &d).unwrap();
        assert!((sf - 1.5 * f).norm() <= 1e-12 * (1.0 + f.norm()));
    }
    let e = scaled
        .scale(&[("plate9".into(), 2.0)])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no ExternalForce 'plate9'") && e.contains("a, b"),
        "{e}"
    );
}
