//! Force sweeps (sweep::stream, and its driver tools::force_sweep):
//! candidates that differ only in forces — the cam's torque expression, w0,
//! the reserves' optimal force — solved on one compiled scene give every
//! metric of the setup as a run of the candidate's own setup does (1e-9
//! relative), warm-started or cold, and a study's <ForceSweep> element
//! writes them.

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::plan::figures::FigureOrMetric;
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
    metrics_of_run_at(&root().join(SETUP), setup_text, out)
}

/// [`metrics_of_run`] of the setup text read as if it were `setup`.
fn metrics_of_run_at(setup: &Path, setup_text: &str, out: &Path) -> Vec<(String, f64)> {
    let Setup::Analyze(s) = Setup::parse(setup_text, setup).unwrap() else {
        unreachable!()
    };
    s.figures
        .iter()
        .filter_map(|e| match e {
            FigureOrMetric::Metric(m) => Some(m),
            FigureOrMetric::Figure(_) => None,
        })
        .map(|m| {
            let t = storage::read(&out.join(&m.file)).unwrap();
            let mut y = vec![0.0; t.time.len()];
            for c in m.columns.split_whitespace() {
                let j = t.column_index(c).unwrap();
                for (v, r) in y.iter_mut().zip(&t.rows) {
                    *v += r[j];
                }
            }
            let v = study::metric_value(m.op, &t.time, &y, || unreachable!()).unwrap();
            (m.name.clone(), v)
        })
        .collect()
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1.0)
}

/// A candidate's own run: the setup text run into `out`, written at 20
/// digits so that the comparisons see the solver's answers, not rounding.
fn own_run(setup: &Path, text: &str, out: &Path) -> statopt::tools::RunSummary {
    tools::run_setup_text(
        setup,
        text,
        &RunOptions {
            results_dir: Some(out.to_path_buf()),
            precision: Some(20),
            threads: Some(2),
            ..Default::default()
        },
    )
    .unwrap()
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
            ..Default::default()
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
        &SweepOptions {
            warm: true,
            ..Default::default()
        },
    )
    .unwrap();
    let cold = force_sweep::run_file(
        &root().join(SETUP),
        Some(&base),
        &specs,
        &opts,
        &SweepOptions {
            warm: false,
            ..Default::default()
        },
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
        let summary = own_run(&root().join(SETUP), &text, &out);
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
    // External load scales: the setup has no external loads.
    let e = run(CandidateSpec {
        w0: 1.0,
        external_scales: vec![("*".into(), 2.0)],
        ..Default::default()
    });
    assert!(e.contains("the setup has no external loads"), "{e}");
}

/// The cam 1 setup with the knee contact method (setups/
/// leg_extension_rajagopal_cam1_kc.xml) over its first second, one w0
/// (its tables then carry no w0 tag), the machine `machine` and a metric
/// of the method's KneeContact table.
fn kc_setup_text(w0: f64, machine: &Path) -> String {
    let mut text =
        std::fs::read_to_string(root().join("setups/leg_extension_rajagopal_cam1_kc.xml")).unwrap();
    let (a, b) = (
        text.find("<Figure").unwrap(),
        text.rfind("</Figure>").unwrap(),
    );
    text.replace_range(a..b + "</Figure>".len(), "");
    text = text.replace("<final_time>5</final_time>", "<final_time>1</final_time>");
    text = text.replace(
        "<contact_weight>1 500 1000</contact_weight>",
        &format!("<contact_weight>{w0}</contact_weight>"),
    );
    text = text.replace("_w0_mean_", "_");
    text = text.replace(
        "../models/leg_extension/machine_cam1_rajagopal.osim",
        &machine.display().to_string(),
    );
    text.replace(
        "<external_loads_file",
        "<Metric name=\"peak_tf_total_N\" file=\"leg_extension_rajagopal_cam1_kc_KneeContact.sto\" columns=\"walker_knee_r_total_N\" op=\"max\"/>\n\t\t<Metric name=\"mean_medial_N\" file=\"leg_extension_rajagopal_cam1_kc_KneeContact.sto\" columns=\"walker_knee_r_medial_N\" op=\"mean\"/>\n\t\t<external_loads_file",
    )
}

/// Every table a candidate's sweep wrote in `tables` equals the table of
/// the same name its own run wrote in `own` (1e-9 of each column's peak;
/// of the diagnostics only status and objective: the solver's counters and
/// residuals depend on its start). Returns how many tables were compared.
fn tables_equal(tables: &Path, own: &Path) -> usize {
    let mut n = 0;
    for entry in std::fs::read_dir(tables).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let other = own.join(&name);
        assert!(other.is_file(), "{name}: the own run wrote no such table");
        if name.ends_with(".xml") {
            assert_eq!(
                std::fs::read_to_string(&path).unwrap(),
                std::fs::read_to_string(&other).unwrap(),
                "{name}"
            );
            n += 1;
            continue;
        }
        let (a, b) = (
            storage::read(&path).unwrap(),
            storage::read(&other).unwrap(),
        );
        assert_eq!(a.labels, b.labels, "{name}");
        assert_eq!(a.time, b.time, "{name}");
        for (j, label) in a.labels.iter().enumerate() {
            if name.ends_with("diagnostics.sto") && label != "status" && label != "objective" {
                continue;
            }
            let peak = b.rows.iter().map(|r| r[j].abs()).fold(1.0, f64::max);
            for (ra, rb) in a.rows.iter().zip(&b.rows) {
                assert!(
                    (ra[j] - rb[j]).abs() <= 1e-9 * peak,
                    "{name} {label}: sweep {} vs own run {}",
                    ra[j],
                    rb[j]
                );
            }
        }
        n += 1;
    }
    n
}

/// With the knee contact method (its rows' right-hand side holds loads of
/// the frame): the cam torque's candidates equal their own runs on every
/// metric, the KneeContact table's included, and the tables the sweep
/// writes on request equal the runs' tables.
#[test]
fn knee_contact_candidates_equal_their_own_runs() {
    let dir = tmp("knee_contact");
    let cases: [(&str, f64); 2] = [(CAM2, 500.0), ("-50", 1.0)];
    let base = kc_setup_text(500.0, &root().join(MACHINE));
    let specs: Vec<CandidateSpec> = cases
        .iter()
        .map(|&(e, w0)| CandidateSpec {
            w0,
            expressions: vec![("cam_torque".into(), e.into())],
            ..Default::default()
        })
        .collect();
    let setup = root().join("setups/leg_extension_rajagopal_cam1_kc.xml");
    let sweep = force_sweep::run_file(
        &setup,
        Some(&base),
        &specs,
        &RunOptions {
            threads: Some(2),
            precision: Some(20),
            ..Default::default()
        },
        &SweepOptions {
            tables: (0..cases.len())
                .map(|k| force_sweep::CandidateTables {
                    dir: dir.join(format!("tables{k}")),
                    w0_tag: false,
                })
                .collect(),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(sweep.frames, 21);
    assert!(sweep.metric_names.iter().any(|n| n == "peak_tf_total_N"));
    assert!(sweep
        .files
        .iter()
        .any(|f| f.ends_with("tables1/leg_extension_rajagopal_cam1_kc_KneeContact.sto")));
    for (k, &(expr, w0)) in cases.iter().enumerate() {
        let d = dir.join(format!("case{k}"));
        std::fs::create_dir_all(&d).unwrap();
        let text = kc_setup_text(w0, &machine_with(expr, &d));
        let out = d.join("out");
        let summary = own_run(&setup, &text, &out);
        assert_eq!(summary.failed, sweep.failed[k], "case {k}");
        // SO (7 with contacts, the contact loads' .mot and .xml), JR and
        // KneeContact reactions, KneeLoads, KneeContact.
        assert_eq!(tables_equal(&dir.join(format!("tables{k}")), &out), 13);
        for (m, (name, v)) in metrics_of_run_at(&setup, &text, &out).iter().enumerate() {
            assert_eq!(&sweep.metric_names[m], name);
            let w = sweep.values[k][m];
            assert!(
                close(w, *v, 1e-9),
                "case {k} {name}: sweep {w} vs own run {v}"
            );
        }
    }
    // The cams differ in the knee's total force.
    assert!(
        (sweep.values[0][0] - sweep.values[1][0]).abs() > 1.0,
        "{:?}",
        sweep.values
    );
}

/// The GC5 walking trial (../shared/models/knee_gc5; SKIP when absent)
/// over its first frames: candidates scaling its external loads (one
/// plate, or all) equal runs whose data file's forces and torques are
/// scaled, with and without the knee contact method, on metrics of the
/// force table (the loads' own columns), the joint reactions and the
/// method's KneeContact table.
#[test]
fn external_load_scales_equal_runs_of_scaled_data() {
    let gc5 = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models/knee_gc5");
    if !gc5.join("setup_ss1.xml").is_file() {
        eprintln!("SKIP external_load_scales_equal_runs_of_scaled_data: ../shared/models/knee_gc5 is absent");
        return;
    }
    let dir = tmp("external");
    let setup = gc5.join("setup_ss1.xml");
    let setup_text = |loads: &Path, knee_contact: bool| -> String {
        let mut t = std::fs::read_to_string(&setup).unwrap();
        t = t.replace("1.09166667", "0.05");
        let kc = if knee_contact {
            "<knee_contact>walker_knee_l</knee_contact>"
        } else {
            ""
        };
        t = t.replace(
            "<use_muscle_physiology>true</use_muscle_physiology>",
            &format!("<use_muscle_physiology>true</use_muscle_physiology><contact_weight>1000</contact_weight>{kc}"),
        );
        let mut metrics = String::from(
            "<Metric name=\"peak_plate1_fy\" file=\"GC5_ss1_SO_force.sto\" columns=\"calcn_l_plate1_left_Fy\" op=\"max\"/>\n\
             <Metric name=\"peak_knee_fy\" file=\"GC5_ss1_JR_ReactionLoads.sto\" columns=\"walker_knee_l_on_tibia_l_in_tibia_l_fy\" op=\"min\"/>\n\
             <Metric name=\"mean_vasint\" file=\"GC5_ss1_SO_force.sto\" columns=\"vasint_l\" op=\"mean\"/>\n",
        );
        if knee_contact {
            metrics.push_str("<Metric name=\"peak_total\" file=\"GC5_ss1_KneeContact.sto\" columns=\"walker_knee_l_total_N\" op=\"max\"/>\n<Metric name=\"mean_lateral\" file=\"GC5_ss1_KneeContact.sto\" columns=\"walker_knee_l_lateral_N\" op=\"mean\"/>\n");
        }
        t.replace(
            "<external_loads_file>GC5_ss1_loads.xml</external_loads_file>",
            &format!(
                "{metrics}<external_loads_file>{}</external_loads_file>",
                loads.display()
            ),
        )
    };
    // The loads file with its data file's forces and torques of the named
    // plates (all: None) scaled by s.
    let scaled_loads = |d: &Path, plates: Option<&[&str]>, s: f64| -> PathBuf {
        let data = std::fs::read_to_string(gc5.join("GC5_ss1_kinetics.mot")).unwrap();
        let prefixes: Vec<String> = match plates {
            None => vec!["1_".into(), "2_".into(), "3_".into()],
            Some(p) => p.iter().map(|x| x[..2].to_string()).collect(),
        };
        let mut out = String::new();
        let mut cols: Vec<bool> = Vec::new();
        let mut body = false;
        for line in data.lines() {
            if body {
                let v: Vec<String> = line
                    .split_whitespace()
                    .zip(&cols)
                    .map(|(x, &c)| {
                        if c {
                            format!("{}", x.parse::<f64>().unwrap() * s)
                        } else {
                            x.to_string()
                        }
                    })
                    .collect();
                out.push_str(&v.join("\t"));
            } else {
                if line.starts_with("time") {
                    cols = line
                        .split_whitespace()
                        .map(|l| {
                            prefixes.iter().any(|p| l.starts_with(p.as_str()))
                                && (l.contains("_force_v") || l.contains("_torque_"))
                        })
                        .collect();
                    body = true;
                }
                out.push_str(line);
            }
            out.push('\n');
        }
        let data_path = d.join("kinetics.mot");
        std::fs::write(&data_path, out).unwrap();
        let xml = std::fs::read_to_string(gc5.join("GC5_ss1_loads.xml"))
            .unwrap()
            .replace(
                "<datafile>GC5_ss1_kinetics.mot</datafile>",
                &format!("<datafile>{}</datafile>", data_path.display()),
            );
        let p = d.join("loads.xml");
        std::fs::write(&p, xml).unwrap();
        p
    };
    let cases: [(Option<&[&str]>, f64); 2] = [(Some(&["1_plate1_left"]), 0.8), (None, 1.1)];
    for knee_contact in [false, true] {
        let base = setup_text(&gc5.join("GC5_ss1_loads.xml"), knee_contact);
        let specs: Vec<CandidateSpec> = cases
            .iter()
            .map(|&(p, s)| CandidateSpec {
                w0: 1000.0,
                external_scales: vec![(
                    p.map_or("*".to_string(), |_| "plate1_left".to_string()),
                    s,
                )],
                ..Default::default()
            })
            .collect();
        let sweep = force_sweep::run_file(
            &setup,
            Some(&base),
            &specs,
            &RunOptions {
                threads: Some(2),
                ..Default::default()
            },
            &SweepOptions::default(),
        )
        .unwrap();
        assert_eq!(sweep.frames, 7);
        for (k, &(plates, s)) in cases.iter().enumerate() {
            let d = dir.join(format!("kc{knee_contact}_case{k}"));
            std::fs::create_dir_all(&d).unwrap();
            let text = setup_text(&scaled_loads(&d, plates, s), knee_contact);
            let out = d.join("out");
            let summary = own_run(&setup, &text, &out);
            assert_eq!(summary.failed, sweep.failed[k], "case {k}");
            let own = metrics_of_run_at(&setup, &text, &out);
            assert_eq!(own.len(), if knee_contact { 5 } else { 3 });
            for (m, (name, v)) in own.iter().enumerate() {
                assert_eq!(&sweep.metric_names[m], name);
                let w = sweep.values[k][m];
                assert!(
                    close(w, *v, 1e-9),
                    "knee contact {knee_contact}, case {k} {name}: sweep {w} vs own run {v}"
                );
            }
            // The scale reached the force table: the plate's own column.
            if k == 0 {
                let unscaled = force_sweep::run_file(
                    &setup,
                    Some(&base),
                    &[CandidateSpec {
                        w0: 1000.0,
                        ..Default::default()
                    }],
                    &RunOptions::default(),
                    &SweepOptions::default(),
                )
                .unwrap();
                let (a, b) = (sweep.values[0][0], unscaled.values[0][0]);
                assert!(close(a, 0.8 * b, 1e-12), "{a} vs 0.8 × {b}");
            }
        }
    }
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
			<write_tables>true</write_tables>
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
    // The candidates' KneeLoads are made from each frame's reactions as
    // they are solved (`writers::knee_tables`): no table it wrote is opened
    // for reading (before, each candidate's ReactionLoads file was).
    let out = dir.join("out");
    let read_back: Vec<_> = storage::opened()
        .into_iter()
        .filter(|(p, _)| p.starts_with(&out))
        .collect();
    assert!(read_back.is_empty(), "read back: {read_back:?}");
    let csv = dir.join("out/shapes_force_sweep.csv");
    assert!(summary.files.contains(&csv));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 5, "{text}");
    assert!(lines[0].starts_with("candidate,w0,frames,failed,quadriceps_work_J,"));
    assert!(lines[1].starts_with("circular,1,21,0,"));
    assert!(lines[4].starts_with("cam2,500,21,0,"));
    // The tables, on request: per candidate, named as a run of its setup
    // with both w0 names them.
    for (c, w0) in [("circular", 1), ("cam2", 500)] {
        let f = dir.join(format!(
            "out/shapes_force_sweep/{c}/leg_extension_rajagopal_cam2_JR_w0_{w0}_KneeLoads.sto"
        ));
        assert!(summary.files.contains(&f), "{}", f.display());
        assert_eq!(storage::read(&f).unwrap().time.len(), 21);
    }
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
    // Checked like every element of a setup document: file, line (the
    // second Candidate's, after <write_tables>) and the nearest known name;
    // `--check` finds it; `--allow-unknown` reads on.
    assert!(
        e.contains("study.xml, line 9") && e.contains("did you mean Candidate?"),
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
    // An external load scale is read (and checked against the setup's loads).
    let scaled = std::fs::read_to_string(&study_file)
        .unwrap()
        .replace("nmae=", "name=")
        .replace(
            "<expression force=\"cam_torque\">-50</expression>",
            "<expression force=\"cam_torque\">-50</expression><external_scale>2</external_scale>",
        );
    std::fs::write(&study_file, scaled).unwrap();
    let e = tools::run_setup(&study_file, &RunOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("the setup has no external loads"), "{e}");
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

/// The examples' --knee-contact setup is the cam 2 setup with the knee
/// contact method and its KneeContact metrics, nothing else.
#[test]
fn the_knee_contact_cam2_setup_differs_only_in_the_method() {
    let body = |name: &str| -> Vec<String> {
        let text = std::fs::read_to_string(root().join(format!("setups/{name}.xml"))).unwrap();
        // After the leading comment; without the method's own lines.
        let start = text.find("-->").unwrap() + 3;
        text[start..]
            .replace(
                "leg_extension_rajagopal_cam2_kc",
                "leg_extension_rajagopal_cam2",
            )
            .lines()
            .filter(|l| {
                !l.contains("<knee_contact>")
                    && !l.contains("KneeContact.sto")
                    && !l.contains("knee contact method's total")
            })
            .map(String::from)
            .collect()
    };
    let (kc, cam2) = (
        body("leg_extension_rajagopal_cam2_kc"),
        body("leg_extension_rajagopal_cam2"),
    );
    assert_eq!(kc, cam2);
    let text =
        std::fs::read_to_string(root().join("setups/leg_extension_rajagopal_cam2_kc.xml")).unwrap();
    assert!(text.contains("<knee_contact>all</knee_contact>"));
    assert!(text.contains("<Metric name=\"peak_tf_total_N\""));
}

/// A w0 sweep with the knee contact method writes the KneeContact table's
/// mean, min and max over w0 (as the other tables'), which the cam 2 knee
/// contact setup's metrics read (it stopped at a missing
/// `_w0_mean_KneeContact.sto` before).
#[test]
fn a_knee_contact_w0_sweep_writes_its_statistics() {
    let dir = tmp("kc_statistics");
    let setup = root().join("setups/leg_extension_rajagopal_cam2_kc.xml");
    let text = std::fs::read_to_string(&setup)
        .unwrap()
        .replace("<final_time>5</final_time>", "<final_time>1</final_time>");
    let out = dir.join("out");
    let summary = tools::run_setup_text(
        &setup,
        &text,
        &RunOptions {
            results_dir: Some(out.clone()),
            threads: Some(2),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(summary.failed, 0);
    let read = |tag: &str| {
        storage::read(&out.join(format!(
            "leg_extension_rajagopal_cam2_kc_w0_{tag}_KneeContact.sto"
        )))
        .unwrap()
    };
    let (mean, min, max) = (read("mean"), read("min"), read("max"));
    let (w1, w1000) = (read("1"), read("1000"));
    assert_eq!(mean.time.len(), 21);
    let j = mean.column_index("walker_knee_r_total_N").unwrap();
    for i in 0..21 {
        let (lo, hi) = (min.rows[i][j], max.rows[i][j]);
        assert!(lo <= mean.rows[i][j] && mean.rows[i][j] <= hi, "row {i}");
        assert!(lo <= w1.rows[i][j].min(w1000.rows[i][j]) + 1e-6, "row {i}");
        assert!(hi >= w1.rows[i][j].max(w1000.rows[i][j]) - 1e-6, "row {i}");
    }
    let metrics =
        std::fs::read_to_string(out.join("leg_extension_rajagopal_cam2_kc_metrics.csv")).unwrap();
    assert!(metrics.contains("peak_tf_total_N,"), "{metrics}");
}

/// A candidate's frame result holds only the outputs its metrics read
/// (`frame::problem::Outputs`): metrics of every static-optimization table
/// (activations, forces, diagnostics, contact rows, generalized forces by
/// source), computed without tables, equal those of the candidate's own
/// tables written by the same sweep (20 digits: the values themselves).
#[test]
fn metrics_of_every_table_equal_those_of_the_written_tables() {
    let dir = tmp("outputs");
    let text = setup_text(Some(500.0), 100.0, None);
    let spec = CandidateSpec {
        w0: 500.0,
        expressions: vec![("cam_torque".into(), "-30-20*cos(q)^2".into())],
        ..Default::default()
    };
    let opts = RunOptions {
        threads: Some(2),
        precision: Some(20),
        ..Default::default()
    };
    let tables = dir.join("tables");
    let with_tables = force_sweep::run_file(
        &root().join(SETUP),
        Some(&text),
        std::slice::from_ref(&spec),
        &opts,
        &SweepOptions {
            tables: vec![force_sweep::CandidateTables {
                dir: tables.clone(),
                w0_tag: false,
            }],
            ..Default::default()
        },
    )
    .unwrap();
    // Per table, the column of the largest values (diagnostics: the
    // objective; its solve time is no result).
    let mut metrics = String::new();
    for kind in [
        "activation",
        "force",
        "diagnostics",
        "ContactForces",
        "ContactBodyForces",
        "GeneralizedForcesBySource",
    ] {
        let file = format!("leg_extension_rajagopal_cam2_SO_{kind}.sto");
        let t = storage::read(&tables.join(&file)).unwrap();
        let column = if kind == "diagnostics" {
            "objective".to_string()
        } else {
            let big = |j: usize| t.rows.iter().fold(0.0f64, |m, r| m.max(r[j].abs()));
            let j = (0..t.labels.len())
                .max_by(|&a, &b| big(a).total_cmp(&big(b)))
                .unwrap();
            assert!(big(j) > 0.0, "{file}: every column is 0");
            t.labels[j].clone()
        };
        metrics.push_str(&format!(
            "<Metric name=\"m_{kind}\" file=\"{file}\" columns=\"{column}\" op=\"max\"/>\n\t\t"
        ));
    }
    let at = text.find("<Metric ").unwrap();
    let mut extended = text.clone();
    extended.insert_str(at, &metrics);
    let only = force_sweep::run_file(
        &root().join(SETUP),
        Some(&extended),
        std::slice::from_ref(&spec),
        &opts,
        &SweepOptions::default(),
    )
    .unwrap();
    let own = metrics_of_run(&extended, &tables);
    assert_eq!(only.metric_names.len(), own.len());
    assert_eq!(own.len(), with_tables.metric_names.len() + 6);
    for (m, (name, v)) in own.iter().enumerate() {
        assert_eq!(&only.metric_names[m], name);
        let s = only.values[0][m];
        assert!(
            close(s, *v, 1e-12),
            "{name}: metrics only {s} vs tables {v}"
        );
    }
}

/// The sweep stage runs a force sweep without the tool, as the Python
/// binding's `force_sweep` does (`sweep::stream::run_file`): its metrics
/// are the tool's bit for bit (on 2 threads against the tool's 1), and its
/// progress callback is told (0, n) once the motion is open, then every
/// frame in order up to (n, n), n the frames solved.
#[test]
fn the_sweep_stage_runs_a_sweep_without_the_tool() {
    use std::sync::{Arc, Mutex};
    let text = setup_text(None, 100.0, None);
    let specs: Vec<CandidateSpec> = [(CAM2, 500.0), ("-50", 1.0)]
        .iter()
        .map(|&(e, w0)| CandidateSpec {
            w0,
            expressions: vec![("cam_torque".into(), e.into())],
            ..Default::default()
        })
        .collect();
    let told = Arc::new(Mutex::new(Vec::new()));
    let seen = told.clone();
    let stage = statopt::sweep::stream::run_file(
        &root().join(SETUP),
        Some(&text),
        false,
        &specs,
        &statopt::sweep::stream::SweepOptions {
            threads: Some(2),
            progress: Some(Arc::new(move |done, total| {
                seen.lock().unwrap().push((done, total))
            })),
            ..Default::default()
        },
    )
    .unwrap();
    let tool = force_sweep::run_file(
        &root().join(SETUP),
        Some(&text),
        &specs,
        &RunOptions {
            threads: Some(1),
            ..Default::default()
        },
        &SweepOptions::default(),
    )
    .unwrap();
    assert_eq!(stage.frames, 21);
    assert_eq!(stage.metric_names, tool.metric_names);
    assert_eq!(stage.failed, tool.failed);
    for (a, b) in stage.values.iter().zip(&tool.values) {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(b));
    }
    let told = told.lock().unwrap();
    let n = stage.frames as u64;
    let expected: Vec<(u64, u64)> = (0..=n).map(|d| (d, n)).collect();
    assert_eq!(*told, expected);
}
