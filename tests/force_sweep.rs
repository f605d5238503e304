//! Force sweeps (tools::force_sweep): candidates that differ only in forces
//! — the cam's torque expression, w0, the reserves' optimal force — solved
//! on one compiled scene give every metric of the setup as a run of the
//! candidate's own setup does (1e-9 relative), warm-started or cold, and a
//! study's <ForceSweep> element writes them.

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::force_sweep::{self, CandidateSpec, SweepOptions};
use statopt::tools::{self, study, RunOptions};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("force_sweep_{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SETUP: &str = "setups/leg_extension_rajagopal_cam2.xml";
const MACHINE: &str = "models/leg_extension/machine_cam2_rajagopal.osim";
const CAM2: &str = "-50*sqrt(1-0.75*sin(q+0.08726646259971647)^2)";

/// The setup's text over the first second (21 frames), with reserves of
/// optimal force `reserve`, contact weight `w0` (or the setup's) and, with
/// `machine`, that machine file.
fn setup_text(w0: Option<f64>, reserve: f64, machine: Option<&Path>) -> String {
    let mut text = std::fs::read_to_string(root().join(SETUP)).unwrap();
    // No figures (they name the tables of every w0); the metrics stay.
    let (a, b) = (
        text.find("<Figure").unwrap(),
        text.rfind("</Figure>").unwrap(),
    );
    text.replace_range(a..b + "</Figure>".len(), "");
    text = text.replace("<final_time>5</final_time>", "<final_time>1</final_time>");
    text = text.replace(
        "<friction_cone>cone</friction_cone>",
        &format!(
            "<friction_cone>cone</friction_cone><reserve_actuators>{reserve}</reserve_actuators>"
        ),
    );
    if let Some(w) = w0 {
        text = text.replace(
            "<contact_weight>1 500 1000</contact_weight>",
            &format!("<contact_weight>{w}</contact_weight>"),
        );
        // One w0: its tables carry no w0 tag.
        text = text.replace("_w0_mean_", "_");
    }
    if let Some(m) = machine {
        text = text.replace(
            "../models/leg_extension/machine_cam2_rajagopal.osim",
            &m.display().to_string(),
        );
    }
    text
}

/// A copy of the machine file with the cam torque `expr`.
fn machine_with(expr: &str, dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join(MACHINE)).unwrap();
    let edited = text.replace(
        &format!("<expression>{CAM2}</expression>"),
        &format!("<expression>{expr}</expression>"),
    );
    assert!(edited != text || expr == CAM2);
    let p = dir.join("machine.osim");
    std::fs::write(&p, edited).unwrap();
    p
}

/// The setup's <Metric>s computed from the tables of a single-w0 run in
/// `out` (their names carry no w0 tag), unrounded.
fn metrics_of_run(setup_text: &str, out: &Path) -> Vec<(String, f64)> {
    let Setup::Analyze(s) = Setup::parse(setup_text, &root().join(SETUP)).unwrap() else {
        unreachable!()
    };
    s.figures
        .iter()
        .filter(|e| e.name == "Metric")
        .map(|el| {
            let t = storage::read(&out.join(el.attr("file").unwrap())).unwrap();
            let mut y = vec![0.0; t.time.len()];
            for c in el.attr("columns").unwrap().split_whitespace() {
                let j = t.column_index(c).unwrap();
                for (v, r) in y.iter_mut().zip(&t.rows) {
                    *v += r[j];
                }
            }
            let v = study::metric_value(el, &t.time, &y, || unreachable!()).unwrap();
            (el.attr("name").unwrap().to_string(), v)
        })
        .collect()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1.0)
}

#[test]
fn candidates_equal_their_own_runs() {
    let dir = tmp("equal");
    // The reserves' names: from the problem of the base setup.
    let reserves: Vec<String> = {
        let text = setup_text(Some(500.0), 100.0, None);
        let out = dir.join("names");
        tools::run_setup_text(
            &root().join(SETUP),
            &text,
            &RunOptions {
                results_dir: Some(out.clone()),
                threads: Some(1),
                ..Default::default()
            },
        )
        .unwrap();
        let t = storage::read(&out.join("leg_extension_rajagopal_cam2_SO_activation.sto")).unwrap();
        t.labels
            .iter()
            .filter(|l| l.ends_with("_reserve"))
            .cloned()
            .collect()
    };
    assert!(!reserves.is_empty());
    // (cam torque, w0, reserves' optimal force)
    let cases: [(&str, f64, f64); 4] = [
        (CAM2, 500.0, 100.0),
        ("-50", 1.0, 100.0),
        ("-30-20*cos(q)^2", 1000.0, 100.0),
        ("-50*sqrt(1-0.51*sin(q+0.08726646259971647)^2)", 500.0, 40.0),
    ];
    let specs: Vec<CandidateSpec> = cases
        .iter()
        .map(|&(e, w0, r)| CandidateSpec {
            w0,
            expressions: vec![("cam_torque".into(), e.into())],
            optimal_forces: if r == 100.0 {
                Vec::new()
            } else {
                reserves.iter().map(|n| (n.clone(), r)).collect()
            },
        })
        .collect();
    let base = setup_text(None, 100.0, None);
    let opts = RunOptions {
        threads: Some(2),
        ..Default::default()
    };
    let warm = force_sweep::run_file(
        &root().join(SETUP),
        Some(&base),
        &specs,
        &opts,
        &SweepOptions { warm: true },
    )
    .unwrap();
    let cold = force_sweep::run_file(
        &root().join(SETUP),
        Some(&base),
        &specs,
        &opts,
        &SweepOptions { warm: false },
    )
    .unwrap();
    assert_eq!(warm.frames, 21);
    assert_eq!(warm.metric_names.len(), 6);
    for (k, &(expr, w0, reserve)) in cases.iter().enumerate() {
        let d = dir.join(format!("case{k}"));
        std::fs::create_dir_all(&d).unwrap();
        let machine = machine_with(expr, &d);
        let text = setup_text(Some(w0), reserve, Some(&machine));
        let out = d.join("out");
        let summary = tools::run_setup_text(
            &root().join(SETUP),
            &text,
            &RunOptions {
                results_dir: Some(out.clone()),
                precision: Some(20),
                threads: Some(2),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(summary.failed, warm.failed[k], "case {k}");
        let own = metrics_of_run(&text, &out);
        for (m, (name, v)) in own.iter().enumerate() {
            assert_eq!(&warm.metric_names[m], name);
            let (w, c) = (warm.values[k][m], cold.values[k][m]);
            assert!(
                close(w, *v, 1e-9),
                "case {k} {name}: sweep {w} vs own run {v}"
            );
            assert!(
                close(c, *v, 1e-9),
                "case {k} {name}: cold sweep {c} vs own run {v}"
            );
            assert!(close(w, c, 1e-11), "case {k} {name}: warm {w} vs cold {c}");
        }
    }
    // The candidates differ: at w0 = 500 a rounder cam (b/a = 0.7) demands
    // more quadriceps work than cam 2 (b/a = 0.5).
    assert_eq!(warm.metric_names[0], "quadriceps_work_J");
    assert!(
        warm.values[3][0] > warm.values[0][0] + 1.0,
        "{:?}",
        warm.values
    );
}

#[test]
fn bad_candidates_are_input_errors() {
    let base = setup_text(Some(500.0), 100.0, None);
    let run = |spec: CandidateSpec| {
        force_sweep::run_file(
            &root().join(SETUP),
            Some(&base),
            &[spec],
            &RunOptions::default(),
            &SweepOptions::default(),
        )
        .unwrap_err()
        .to_string()
    };
    let e = run(CandidateSpec {
        w0: 500.0,
        expressions: vec![("no_such_force".into(), "-50".into())],
        ..Default::default()
    });
    assert!(
        e.contains("candidate 0") && e.contains("no passive force 'no_such_force'"),
        "{e}"
    );
    let e = run(CandidateSpec {
        w0: 500.0,
        expressions: vec![("cam_torque".into(), "-50*(".into())],
        ..Default::default()
    });
    assert!(e.contains("the expression of 'cam_torque'"), "{e}");
    let e = run(CandidateSpec {
        w0: -1.0,
        ..Default::default()
    });
    assert!(e.contains("w0 = -1 lies outside"), "{e}");
    let e = run(CandidateSpec {
        w0: 1.0,
        optimal_forces: vec![("vasint_r".into(), 10.0)],
        ..Default::default()
    });
    assert!(e.contains("no actuator 'vasint_r'"), "{e}");
    // The knee contact method's rows are not swept yet: said, not ignored.
    let e = force_sweep::run_file(
        &root().join("setups/leg_extension_rajagopal_cam1_kc.xml"),
        None,
        &[CandidateSpec {
            w0: 500.0,
            ..Default::default()
        }],
        &RunOptions::default(),
        &SweepOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("<knee_contact>") && e.contains("knee contact method"),
        "{e}"
    );
}

#[test]
fn a_study_force_sweep_element_writes_its_metrics() {
    let dir = tmp("study");
    let setup = dir.join("setup.xml");
    std::fs::write(&setup, setup_text(None, 100.0, Some(&root().join(MACHINE)))).unwrap();
    // Relative paths of the setup resolve against its own folder: point
    // them back at the repository.
    let text = std::fs::read_to_string(&setup)
        .unwrap()
        .replace("../models/", &format!("{}/models/", root().display()))
        .replace("../motions/", &format!("{}/motions/", root().display()));
    std::fs::write(&setup, text).unwrap();
    let study_file = dir.join("study.xml");
    std::fs::write(
        &study_file,
        format!(
            r#"<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
	<StatoptStudy name="cams">
		<results_directory>out</results_directory>
		<ForceSweep name="shapes" setup="setup.xml">
			<contact_weight>1 500</contact_weight>
			<Candidate name="circular"><expression force="cam_torque">-50</expression></Candidate>
			<Candidate name="cam2"><expression force="cam_torque">{CAM2}</expression></Candidate>
		</ForceSweep>
	</StatoptStudy>
</OpenSimDocument>
"#
        ),
    )
    .unwrap();
    let summary = tools::run_setup(&study_file, &RunOptions::default()).unwrap();
    let csv = dir.join("out/shapes_force_sweep.csv");
    assert!(summary.files.contains(&csv));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    assert!(lines[0].starts_with("candidate,w0,frames,failed,quadriceps_work_J,"));
    assert!(lines[1].starts_with("circular,1,21,0,"));
    assert!(lines[4].starts_with("cam2,500,21,0,"));
    // A candidate element it does not know is an error naming it.
    let bad = std::fs::read_to_string(&study_file)
        .unwrap()
        .replace("<Candidate name=\"cam2\">", "<Candidat name=\"cam2\">")
        .replace(
            "</expression></Candidate>\n\t\t</ForceSweep>",
            "</expression></Candidat>\n\t\t</ForceSweep>",
        );
    std::fs::write(&study_file, bad).unwrap();
    let e = tools::run_setup(&study_file, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown element <Candidat>"), "{e}");
    // Checked like every element of a setup document: file, line and the
    // nearest known name; `--check` finds it; `--allow-unknown` reads on.
    assert!(
        e.contains("study.xml, line 8") && e.contains("did you mean Candidate?"),
        "{e}"
    );
    let report = statopt::tools::check::run(&study_file, false);
    // The sweep's setup is checked too.
    assert!(
        report.checked.iter().any(|c| c.ends_with("setup.xml")),
        "{:?}",
        report.checked
    );
    assert!(
        report
            .errors
            .iter()
            .any(|e| e.to_string().contains("did you mean Candidate?")),
        "{:?}",
        report.errors
    );
    let lenient = RunOptions {
        allow_unknown: true,
        ..Default::default()
    };
    let summary = tools::run_setup(&study_file, &lenient).unwrap();
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("<Candidat>") && w.contains("--allow-unknown")),
        "{:?}",
        summary.warnings
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().count(), 3, "{text}");
    // An attribute it does not know, likewise.
    let bad = std::fs::read_to_string(&study_file)
        .unwrap()
        .replace("<Candidat name=\"cam2\">", "<Candidate nmae=\"cam2\">")
        .replace("</Candidat>", "</Candidate>");
    std::fs::write(&study_file, bad).unwrap();
    let e = tools::run_setup(&study_file, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nmae") && e.contains("did you mean name?"),
        "{e}"
    );
}

/// The design sweep compares its circular cam with the cam 1 setup's run,
/// and sweeps the cam 2 setup: the two stay alike but for the cam (the
/// cam 2 setup once titled its quadriceps power figure "cam 1").
#[test]
fn the_rajagopal_cam_setups_differ_only_in_the_cam() {
    let read = |n: u8| {
        std::fs::read_to_string(root().join(format!("setups/leg_extension_rajagopal_cam{n}.xml")))
            .unwrap()
    };
    let cam1 = read(1).replace("cam1", "cam2").replace("cam 1", "cam 2");
    let cam2 = read(2);
    for (k, (a, b)) in cam1.lines().zip(cam2.lines()).enumerate() {
        assert_eq!(a, b, "line {}", k + 1);
    }
    assert_eq!(cam1.lines().count(), cam2.lines().count());
}
