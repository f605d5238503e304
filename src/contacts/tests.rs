//! Tests of the point-on-plane contact: closed-form geometry, the weighting
//! function of eq. 8, slip velocities, virtual work of the multiplier
//! columns, friction signs and located input errors.

use std::f64::consts::PI;
use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::element::plane_axes;
use super::*;
use crate::dynamics::{kinematics, Data};
use crate::model::{body_fixed_xyz, compile, Model};
use crate::parse::osim::ModelSpec;
use crate::xml;

fn v3(a: [f64; 3]) -> String {
    format!("{} {} {}", a[0], a[1], a[2])
}

fn offset(name: &str, parent: &str, t: [f64; 3], o: [f64; 3]) -> String {
    format!(
        r#"<PhysicalOffsetFrame name="{name}"><socket_parent>{parent}</socket_parent><translation>{}</translation><orientation>{}</orientation></PhysicalOffsetFrame>"#,
        v3(t),
        v3(o)
    )
}

fn body(name: &str) -> String {
    format!(
        r#"<Body name="{name}"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>"#
    )
}

/// One TransformAxis: driven by `coord` with slope 1, or constant 0.
fn axis(name: &str, a: [f64; 3], coord: Option<&str>) -> String {
    let f = match coord {
        Some(_) => {
            r#"<LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction>"#
        }
        None => r#"<Constant name="function"><value>0</value></Constant>"#,
    };
    format!(
        r#"<TransformAxis name="{name}"><coordinates>{}</coordinates><axis>{}</axis>{f}</TransformAxis>"#,
        coord.unwrap_or(""),
        v3(a)
    )
}

fn coords(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!(r#"<Coordinate name="{n}"/>"#))
        .collect()
}

/// A test model:
/// - `plate` on a CustomJoint from ground (rotation qa about a tilted axis,
///   translations qx, qy), with offset frames on both sides;
/// - `rod` on a PinJoint from `plate` (qr), both joint frames rotated;
/// - `arm` on a PinJoint from ground (qb), about a tilted axis;
/// - `spin` on a PinJoint about ground z through the ground origin (qs);
/// - `block` on a CustomJoint translating along ground x (bx) and y (by).
fn test_model() -> Model {
    let plate_joint = format!(
        r#"<CustomJoint name="j_plate"><socket_parent_frame>g_off</socket_parent_frame><socket_child_frame>plate_off</socket_child_frame>
<coordinates>{}</coordinates><frames>{}{}</frames><SpatialTransform>{}{}{}{}{}{}</SpatialTransform></CustomJoint>"#,
        coords(&["qa", "qx", "qy"]),
        offset("g_off", "/ground", [0.1, 0.2, -0.1], [0.0, 0.0, 0.3]),
        offset(
            "plate_off",
            "/bodyset/plate",
            [0.05, 0.0, 0.02],
            [0.2, -0.3, 0.1]
        ),
        axis("rotation1", [0.3, 0.2, 1.0], Some("qa")),
        axis("rotation2", [1.0, 0.0, 0.0], None),
        axis("rotation3", [0.0, 1.0, 0.0], None),
        axis("translation1", [1.0, 0.0, 0.0], Some("qx")),
        axis("translation2", [0.0, 1.0, 0.0], Some("qy")),
        axis("translation3", [0.0, 0.0, 1.0], None),
    );
    let rod_joint = format!(
        r#"<PinJoint name="j_rod"><socket_parent_frame>plate_offset</socket_parent_frame><socket_child_frame>rod_offset</socket_child_frame>
<coordinates>{}</coordinates><frames>{}{}</frames></PinJoint>"#,
        coords(&["qr"]),
        offset(
            "plate_offset",
            "/bodyset/plate",
            [0.3, -0.2, 0.1],
            [0.4, 0.1, 0.0]
        ),
        offset(
            "rod_offset",
            "/bodyset/rod",
            [0.0, 0.1, 0.0],
            [0.0, 0.2, 0.0]
        ),
    );
    let arm_joint = format!(
        r#"<PinJoint name="j_arm"><socket_parent_frame>ground_offset</socket_parent_frame><socket_child_frame>arm_offset</socket_child_frame>
<coordinates>{}</coordinates><frames>{}{}</frames></PinJoint>"#,
        coords(&["qb"]),
        offset("ground_offset", "/ground", [0.4, 0.5, 0.2], [0.3, 0.5, 0.0]),
        offset(
            "arm_offset",
            "/bodyset/arm",
            [0.0, 0.2, 0.0],
            [0.0, 0.0, 0.0]
        ),
    );
    let spin_joint = format!(
        r#"<PinJoint name="j_spin"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/spin</socket_child_frame>
<coordinates>{}</coordinates></PinJoint>"#,
        coords(&["qs"]),
    );
    let block_joint = format!(
        r#"<CustomJoint name="j_block"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/block</socket_child_frame>
<coordinates>{}</coordinates><SpatialTransform>{}{}{}{}{}{}</SpatialTransform></CustomJoint>"#,
        coords(&["bx", "by"]),
        axis("rotation1", [0.0, 0.0, 1.0], None),
        axis("rotation2", [1.0, 0.0, 0.0], None),
        axis("rotation3", [0.0, 1.0, 0.0], None),
        axis("translation1", [1.0, 0.0, 0.0], Some("bx")),
        axis("translation2", [0.0, 1.0, 0.0], Some("by")),
        axis("translation3", [0.0, 0.0, 1.0], None),
    );
    let text = format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="contacts">
<BodySet name="bodyset"><objects>{}{}{}{}{}</objects></BodySet>
<JointSet name="jointset"><objects>{plate_joint}{rod_joint}{arm_joint}{spin_joint}{block_joint}</objects></JointSet>
</Model></OpenSimDocument>"#,
        body("plate"),
        body("rod"),
        body("spin"),
        body("block"),
        body("arm"),
    );
    let root = xml::parse_str(&text, Path::new("contacts.osim")).unwrap();
    compile(&ModelSpec::from_document(&root, Path::new("contacts.osim")).unwrap())
        .unwrap_or_else(|e| panic!("{e}"))
}

fn el(text: &str) -> xml::Element {
    xml::parse_str(text, Path::new("contacts.xml")).unwrap()
}

fn contact(model: &Model, props: &str) -> Contact {
    let text = format!(r#"<PointOnPlaneContact name="c">{props}</PointOnPlaneContact>"#);
    Contact::from_xml(&el(&text), model)
        .unwrap_or_else(|e| panic!("{e}"))
        .expect("a contact")
}

fn contact_err(model: &Model, text: &str) -> String {
    Contact::from_xml(&el(text), model)
        .err()
        .unwrap_or_else(|| panic!("expected an error for {text}"))
        .to_string()
}

/// Data with q and u set by coordinate name (others 0), kinematics::full done.
fn data_at(model: &Model, q: &[(&str, f64)], u: &[(&str, f64)]) -> Data {
    let mut d = Data::new(model);
    for (n, v) in q {
        d.q[model.coordinate_index(n).unwrap()] = *v;
    }
    for (n, v) in u {
        d.u[model.coordinate_index(n).unwrap()] = *v;
    }
    kinematics::full(model, &mut d);
    d
}

fn data_q(model: &Model, q: &[f64]) -> Data {
    let mut d = Data::new(model);
    d.q.copy_from_slice(q);
    kinematics::positions(model, &mut d);
    d
}

fn close(a: &Vector3<f64>, b: &Vector3<f64>, tol: f64) -> bool {
    (a - b).norm() <= tol
}

// ---------------------------------------------------------------- eq. 8

#[test]
fn weight_function_eq8() {
    let (dt, dz) = (0.02, 0.01);
    // At the middle of the transition zone the tanh argument is 0.
    assert!((weight(dt + dz / 2.0, dt, dz) - 0.5).abs() < 1e-15);
    // At d_tol the argument is +π, at d_tol + d_trans it is −π.
    let hi = 0.5 * (1.0 + PI.tanh());
    let lo = 0.5 * (1.0 - PI.tanh());
    assert!((weight(dt, dt, dz) - hi).abs() < 1e-15);
    assert!(hi > 0.9981 && hi < 0.9982, "{hi}");
    assert!((weight(dt + dz, dt, dz) - lo).abs() < 1e-15);
    // Beyond the zone: exactly 0 (the plugin's cut-off).
    assert_eq!(weight(dt + dz + 1e-9, dt, dz), 0.0);
    assert_eq!(weight(5.0, dt, dz), 0.0);
    // Well inside (or penetrating): 1.
    assert!((weight(dt - 5.0 * dz, dt, dz) - 1.0).abs() < 1e-12);
    assert!((weight(-0.3, dt, dz) - 1.0).abs() < 1e-15);
    // Odd symmetry about the midpoint: w(m + x) + w(m − x) = 1.
    for x in [0.001, 0.002, 0.0045] {
        let m = dt + dz / 2.0;
        assert!((weight(m + x, dt, dz) + weight(m - x, dt, dz) - 1.0).abs() < 1e-14);
    }
    // Monotone non-increasing.
    let mut prev = f64::INFINITY;
    for i in 0..=400 {
        let d = -0.01 + i as f64 * 1e-4;
        let w = weight(d, dt, dz);
        assert!(w <= prev && (0.0..=1.0).contains(&w), "d={d} w={w}");
        prev = w;
    }
    // Negative tolerance: no effect of the distance.
    for d in [-1.0, 0.0, 0.5, 100.0] {
        assert_eq!(weight(d, -1.0, dz), 1.0);
    }
}

// ---------------------------------------------------------------- axes

#[test]
fn in_plane_axes_are_the_documented_right_handed_choice() {
    let x = Vector3::x();
    let y = Vector3::y();
    let z = Vector3::z();
    let (e1, e2) = plane_axes(&y);
    assert!(close(&e1, &z, 1e-15) && close(&e2, &x, 1e-15));
    let (e1, e2) = plane_axes(&z);
    assert!(close(&e1, &x, 1e-15) && close(&e2, &y, 1e-15));
    let (e1, e2) = plane_axes(&x);
    assert!(close(&e1, &y, 1e-15) && close(&e2, &z, 1e-15));
    let (e1, e2) = plane_axes(&(-y));
    assert!(close(&e1, &z, 1e-15) && close(&e2, &(-x), 1e-15));
    for n in [
        Vector3::new(0.2, 1.0, -0.3),
        Vector3::new(-1.0, 1.0, 1.0),
        Vector3::new(0.0, -0.7, 0.7),
        Vector3::new(1e-9, 0.0, -1.0),
    ] {
        let n = n.normalize();
        let (e1, e2) = plane_axes(&n);
        assert!((e1.norm() - 1.0).abs() < 1e-14 && (e2.norm() - 1.0).abs() < 1e-14);
        assert!(e1.dot(&n).abs() < 1e-14 && e2.dot(&n).abs() < 1e-14);
        assert!(close(&e1.cross(&e2), &n, 1e-14), "right-handed for {n}");
    }
}

// ---------------------------------------------------------------- geometry

/// A plane on the moving, tilted `plate`; the point is a ground station built
/// at a known height above a known in-plane location. The plane in ground is
/// found independently, from three plate stations.
#[test]
fn distance_and_projection_on_tilted_moving_plane() {
    let m = test_model();
    let plate = m.body_index("plate").unwrap();
    let n_b = Vector3::new(0.2, 1.0, -0.3);
    let o_b = Vector3::new(0.1, 0.05, -0.02);
    let d = data_at(&m, &[("qa", 0.7), ("qx", -0.2), ("qy", 0.35)], &[]);
    // Two in-plane body vectors, perpendicular to n_b.
    let u_b = n_b.cross(&Vector3::new(1.0, 0.0, 0.0));
    let w_b = n_b.cross(&u_b);
    let o = d.station_position(plate, &o_b);
    let a = d.station_position(plate, &(o_b + u_b)) - o;
    let b = d.station_position(plate, &(o_b + w_b)) - o;
    let mut n = a.cross(&b).normalize();
    if n.dot(&(d.rotation[plate] * n_b)) < 0.0 {
        n = -n;
    }
    let foot = o + 0.3 * a.normalize() - 0.4 * b.normalize();
    for height in [0.05, -0.02, 0.0] {
        let p = foot + height * n;
        let c = contact(
            &m,
            &format!(
                "<point_body>ground</point_body><point_location>{}</point_location>
                 <plane_body>plate</plane_body><plane_origin>{}</plane_origin>
                 <plane_normal>{}</plane_normal>
                 <contact_tolerance>0</contact_tolerance><contact_transition_zone>0.1</contact_transition_zone>",
                v3(p.into()),
                v3(o_b.into()),
                v3(n_b.into())
            ),
        );
        let st = c.state(&m, &d);
        assert!(
            (st.distance - height).abs() < 1e-13,
            "{} vs {height}",
            st.distance
        );
        assert!(close(&st.projection_ground, &foot, 1e-13));
        assert!(close(&st.point_ground, &p, 1e-14));
        assert!(close(&st.normal_ground, &n, 1e-13));
        assert!(st.e1_ground.dot(&n).abs() < 1e-13 && st.e2_ground.dot(&n).abs() < 1e-13);
        assert!(close(&st.e1_ground.cross(&st.e2_ground), &n, 1e-13));
        // w with d_tol = 0, d_trans = 0.1: 0.5 at d = 0.05, ≈1 below 0.
        let want_w = 0.5 * (1.0 + (-PI * (2.0 * height - 0.1) / 0.1).tanh());
        assert!((st.weight - want_w).abs() < 1e-12);
        // Nothing moves: static.
        assert_eq!(st.slip_speed, 0.0);
        assert_eq!(st.regime, Regime::Static);
    }
}

/// A point at rest in ground touching a plane that spins about ground z
/// through the origin: the slip is −(ω × p) projected into the plane.
/// With plane normal +y in `spin`, at angle q the normal is (−sin q, cos q, 0)
/// and the in-plane directions are z and t = (cos q, sin q, 0); ω × p has no
/// z part, so slip = −ω (−p_y cos q + p_x sin q) t.
#[test]
fn slip_on_rotating_plane_and_regime_switch() {
    let m = test_model();
    let p = Vector3::new(0.5, -0.6, 0.1);
    let c = contact(
        &m,
        &format!(
            "<point_body>ground</point_body><point_location>{}</point_location>
             <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal><v_trans>0.25</v_trans>",
            v3(p.into())
        ),
    );
    let q: f64 = 0.3;
    let (s, co) = q.sin_cos();
    let t = Vector3::new(co, s, 0.0);
    let k = -p.y * co + p.x * s; // slip = −ω k t
    for om in [2.0, -1.3] {
        let d = data_at(&m, &[("qs", q)], &[("qs", om)]);
        let st = c.state(&m, &d);
        assert!(close(&st.normal_ground, &Vector3::new(-s, co, 0.0), 1e-15));
        assert!((st.distance - (-p.x * s + p.y * co)).abs() < 1e-15);
        let want = -om * k * t;
        assert!(
            close(&st.slip_velocity, &want, 1e-14),
            "{} vs {want}",
            st.slip_velocity
        );
        assert!((st.slip_speed - (om * k).abs()).abs() < 1e-14);
        assert_eq!(st.regime, Regime::Kinetic);
    }
    // Switch at v_trans = 0.25: slip speed = |ω k|.
    let om_switch = 0.25 / k.abs();
    let below = c.state(
        &m,
        &data_at(&m, &[("qs", q)], &[("qs", om_switch * (1.0 - 1e-9))]),
    );
    let above = c.state(
        &m,
        &data_at(&m, &[("qs", q)], &[("qs", om_switch * (1.0 + 1e-9))]),
    );
    assert_eq!(below.regime, Regime::Static);
    assert_eq!(above.regime, Regime::Kinetic);
}

/// A point on `point_body` (rod: a child of the plate; arm: on its own
/// branch) against a plane on the plate.
fn plate_contact(m: &Model, point_body: &str, normal: [f64; 3], extra: &str) -> Contact {
    contact(
        m,
        &format!(
            "<point_body>{point_body}</point_body><point_location>0.15 -0.4 0.05</point_location>
             <plane_body>plate</plane_body><plane_origin>0.1 0.05 -0.02</plane_origin>
             <plane_normal>{}</plane_normal><optimal_force>250</optimal_force>
             <kinetic_friction>0.6</kinetic_friction>{extra}",
            v3(normal)
        ),
    )
}

const Q: [(&str, f64); 5] = [
    ("qa", 0.7),
    ("qx", -0.2),
    ("qy", 0.35),
    ("qr", -0.8),
    ("qb", 0.45),
];
const U: [(&str, f64); 5] = [
    ("qa", 0.9),
    ("qx", 0.4),
    ("qy", -0.7),
    ("qr", 1.6),
    ("qb", -1.1),
];

/// The slip velocity equals the time derivative of p's coordinates in the
/// plane body (central differences along q + t u), rotated to ground and
/// projected into the plane.
#[test]
fn slip_velocity_is_the_rate_of_the_point_in_the_plane_frame() {
    let m = test_model();
    let plate = m.body_index("plate").unwrap();
    for name in ["rod", "arm"] {
        let a = m.body_index(name).unwrap();
        let c = plate_contact(&m, name, [0.2, 1.0, -0.3], "");
        let d = data_at(&m, &Q, &U);
        let st = c.state(&m, &d);
        let in_plate = |t: f64| {
            let q: Vec<(&str, f64)> = Q
                .iter()
                .zip(&U)
                .map(|((n, q), (_, u))| (*n, q + t * u))
                .collect();
            let dd = data_at(&m, &q, &[]);
            dd.rotation[plate].transpose() * (dd.station_position(a, &c.point) - dd.position[plate])
        };
        let h = 1e-5;
        let rate = d.rotation[plate] * ((in_plate(h) - in_plate(-h)) / (2.0 * h));
        let n = st.normal_ground;
        let want = rate - n * rate.dot(&n);
        assert!(want.norm() > 0.1, "the test must slide: {want}");
        assert!(
            close(&st.slip_velocity, &want, 1e-8),
            "{name}: {} vs {want}",
            st.slip_velocity
        );
        assert!(st.slip_velocity.dot(&n).abs() < 1e-14);
    }
}

// ---------------------------------------------------------------- forces

/// Generalized force by virtual work: the constant forces (f_plane on the
/// plate's material point at p*, −f_plane on the rod's point p) do work
/// Σ gen_k dq_k under a perturbation of each coordinate.
fn virtual_work(
    m: &Model,
    c: &Contact,
    st: &ContactState,
    d: &Data,
    f_plane: &Vector3<f64>,
) -> Vec<f64> {
    let (a, b) = (c.point_body, c.plane_body);
    let s_b = d.rotation[b].transpose() * (st.projection_ground - d.position[b]);
    let h = 1e-6;
    (0..m.nq())
        .map(|k| {
            let (mut qp, mut qm) = (d.q.clone(), d.q.clone());
            qp[k] += h;
            qm[k] -= h;
            let (dp, dm) = (data_q(m, &qp), data_q(m, &qm));
            let dx_b = (dp.station_position(b, &s_b) - dm.station_position(b, &s_b)) / (2.0 * h);
            let dx_a =
                (dp.station_position(a, &c.point) - dm.station_position(a, &c.point)) / (2.0 * h);
            f_plane.dot(&dx_b) - f_plane.dot(&dx_a)
        })
        .collect()
}

fn assert_vec_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!(
            (x - y).abs() <= tol * (1.0 + y.abs()),
            "{what}: {a:?} vs {b:?}"
        );
    }
}

/// Multiplier columns against virtual work, for a point on the arm (its own
/// branch: every coordinate of both bodies is loaded) and on the rod (a child
/// of the plate: the pair is internal to the plate's subtree, so under the
/// plate's coordinates only its couple works: the normal pair, whose line
/// of action joins p and p*, does no work there).
#[test]
fn unit_generalized_forces_equal_virtual_work() {
    let m = test_model();
    let idx = |n: &str| m.coordinate_index(n).unwrap();
    let d = data_at(&m, &Q, &U);
    for name in ["arm", "rod"] {
        // Normal sign chosen so that d > 0, and d_trans = 2.5 d so that
        // w(d) = ½ (1 + tanh(π/5)) ≈ 0.78 with d_tol = 0.
        let probe = plate_contact(&m, name, [0.2, 1.0, -0.3], "");
        let d0 = probe.state(&m, &d).distance;
        assert!(d0.abs() > 0.05, "{name}: p and p* must differ: d = {d0}");
        let sign = d0.signum();
        let c = plate_contact(
            &m,
            name,
            [0.2 * sign, sign, -0.3 * sign],
            &format!(
                "<contact_tolerance>0</contact_tolerance><contact_transition_zone>{}</contact_transition_zone>",
                2.5 * d0.abs()
            ),
        );
        let st = c.state(&m, &d);
        let want_w = 0.5 * (1.0 + (PI / 5.0).tanh());
        assert!((st.weight - want_w).abs() < 1e-12, "w = {}", st.weight);
        let mut cols = [vec![0.0; m.nq()], vec![0.0; m.nq()], vec![0.0; m.nq()]];
        c.add_unit_generalized_forces(&m, &d, &st, &mut cols);
        let s = st.weight * 250.0;
        let dirs = [-st.normal_ground, st.e1_ground, st.e2_ground];
        for (i, dir) in dirs.iter().enumerate() {
            let want = virtual_work(&m, &c, &st, &d, &(dir * s));
            let loaded: &[&str] = match (name, i) {
                ("arm", _) => &["qa", "qx", "qy", "qb"],
                ("rod", 0) => &["qr"],
                _ => &["qa", "qr"],
            };
            for n in loaded {
                assert!(
                    want[idx(n)].abs() > 1e-3,
                    "{name} column {i} must load {n}: {want:?}"
                );
            }
            if (name, i) == ("rod", 0) {
                for n in ["qa", "qx", "qy"] {
                    assert!(
                        cols[0][idx(n)].abs() < 1e-12,
                        "internal normal pair: {:?}",
                        cols[0]
                    );
                }
            }
            assert_vec_close(&cols[i], &want, 1e-7, &format!("{name} column {i}"));
            // forces() gives the same pair.
            let mut lambda = [0.0; 3];
            lambda[i] = 1.0;
            let (f_a, x_a, f_b) = c.forces(&st, lambda, false);
            assert!(close(&f_b, &(dir * s), 1e-12) && close(&f_a, &(-dir * s), 1e-12));
            assert!(close(&x_a, &st.point_ground, 0.0));
        }
        // Kinetic column: −n + μk v̂ on the plate, the opposite on the point.
        assert_eq!(st.regime, Regime::Kinetic);
        let mut kin = vec![0.0; m.nq()];
        c.add_kinetic_normal_column(&m, &d, &st, &mut kin);
        let v_hat = st.slip_velocity / st.slip_speed;
        let f_plane = (-st.normal_ground + 0.6 * v_hat) * s;
        let want = virtual_work(&m, &c, &st, &d, &f_plane);
        assert_vec_close(&kin, &want, 1e-7, "kinetic");
        let (f_a, _, f_b) = c.forces(&st, [2.0, 7.0, -9.0], true);
        assert!(close(&f_b, &(2.0 * f_plane), 1e-11) && close(&f_a, &(-2.0 * f_plane), 1e-11));
        // Accumulation: a second call adds.
        c.add_kinetic_normal_column(&m, &d, &st, &mut kin);
        let twice: Vec<f64> = want.iter().map(|x| 2.0 * x).collect();
        assert_vec_close(&kin, &twice, 1e-7, "accumulates");
    }
}

/// A block (point body) sliding on the ground (plane body, normal +y): the
/// normal force pushes the block up, kinetic friction opposes its slide.
#[test]
fn block_sliding_on_ground_gets_friction_against_its_motion() {
    let m = test_model();
    let (bx, by) = (
        m.coordinate_index("bx").unwrap(),
        m.coordinate_index("by").unwrap(),
    );
    let c = contact(
        &m,
        "<point_body>block</point_body><point_location>0 -0.1 0</point_location>
         <plane_body>ground</plane_body>",
    );
    // Plugin defaults: μs 0.8, μk 0.5, F0 100, v_trans 0.1, w = 1.
    for vx in [1.0, -2.0] {
        let d = data_at(&m, &[("bx", 0.3), ("by", 0.1)], &[("bx", vx)]);
        let st = c.state(&m, &d);
        assert!(st.distance.abs() < 1e-15 && st.weight == 1.0);
        assert!(close(&st.slip_velocity, &Vector3::new(vx, 0.0, 0.0), 1e-15));
        assert_eq!(st.regime, Regime::Kinetic);
        let mut g = vec![0.0; m.nq()];
        c.add_kinetic_normal_column(&m, &d, &st, &mut g);
        assert!(
            (g[by] - 100.0).abs() < 1e-12,
            "normal pushes the block up: {g:?}"
        );
        assert!(
            (g[bx] + 50.0 * vx.signum()).abs() < 1e-12,
            "friction opposes the slide: {g:?}"
        );
        let (f_block, at, f_ground) = c.forces(&st, [2.0, 0.0, 0.0], true);
        assert!(close(
            &f_block,
            &Vector3::new(-100.0 * vx.signum(), 200.0, 0.0),
            1e-12
        ));
        assert!(close(&f_ground, &(-f_block), 0.0));
        assert!(close(&at, &Vector3::new(0.3, 0.0, 0.0), 1e-15));
        // Static columns: n = +y so e1 = +z, e2 = +x (documented choice);
        // on the block the forces are +y, −z, −x.
        let mut cols = [vec![0.0; m.nq()], vec![0.0; m.nq()], vec![0.0; m.nq()]];
        c.add_unit_generalized_forces(&m, &d, &st, &mut cols);
        assert!((cols[0][by] - 100.0).abs() < 1e-12 && cols[0][bx].abs() < 1e-12);
        assert!(cols[1].iter().all(|x| x.abs() < 1e-12), "{:?}", cols[1]);
        assert!((cols[2][bx] + 100.0).abs() < 1e-12 && cols[2][by].abs() < 1e-12);
    }
    // Below v_trans: static.
    let d = data_at(&m, &[("bx", 0.3), ("by", 0.1)], &[("bx", 0.05)]);
    assert_eq!(c.state(&m, &d).regime, Regime::Static);
}

#[test]
fn separated_contact_has_zero_columns() {
    let m = test_model();
    let c = contact(
        &m,
        "<point_body>block</point_body><plane_body>ground</plane_body>
         <contact_tolerance>0.01</contact_tolerance><contact_transition_zone>0.02</contact_transition_zone>",
    );
    let d = data_at(&m, &[("by", 0.0301)], &[]);
    let st = c.state(&m, &d);
    assert_eq!(st.weight, 0.0);
    let mut cols = [vec![0.0; m.nq()], vec![0.0; m.nq()], vec![0.0; m.nq()]];
    c.add_unit_generalized_forces(&m, &d, &st, &mut cols);
    assert!(cols.iter().flatten().all(|x| *x == 0.0));
    let d = data_at(&m, &[("by", 0.02)], &[]);
    let st = c.state(&m, &d);
    assert!((st.weight - 0.5).abs() < 1e-12);
}

// ---------------------------------------------------------------- reading

#[test]
fn plugin_spelling_and_defaults() {
    let m = test_model();
    let plugin = Contact::from_xml(
        &el(r#"<ContactPointOnPlane name="heel">
  <point_body>block</point_body>
  <point_location>0.1 0.2 0.3</point_location>
</ContactPointOnPlane>"#),
        &m,
    )
    .unwrap()
    .unwrap();
    assert_eq!(plugin.type_name, "ContactPointOnPlane");
    assert_eq!(plugin.name, "heel");
    assert_eq!(plugin.point_body, m.body_index("block").unwrap());
    assert_eq!(plugin.plane_body, 0);
    assert_eq!(plugin.point, Vector3::new(0.1, 0.2, 0.3));
    assert_eq!(plugin.origin, Vector3::zeros());
    assert_eq!(plugin.normal, Vector3::y());
    assert_eq!(
        (
            plugin.mu_s,
            plugin.mu_k,
            plugin.d_tol,
            plugin.d_trans,
            plugin.v_trans,
            plugin.optimal_force
        ),
        (0.8, 0.5, -1.0, 0.01, 0.1, 100.0)
    );
    assert!(plugin.applies_force);

    let ours = contact(
        &m,
        "<point_body>/bodyset/rod</point_body><plane_body>/bodyset/plate</plane_body>
         <plane_normal>0 0 -3</plane_normal><static_friction>0.3</static_friction>
         <kinetic_friction>0.4</kinetic_friction><appliesForce>false</appliesForce>",
    );
    assert_eq!(ours.point_body, m.body_index("rod").unwrap());
    assert_eq!(ours.plane_body, m.body_index("plate").unwrap());
    assert_eq!(ours.normal, -Vector3::z());
    // μk > μs is accepted.
    assert_eq!((ours.mu_s, ours.mu_k), (0.3, 0.4));
    assert!(!ours.applies_force);

    // Not a contact.
    assert!(
        Contact::from_xml(&el("<CoordinateActuator name=\"x\"/>"), &m)
            .unwrap()
            .is_none()
    );
}

/// A plane given on an offset frame is stored in the base body.
#[test]
fn plane_on_offset_frame_socket() {
    let m = test_model();
    let c = contact(
        &m,
        "<socket_point_frame>/bodyset/rod</socket_point_frame>
         <socket_plane_frame>/jointset/j_rod/plate_offset</socket_plane_frame>
         <plane_origin>0 0 0.1</plane_origin><plane_normal>0 0 1</plane_normal>",
    );
    let r: Matrix3<f64> = body_fixed_xyz(&Vector3::new(0.4, 0.1, 0.0));
    assert_eq!(c.plane_body, m.body_index("plate").unwrap());
    assert!(close(&c.normal, &(r * Vector3::z()), 1e-15));
    assert!(close(
        &c.origin,
        &(Vector3::new(0.3, -0.2, 0.1) + r * Vector3::new(0.0, 0.0, 0.1)),
        1e-15
    ));
    let (e1, e2) = plane_axes(&c.normal);
    assert_eq!((c.e1, c.e2), (e1, e2));
}

#[test]
fn bad_input_is_a_located_error() {
    let m = test_model();
    let cases: &[(&str, &[&str])] = &[
        (
            "<PointOnPlaneContact name=\"c\">\n<point_body>femur</point_body></PointOnPlaneContact>",
            &["line 2", "<point_body>", "unknown body or frame 'femur'"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<plane_body>nowhere</plane_body></PointOnPlaneContact>",
            &["line 2", "<plane_body>", "'nowhere'"],
        ),
        (
            "<PointOnPlaneContact name=\"c\">\n<plane_body>plate</plane_body></PointOnPlaneContact>",
            &["line 1", "<PointOnPlaneContact name=\"c\">", "missing property <point_body>"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<plane_normal>0 0 0</plane_normal></PointOnPlaneContact>",
            &["line 2", "<plane_normal>", "non-zero"],
        ),
        (
            "<ContactPointOnPlane name=\"c\"><point_body>rod</point_body>\n<static_friction>-0.1</static_friction></ContactPointOnPlane>",
            &["line 2", "<static_friction>", "negative"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n\n<kinetic_friction>-1</kinetic_friction></PointOnPlaneContact>",
            &["line 3", "<kinetic_friction>", "negative"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<v_trans>0</v_trans></PointOnPlaneContact>",
            &["line 2", "<v_trans>", "positive"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<v_trans>-0.2</v_trans></PointOnPlaneContact>",
            &["line 2", "<v_trans>", "positive"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body><contact_tolerance>0.01</contact_tolerance>\n<contact_transition_zone>0</contact_transition_zone></PointOnPlaneContact>",
            &["line 2", "<contact_transition_zone>", "positive"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<optimal_force>-5</optimal_force></PointOnPlaneContact>",
            &["line 2", "<optimal_force>", "positive"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<point_location>1 2</point_location></PointOnPlaneContact>",
            &["line 2", "<point_location>", "expected 3 numbers"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<static_friction>Inf</static_friction></PointOnPlaneContact>",
            &["line 2", "<static_friction>", "finite"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>plate</point_body>\n<plane_body>/bodyset/plate</plane_body></PointOnPlaneContact>",
            &["line 1", "same body"],
        ),
        (
            "<PointOnPlaneContact name=\"c\"><point_body>rod</point_body>\n<socket_point_frame>/bodyset/rod</socket_point_frame></PointOnPlaneContact>",
            &["line 2", "<socket_point_frame>", "not both"],
        ),
    ];
    for (text, wants) in cases {
        let e = contact_err(&m, text);
        assert!(e.contains("contacts.xml"), "{e}");
        for w in *wants {
            assert!(e.contains(w), "'{w}' missing in: {e}");
        }
    }
    // A zero transition zone is fine when the distance has no effect.
    contact(
        &m,
        "<point_body>rod</point_body><contact_transition_zone>0</contact_transition_zone>",
    );
}

/// `speed_weight` (statopt): the weight falls with the slip speed from full
/// strength at s_full to none at s_zero, times w(d); without the property the
/// weight is the paper's w(d) at any slip speed.
#[test]
fn speed_weight_weakens_a_sliding_contact() {
    let m = test_model();
    let p = Vector3::new(0.5, -0.6, 0.1);
    let props = format!(
        "<point_body>ground</point_body><point_location>{}</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>",
        v3(p.into())
    );
    let plain = contact(&m, &props);
    let weighted = contact(&m, &format!("{props}<speed_weight>0.12 0.8</speed_weight>"));
    let q: f64 = 0.3;
    let (s, co) = q.sin_cos();
    let k = (-p.y * co + p.x * s).abs(); // slip speed = |ω| k
    for (speed, want) in [(0.0, 1.0), (0.12, 1.0), (0.46, 0.5), (0.8, 0.0), (2.0, 0.0)] {
        let d = data_at(&m, &[("qs", q)], &[("qs", speed / k)]);
        let (a, b) = (plain.state(&m, &d), weighted.state(&m, &d));
        assert!((a.slip_speed - speed).abs() < 1e-12);
        assert_eq!(a.weight, 1.0, "no speed effect without the property");
        assert!(
            (b.weight - want).abs() < 1e-12,
            "s = {speed}: weight {}",
            b.weight
        );
    }
    // Monotone and C¹ in between: the smoothstep's slope vanishes at both ends.
    let f = |s: f64| weighted.speed_factor(s);
    assert!((f(0.12 + 1e-7) - 1.0).abs() < 1e-12 && f(0.8 - 1e-7) < 1e-12);
    let xs: Vec<f64> = (0..=100).map(|i| 0.1 + 0.72 * i as f64 / 100.0).collect();
    assert!(xs.windows(2).all(|w| f(w[1]) <= f(w[0])));
    // Bad values are refused with the element's location.
    let e = contact_err(&m, &format!("<PointOnPlaneContact name=\"c\">{props}<speed_weight>0.8 0.12</speed_weight></PointOnPlaneContact>"));
    assert!(e.contains("speed_weight") && e.contains("line"), "{e}");
}

/// `held_intervals` (statopt, issue 36): within t0 <= t < t1 a contact is on
/// the floor whatever its slip: its weight is w(d) alone (no slip-speed
/// gate) and its regime static; outside, the gate and the kinetic regime
/// apply as before. Bad values are refused naming the element and its line.
#[test]
fn held_intervals_keep_a_rolling_contact_on_the_floor() {
    let m = test_model();
    let p = Vector3::new(0.5, -0.6, 0.1);
    let props = format!(
        "<point_body>ground</point_body><point_location>{}</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>
         <v_trans>0.8</v_trans><speed_weight>0.12 0.8</speed_weight>",
        v3(p.into())
    );
    let plain = contact(&m, &props);
    assert!(plain.held_intervals.is_empty() && !plain.is_held_at(0.2));
    let c = contact(
        &m,
        &format!("{props}<held_intervals>0.1 0.3 0.5 0.55</held_intervals>"),
    );
    assert_eq!(c.held_intervals, vec![(0.1, 0.3), (0.5, 0.55)]);
    for (t, held) in [
        (0.0, false),
        (0.1, true),
        (0.2999, true),
        (0.3, false),
        (0.52, true),
    ] {
        assert_eq!(c.is_held_at(t), held, "t = {t}");
    }
    // Sliding at 1.2 m/s: gated to nothing and kinetic; held: full w(d)
    // and static, the distance's weight unchanged.
    let q: f64 = 0.3;
    let k = (-p.y * q.cos() + p.x * q.sin()).abs();
    let d = data_at(&m, &[("qs", q)], &[("qs", 1.2 / k)]);
    let mut st = c.state(&m, &d);
    assert!((st.slip_speed - 1.2).abs() < 1e-12);
    assert_eq!((st.weight, st.regime), (0.0, Regime::Kinetic));
    c.hold(&mut st);
    let w = weight(st.distance, c.d_tol, c.d_trans);
    assert!(w > 0.0 && st.weight == w, "{} against {w}", st.weight);
    assert_eq!((st.beta, st.regime), (0.0, Regime::Static));
    for bad in [
        "<held_intervals>0.3 0.1</held_intervals>",
        "<held_intervals>0.1 0.3 0.5</held_intervals>",
    ] {
        let e = contact_err(
            &m,
            &format!("<PointOnPlaneContact name=\"c\">{props}{bad}</PointOnPlaneContact>"),
        );
        assert!(
            e.contains("held_intervals") && e.contains("line"),
            "{bad}: {e}"
        );
    }
}

/// `plane_velocity` (statopt): slip is taken against the plane's moving
/// surface. A point at rest over a belt running at +1 m/s slips at −1 m/s
/// (kinetic); a point moving with the belt does not slip (static).
#[test]
fn plane_velocity_makes_slip_relative_to_a_moving_surface() {
    let m = test_model();
    let props = "<point_body>ground</point_body><point_location>0.5 -0.6 0.1</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>";
    let belt = contact(
        &m,
        &format!("{props}<plane_velocity>1 0 0</plane_velocity>"),
    );
    let still = contact(&m, props);
    // The plate at rest (q = 0, no speed): the point is at rest over it.
    let d = data_at(&m, &[("qs", 0.0)], &[("qs", 0.0)]);
    let (a, b) = (still.state(&m, &d), belt.state(&m, &d));
    assert_eq!(a.slip_speed, 0.0);
    assert!(
        close(&b.slip_velocity, &Vector3::new(-1.0, 0.0, 0.0), 1e-15),
        "{}",
        b.slip_velocity
    );
    assert_eq!(b.regime, Regime::Kinetic);
    // Rotated plate: the surface velocity turns with it (plane frame).
    let q: f64 = 0.3;
    let d = data_at(&m, &[("qs", q)], &[("qs", 0.0)]);
    let b = belt.state(&m, &d);
    let t = Vector3::new(q.cos(), q.sin(), 0.0);
    assert!(close(&b.slip_velocity, &(-t), 1e-14), "{}", b.slip_velocity);
    // A velocity off the plane is refused with the element's location.
    let e = contact_err(&m, &format!("<PointOnPlaneContact name=\"c\">{props}<plane_velocity>0 1 0</plane_velocity></PointOnPlaneContact>"));
    assert!(e.contains("plane_velocity") && e.contains("line"), "{e}");
}

/// `off_intervals` / `off_weight` (statopt, issue 36): the contact is off
/// (or weakened by `off_weight`) for t0 <= t < t1 of each pair and on
/// outside; bad values are refused naming the element and its line.
#[test]
fn off_intervals_switch_a_contact_off_in_time() {
    let m = test_model();
    let props = "<point_body>ground</point_body><point_location>0.5 -0.6 0.1</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>";
    let plain = contact(&m, props);
    assert!(plain.off_intervals.is_empty() && plain.off_weight == 0.0);
    assert!(!plain.is_off_at(0.0));
    let c = contact(
        &m,
        &format!(
            "{props}<off_intervals>0.1 0.3 0.5 0.55</off_intervals><off_weight>0.01</off_weight>"
        ),
    );
    assert_eq!(c.off_intervals, vec![(0.1, 0.3), (0.5, 0.55)]);
    assert_eq!(c.off_weight, 0.01);
    for (t, off) in [
        (0.0, false),
        (0.1, true),
        (0.2999, true),
        (0.3, false),
        (0.52, true),
        (0.55, false),
    ] {
        assert_eq!(c.is_off_at(t), off, "t = {t}");
    }
    for bad in [
        "<off_intervals>0.3 0.1</off_intervals>",
        "<off_intervals>0.1 0.3 0.5</off_intervals>",
        "<off_intervals>0.5 0.6 0.1 0.2</off_intervals>",
        "<off_weight>1</off_weight>",
        "<off_weight>-0.1</off_weight>",
    ] {
        let e = contact_err(
            &m,
            &format!("<PointOnPlaneContact name=\"c\">{props}{bad}</PointOnPlaneContact>"),
        );
        assert!(e.contains("off_") && e.contains("line"), "{bad}: {e}");
    }
}

/// `time_weight` (statopt, issue 36): the factor is linear between the
/// knots and holds the end knots' values outside; 1 without knots; knots
/// out of order or a factor outside [0, 1] are refused with the line.
#[test]
fn time_weight_scales_a_contact_between_its_knots() {
    let m = test_model();
    let props = "<point_body>ground</point_body><point_location>0.5 -0.6 0.1</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>";
    assert_eq!(contact(&m, props).time_factor(0.3), 1.0);
    let c = contact(
        &m,
        &format!("{props}<time_weight>0.4 1 0.5 0 0.6 0.5 0.7 1</time_weight>"),
    );
    for (t, want) in [
        (0.0, 1.0),
        (0.45, 0.5),
        (0.5, 0.0),
        (0.55, 0.25),
        (0.65, 0.75),
        (0.9, 1.0),
    ] {
        assert!(
            (c.time_factor(t) - want).abs() < 1e-9,
            "t = {t}: {}",
            c.time_factor(t)
        );
    }
    for bad in [
        "<time_weight>0.5 1 0.4 0</time_weight>",
        "<time_weight>0.5 1.5</time_weight>",
        "<time_weight>0.5</time_weight>",
    ] {
        let e = contact_err(
            &m,
            &format!("<PointOnPlaneContact name=\"c\">{props}{bad}</PointOnPlaneContact>"),
        );
        assert!(
            e.contains("time_weight") && e.contains("line"),
            "{bad}: {e}"
        );
    }
}

/// `force_target_*` (statopt, issue 36): read into one spec per contact;
/// the target holds linearly between two knots that are both on, at an on
/// knot's own time, and nowhere else; a partial set, a row count or knot
/// that does not fit, an axis that is not a unit vector or a non-positive
/// optimal force is refused with the line.
#[test]
fn force_target_knots_hold_between_on_knots() {
    let m = test_model();
    let props = "<point_body>ground</point_body><point_location>0.5 -0.6 0.1</point_location>
         <plane_body>spin</plane_body><plane_normal>0 1 0</plane_normal>";
    assert!(contact(&m, props).force_target.is_none());
    let c = contact(
        &m,
        &format!(
            "{props}<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows>
             <force_target>0.1 1 0 1 0 100 0.2 1 1 0 0 50 0.3 0 0 1 0 0 0.5 1 0 1 0 10</force_target>
             <force_target_optimal_force>2</force_target_optimal_force>"
        ),
    );
    let spec = c.force_target.as_ref().unwrap();
    assert_eq!((spec.group.as_str(), spec.rows), ("g", 1));
    assert_eq!(spec.optimal_force, vec![2.0]);
    let at = |t: f64| spec.value_at(t).map(|v| v[0]);
    assert_eq!(at(0.05), None);
    assert_eq!(at(0.1), Some((Vector3::y(), 100.0)));
    let (axis, f) = at(0.15).unwrap();
    assert!((f - 75.0).abs() < 1e-12);
    assert!((axis - Vector3::new(1.0, 1.0, 0.0).normalize()).norm() < 1e-12);
    assert_eq!(at(0.25), None, "the third knot is off");
    assert_eq!(at(0.4), None);
    assert_eq!(at(0.5), Some((Vector3::y(), 10.0)));
    assert_eq!(at(0.6), None);
    for bad in [
        "<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows>",
        "<force_target_group>g</force_target_group><force_target_rows>4</force_target_rows><force_target>0 1 0 1 0 1</force_target>",
        "<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows><force_target>0 1 0 2 0 1</force_target>",
        "<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows><force_target>0 1 0 1 0 1 0 1 0 1 0 2</force_target>",
        "<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows><force_target>0 2 0 1 0 1</force_target>",
        "<force_target_group>g</force_target_group><force_target_rows>1</force_target_rows><force_target>0 1 0 1 0 1</force_target><force_target_optimal_force>0</force_target_optimal_force>",
    ] {
        let e = contact_err(
            &m,
            &format!("<PointOnPlaneContact name=\"c\">{props}{bad}</PointOnPlaneContact>"),
        );
        assert!(
            e.contains("force_target") && e.contains("line"),
            "{bad}: {e}"
        );
    }
}
