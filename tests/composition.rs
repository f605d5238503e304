//! Model composition (`<artifact_files>`), the composed-scene writer and the
//! minimum-jerk motion generator, through the public API and the tools.
//!
//! The composed model: a "human" shank (3 kg, mass center 0.2 m from the
//! knee) on a pin joint at the origin, and a machine "lever" (2 kg, mass
//! center 0.3 m from its pivot) on a pin joint about the same axis, 0.1 m
//! along it. A point-on-plane contact from a force-set file joins the shin
//! point 0.35 m from the knee to a pad frame on the lever. With both
//! horizontal (90°) and still, the lever hangs on the shin: the contact
//! carries N = m_l g 0.3 / 0.35 and the knee actuators hold both weights,
//! τ = (m_s 0.2 + m_l 0.3) g, shared by two CoordinateActuators of optimal
//! forces 100 and 1 in the ratio of their optimal forces (minimum Σa²).

mod common;
use common::col;

use std::path::{Path, PathBuf};

use statopt::model::compile;
use statopt::motion::coordinates::{CoordinateSplines, MissingCoordinate};
use statopt::parse::compose::read_composed;
use statopt::parse::osim::ModelSpec;
use statopt::parse::setup::Setup;
use statopt::storage::{self};
use statopt::tools::motion_gen::{generate, parse_link, MinJerkMotion};
use statopt::tools::scene::{compose_scene, write_document};
use statopt::tools::{analyze, inverse_dynamics, RunOptions};

const G: f64 = 9.80665;

const HUMAN: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenSimDocument Version="40000">
<Model name="human">
<gravity>0 -9.80665 0</gravity>
<Ground name="ground"/>
<BodySet><objects>
<Body name="shank"><mass>3</mass><mass_center>0 -0.2 0</mass_center><inertia>0.05 0.01 0.05 0 0 0</inertia></Body>
</objects></BodySet>
<JointSet><objects>
<PinJoint name="knee"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/shank</socket_child_frame>
<coordinates><Coordinate name="knee_angle"><default_value>0.3</default_value><range>-3 3</range></Coordinate></coordinates></PinJoint>
</objects></JointSet>
<ForceSet><objects>
<CoordinateActuator name="knee_act"><coordinate>knee_angle</coordinate><optimal_force>100</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>
</objects></ForceSet>
<MarkerSet><objects><Marker name="ankle"><socket_parent_frame>/bodyset/shank</socket_parent_frame><location>0 -0.4 0</location></Marker></objects></MarkerSet>
</Model>
</OpenSimDocument>
"#;

const MACHINE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenSimDocument Version="40000">
<Model name="machine &amp; lever">
<gravity>0 -9.80665 0</gravity>
<Ground name="ground"/>
<BodySet><objects>
<Body name="lever"><mass>2</mass><mass_center>0 -0.3 0</mass_center><inertia>0.02 0.001 0.02 0 0 0</inertia>
<components><PhysicalOffsetFrame name="pad"><socket_parent>..</socket_parent><translation>0 -0.35 0</translation></PhysicalOffsetFrame></components>
</Body>
</objects></BodySet>
<JointSet><objects>
<PinJoint name="lever_pin"><socket_parent_frame>pivot</socket_parent_frame><socket_child_frame>/bodyset/lever</socket_child_frame>
<coordinates><Coordinate name="lever_angle"><default_value>-0.2</default_value><range>-3 3</range></Coordinate></coordinates>
<frames><PhysicalOffsetFrame name="pivot"><socket_parent>/ground</socket_parent><translation>0 0 0.1</translation></PhysicalOffsetFrame></frames>
</PinJoint>
</objects></JointSet>
<MarkerSet><objects><Marker name="pad_marker"><socket_parent_frame>/bodyset/lever/pad</socket_parent_frame><location>0 0 0</location></Marker></objects></MarkerSet>
</Model>
</OpenSimDocument>
"#;

/// Force-set file: the shin-pad contact (plane on the artifact's pad frame)
/// and a weak knee reserve.
const CONTACTS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenSimDocument Version="40000"><ForceSet name="contacts"><objects>
<PointOnPlaneContact name="shin_pad">
  <point_body>shank</point_body><point_location>0 -0.35 0</point_location>
  <plane_body>/bodyset/lever/pad</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>-1 0 0</plane_normal>
  <optimal_force>100</optimal_force>
</PointOnPlaneContact>
<CoordinateActuator name="knee_reserve"><coordinate>knee_angle</coordinate><optimal_force>1</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>
</objects></ForceSet></OpenSimDocument>
"#;

fn still_motion(knee_deg: f64, lever_deg: f64) -> String {
    let mut s = String::from(
        "still\nversion=1\nnRows=11\nnColumns=3\ninDegrees=yes\nendheader\ntime\tknee_angle\tlever_angle\n",
    );
    for k in 0..11 {
        s.push_str(&format!("{:.2}\t{knee_deg}\t{lever_deg}\n", k as f64 * 0.1));
    }
    s
}

fn analyze_setup(artifacts: &str, force_sets: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><AnalyzeTool name="legext">
<model_file>human.osim</model_file><artifact_files>{artifacts}</artifact_files>
<replace_force_set>false</replace_force_set><force_set_files>{force_sets}</force_set_files>
<results_directory>out</results_directory><output_precision>12</output_precision>
<initial_time>0</initial_time><final_time>1</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet>
<coordinates_file>still.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
</AnalyzeTool></OpenSimDocument>"#
    )
}

/// A folder holding the human, machine and contact files and a still motion.
fn case(name: &str) -> PathBuf {
    let dir = common::out_dir(&format!("composition_{name}"));
    std::fs::write(dir.join("human.osim"), HUMAN).unwrap();
    std::fs::write(dir.join("machine.osim"), MACHINE).unwrap();
    std::fs::write(dir.join("contacts.xml"), CONTACTS).unwrap();
    std::fs::write(dir.join("still.mot"), still_motion(90.0, 90.0)).unwrap();
    dir
}

fn read_analyze(p: &Path) -> statopt::parse::setup::AnalyzeSetup {
    match Setup::read(p).unwrap() {
        Setup::Analyze(s) => s,
        _ => panic!("not an AnalyzeTool setup"),
    }
}

#[test]
fn composed_model_with_contact_in_force_set_file_runs_static_optimization() {
    let dir = case("so");
    std::fs::write(
        dir.join("setup.xml"),
        analyze_setup("machine.osim", "contacts.xml"),
    )
    .unwrap();
    let setup = read_analyze(&dir.join("setup.xml"));
    assert_eq!(setup.artifact_files, vec![dir.join("machine.osim")]);
    analyze::run(&setup, &RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));

    let act = storage::read(&dir.join("out/legext_SO_activation.sto")).unwrap();
    let cf = storage::read(&dir.join("out/legext_SO_ContactForces.sto")).unwrap();
    let tau = (3.0 * 0.2 + 2.0 * 0.3) * G;
    let normal = 2.0 * G * 0.3 / 0.35;
    // min a1² + a2² s.t. 100 a1 + 1 a2 = tau.
    let (a1, a2) = (100.0 * tau / 10001.0, tau / 10001.0);
    for (i, (k, r)) in col(&act, "knee_act")
        .iter()
        .zip(col(&act, "knee_reserve"))
        .enumerate()
    {
        assert!((k - a1).abs() < 1e-6, "frame {i}: knee_act {k} vs {a1}");
        assert!((r - a2).abs() < 1e-6, "frame {i}: knee_reserve {r} vs {a2}");
    }
    for fy in col(&cf, "shin_pad_fy") {
        // Force on the shin (point body): along the plane normal, -y.
        assert!(
            (fy + normal).abs() < 1e-6 * normal,
            "fy {fy} vs {}",
            -normal
        );
    }
    for fx in col(&cf, "shin_pad_fx") {
        assert!(fx.abs() < 1e-6, "shear {fx}");
    }
    for d in col(&cf, "shin_pad_distance") {
        assert!(d.abs() < 1e-12, "distance {d}");
    }
}

#[test]
fn inverse_dynamics_with_artifact_files() {
    let dir = case("id");
    std::fs::write(
        dir.join("setup_id.xml"),
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><InverseDynamicsTool name="legext">
<model_file>human.osim</model_file><artifact_files>machine.osim</artifact_files>
<coordinates_file>still.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
<results_directory>out</results_directory><output_gen_force_file>id.sto</output_gen_force_file>
<forces_to_exclude>Muscles</forces_to_exclude>
</InverseDynamicsTool></OpenSimDocument>"#,
    )
    .unwrap();
    let Setup::InverseDynamics(s) = Setup::read(&dir.join("setup_id.xml")).unwrap() else {
        panic!("not an ID setup")
    };
    inverse_dynamics::run(&s, &RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let id = storage::read(&dir.join("out/id.sto")).unwrap();
    // Holding each horizontal body still takes m g r about its pin.
    for v in col(&id, "knee_angle_moment") {
        assert!((v - 3.0 * G * 0.2).abs() < 1e-6, "{v}");
    }
    for v in col(&id, "lever_angle_moment") {
        assert!((v - 2.0 * G * 0.3).abs() < 1e-6, "{v}");
    }
}

#[test]
fn clashes_through_a_setup_name_both_files() {
    let dir = case("clash");
    // The machine reuses the human's body name.
    std::fs::write(
        dir.join("machine_bad.osim"),
        MACHINE
            .replace("\"lever\"", "\"shank\"")
            .replace("/bodyset/lever", "/bodyset/shank"),
    )
    .unwrap();
    std::fs::write(dir.join("setup.xml"), analyze_setup("machine_bad.osim", "")).unwrap();
    let setup = read_analyze(&dir.join("setup.xml"));
    let e = analyze::run(&setup, &RunOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{msg}");
    assert!(
        msg.contains("machine_bad.osim") && msg.contains("human.osim"),
        "{msg}"
    );
    assert!(
        msg.contains("body 'shank'") && msg.contains("<Body name=\"shank\">"),
        "{msg}"
    );

    // The same artifact twice: its joint clashes with itself.
    std::fs::write(
        dir.join("setup2.xml"),
        analyze_setup("machine.osim machine.osim", ""),
    )
    .unwrap();
    let setup = read_analyze(&dir.join("setup2.xml"));
    let msg = analyze::run(&setup, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("machine.osim") && msg.contains("clashes"),
        "{msg}"
    );

    // Different gravity.
    std::fs::write(
        dir.join("machine_g.osim"),
        MACHINE.replace("0 -9.80665 0", "0 -9.81 0"),
    )
    .unwrap();
    std::fs::write(dir.join("setup3.xml"), analyze_setup("machine_g.osim", "")).unwrap();
    let setup = read_analyze(&dir.join("setup3.xml"));
    let msg = analyze::run(&setup, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("gravity") && msg.contains("machine_g.osim") && msg.contains("human.osim"),
        "{msg}"
    );
}

#[test]
fn scene_document_recompiles_to_the_same_model() {
    let dir = case("scene");
    let composed = read_composed(&dir.join("human.osim"), &[dir.join("machine.osim")]).unwrap();
    let direct = compile(&composed).unwrap();
    let scene = compose_scene(
        &dir.join("human.osim"),
        &[dir.join("machine.osim")],
        &[dir.join("contacts.xml")],
        false,
    )
    .unwrap();
    assert_eq!(scene.omitted_contacts, vec!["shin_pad".to_string()]);
    let out = dir.join("sub");
    std::fs::create_dir_all(&out).unwrap();
    write_document(&scene.document, &out.join("scene.osim")).unwrap();

    let spec = ModelSpec::read(&out.join("scene.osim")).unwrap_or_else(|e| panic!("{e}"));
    let again = compile(&spec).unwrap();
    let names = |m: &statopt::model::Model| -> Vec<(String, f64)> {
        m.bodies.iter().map(|b| (b.name.clone(), b.mass)).collect()
    };
    assert_eq!(names(&again), names(&direct));
    assert_eq!(again.bodies.len(), 3); // ground, shank, lever
    let coords = |m: &statopt::model::Model| -> Vec<(String, f64)> {
        m.coordinates
            .iter()
            .map(|c| (c.name.clone(), c.default_value))
            .collect()
    };
    assert_eq!(coords(&again), coords(&direct));
    for (a, b) in again.bodies.iter().zip(&direct.bodies) {
        assert_eq!(a.mass_center, b.mass_center);
        assert_eq!(a.inertia, b.inertia);
        assert_eq!(a.parent, b.parent);
    }
    for (a, b) in again.joints.iter().zip(&direct.joints).skip(1) {
        assert_eq!(a.x_pf, b.x_pf, "joint {}", a.name);
        assert_eq!(a.x_bm, b.x_bm, "joint {}", a.name);
    }
    let pad = again.frame("/bodyset/lever/pad").unwrap();
    assert_eq!(again.bodies[pad.body].name, "lever");
    // Forces: the human's and the force-set file's actuator; the contact left out.
    let forces: Vec<&str> = spec.forces.iter().map(|f| f.name_attr()).collect();
    assert_eq!(forces, vec!["knee_act", "knee_reserve"]);
    // Markers of both documents are in one MarkerSet; the escaped model name
    // is untouched (the artifact's name does not replace the human's).
    let doc = statopt::xml::parse_file(&out.join("scene.osim")).unwrap();
    let markers: Vec<&str> = doc
        .path(&["Model", "MarkerSet", "objects"])
        .unwrap()
        .children
        .iter()
        .map(|m| m.name_attr())
        .collect();
    assert_eq!(markers, vec!["ankle", "pad_marker"]);
    assert_eq!(doc.child("Model").unwrap().name_attr(), "human");

    // A clash in a set statopt does not model (markers) is caught too.
    std::fs::write(
        dir.join("machine_m.osim"),
        MACHINE.replace("pad_marker", "ankle"),
    )
    .unwrap();
    let e = compose_scene(
        &dir.join("human.osim"),
        &[dir.join("machine_m.osim")],
        &[],
        false,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("machine_m.osim") && e.contains("human.osim") && e.contains("ankle"),
        "{e}"
    );
}

/// Minimum jerk: q(t) = A + (B − A)(10s³ − 15s⁴ + 6s⁵), s = t/T; q(T/2) is the
/// midpoint, the peak speed 15/8 (B − A)/T at T/2, and velocity and
/// acceleration vanish at both ends.
#[test]
fn minimum_jerk_motion_file() {
    let dir = case("motion");
    let (_, model) = statopt::tools::loading::load_composed_model(
        &dir.join("human.osim"),
        &[dir.join("machine.osim")],
    )
    .unwrap();
    let (a, b, t_end, rate) = (-95.0, -5.0, 5.0, 100.0);
    let m = MinJerkMotion {
        coordinate: "knee_angle".into(),
        also: vec![],
        from: a,
        to: b,
        duration: t_end,
        rate,
        links: vec![parse_link("lever_angle=1*knee_angle+12.5").unwrap()],
        ..MinJerkMotion::default()
    };
    let (table, warnings) = generate(&model, &m, &[]).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let path = dir.join("legext.mot");
    storage::write(&path, &table, 10).unwrap();
    let t = storage::read(&path).unwrap();
    assert!(t.in_degrees);
    assert_eq!(t.len(), 501);
    assert_eq!(t.labels, vec!["knee_angle", "lever_angle"]);
    let q = col(&t, "knee_angle");
    let lever = col(&t, "lever_angle");
    assert!((t.time[500] - t_end).abs() < 1e-12);
    assert!((q[0] - a).abs() < 1e-10, "{}", q[0]);
    assert!((q[250] - (a + b) / 2.0).abs() < 1e-9, "{}", q[250]);
    assert!((q[500] - b).abs() < 1e-10, "{}", q[500]);
    for (k, l) in q.iter().zip(&lever) {
        assert!((l - (k + 12.5)).abs() < 1e-9);
    }
    // Analytically from the written values: differences at the ends.
    let h = 1.0 / rate;
    let peak_v = 15.0 / 8.0 * (b - a) / t_end;
    let peak_acc = 10.0 / 3f64.sqrt() * (b - a) / (t_end * t_end);
    let jerk0 = 60.0 * (b - a) / t_end.powi(3);
    let v_mid = (q[251] - q[249]) / (2.0 * h);
    assert!(
        (v_mid - peak_v).abs() < 1e-3,
        "mid speed {v_mid} vs {peak_v}"
    );
    for (i0, i1, i2) in [(0, 1, 2), (500, 499, 498)] {
        let v = (q[i1] - q[i0]) / h;
        let acc = (q[i2] - 2.0 * q[i1] + q[i0]) / (h * h);
        assert!(v.abs() < 1e-4 * peak_v, "end speed {v}");
        // q(2h) − 2q(h) + q(0) = 60 (B − A) h³/T³ to leading order: the
        // acceleration vanishes at the end like h |q'''(0)|.
        assert!(acc.abs() < 1.1 * h * jerk0, "end acceleration {acc}");
        assert!(acc.abs() < 0.05 * peak_acc);
    }
    // Through statopt's own quintic splines of the file (rad, rad/s, rad/s²).
    let splines =
        CoordinateSplines::new(&model, &t, MissingCoordinate::DefaultValue, &path).unwrap();
    let (mut qq, mut u, mut udot) = (vec![0.0; 2], vec![0.0; 2], vec![0.0; 2]);
    let ik = model.coordinate_index("knee_angle").unwrap();
    // The natural quintic spline has q''' = 0 at its ends where minimum jerk
    // has |q'''| = 60 |B − A| / T³, so its end acceleration is off by about
    // h |q'''| (2 % of the peak acceleration here).
    for time in [0.0, t_end] {
        splines.eval(time, &mut qq, &mut u, &mut udot);
        assert!(
            u[ik].abs() < 1e-4 * peak_v.to_radians(),
            "u({time}) = {}",
            u[ik]
        );
        assert!(
            udot[ik].abs() < h * jerk0.to_radians(),
            "u'({time}) = {}",
            udot[ik]
        );
    }
    splines.eval(t_end / 2.0, &mut qq, &mut u, &mut udot);
    assert!((u[ik] - peak_v.to_radians()).abs() < 1e-6, "{}", u[ik]);

    // --touch: the lever follows the shin so that the pad stays on it. Here
    // d = 0.35 sin(lever − knee) (both pins about z through the origin's z
    // axis), so the solution near the start lever = knee + 12.5° is lever = knee.
    let contacts = statopt::forces::force_set_members(
        &statopt::xml::parse_str(CONTACTS, Path::new("contacts.xml")).unwrap(),
    )
    .unwrap();
    let touching = MinJerkMotion {
        touch: vec![statopt::tools::motion_gen::parse_touch("shin_pad=lever_angle").unwrap()],
        links: vec![],
        rate: 20.0,
        ..m.clone()
    };
    let e = generate(&model, &touching, &[]).unwrap_err().to_string();
    assert!(e.contains("shin_pad"), "{e}");
    let linked_start = MinJerkMotion {
        links: m.links.clone(),
        ..touching.clone()
    };
    for motion in [&touching, &linked_start] {
        let (tt, _) = generate(&model, motion, &contacts).unwrap();
        for (k, l) in col(&tt, "knee_angle").iter().zip(col(&tt, "lever_angle")) {
            assert!((l - k).abs() < 1e-8, "lever {l} vs knee {k}");
        }
    }
    let twice = MinJerkMotion {
        also: vec!["lever_angle".into()],
        ..touching.clone()
    };
    let e = generate(&model, &twice, &contacts).unwrap_err().to_string();
    assert!(e.contains("already"), "{e}");

    // Other coordinates at their defaults (degrees in the file).
    let m2 = MinJerkMotion {
        links: vec![],
        ..m.clone()
    };
    let (t2, _) = generate(&model, &m2, &[]).unwrap();
    for v in col(&t2, "lever_angle") {
        assert!((v - (-0.2f64).to_degrees()).abs() < 1e-12);
    }
    // Bad input.
    let bad = MinJerkMotion {
        coordinate: "nope".into(),
        ..m.clone()
    };
    let e = generate(&model, &bad, &[]).unwrap_err().to_string();
    assert!(e.contains("nope") && e.contains("knee_angle"), "{e}");
    let bad = MinJerkMotion {
        duration: 0.0,
        ..m.clone()
    };
    assert!(generate(&model, &bad, &[]).is_err());
    // Leaving the range is reported.
    let wide = MinJerkMotion { from: -200.0, ..m };
    let (_, w) = generate(&model, &wide, &[]).unwrap();
    assert!(
        w.iter()
            .any(|w| w.contains("knee_angle") && w.contains("range")),
        "{w:?}"
    );
}
