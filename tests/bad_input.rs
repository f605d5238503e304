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
    // It says that the missing file is the setup (it said "cannot read or
    // write file", which file of the run not said).
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("/nonexistent/setup.xml: no such setup file"),
        "{err}"
    );
    for args in [&["--check"][..], &["predict-grf"][..]] {
        let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .args(args)
            .arg("/nonexistent/setup.xml")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("no such setup file"), "{args:?}: {err}");
    }
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

// ---------------------------------------------------------------------
// What a newcomer meets (issue 38): `--check` checks what the run will do,
// root causes first; `--allow-unknown` says what it read on past.

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tool(args: &[&std::ffi::OsStr]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!err.contains("panicked"), "the tool panicked:\n{err}");
    (out.status.code().unwrap_or(-1), err)
}

/// The leg extension setup of cam 1 with `<contact_weight>` misspelt
/// `<contact_wieght>`, written to `dir` (its paths made absolute, its
/// results folder in `dir`).
fn misspelt_setup(dir: &std::path::Path) -> PathBuf {
    let text = std::fs::read_to_string(repo().join("setups/leg_extension_cam1.xml")).unwrap();
    assert!(text.contains("<contact_weight>1 500 1000</contact_weight>"));
    let text = text
        .replace("contact_weight>", "contact_wieght>")
        .replace(
            "../output/leg_extension_cam1",
            &dir.join("results").display().to_string(),
        )
        .replace("../", &format!("{}/", repo().display()));
    let path = dir.join("typo.xml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn check_honours_the_results_dir_of_the_command_line() {
    let dir = common::out_dir("bad_input_check_o_file");
    let file = dir.join("a_file");
    std::fs::write(&file, "not a folder").unwrap();
    let setup = repo().join("setups/leg_extension_cam1.xml");
    // -o FILE and -o FILE/sub: the run would fail, so the check does, naming -o.
    for o in [file.clone(), file.join("sub")] {
        let (code, err) = tool(&[
            "--check".as_ref(),
            setup.as_os_str(),
            "-o".as_ref(),
            o.as_os_str(),
        ]);
        assert_eq!(code, 2, "--check -o {}: {err}", o.display());
        assert!(
            err.contains(&format!("-o {}: the results folder", o.display()))
                && err.contains("1 problem(s)"),
            "{err}"
        );
    }
    // A study's -o FILE: one problem, not one more per setup under it.
    let study = repo().join("setups/leg_extension_study.xml");
    let (code, err) = tool(&[
        "--check".as_ref(),
        study.as_os_str(),
        "-o".as_ref(),
        file.as_os_str(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains(&format!(
            "-o {}: the results folder is a file",
            file.display()
        )) && err.contains("1 problem(s)"),
        "{err}"
    );
    // The same setup with a folder that can be made: no problem.
    let (code, err) = tool(&[
        "--check".as_ref(),
        setup.as_os_str(),
        "-o".as_ref(),
        dir.join("new/folder").as_os_str(),
        "--reduce".as_ref(),
    ]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_misspelt_element_is_the_first_problem_and_its_consequences_are_not_listed() {
    let dir = common::out_dir("bad_input_misspelt_check");
    let setup = misspelt_setup(&dir);
    let (code, err) = tool(&["--check".as_ref(), setup.as_os_str()]);
    assert_eq!(code, 2, "{err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert!(
        errors.first().is_some_and(
            |e| e.contains("contact_wieght") && e.contains("did you mean contact_weight?")
        ),
        "{err}"
    );
    // Not the 18 figure references that a single w0 would leave wrong.
    assert!(errors.len() <= 3, "{} problems:\n{err}", errors.len());
    assert!(!err.contains("names w0 ="), "{err}");
}

#[test]
fn allow_unknown_says_what_it_read_on_past() {
    let dir = common::out_dir("bad_input_misspelt_allow");
    let setup = misspelt_setup(&dir);
    // The check: a warning naming the element.
    let (_, err) = tool(&[
        "--check".as_ref(),
        setup.as_os_str(),
        "--allow-unknown".as_ref(),
    ]);
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning:") && l.contains("contact_wieght")),
        "{err}"
    );
    // The references to w0 tables the run would not write: one problem.
    assert_eq!(err.matches("error:").count(), 1, "{err}");
    // The run: it stops before the first frame (the figures name tables a
    // single w0 does not write) and says what it read on past.
    let (code, err) = tool(&[setup.as_os_str(), "--allow-unknown".as_ref()]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("single w0") && err.contains("contact_wieght"),
        "{err}"
    );
    // The warning is printed as the setup is read, before the run fails.
    let warned = err
        .lines()
        .position(|l| l.starts_with("warning:") && l.contains("contact_wieght"));
    let failed = err.lines().position(|l| l.starts_with("error:"));
    assert!(warned.is_some() && warned < failed, "{err}");
    assert!(
        !dir.join("results").exists()
            || std::fs::read_dir(dir.join("results"))
                .unwrap()
                .next()
                .is_none(),
        "the run wrote tables before failing"
    );
    // Without figures the run succeeds, and warns.
    let text = std::fs::read_to_string(&setup).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let first = lines.iter().position(|l| l.contains("<Figure")).unwrap();
    let last = lines.iter().rposition(|l| l.contains("<Metric")).unwrap();
    let plain = dir.join("plain.xml");
    std::fs::write(
        &plain,
        [&lines[..first], &lines[last + 1..]].concat().join("\n"),
    )
    .unwrap();
    let (code, err) = tool(&[
        plain.as_os_str(),
        "--allow-unknown".as_ref(),
        "-o".as_ref(),
        dir.join("plain").as_os_str(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning:") && l.contains("contact_wieght")),
        "{err}"
    );
}

/// Paths in messages read as the user would write them: `setups/../output`
/// is `output` where `setups` is a folder (issue 38: the study's summary
/// said "files written to setups/../output/..."), but a `..` after a
/// symbolic link is kept (it leads elsewhere).
#[test]
fn paths_in_setups_are_tidied_where_that_names_the_same_file() {
    use statopt::parse::setup::{resolve, tidy};
    let dir = common::out_dir("bad_input_tidy");
    std::fs::create_dir_all(dir.join("real/setups")).unwrap();
    std::os::unix::fs::symlink(dir.join("real/setups"), dir.join("link")).unwrap();
    assert_eq!(
        resolve(&dir.join("real/setups"), "../output/x"),
        dir.join("real/output/x")
    );
    assert_eq!(
        resolve(&dir.join("link"), "../output/x"),
        dir.join("link/../output/x")
    );
    // A folder that is not there yet keeps its `..` too.
    assert_eq!(tidy(&dir.join("nowhere/../x")), dir.join("nowhere/../x"));
    assert_eq!(tidy(std::path::Path::new("./a")), PathBuf::from("a"));
    // The shipped study's summary names its folders without `..`.
    let setup = repo().join("setups/leg_extension_cam1.xml");
    let s = match statopt::parse::setup::Setup::read(&setup).unwrap() {
        statopt::parse::setup::Setup::Analyze(a) => a,
        _ => unreachable!(),
    };
    assert_eq!(
        s.results_directory,
        repo().join("output/leg_extension_cam1")
    );
}
