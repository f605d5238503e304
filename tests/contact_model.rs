//! The paper's contact model through the whole tool (setup → model →
//! static optimization with contacts → tables), against closed-form answers
//! (Krüger & Wartzack 2017, Figure 5 and eqs. 1–16) and invariants.

mod common;
use common::{col, run_setup};

use std::path::PathBuf;

use statopt::storage::{self};

const G: f64 = 9.80665;
const MASS: f64 = 10.0;
const F_M: f64 = 100.0; // the "muscle": a PointActuator along the slope
const F0: f64 = 100.0; // contact optimal_force

/// A block that can only translate (CustomJoint tx, ty, tz), a point-on-plane
/// contact between the block's origin and a ground plane through the origin
/// with normal tilted by `theta` about z, and actuators given as XML.
fn block_model(theta: f64, contact_extra: &str, actuators: &str) -> String {
    let n = (-theta.sin(), theta.cos());
    let axis = |name: &str, coord: &str, ax: &str| {
        format!(
            r#"<TransformAxis name="{name}"><coordinates>{coord}</coordinates><axis>{ax}</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>"#
        )
    };
    let rot = |name: &str, ax: &str| {
        format!(r#"<TransformAxis name="{name}"><coordinates/><axis>{ax}</axis></TransformAxis>"#)
    };
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><Model name="block">
<gravity>0 -{G} 0</gravity>
<BodySet><objects><Body name="block"><mass>{MASS}</mass><mass_center>0 0 0</mass_center><inertia>0.1 0.1 0.1 0 0 0</inertia></Body></objects></BodySet>
<JointSet><objects><CustomJoint name="slide"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/block</socket_child_frame>
<coordinates><Coordinate name="tx"><range>-100 100</range></Coordinate><Coordinate name="ty"><range>-100 100</range></Coordinate><Coordinate name="tz"><range>-100 100</range></Coordinate></coordinates>
<SpatialTransform>{}{}{}{}{}{}</SpatialTransform></CustomJoint></objects></JointSet>
<ForceSet><objects>
{actuators}
<PointOnPlaneContact name="floor">
  <point_body>block</point_body><point_location>0 0 0</point_location>
  <plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>{} {} 0</plane_normal>
  <optimal_force>{F0}</optimal_force>{contact_extra}
</PointOnPlaneContact>
</objects></ForceSet></Model></OpenSimDocument>"#,
        rot("rotation1", "1 0 0"),
        rot("rotation2", "0 1 0"),
        rot("rotation3", "0 0 1"),
        axis("translation1", "tx", "1 0 0"),
        axis("translation2", "ty", "0 1 0"),
        axis("translation3", "tz", "0 0 1"),
        n.0,
        n.1
    )
}

fn point_actuator(name: &str, dir: (f64, f64, f64), optimal_force: f64) -> String {
    format!(
        r#"<PointActuator name="{name}"><body>block</body><point>0 0 0</point><point_is_global>false</point_is_global><direction>{} {} {}</direction><force_is_global>true</force_is_global><optimal_force>{optimal_force}</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></PointActuator>"#,
        dir.0, dir.1, dir.2
    )
}

/// Motion: q(t) = f(t) for tx, ty, tz on 41 rows over 2 s.
fn motion(f: impl Fn(f64) -> [f64; 3]) -> String {
    let mut s = String::from("block motion\nversion=1\nnRows=41\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n");
    for k in 0..41 {
        let t = k as f64 * 0.05;
        let q = f(t);
        s.push_str(&format!(
            "{t:.4}\t{:.15}\t{:.15}\t{:.15}\n",
            q[0], q[1], q[2]
        ));
    }
    s
}

fn setup(model_file: &str, motion_file: &str, so_extra: &str, loads: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><AnalyzeTool name="block">
<model_file>{model_file}</model_file><results_directory>out</results_directory><output_precision>14</output_precision>
<initial_time>0</initial_time><final_time>2</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO">{so_extra}</StaticOptimization></objects></AnalysisSet>
<external_loads_file>{loads}</external_loads_file>
<coordinates_file>{motion_file}</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
</AnalyzeTool></OpenSimDocument>"#
    )
}

/// Write model, motion and setup into a fresh folder and run the setup.
fn run_case(name: &str, model: &str, motion_text: &str, so_extra: &str) -> PathBuf {
    let dir = common::out_dir(&format!("contact_{name}"));
    std::fs::write(dir.join("model.osim"), model).unwrap();
    std::fs::write(dir.join("motion.mot"), motion_text).unwrap();
    std::fs::write(
        dir.join("setup.xml"),
        setup("model.osim", "motion.mot", so_extra, ""),
    )
    .unwrap();
    run_setup(&dir.join("setup.xml"));
    dir.join("out")
}

const WEIGHTS: [f64; 10] = [1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6];

fn tag(w: f64) -> String {
    let t = format!("{w}");
    if t.len() <= 8 {
        t
    } else {
        format!("{w:e}")
    }
}

/// Figure 5: the share of the downhill load the muscle carries, as a
/// function of w0, is a = G F_m / (F_m² + w0 F0²) while friction can carry the
/// rest; once the friction limit binds, the muscle carries G − μ N.
#[test]
fn block_on_incline_matches_the_analytic_optimum_for_every_w0() {
    let weights = WEIGHTS
        .iter()
        .map(|w| format!("{w:e}"))
        .collect::<Vec<_>>()
        .join(" ");
    for (theta_deg, mu) in [(20.0f64, 0.8), (50.0, 0.8)] {
        let theta = theta_deg.to_radians();
        let up = (theta.cos(), theta.sin(), 0.0);
        let model = block_model(
            theta,
            &format!("<static_friction>{mu}</static_friction>"),
            &point_actuator("muscle", up, F_M),
        );
        let still = motion(|_| [0.0, 0.0, 0.0]);
        for friction in ["cone", "pyramid"] {
            let out = run_case(
                &format!("incline_{theta_deg}_{friction}"),
                &model,
                &still,
                &format!("<contact_weight>{weights}</contact_weight><friction_cone>{friction}</friction_cone>"),
            );
            let (downhill, normal) = (MASS * G * theta.sin(), MASS * G * theta.cos());
            for &w0 in &WEIGHTS {
                let act =
                    storage::read(&out.join(format!("block_SO_w0_{}_activation.sto", tag(w0))))
                        .unwrap();
                let cf =
                    storage::read(&out.join(format!("block_SO_w0_{}_ContactForces.sto", tag(w0))))
                        .unwrap();
                let free = downhill * F_M / (F_M * F_M + w0 * F0 * F0);
                let expect = if (downhill - F_M * free) <= mu * normal {
                    free
                } else {
                    (downhill - mu * normal) / F_M
                };
                for (i, a) in col(&act, "muscle").iter().enumerate() {
                    assert!((a - expect).abs() < 1e-6, "theta {theta_deg}, {friction}, w0 {w0}: a = {a}, analytic {expect} (frame {i})");
                }
                // Friction on the block along the slope, and the limit when it binds.
                let f = [
                    col(&cf, "floor_fx")[0],
                    col(&cf, "floor_fy")[0],
                    col(&cf, "floor_fz")[0],
                ];
                let shear = f[0] * up.0 + f[1] * up.1;
                let n_force = -f[0] * theta.sin() + f[1] * theta.cos();
                assert!(
                    (n_force - normal).abs() < 1e-6 * normal.max(1.0),
                    "normal {n_force} vs {normal}"
                );
                assert!(
                    (shear - (downhill - F_M * expect)).abs() < 1e-6 * downhill,
                    "shear {shear}"
                );
                assert!(
                    shear <= mu * n_force * (1.0 + 1e-7),
                    "friction limit exceeded: {shear} > {}",
                    mu * n_force
                );
                if theta_deg == 50.0 && w0 >= 10.0 {
                    assert!(
                        (shear - mu * n_force).abs() < 1e-6 * n_force,
                        "friction limit should bind exactly: {shear} vs {}",
                        mu * n_force
                    );
                }
            }
            // The muscle's share falls as w0 grows (Figure 5).
            let mut last = f64::INFINITY;
            for &w0 in &WEIGHTS {
                let act =
                    storage::read(&out.join(format!("block_SO_w0_{}_activation.sto", tag(w0))))
                        .unwrap();
                let a = col(&act, "muscle")[0];
                assert!(
                    a <= last + 1e-8,
                    "not monotone at w0 {w0}: {a} after {last}"
                );
                last = a;
            }
        }
    }
}

/// A block sliding along a level plane faster than v_trans: kinetic friction
/// μ_k N opposes the slip, the pushing actuator supplies exactly that.
#[test]
fn sliding_block_gets_kinetic_friction_opposing_the_slip() {
    let mu_k = 0.5;
    let acts = point_actuator("push", (1.0, 0.0, 0.0), F_M)
        + &point_actuator("side", (0.0, 0.0, 1.0), F_M);
    let model = block_model(
        0.0,
        &format!("<kinetic_friction>{mu_k}</kinetic_friction><v_trans>0.1</v_trans>"),
        &acts,
    );
    for (speed, sign) in [(0.5, 1.0), (-0.3, -1.0)] {
        let out = run_case(
            &format!("sliding_{sign}"),
            &model,
            &motion(|t| [speed * t, 0.0, 0.0]),
            "<contact_weight>1000</contact_weight>",
        );
        let act = storage::read(&out.join("block_SO_activation.sto")).unwrap();
        let cf = storage::read(&out.join("block_SO_ContactForces.sto")).unwrap();
        let n = MASS * G;
        for i in 0..act.time.len() {
            assert_eq!(col(&cf, "floor_regime")[i], 1.0, "kinetic regime expected");
            assert!((col(&cf, "floor_fy")[i] - n).abs() < 1e-6 * n);
            assert!(
                (col(&cf, "floor_fx")[i] + sign * mu_k * n).abs() < 1e-6 * n,
                "friction {} vs {}",
                col(&cf, "floor_fx")[i],
                -sign * mu_k * n
            );
            assert!((col(&act, "push")[i] * F_M - sign * mu_k * n).abs() < 1e-6 * n);
            assert!(col(&cf, "floor_fz")[i].abs() < 1e-9);
        }
    }
}

/// A contact whose point is beyond d_tol + d_trans has w(d) = 0 and carries
/// no force; the actuators hold the block.
#[test]
fn contact_beyond_the_transition_zone_carries_no_force() {
    let acts = point_actuator("lift", (0.0, 1.0, 0.0), F_M);
    let model = block_model(0.0, "<contact_tolerance>0</contact_tolerance><contact_transition_zone>0.01</contact_transition_zone>", &acts);
    let out = run_case(
        "disengaged",
        &model,
        &motion(|_| [0.0, 0.05, 0.0]),
        "<contact_weight>1e6</contact_weight>",
    );
    let act = storage::read(&out.join("block_SO_activation.sto")).unwrap();
    let cf = storage::read(&out.join("block_SO_ContactForces.sto")).unwrap();
    for i in 0..act.time.len() {
        assert_eq!(col(&cf, "floor_weight")[i], 0.0);
        for c in ["floor_fx", "floor_fy", "floor_fz"] {
            assert_eq!(col(&cf, c)[i], 0.0, "{c}");
        }
        assert!((col(&act, "lift")[i] * F_M - MASS * G).abs() < 1e-6 * MASS * G);
    }
}

/// A box (3 rotations, 3 translations) resting on four corner contacts,
/// rocking and drifting; residual actuators keep every frame feasible. On
/// every frame of every run (three w0, cone and pyramid) the friction
/// constraints and the equations of motion hold to solver tolerance, and the
/// exported ExternalLoads reproduce the run without contacts.
#[test]
fn multi_contact_invariants_and_external_loads_round_trip() {
    let dir = common::out_dir("contact_box");
    let coords = ["rx", "ry", "rz", "tx", "ty", "tz"];
    let axes = ["1 0 0", "0 1 0", "0 0 1", "1 0 0", "0 1 0", "0 0 1"];
    let names = [
        "rotation1",
        "rotation2",
        "rotation3",
        "translation1",
        "translation2",
        "translation3",
    ];
    let st: String = (0..6)
        .map(|i| format!(r#"<TransformAxis name="{}"><coordinates>{}</coordinates><axis>{}</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>"#, names[i], coords[i], axes[i]))
        .collect();
    let coordinates: String = coords
        .iter()
        .map(|c| format!("<Coordinate name=\"{c}\"><range>-10 10</range></Coordinate>"))
        .collect();
    let residuals: String = coords
        .iter()
        .map(|c| format!("<CoordinateActuator name=\"{c}_residual\"><coordinate>{c}</coordinate><optimal_force>1</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>"))
        .collect();
    let lift = point_actuator("lift", (0.0, 1.0, 0.0), 50.0)
        .replace("<body>block</body>", "<body>box</body>");
    let contacts: String = [(0.2, 0.1), (-0.2, 0.1), (0.2, -0.1), (-0.2, -0.1)]
        .iter()
        .enumerate()
        .map(|(k, (x, z))| {
            format!(
                r#"<PointOnPlaneContact name="c{k}"><point_body>box</point_body><point_location>{x} -0.05 {z}</point_location><plane_body>ground</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>0 1 0</plane_normal><contact_tolerance>0.002</contact_tolerance><contact_transition_zone>0.01</contact_transition_zone></PointOnPlaneContact>"#
            )
        })
        .collect();
    let model = |with_contacts: bool| {
        format!(
            r#"<OpenSimDocument Version="40000"><Model name="box"><gravity>0 -{G} 0</gravity>
<BodySet><objects><Body name="box"><mass>8</mass><mass_center>0 0 0</mass_center><inertia>0.05 0.1 0.08 0 0 0</inertia></Body></objects></BodySet>
<JointSet><objects><CustomJoint name="free"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/box</socket_child_frame><coordinates>{coordinates}</coordinates><SpatialTransform>{st}</SpatialTransform></CustomJoint></objects></JointSet>
<ForceSet><objects>{residuals}{lift}{}</objects></ForceSet></Model></OpenSimDocument>"#,
            if with_contacts { contacts.as_str() } else { "" }
        )
    };
    std::fs::write(dir.join("box.osim"), model(true)).unwrap();
    std::fs::write(dir.join("box_free.osim"), model(false)).unwrap();
    let mut m = String::from("box motion\nversion=1\nnRows=61\nnColumns=7\ninDegrees=no\nendheader\ntime\trx\try\trz\ttx\tty\ttz\n");
    for k in 0..61 {
        let t = k as f64 * 0.05;
        let w = 2.0 * std::f64::consts::PI * 0.5 * t;
        // rocking about x and z lifts corners in and out of the transition zone; slow drift keeps contacts static, a fast slide at the end makes them kinetic
        let q = [
            0.03 * w.sin(),
            0.1 * t,
            0.02 * (2.0 * w).sin(),
            0.02 * t
                + if t > 2.5 {
                    0.6 * (t - 2.5) * (t - 2.5)
                } else {
                    0.0
                },
            0.05 + 0.004 * w.cos(),
            0.01 * t,
        ];
        m.push_str(&format!(
            "{t:.4}\t{}\n",
            q.iter()
                .map(|v| format!("{v:.15}"))
                .collect::<Vec<_>>()
                .join("\t")
        ));
    }
    std::fs::write(dir.join("box.mot"), &m).unwrap();
    for friction in ["cone", "pyramid"] {
        std::fs::write(
            dir.join(format!("setup_{friction}.xml")),
            setup("box.osim", "box.mot", &format!("<contact_weight>1 500 1000</contact_weight><friction_cone>{friction}</friction_cone>"), "")
                .replace("<final_time>2</final_time>", "<final_time>3</final_time>")
                .replace("<results_directory>out</results_directory>", &format!("<results_directory>out_{friction}</results_directory>")),
        )
        .unwrap();
        run_setup(&dir.join(format!("setup_{friction}.xml")));
        let mut kinetic_frames = 0;
        for w in ["1", "500", "1000"] {
            let diag =
                storage::read(&dir.join(format!("out_{friction}/block_SO_w0_{w}_diagnostics.sto")))
                    .unwrap();
            for (i, t) in diag.time.iter().enumerate() {
                assert_eq!(
                    col(&diag, "status")[i],
                    0.0,
                    "{friction} w0 {w} t={t}: not solved"
                );
                assert!(
                    col(&diag, "relative_residual")[i] < 1e-6,
                    "{friction} w0 {w} t={t}: EOM residual {}",
                    col(&diag, "relative_residual")[i]
                );
                assert!(
                    col(&diag, "friction_violation")[i] < 1e-6,
                    "{friction} w0 {w} t={t}: friction violated by {}",
                    col(&diag, "friction_violation")[i]
                );
            }
            let cf = storage::read(
                &dir.join(format!("out_{friction}/block_SO_w0_{w}_ContactForces.sto")),
            )
            .unwrap();
            kinetic_frames += col(&cf, "c0_regime").iter().filter(|r| **r == 1.0).count();
            assert!(
                col(&cf, "c0_weight").iter().any(|w| *w < 0.99),
                "rocking should take a corner into the transition zone"
            );
        }
        assert!(
            kinetic_frames > 0,
            "the fast slide should make contacts kinetic"
        );
        // Sweep statistics exist and bracket each run.
        let mean =
            storage::read(&dir.join(format!("out_{friction}/block_SO_w0_mean_ContactForces.sto")))
                .unwrap();
        let lo =
            storage::read(&dir.join(format!("out_{friction}/block_SO_w0_min_ContactForces.sto")))
                .unwrap();
        let hi =
            storage::read(&dir.join(format!("out_{friction}/block_SO_w0_max_ContactForces.sto")))
                .unwrap();
        let runs: Vec<_> = ["1", "500", "1000"]
            .iter()
            .map(|w| {
                storage::read(
                    &dir.join(format!("out_{friction}/block_SO_w0_{w}_ContactForces.sto")),
                )
                .unwrap()
            })
            .collect();
        assert_eq!(mean.time, runs[0].time);
        for i in 0..mean.time.len() {
            for j in 0..mean.labels.len() {
                assert!(
                    lo.rows[i][j] <= mean.rows[i][j] + 1e-12
                        && mean.rows[i][j] <= hi.rows[i][j] + 1e-12
                );
                // They are the statistics of the runs' tables (as written,
                // to the table's precision).
                let vals: Vec<f64> = runs.iter().map(|r| r.rows[i][j]).collect();
                let want = [
                    vals.iter().sum::<f64>() / 3.0,
                    vals.iter().copied().fold(f64::INFINITY, f64::min),
                    vals.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                ];
                for (got, want) in [&mean, &lo, &hi].iter().zip(want) {
                    assert!((got.rows[i][j] - want).abs() <= 1e-8 * want.abs().max(1.0));
                }
            }
        }
    }
    // Round trip: the exported loads on the contact-free model reproduce the activations.
    let loads = "out_cone/block_SO_w0_1000_ContactExternalLoads.xml";
    std::fs::write(
        dir.join("setup_roundtrip.xml"),
        setup("box_free.osim", "box.mot", "", loads)
            .replace("<final_time>2</final_time>", "<final_time>3</final_time>")
            .replace(
                "<results_directory>out</results_directory>",
                "<results_directory>out_roundtrip</results_directory>",
            ),
    )
    .unwrap();
    run_setup(&dir.join("setup_roundtrip.xml"));
    let with = storage::read(&dir.join("out_cone/block_SO_w0_1000_activation.sto")).unwrap();
    let without = storage::read(&dir.join("out_roundtrip/block_SO_activation.sto")).unwrap();
    assert_eq!(with.time.len(), without.time.len());
    let mut worst = 0.0f64;
    for (j, label) in with.labels.iter().enumerate() {
        let k = without.column_index(label).unwrap();
        for i in 0..with.time.len() {
            worst = worst.max((with.rows[i][j] - without.rows[i][k]).abs());
        }
    }
    println!("ExternalLoads round trip: worst activation difference {worst:.2e}");
    assert!(worst < 1e-4, "round trip differs by {worst}");
}

/// Bad contact input gets a clear error naming the file, line and element.
#[test]
fn bad_contact_input_is_reported() {
    let cases = [
        (
            "zero_normal",
            block_model(0.0, "", "").replace(
                "<plane_normal>-0 1 0</plane_normal>",
                "<plane_normal>0 0 0</plane_normal>",
            ),
            "normal",
        ),
        (
            "unknown_body",
            block_model(0.0, "", "").replace(
                "<point_body>block</point_body>",
                "<point_body>brick</point_body>",
            ),
            "brick",
        ),
        (
            "negative_friction",
            block_model(0.0, "<static_friction>-0.2</static_friction>", ""),
            "friction",
        ),
        (
            "v_trans",
            block_model(0.0, "<v_trans>0</v_trans>", ""),
            "v_trans",
        ),
    ];
    for (name, model, needle) in cases {
        let dir = common::out_dir(&format!("contact_bad_{name}"));
        std::fs::write(dir.join("model.osim"), &model).unwrap();
        std::fs::write(dir.join("motion.mot"), motion(|_| [0.0; 3])).unwrap();
        std::fs::write(
            dir.join("setup.xml"),
            setup("model.osim", "motion.mot", "", ""),
        )
        .unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .arg(dir.join("setup.xml"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains("model.osim")
                && err.contains("line")
                && err.contains("floor")
                && err.to_lowercase().contains(needle),
            "{name}: {err}"
        );
    }
}
