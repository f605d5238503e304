//! The BodyKinematics and PointKinematics analyses.
//!
//! - Against OpenSim 4.6 on the gait10dof18musc walk (../shared/validation):
//!   tests/data/kinematics/setup_walk_kinematics.xml run by statopt, its
//!   tables compared with OpenSim's, made by
//!   tests/reference_scripts/kinematics_reference.py (OpenSim 4.6's
//!   AnalyzeTool on the same setup: positions and velocities as it writes
//!   them; accelerations of the motion, u' = S_u', by OpenSim's
//!   calcBodyAccelerationFromUDot, since OpenSim's AnalyzeTool writes forward
//!   dynamics there; rows 0-2, every 10th and the last 3 stored). Tolerance:
//!   1e-6 of each column's peak over the stored rows, plus 1e-12 for the
//!   columns that are round-off (the walk is planar: its Z columns are
//!   1e-18).
//! - A bad body or frame name is refused at its element and line.
//! - Invariants on a 4-coordinate linkage moved by smooth functions sampled
//!   at 1 kHz: velocities are the positions' derivatives, accelerations the
//!   velocities' (central differences), the angular velocity is that of the
//!   Euler angles' rotation, the centre of mass is the mass-weighted mean of
//!   the bodies', a point relative to its own body stays where it is.

mod common;

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage::{self, Storage};
use statopt::tools::{analyze, RunOptions};

fn run(setup: &Path, out: &Path) -> statopt::Result<statopt::tools::RunSummary> {
    let setup = match Setup::read(setup)? {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    analyze::run(
        &setup,
        &RunOptions {
            results_dir: Some(out.to_path_buf()),
            ..Default::default()
        },
    )
}

#[test]
fn kinematics_match_opensim_on_the_walk() {
    let Some(_) = common::validation_dir("kinematics_match_opensim_on_the_walk") else {
        return;
    };
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/kinematics");
    let out = common::out_dir("kinematics_walk");
    let summary = run(&data.join("setup_walk_kinematics.xml"), &out).unwrap();
    assert_eq!(summary.frames, 151);
    let mut names: Vec<String> = summary
        .files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().to_string())
        .collect();
    names.sort();
    let mut expected: Vec<String> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.ends_with(".sto"))
        .collect();
    expected.sort();
    assert_eq!(names, expected, "OpenSim 4.6's file names");
    let mut failures = Vec::new();
    let mut report = Vec::new();
    for name in &expected {
        let reference = storage::read(&data.join(name)).unwrap();
        let ours = storage::read(&out.join(name)).unwrap();
        let text = std::fs::read_to_string(out.join(name)).unwrap();
        let degrees = name.starts_with("walk_BodyKinematics_");
        assert!(
            text.contains(if degrees {
                "inDegrees=yes"
            } else {
                "inDegrees=no"
            }),
            "{name}: inDegrees"
        );
        let mut worst = (0.0f64, String::new());
        for (j, label) in reference.labels.iter().enumerate() {
            // Columns are matched by OpenSim 4.6's own labels, PointKinematics'
            // state_0..2 included.
            let k = ours
                .column_index(label)
                .unwrap_or_else(|| panic!("{name}: no column {label}"));
            let peak = reference
                .rows
                .iter()
                .map(|r| r[j].abs())
                .fold(0.0, f64::max);
            let tol = 1e-6 * peak + 1e-12;
            for (i, t) in reference.time.iter().enumerate() {
                let row = ours
                    .time
                    .iter()
                    .position(|s| (s - t).abs() < 1e-9)
                    .unwrap_or_else(|| panic!("{name}: no row at t = {t}"));
                let (o, r) = (ours.rows[row][k], reference.rows[i][j]);
                let d = (o - r).abs();
                if d.is_nan() || d > tol {
                    failures.push(format!("{name} {label} t={t}: ours {o} vs OpenSim {r}"));
                }
                if d / tol > worst.0 {
                    worst = (d / tol, format!("{label} t={t:.4}"));
                }
            }
        }
        report.push(format!(
            "  {name}: worst {:.1e} of the tolerance ({})",
            worst.0, worst.1
        ));
    }
    eprintln!("kinematics vs OpenSim 4.6:\n{}", report.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A linkage: link1 turns about ground's z and x (coordinates a, b),
/// link2 turns about the z axis of a frame offset on link1 (c) and slides
/// along its y (d).
const LINKAGE: &str = r#"<OpenSimDocument Version="40000"><Model name="linkage"><gravity>0 -9.80665 0</gravity>
<BodySet><objects>
<Body name="link1"><mass>3</mass><mass_center>0.1 -0.4 0.05</mass_center><inertia>0.1 0.02 0.1 0 0 0</inertia></Body>
<Body name="link2"><mass>2</mass><mass_center>-0.05 -0.3 0.08</mass_center><inertia>0.05 0.01 0.05 0 0 0</inertia></Body>
</objects></BodySet>
<JointSet><objects>
<CustomJoint name="j1"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/link1</socket_child_frame>
<coordinates><Coordinate name="a"><range>-3 3</range></Coordinate><Coordinate name="b"><range>-3 3</range></Coordinate></coordinates>
<SpatialTransform>
<TransformAxis name="rotation1"><coordinates>a</coordinates><axis>0 0 1</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="rotation2"><coordinates>b</coordinates><axis>1 0 0</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="rotation3"><coordinates/><axis>0 1 0</axis></TransformAxis>
<TransformAxis name="translation1"><coordinates/><axis>1 0 0</axis></TransformAxis>
<TransformAxis name="translation2"><coordinates/><axis>0 1 0</axis></TransformAxis>
<TransformAxis name="translation3"><coordinates/><axis>0 0 1</axis></TransformAxis>
</SpatialTransform></CustomJoint>
<CustomJoint name="j2"><socket_parent_frame>link1_offset</socket_parent_frame><socket_child_frame>/bodyset/link2</socket_child_frame>
<frames><PhysicalOffsetFrame name="link1_offset"><socket_parent>/bodyset/link1</socket_parent><translation>0.05 -0.45 0.02</translation><orientation>0.1 0.2 0.3</orientation></PhysicalOffsetFrame></frames>
<coordinates><Coordinate name="c"><range>-3 3</range></Coordinate><Coordinate name="d"><range>-3 3</range></Coordinate></coordinates>
<SpatialTransform>
<TransformAxis name="rotation1"><coordinates>c</coordinates><axis>0 0 1</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="rotation2"><coordinates/><axis>1 0 0</axis></TransformAxis>
<TransformAxis name="rotation3"><coordinates/><axis>0 1 0</axis></TransformAxis>
<TransformAxis name="translation1"><coordinates/><axis>1 0 0</axis></TransformAxis>
<TransformAxis name="translation2"><coordinates>d</coordinates><axis>0 1 0</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>
<TransformAxis name="translation3"><coordinates/><axis>0 0 1</axis></TransformAxis>
</SpatialTransform></CustomJoint>
</objects></JointSet></Model></OpenSimDocument>"#;

/// The linkage, a motion of smooth functions sampled at 1 kHz (t = 0..2 s),
/// and a setup holding `analyses`, written into `dir`.
fn linkage_case(dir: &Path, analyses: &str) -> PathBuf {
    std::fs::write(dir.join("linkage.osim"), LINKAGE).unwrap();
    let mut mot = String::from(
        "linkage motion\nversion=1\nnRows=2001\nnColumns=5\ninDegrees=yes\nendheader\ntime\ta\tb\tc\td\n",
    );
    for i in 0..=2000 {
        let t = i as f64 * 1e-3;
        let w = 2.0 * std::f64::consts::PI;
        mot.push_str(&format!(
            "{t:.6}\t{:.15}\t{:.15}\t{:.15}\t{:.15}\n",
            60.0 * (w * 0.8 * t).sin(),
            40.0 * (w * 0.5 * t + 0.3).sin(),
            75.0 * (w * 0.7 * t).cos(),
            -0.5 + 0.1 * (w * t).sin()
        ));
    }
    std::fs::write(dir.join("linkage.mot"), mot).unwrap();
    let setup = format!(
        r#"<OpenSimDocument Version="40600"><AnalyzeTool name="linkage">
<model_file>linkage.osim</model_file><results_directory>.</results_directory>
<output_precision>16</output_precision><initial_time>0.2</initial_time><final_time>1.8</final_time>
<AnalysisSet name="Analyses"><objects>{analyses}</objects><groups/></AnalysisSet>
<coordinates_file>linkage.mot</coordinates_file>
<lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
</AnalyzeTool></OpenSimDocument>"#
    );
    let p = dir.join("setup.xml");
    std::fs::write(&p, setup).unwrap();
    p
}

fn column(s: &Storage, label: &str) -> Vec<f64> {
    let k = s
        .column_index(label)
        .unwrap_or_else(|| panic!("no column {label}"));
    s.rows.iter().map(|r| r[k]).collect()
}

/// Largest |central difference of `x` − `dx`| over the interior rows,
/// relative to `dx`'s peak.
fn derivative_error(t: &[f64], x: &[f64], dx: &[f64]) -> f64 {
    let peak = dx.iter().map(|v| v.abs()).fold(0.0, f64::max);
    (1..t.len() - 1)
        .map(|i| ((x[i + 1] - x[i - 1]) / (t[i + 1] - t[i - 1]) - dx[i]).abs())
        .fold(0.0, f64::max)
        / peak
}

#[test]
fn velocities_and_accelerations_are_derivatives() {
    let out = common::out_dir("kinematics_invariants");
    let setup = linkage_case(
        &out,
        r#"<BodyKinematics name="BK"><in_degrees>false</in_degrees><bodies>all</bodies></BodyKinematics>
<PointKinematics name="PK"><body_name>link2</body_name><point_name>tip</point_name><point>0.02 -0.6 0.1</point></PointKinematics>
<PointKinematics name="Own"><body_name>link2</body_name><relative_to_body_name>link2</relative_to_body_name><point_name>tip</point_name><point>0.02 -0.6 0.1</point></PointKinematics>"#,
    );
    let summary = run(&setup, &out).unwrap();
    assert_eq!(summary.frames, 1601);
    let read = |f: &str| storage::read(&out.join(f)).unwrap();
    let (p, v, a) = (
        read("linkage_BK_pos_global.sto"),
        read("linkage_BK_vel_global.sto"),
        read("linkage_BK_acc_global.sto"),
    );
    let t = p.time.clone();
    // Central differences at 1 ms on motions of at most 1 Hz err by about
    // (2 pi 1 Hz 1 ms)^2 / 6 = 7e-6 of the peak.
    let tol = 1e-4;
    let mut worst = 0.0f64;
    for body in ["link1", "link2", "center_of_mass"] {
        for x in ["X", "Y", "Z"] {
            let l = format!("{body}_{x}");
            let e1 = derivative_error(&t, &column(&p, &l), &column(&v, &l));
            let e2 = derivative_error(&t, &column(&v, &l), &column(&a, &l));
            assert!(e1 < tol && e2 < tol, "{l}: {e1:.1e} {e2:.1e}");
            worst = worst.max(e1).max(e2);
        }
    }
    for body in ["link1", "link2"] {
        // The angular velocity is that of the orientation the Euler
        // angles give: w = vee(dR/dt Rᵀ); the angular acceleration its
        // derivative.
        let angles: Vec<Vec<f64>> = ["Ox", "Oy", "Oz"]
            .iter()
            .map(|o| column(&p, &format!("{body}_{o}")))
            .collect();
        let rot = |i: usize| {
            statopt::model::body_fixed_xyz(&nalgebra::Vector3::new(
                angles[0][i],
                angles[1][i],
                angles[2][i],
            ))
        };
        let w: Vec<Vec<f64>> = ["Ox", "Oy", "Oz"]
            .iter()
            .map(|o| column(&v, &format!("{body}_{o}")))
            .collect();
        let peak = w.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max);
        assert!(peak > 1.0, "{body} turns: peak {peak}");
        for i in 1..t.len() - 1 {
            let rdot = (rot(i + 1) - rot(i - 1)) / (t[i + 1] - t[i - 1]);
            let s = rdot * rot(i).transpose();
            let fd = [s[(2, 1)], s[(0, 2)], s[(1, 0)]];
            for k in 0..3 {
                let e = (fd[k] - w[k][i]).abs() / peak;
                assert!(
                    e < tol,
                    "{body} angular velocity {k} at t={}: {e:.1e}",
                    t[i]
                );
                worst = worst.max(e);
            }
        }
        for o in ["Ox", "Oy", "Oz"] {
            let l = format!("{body}_{o}");
            let e = derivative_error(&t, &column(&v, &l), &column(&a, &l));
            assert!(e < tol, "{l}: {e:.1e}");
            worst = worst.max(e);
        }
    }
    // The point: derivatives too, and relative to its own body it stays put.
    let (pp, pv, pa) = (
        read("linkage_PK_tip_pos.sto"),
        read("linkage_PK_tip_vel.sto"),
        read("linkage_PK_tip_acc.sto"),
    );
    // OpenSim 4.6's labels: state_0..2 are the point's X, Y, Z.
    assert_eq!(pp.labels, ["state_0", "state_1", "state_2"]);
    for x in 0..3 {
        let l = format!("state_{x}");
        let e1 = derivative_error(&t, &column(&pp, &l), &column(&pv, &l));
        let e2 = derivative_error(&t, &column(&pv, &l), &column(&pa, &l));
        assert!(e1 < tol && e2 < tol, "{l}: {e1:.1e} {e2:.1e}");
        worst = worst.max(e1).max(e2);
    }
    let own = read("linkage_Own_tip_pos.sto");
    for (k, x) in [0.02, -0.6, 0.1].iter().enumerate() {
        for r in &own.rows {
            assert!((r[k] - x).abs() < 1e-12, "relative to its own body: {r:?}");
        }
    }
    // The centre of mass: the bodies' mass centres weighted 3 : 2.
    for x in ["X", "Y", "Z"] {
        let (c, l1, l2) = (
            column(&p, &format!("center_of_mass_{x}")),
            column(&p, &format!("link1_{x}")),
            column(&p, &format!("link2_{x}")),
        );
        for i in 0..t.len() {
            assert!((c[i] - (3.0 * l1[i] + 2.0 * l2[i]) / 5.0).abs() < 1e-12);
        }
    }
    eprintln!("worst derivative error: {worst:.1e} of the peak (tolerance {tol:.0e})");
}

#[test]
fn a_bad_body_or_frame_name_is_refused_at_its_element() {
    let out = common::out_dir("kinematics_bad_names");
    for (analysis, element, needle) in [
        (
            "<BodyKinematics name=\"BK\"><bodies>link1 lnik2</bodies></BodyKinematics>",
            "<bodies>",
            "no body named 'lnik2' in the model",
        ),
        (
            "<BodyKinematics name=\"BK\"><bodies>ground</bodies></BodyKinematics>",
            "<bodies>",
            "ground is not a body of the BodySet",
        ),
        (
            "<PointKinematics name=\"PK\"><body_name>link3</body_name></PointKinematics>",
            "<body_name>",
            "no body or frame named 'link3'",
        ),
        (
            "<PointKinematics name=\"PK\"><body_name>link2</body_name><relative_to_body_name>pelvis</relative_to_body_name></PointKinematics>",
            "<relative_to_body_name>",
            "no body or frame named 'pelvis'",
        ),
        (
            "<BodyKinematics name=\"BK\"><bodies></bodies></BodyKinematics>",
            "<bodies>",
            "<bodies> is empty",
        ),
    ] {
        let setup = linkage_case(&out, analysis);
        let e = run(&setup, &out).unwrap_err().to_string();
        assert!(
            e.contains("setup.xml") && e.contains("line 4") && e.contains(element),
            "{analysis}: {e}"
        );
        assert!(e.contains(needle), "{analysis}: {e}");
        if needle.contains("lnik2") {
            assert!(e.contains("did you mean link2?"), "{e}");
        }
        // Refused before any table is written.
        assert!(
            !std::fs::read_dir(&out)
                .unwrap()
                .any(|f| f.unwrap().file_name().to_string_lossy().ends_with(".sto")),
            "{analysis}: a table was written"
        );
    }
    // --check finds the same.
    let setup = linkage_case(
        &out,
        "<BodyKinematics name=\"BK\"><bodies>link1 lnik2</bodies></BodyKinematics>",
    );
    let report = statopt::tools::check::run(&setup, false);
    assert!(
        report
            .errors
            .iter()
            .any(|e| e.to_string().contains("no body named 'lnik2'")),
        "--check: {:?}",
        report.errors
    );
}

/// A point on an offset frame (named by its path, as OpenSim's
/// PointKinematics takes it) is the point of the frame's body at the
/// frame's transform of it; relative to its own frame it stays put.
#[test]
fn a_point_on_an_offset_frame() {
    let out = common::out_dir("kinematics_offset_frame");
    let (p, t, angles) = (
        nalgebra::Vector3::new(0.1, -0.2, 0.3),
        nalgebra::Vector3::new(0.05, -0.45, 0.02),
        nalgebra::Vector3::new(0.1, 0.2, 0.3),
    );
    let on_body = statopt::model::body_fixed_xyz(&angles) * p + t;
    let setup = linkage_case(
        &out,
        &format!(
            r#"<PointKinematics name="Off"><body_name>/jointset/j2/link1_offset</body_name><point_name>q</point_name><point>{} {} {}</point></PointKinematics>
<PointKinematics name="Body"><body_name>link1</body_name><point_name>q</point_name><point>{} {} {}</point></PointKinematics>
<PointKinematics name="Own"><body_name>/jointset/j2/link1_offset</body_name><relative_to_body_name>/jointset/j2/link1_offset</relative_to_body_name><point_name>q</point_name><point>{} {} {}</point></PointKinematics>"#,
            p[0], p[1], p[2], on_body[0], on_body[1], on_body[2], p[0], p[1], p[2]
        ),
    );
    run(&setup, &out).unwrap();
    for kind in ["pos", "vel", "acc"] {
        let off = storage::read(&out.join(format!("linkage_Off_q_{kind}.sto"))).unwrap();
        let body = storage::read(&out.join(format!("linkage_Body_q_{kind}.sto"))).unwrap();
        let peak = body
            .rows
            .iter()
            .flatten()
            .map(|x| x.abs())
            .fold(0.0, f64::max);
        assert!(peak > 0.1, "{kind}: the point moves");
        for (a, b) in off.rows.iter().zip(&body.rows) {
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() < 1e-12 * peak.max(1.0),
                    "{kind}: {a:?} vs {b:?}"
                );
            }
        }
    }
    let own = storage::read(&out.join("linkage_Own_q_pos.sto")).unwrap();
    for r in &own.rows {
        for k in 0..3 {
            assert!(
                (r[k] - p[k]).abs() < 1e-12,
                "relative to its own frame: {r:?}"
            );
        }
    }
}
