//! Bad input gets one clear error naming the file, the element or column and
//! the line, and exit status 2 — never a panic.

mod common;

use std::path::PathBuf;
use std::process::Command;

const MODEL: &str = include_str!("../models/double_pendulum.osim");
const MOTION: &str = include_str!("../motions/double_pendulum_swing.mot");

fn setup_xml(model: &str, motion: &str, time_range: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40600">
  <InverseDynamicsTool name="t">
    <results_directory>out</results_directory>
    <model_file>{model}</model_file>
    <time_range>{time_range}</time_range>
    <forces_to_exclude>Muscles</forces_to_exclude>
    <coordinates_file>{motion}</coordinates_file>
    <lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
    <output_gen_force_file>id.sto</output_gen_force_file>
  </InverseDynamicsTool>
</OpenSimDocument>
"#
    )
}

/// Write the files of one scenario and run the tool; returns (status, stderr).
fn run(name: &str, model: &str, motion: &str, time_range: &str) -> (i32, String, PathBuf) {
    let dir = common::out_dir(&format!("bad_input_{name}"));
    std::fs::write(dir.join("model.osim"), model).unwrap();
    std::fs::write(dir.join("motion.mot"), motion).unwrap();
    std::fs::write(
        dir.join("setup.xml"),
        setup_xml("model.osim", "motion.mot", time_range),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("setup.xml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !stderr.contains("panicked"),
        "{name}: the tool panicked:\n{stderr}"
    );
    (out.status.code().unwrap_or(-1), stderr, dir)
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .map(|i| i + 1)
        .unwrap_or_else(|| panic!("'{needle}' not in text"))
}

#[test]
fn good_input_runs() {
    let (code, err, dir) = run("good", MODEL, MOTION, "0 2");
    assert_eq!(code, 0, "{err}");
    assert!(dir.join("out/id.sto").is_file());
}

#[test]
fn missing_model_file() {
    let dir = common::out_dir("bad_input_missing");
    std::fs::write(
        dir.join("setup.xml"),
        setup_xml("nowhere.osim", "motion.mot", "0 1"),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("setup.xml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("nowhere.osim"), "{err}");
}

#[test]
fn missing_setup_file() {
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg("/nonexistent/setup.xml")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/setup.xml"));
}

#[test]
fn malformed_xml() {
    let cut = &MODEL[..MODEL.find("<JointSet").unwrap()];
    let (code, err, _) = run("malformed", cut, MOTION, "0 1");
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("model.osim") && err.contains("line"), "{err}");
}

#[test]
fn unknown_joint_type() {
    let model = MODEL
        .replacen(
            "<PinJoint name=\"elbow\">",
            "<HingeJoint name=\"elbow\">",
            1,
        )
        .replacen(
            "</PinJoint>\n\t\t\t</objects>",
            "</HingeJoint>\n\t\t\t</objects>",
            1,
        );
    assert!(model.contains("HingeJoint name=\"elbow\">") && model.contains("</HingeJoint>"));
    let (code, err, _) = run("unknown_joint", &model, MOTION, "0 1");
    assert_eq!(code, 2, "{err}");
    let line = line_of(&model, "<HingeJoint");
    assert!(
        err.contains("model.osim")
            && err.contains(&format!("line {line}"))
            && err.contains("HingeJoint")
            && err.contains("elbow"),
        "{err}"
    );
}

#[test]
fn socket_naming_missing_frame() {
    let model = MODEL.replacen(
        "<socket_child_frame>lower_offset</socket_child_frame>",
        "<socket_child_frame>forearm_offset</socket_child_frame>",
        1,
    );
    let (code, err, _) = run("bad_socket", &model, MOTION, "0 1");
    assert_eq!(code, 2, "{err}");
    let line = line_of(&model, "<PinJoint name=\"elbow\"");
    assert!(
        err.contains("forearm_offset")
            && err.contains(&format!("line {line}"))
            && err.contains("elbow"),
        "{err}"
    );
}

#[test]
fn nan_in_motion() {
    let motion = MOTION.replacen("0.0400\t", "0.0400\tNaN\t", 1);
    let motion = motion.replacen("NaN\t3.7", "NaN\t", 1);
    let bad_line = line_of(&motion, "NaN");
    let (code, err, _) = run("nan", MODEL, &motion, "0 1");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("motion.mot") && err.contains(&format!("line {bad_line}")),
        "{err}"
    );
}

#[test]
fn time_range_outside_data() {
    let (code, err, _) = run("time_range", MODEL, MOTION, "5 6");
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("time_range") && err.contains("setup.xml"),
        "{err}"
    );
}

#[test]
fn motion_lacking_a_coordinate_warns_and_uses_default() {
    // Drop the q2 column: OpenSim's ID tool uses the coordinate's default value.
    let motion: String = MOTION
        .lines()
        .map(|l| {
            if l.starts_with("nColumns") {
                "nColumns=2".to_string()
            } else {
                let f: Vec<&str> = l.split('\t').collect();
                if f.len() == 3 {
                    format!("{}\t{}", f[0], f[1])
                } else {
                    l.to_string()
                }
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let (code, err, _) = run("missing_coord", MODEL, &motion, "0 1");
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("q2") && err.contains("default"), "{err}");
}
