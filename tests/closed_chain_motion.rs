//! `statopt-tool motion` on a closed chain: a planar seated leg press made of
//! a leg (thigh 0.4 m, shank 0.4 m on pins about z, hip fixed to the ground)
//! whose foot (heel 0.06 m ahead of and 0.05 m below the ankle, toe 0.15 m
//! above the heel) pushes a footplate carried by a sled on a slider along x.
//! The plate's plane faces the hip (normal −x). With the hip at 0 and the
//! knee at angle k (negative: flexed), the sole is flush with the plate when
//! ankle = −k, and the sled is then at x = 0.46 + 0.4 cos k.
//!
//! Defects covered (issue 35): several `--touch` solved one after another
//! (a later one reopened an earlier contact); no way to keep a loaded point
//! where it landed (`--plant`); no repetitions (`--return`, `--repeat`,
//! `--hold-start`, `--hold-end`); `--setup` refused a setup whose motion file
//! is the one being written.

mod common;
use common::col;

use std::path::{Path, PathBuf};
use std::process::Command;

use nalgebra::Vector3;
use statopt::contacts::closure::{close_contact, contact_distance};
use statopt::contacts::Contact;
use statopt::dynamics::{kinematics, Data};
use statopt::model::Model;
use statopt::storage::{self, Storage};

const LEG: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenSimDocument Version="40000">
<Model name="leg_press">
<gravity>0 -9.80665 0</gravity>
<Ground name="ground"/>
<BodySet><objects>
<Body name="thigh"><mass>7</mass><mass_center>0.2 0 0</mass_center><inertia>0.01 0.1 0.1 0 0 0</inertia></Body>
<Body name="shank"><mass>3</mass><mass_center>0.2 0 0</mass_center><inertia>0.005 0.04 0.04 0 0 0</inertia></Body>
<Body name="foot"><mass>1</mass><mass_center>0.05 0.05 0</mass_center><inertia>0.001 0.002 0.002 0 0 0</inertia></Body>
<Body name="sled"><mass>20</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia>
<components><PhysicalOffsetFrame name="plate"><socket_parent>..</socket_parent><translation>0 0 0</translation></PhysicalOffsetFrame></components>
</Body>
</objects></BodySet>
<JointSet><objects>
<PinJoint name="hip"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/thigh</socket_child_frame>
<coordinates><Coordinate name="hip_flexion"><default_value>0</default_value><range>-2 2</range></Coordinate></coordinates></PinJoint>
<PinJoint name="knee"><socket_parent_frame>knee_in_thigh</socket_parent_frame><socket_child_frame>/bodyset/shank</socket_child_frame>
<coordinates><Coordinate name="knee_angle"><default_value>-0.5</default_value><range>-2.5 0.1</range></Coordinate></coordinates>
<frames><PhysicalOffsetFrame name="knee_in_thigh"><socket_parent>/bodyset/thigh</socket_parent><translation>0.4 0 0</translation></PhysicalOffsetFrame></frames>
</PinJoint>
<PinJoint name="ankle"><socket_parent_frame>ankle_in_shank</socket_parent_frame><socket_child_frame>/bodyset/foot</socket_child_frame>
<coordinates><Coordinate name="ankle_angle"><default_value>0.5</default_value><range>-2 2</range></Coordinate></coordinates>
<frames><PhysicalOffsetFrame name="ankle_in_shank"><socket_parent>/bodyset/shank</socket_parent><translation>0.4 0 0</translation></PhysicalOffsetFrame></frames>
</PinJoint>
<SliderJoint name="rail"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/sled</socket_child_frame>
<coordinates><Coordinate name="sled_x"><default_value>0.8</default_value><range>-1 2</range></Coordinate></coordinates></SliderJoint>
</objects></JointSet>
</Model>
</OpenSimDocument>
"#;

const CONTACTS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<OpenSimDocument Version="40000"><ForceSet name="feet"><objects>
<PointOnPlaneContact name="heel">
  <point_body>foot</point_body><point_location>0.06 -0.05 0</point_location>
  <plane_body>/bodyset/sled/plate</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>-1 0 0</plane_normal>
  <optimal_force>1000</optimal_force>
</PointOnPlaneContact>
<PointOnPlaneContact name="toe">
  <point_body>foot</point_body><point_location>0.06 0.15 0</point_location>
  <plane_body>/bodyset/sled/plate</plane_body><plane_origin>0 0 0</plane_origin><plane_normal>-1 0 0</plane_normal>
  <optimal_force>1000</optimal_force>
</PointOnPlaneContact>
</objects></ForceSet></OpenSimDocument>
"#;

/// A folder with the model and the contacts.
fn case(name: &str) -> PathBuf {
    let dir = common::out_dir(&format!("closed_chain_{name}"));
    std::fs::write(dir.join("leg.osim"), LEG).unwrap();
    std::fs::write(dir.join("feet.xml"), CONTACTS).unwrap();
    dir
}

fn model_and_contacts(dir: &Path) -> (Model, Vec<Contact>) {
    let (_, model) =
        statopt::tools::loading::load_composed_model(&dir.join("leg.osim"), &[]).unwrap();
    let elements = statopt::forces::read_force_set_file(&dir.join("feet.xml")).unwrap();
    let contacts = elements
        .iter()
        .map(|e| Contact::from_xml(e, &model).unwrap().unwrap())
        .collect();
    (model, contacts)
}

/// `statopt-tool motion` in `dir` with the leg and its contacts, the knee
/// from −60° to −10° in 1 s at 100 rows/s, and `extra` options.
fn motion(dir: &Path, extra: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .current_dir(dir)
        .args([
            "motion",
            "--model",
            "leg.osim",
            "--force-set",
            "feet.xml",
            "--coordinate",
            "knee_angle",
            "--from",
            "-60",
            "--to",
            "-10",
            "--duration",
            "1",
        ])
        .args(extra)
        .output()
        .unwrap()
}

fn ok(out: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "statopt-tool motion failed: {err}");
    err
}

/// Model-unit coordinates of row `i` of a file (degrees → rad; a missing
/// column: the default value).
fn q_of(model: &Model, t: &Storage, i: usize) -> Vec<f64> {
    model
        .coordinates
        .iter()
        .map(|c| {
            let Some(j) = t.column_index(&c.name) else {
                return c.default_value;
            };
            let v = t.rows[i][j];
            if c.motion_type == statopt::model::MotionType::Rotational {
                v.to_radians()
            } else {
                v
            }
        })
        .collect()
}

/// The contact point relative to the plane origin, in the plane body.
fn on_plate(model: &Model, data: &mut Data, c: &Contact, q: &[f64]) -> Vector3<f64> {
    data.q.copy_from_slice(q);
    kinematics::positions(model, data);
    let p = data.station_position(c.point_body, &c.point);
    let o = data.station_position(c.plane_body, &c.origin);
    data.rotation[c.plane_body].transpose() * (p - o)
}

/// Two `--touch` in one call close both contacts on every row (1e-9 m), and
/// the coordinates equal the closed form (sole flush: ankle = −knee; sled
/// at 0.46 + 0.4 cos knee). Solving them one after another, as the tool did,
/// leaves the heel open: turning the ankle for the toe moves the heel.
#[test]
fn two_touches_are_solved_together() {
    let dir = case("two_touches");
    let (model, contacts) = model_and_contacts(&dir);
    let (heel, toe) = (&contacts[0], &contacts[1]);
    let out = motion(
        &dir,
        &[
            "--touch",
            "heel=sled_x",
            "--touch",
            "toe=ankle_angle",
            "-o",
            "press.mot",
        ],
    );
    ok(&out);
    let t = storage::read(&dir.join("press.mot")).unwrap();
    assert_eq!(t.len(), 101);
    let mut data = Data::new(&model);
    let (knee, ankle, sled, hip) = (
        col(&t, "knee_angle"),
        col(&t, "ankle_angle"),
        col(&t, "sled_x"),
        col(&t, "hip_flexion"),
    );
    let mut worst: f64 = 0.0;
    for i in 0..t.len() {
        let q = q_of(&model, &t, i);
        for c in [heel, toe] {
            let d = contact_distance(&model, &mut data, c, &q);
            worst = worst.max(d.abs());
            assert!(
                d.abs() < 1e-9,
                "row {i}: {} is {d} m from the plate",
                c.name
            );
        }
        assert!(
            (ankle[i] + knee[i]).abs() < 1e-7,
            "row {i}: ankle {} knee {}",
            ankle[i],
            knee[i]
        );
        let x = 0.46 + 0.4 * knee[i].to_radians().cos();
        assert!(
            (sled[i] - x).abs() < 1e-9,
            "row {i}: sled {} vs {x}",
            sled[i]
        );
        assert_eq!(hip[i], 0.0);
    }
    eprintln!("two touches: largest contact distance on 101 rows {worst:e} m");
    // A coordinate and a contact may be named more than once: the same
    // two unknowns and two contacts, the same file.
    let out = motion(
        &dir,
        &[
            "--touch",
            "heel=sled_x",
            "--touch",
            "toe=sled_x",
            "--touch",
            "toe=ankle_angle",
            "--touch",
            "heel=ankle_angle",
            "-o",
            "again.mot",
        ],
    );
    ok(&out);
    let again = storage::read(&dir.join("again.mot")).unwrap();
    assert_eq!(again.rows, t.rows);

    // The old way, one contact after the other on the last row, from the
    // defaults: the toe's ankle turn reopens the heel by centimetres.
    let mut q: Vec<f64> = model.coordinates.iter().map(|c| c.default_value).collect();
    q[model.coordinate_index("knee_angle").unwrap()] = (-10f64).to_radians();
    let (isled, iankle) = (
        model.coordinate_index("sled_x").unwrap(),
        model.coordinate_index("ankle_angle").unwrap(),
    );
    close_contact(&model, &mut data, heel, isled, &mut q, 1.0).unwrap();
    close_contact(&model, &mut data, toe, iankle, &mut q, 1.0).unwrap();
    let reopened = contact_distance(&model, &mut data, heel, &q);
    assert!(
        reopened.abs() > 1e-3,
        "sequential closure left the heel at {reopened} m"
    );
    eprintln!("one after another: heel {reopened:e} m off the plate");
}

/// `--plant heel=...`: the heel stays on the plate where it landed on the
/// first row (in the plate's frame) while the knee extends: the hip turns
/// to hold it. Without --plant the heel slides centimetres along the plate.
#[test]
fn planted_heel_stays_where_it_landed() {
    let dir = case("plant");
    let (model, contacts) = model_and_contacts(&dir);
    let (heel, toe) = (&contacts[0], &contacts[1]);
    let out = motion(
        &dir,
        &[
            "--touch",
            "toe=ankle_angle",
            "--plant",
            "heel=sled_x,hip_flexion",
            "-o",
            "planted.mot",
        ],
    );
    ok(&out);
    let t = storage::read(&dir.join("planted.mot")).unwrap();
    let mut data = Data::new(&model);
    let start = on_plate(&model, &mut data, heel, &q_of(&model, &t, 0));
    let (mut drift, mut dist): (f64, f64) = (0.0, 0.0);
    for i in 0..t.len() {
        let q = q_of(&model, &t, i);
        let p = on_plate(&model, &mut data, heel, &q);
        drift = drift.max((p.y - start.y).abs()).max((p.z - start.z).abs());
        dist = dist
            .max(p.x.abs())
            .max(contact_distance(&model, &mut data, toe, &q).abs());
    }
    eprintln!("planted heel: in-plane drift {drift:e} m, largest distance {dist:e} m");
    assert!(
        drift < 1e-9,
        "the planted heel moved {drift} m along the plate"
    );
    assert!(dist < 1e-9, "a contact opened by {dist} m");
    let hip = col(&t, "hip_flexion");
    let span = hip.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - hip.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(span > 5.0, "the hip turned only {span}° to hold the heel");

    // Touched only, the heel slides along the plate as the knee extends.
    let out = motion(
        &dir,
        &[
            "--touch",
            "heel=sled_x",
            "--touch",
            "toe=ankle_angle",
            "-o",
            "touched.mot",
        ],
    );
    ok(&out);
    let t = storage::read(&dir.join("touched.mot")).unwrap();
    let first = on_plate(&model, &mut data, heel, &q_of(&model, &t, 0));
    let last = on_plate(&model, &mut data, heel, &q_of(&model, &t, t.len() - 1));
    assert!((last.y - first.y).abs() > 0.05, "{} → {}", first.y, last.y);
}

/// More conditions than coordinates that can meet them: the heel planted
/// with only the sled free cannot hold its height; the error names the
/// row's time, the contact and how far it is off, and what to free.
#[test]
fn an_open_row_is_an_error() {
    let dir = case("overdetermined");
    let out = motion(
        &dir,
        &[
            "--touch",
            "toe=ankle_angle",
            "--plant",
            "heel=sled_x",
            "-o",
            "x.mot",
        ],
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("at t = 0.01"), "{err}");
    assert!(err.contains("contact 'heel'"), "{err}");
    assert!(err.contains("free another coordinate"), "{err}");
    assert!(!dir.join("x.mot").exists(), "an open motion was written");
    // Values rounded to 8 decimals (the old default) leave the heel
    // 1.7e-9 m off the plate: an error naming the decimals, no file.
    let out = motion(
        &dir,
        &[
            "--touch",
            "toe=ankle_angle",
            "--plant",
            "heel=sled_x,hip_flexion",
            "--precision",
            "8",
            "-o",
            "p8.mot",
        ],
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("rounded to 8 decimals") && err.contains("'heel'"),
        "{err}"
    );
    assert!(!dir.join("p8.mot").exists());
    // A coordinate that does not move the contact.
    let out = motion(
        &dir,
        &[
            "--touch",
            "heel=hip_flexion",
            "--touch",
            "toe=hip_flexion",
            "-o",
            "y.mot",
        ],
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("at t = 0,") && err.contains("from its plane"),
        "{err}"
    );
}

/// `--return --repeat 2 --hold-start 0.2`: rows strictly increasing in
/// time, 2 × (0.2 + 1 + 1) s, the last row the first's pose, zero velocity
/// at every turn (the one-sided difference over a row is O(h³ q''') of a
/// minimum-jerk end: below 1e-3 of the peak speed), contacts closed and the
/// planted heel held throughout.
#[test]
fn repetitions_there_and_back() {
    let dir = case("repeat");
    let (model, contacts) = model_and_contacts(&dir);
    let out = motion(
        &dir,
        &[
            "--touch",
            "toe=ankle_angle",
            "--plant",
            "heel=sled_x,hip_flexion",
            "--return",
            "--repeat",
            "2",
            "--hold-start",
            "0.2",
            "-o",
            "reps.mot",
        ],
    );
    ok(&out);
    let t = storage::read(&dir.join("reps.mot")).unwrap();
    assert_eq!(t.len(), 2 * (20 + 100 + 100) + 1);
    assert!(
        t.time.windows(2).all(|w| w[1] > w[0]),
        "times not increasing"
    );
    assert!((t.time[t.len() - 1] - 4.4).abs() < 1e-12);
    let last = t.len() - 1;
    for (j, l) in t.labels.iter().enumerate() {
        assert!(
            (t.rows[0][j] - t.rows[last][j]).abs() < 1e-8,
            "{l}: start {} end {}",
            t.rows[0][j],
            t.rows[last][j]
        );
    }
    let h = 0.01;
    // Turns: end of the first hold (row 20), top (120), bottom (220), the
    // second repetition's hold end (240) and top (340).
    for j in 0..t.labels.len() {
        let c = t.column(j);
        let peak = c
            .windows(2)
            .map(|w| ((w[1] - w[0]) / h).abs())
            .fold(0.0, f64::max);
        for k in [20, 120, 220, 240, 340] {
            for (a, b) in [(k - 1, k), (k, k + 1)] {
                let v = (c[b] - c[a]) / h;
                assert!(
                    v.abs() <= 1e-3 * peak,
                    "{} at t = {}: speed {v} (peak {peak})",
                    t.labels[j],
                    t.time[k]
                );
            }
        }
    }
    let knee = col(&t, "knee_angle");
    assert!((knee[120] + 10.0).abs() < 1e-9 && (knee[220] + 60.0).abs() < 1e-9);
    let mut data = Data::new(&model);
    let start = on_plate(&model, &mut data, &contacts[0], &q_of(&model, &t, 0));
    for i in 0..t.len() {
        let q = q_of(&model, &t, i);
        let p = on_plate(&model, &mut data, &contacts[0], &q);
        assert!(
            (p - start).norm() < 1e-9,
            "row {i}: heel moved {}",
            (p - start).norm()
        );
        assert!(contact_distance(&model, &mut data, &contacts[1], &q).abs() < 1e-9);
    }
    // A repetition must end where the next begins.
    let out = motion(&dir, &["--repeat", "2", "-o", "bad.mot"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--return"));
}

/// `motion --setup` before the setup's motion file exists: the file it
/// writes. The model must still exist (error names model_file).
#[test]
fn setup_whose_motion_is_not_written_yet() {
    let dir = case("setup");
    let setup = |model: &str| {
        format!(
            r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><AnalyzeTool name="press">
<model_file>{model}</model_file><force_set_files>feet.xml</force_set_files><replace_force_set>false</replace_force_set>
<results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>1</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet>
<coordinates_file>press.mot</coordinates_file><external_loads_file>loads.xml</external_loads_file>
</AnalyzeTool></OpenSimDocument>"#
        )
    };
    std::fs::write(dir.join("press_setup.xml"), setup("leg.osim")).unwrap();
    let run = |setup: &str, out: &str| {
        Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .current_dir(&dir)
            .args([
                "motion",
                "--setup",
                setup,
                "--coordinate",
                "knee_angle",
                "--from",
                "-60",
                "--to",
                "-10",
                "--duration",
                "1",
                "--touch",
                "heel=sled_x",
                "--touch",
                "toe=ankle_angle",
                "-o",
                out,
            ])
            .output()
            .unwrap()
    };
    ok(&run("press_setup.xml", "press.mot"));
    assert!(dir.join("press.mot").exists());
    std::fs::write(dir.join("bad_setup.xml"), setup("missing.osim")).unwrap();
    let out = run("bad_setup.xml", "other.mot");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("model_file") && err.contains("missing.osim"),
        "{err}"
    );
}

/// The AnalyzeTool's `<close_contacts>` with two entries (the in-memory
/// closure of a table): closed together, both within 1e-9 m on every row,
/// where closing them one after another left the heel open.
#[test]
fn close_contacts_with_two_entries_closes_both() {
    let dir = case("close_contacts");
    let (model, contacts) = model_and_contacts(&dir);
    let mut table = Storage {
        name: "knee".into(),
        labels: vec!["knee_angle".into()],
        time: (0..=50).map(|k| k as f64 * 0.02).collect(),
        rows: (0..=50).map(|k| vec![-60.0 + k as f64]).collect(),
        in_degrees: true,
        metadata: vec![],
    };
    let closures = vec![
        (
            contacts[0].clone(),
            model.coordinate_index("sled_x").unwrap(),
        ),
        (
            contacts[1].clone(),
            model.coordinate_index("ankle_angle").unwrap(),
        ),
    ];
    let knee_only = table.clone();
    statopt::contacts::closure::close_contacts(&model, &mut table, &closures).unwrap();
    let mut data = Data::new(&model);
    for i in 0..table.len() {
        let q = q_of(&model, &table, i);
        for c in &contacts {
            let d = contact_distance(&model, &mut data, c, &q);
            assert!(
                d.abs() < 1e-9,
                "t = {}: {} is {d} m off",
                table.time[i],
                c.name
            );
        }
    }
    // The same streamed (`StreamClosure`, the state stream's row
    // transform): values per row knee (deg), sled (m), ankle (deg), the
    // closed coordinates absent from the file (each row starts from the
    // row before's solution); equal to the whole-table closure.
    use statopt::motion::stream::RowTransform;
    let deg = std::f64::consts::PI / 180.0;
    let columns: Vec<Option<(usize, f64)>> = model
        .coordinates
        .iter()
        .map(|c| match c.name.as_str() {
            "knee_angle" => Some((0, deg)),
            "sled_x" => Some((1, 1.0)),
            "ankle_angle" => Some((2, deg)),
            _ => None,
        })
        .collect();
    let mut stream = statopt::contacts::closure::StreamClosure::new(
        &model,
        closures,
        vec![true, true],
        columns,
        "test".into(),
    );
    stream.begin_window(0);
    let (isled, iankle) = (
        table.column_index("sled_x").unwrap(),
        table.column_index("ankle_angle").unwrap(),
    );
    for i in 0..knee_only.len() {
        let mut values = [knee_only.rows[i][0], 0.8, 0.5 / deg];
        stream.apply(i, knee_only.time[i], &mut values).unwrap();
        assert!((values[1] - table.rows[i][isled]).abs() < 1e-12);
        assert!((values[2] - table.rows[i][iankle]).abs() < 1e-10);
    }
}

/// A touched coordinate that drives another through a
/// CoordinateCouplerConstraint: `drive` (a pedal's pin) sets
/// ankle_angle = drive, so only through the coupler does `drive` turn the
/// foot. The coupler is applied inside the solve: both contacts closed on
/// every row (1e-9 m) with the ankle written as its dependent value, and
/// drive = −knee (the sole flush).
#[test]
fn a_touched_coordinate_moves_its_coupler_dependent() {
    let dir = case("coupler");
    let coupled = LEG
        .replace(
            "</objects></BodySet>",
            r#"<Body name="pedal"><mass>0.1</mass><mass_center>0 0 0</mass_center><inertia>0.001 0.001 0.001 0 0 0</inertia></Body>
</objects></BodySet>"#,
        )
        .replace(
            "</objects></JointSet>",
            r#"<PinJoint name="pedal_pin"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/pedal</socket_child_frame>
<coordinates><Coordinate name="drive"><default_value>0.5</default_value><range>-2 2</range></Coordinate></coordinates></PinJoint>
</objects></JointSet>
<ConstraintSet><objects><CoordinateCouplerConstraint name="ankle_follows_drive"><coupled_coordinates_function><LinearFunction><coefficients>1 0</coefficients></LinearFunction></coupled_coordinates_function><independent_coordinate_names>drive</independent_coordinate_names><dependent_coordinate_name>ankle_angle</dependent_coordinate_name></CoordinateCouplerConstraint></objects></ConstraintSet>"#,
        );
    std::fs::write(dir.join("leg.osim"), coupled).unwrap();
    let (model, contacts) = model_and_contacts(&dir);
    assert_eq!(model.couplers.len(), 1);
    let out = motion(
        &dir,
        &[
            "--touch",
            "heel=sled_x",
            "--touch",
            "toe=drive",
            "-o",
            "coupled.mot",
        ],
    );
    ok(&out);
    let t = storage::read(&dir.join("coupled.mot")).unwrap();
    let (knee, drive, ankle) = (
        col(&t, "knee_angle"),
        col(&t, "drive"),
        col(&t, "ankle_angle"),
    );
    let mut data = Data::new(&model);
    for i in 0..t.len() {
        assert!((ankle[i] - drive[i]).abs() < 1e-9, "row {i}");
        assert!(
            (drive[i] + knee[i]).abs() < 1e-7,
            "row {i}: drive {}",
            drive[i]
        );
        let q = q_of(&model, &t, i);
        for c in &contacts {
            let d = contact_distance(&model, &mut data, c, &q);
            assert!(d.abs() < 1e-9, "row {i}: {} is {d} m off", c.name);
        }
    }
}
