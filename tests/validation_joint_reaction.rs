//! JointReaction against OpenSim 4.6 on every validation case, running each
//! case's setup_JR_child.xml and setup_JR_ground.xml unchanged (their
//! forces_file is OpenSim's own SO force file in results/; only the results
//! directory is redirected). Tolerance per column (forces, moments and
//! points): max |difference| <= 0.5% of the column's peak |value| + 0.5.

mod common;

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, RunOptions};

#[test]
fn joint_reactions_match_opensim_on_every_validation_case() {
    let Some(root) =
        common::validation_dir("joint_reactions_match_opensim_on_every_validation_case")
    else {
        return;
    };
    let mut failures = Vec::new();
    for case in common::CASES {
        let dir = root.join(case);
        for which in ["child", "ground"] {
            let setup = match Setup::read(&dir.join(format!("setup_JR_{which}.xml"))).unwrap() {
                Setup::Analyze(s) => s,
                _ => panic!("setup_JR_{which}.xml is not an AnalyzeTool setup"),
            };
            let out = common::out_dir(&format!("jr_{case}_{which}"));
            let opts = RunOptions {
                results_dir: Some(out.clone()),
                precision: Some(12),
                verbose: false,
                ..Default::default()
            };
            let summary = analyze::run(&setup, &opts).unwrap_or_else(|e| panic!("{case}: {e}"));
            for w in &summary.warnings {
                println!("{case} {which}: warning: {w}");
            }
            let file = summary.files[0].file_name().unwrap().to_owned();
            let ours = storage::read(&summary.files[0]).unwrap();
            let reference = storage::read(&dir.join("results").join(&file)).unwrap();
            assert_eq!(ours.name, "Joint Reaction Loads");
            assert_eq!(
                ours.labels, reference.labels,
                "{case} {which}: column labels differ"
            );
            let errors = common::compare(&ours, &reference);
            let worst = errors
                .iter()
                .max_by(|a, b| {
                    let ra = a.max_abs / (0.005 * a.peak + 0.5);
                    let rb = b.max_abs / (0.005 * b.peak + 0.5);
                    ra.total_cmp(&rb)
                })
                .unwrap();
            println!(
                "{case} {which}: worst column {} max |diff| {:.3e} (peak {:.2}, tolerance {:.3}) at t={:.4}",
                worst.label,
                worst.max_abs,
                worst.peak,
                0.005 * worst.peak + 0.5,
                worst.worst_time
            );
            for e in &errors {
                if !(e.max_abs <= 0.005 * e.peak + 0.5) {
                    failures.push(format!(
                        "{case} {which}: {} max |diff| {:.4} > {:.4} (peak {:.2}) at t={}",
                        e.label,
                        e.max_abs,
                        0.005 * e.peak + 0.5,
                        e.peak,
                        e.worst_time
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A forces file lacking an actuator, or no forces file, is an error naming
/// the actuators (OpenSim silently falls back to default muscle states).
#[test]
fn missing_actuator_forces_are_reported() {
    let Some(root) = common::validation_dir("missing_actuator_forces_are_reported") else {
        return;
    };
    let dir = root.join("arm26");
    let out = common::out_dir("jr_missing_actuator");
    // The SO force file without its BRA column.
    let mut forces =
        storage::read(&dir.join("results/arm26_StaticOptimization_force.sto")).unwrap();
    let j = forces.column_index("BRA").unwrap();
    forces.labels.remove(j);
    for r in &mut forces.rows {
        r.remove(j);
    }
    let forces_path = out.join("no_bra.sto");
    storage::write(&forces_path, &forces, 8).unwrap();
    let text = std::fs::read_to_string(dir.join("setup_JR_child.xml")).unwrap();
    let abs = |t: &str| t.replace("inputs/", &format!("{}/inputs/", dir.display()));
    for (forces_file, expect) in [
        (forces_path.display().to_string(), "BRA"),
        (String::new(), "no <forces_file>"),
    ] {
        let setup_text =
            abs(&text).replace("results/arm26_StaticOptimization_force.sto", &forces_file);
        let setup_path = out.join("setup.xml");
        std::fs::write(&setup_path, setup_text).unwrap();
        let setup = match Setup::read(&setup_path).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        let opts = RunOptions {
            results_dir: Some(out.clone()),
            precision: None,
            verbose: false,
            ..Default::default()
        };
        let err = analyze::run(&setup, &opts)
            .expect_err("must refuse")
            .to_string();
        assert!(err.contains(expect), "error should name {expect}: {err}");
        println!("{err}");
    }
}

/// The per-frame entry point for static optimization
/// (`static_optimization_reactions`, fed the frame's solved forces) gives the
/// same reactions as a JointReaction run reading those forces from a file.
#[test]
fn static_optimization_frames_give_the_reactions_of_their_force_file() {
    use statopt::frame::Workspace;
    use statopt::tools::analyze::{frame_rows, load_states};
    use statopt::tools::joint_reaction::{
        resolve_reactions, static_optimization_reactions, JointReactionSetup,
    };
    use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};
    let Some(root) =
        common::validation_dir("static_optimization_frames_give_the_reactions_of_their_force_file")
    else {
        return;
    };
    for case in ["arm26", "leg6dof9musc_stance"] {
        let dir = root.join(case);
        let out = common::out_dir(&format!("jr_so_{case}"));
        let analyze_setup = |name: &str| match Setup::read(&dir.join(name)).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        let so_setup = analyze_setup("setup_SO.xml");
        let so: StaticOptimizationSetup = so_setup.static_optimization().unwrap().clone();
        let (problem, _) = SoProblem::build(&so_setup, &so).unwrap();
        let states = load_states(&so_setup, &problem.model).unwrap();
        let udot = states
            .speed_derivatives(so_setup.coordinates_file.as_ref().unwrap())
            .unwrap();
        let rows: Vec<usize> =
            frame_rows(&states.time, so_setup.initial_time, so_setup.final_time, 1)
                .into_iter()
                .step_by(7)
                .collect();
        let jr_setup = analyze_setup("setup_JR_child.xml");
        let jr: JointReactionSetup = jr_setup.joint_reactions().next().unwrap().clone();
        let (specs, _) = resolve_reactions(&problem.model, &jr).unwrap();
        let mut ws = Workspace::new(&problem.model, &problem.muscles);
        let mut forces = storage::Storage {
            name: "forces".into(),
            labels: problem.labels.clone(),
            ..Default::default()
        };
        let mut direct = Vec::new();
        for &i in &rows {
            let (t, q, u) = (states.time[i], &states.q[i], &states.u[i]);
            let r = problem.solve_frame(t, q, u, &udot[i], &mut ws.data, &mut ws.muscles);
            let mut o = vec![0.0; 9 * specs.len()];
            static_optimization_reactions(&problem, t, &r, &mut ws, &specs, &mut o).unwrap();
            // Reusing the frame's kinematics and muscle paths from the
            // workspace it was solved in gives what a fresh workspace, which
            // recomputes them, gives: bit for bit.
            let mut fresh = Workspace::new(&problem.model, &problem.muscles);
            let mut again = vec![0.0; o.len()];
            static_optimization_reactions(&problem, t, &r, &mut fresh, &specs, &mut again).unwrap();
            assert!(
                o.iter()
                    .zip(&again)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{case} t = {t}: reactions from the reused workspace differ from a fresh one"
            );
            forces.time.push(t);
            forces.rows.push(r.forces.clone());
            direct.push(o);
        }
        let forces_path = out.join("so_forces.sto");
        storage::write(&forces_path, &forces, 16).unwrap();
        // The JR setup, reading that file, with absolute input paths.
        let text = std::fs::read_to_string(dir.join("setup_JR_child.xml")).unwrap();
        let so_file = text
            .split("<forces_file>")
            .nth(1)
            .and_then(|s| s.split("</forces_file>").next())
            .unwrap()
            .to_string();
        let text = text
            .replace("inputs/", &format!("{}/inputs/", dir.display()))
            .replace(&so_file, &forces_path.display().to_string());
        let setup_path = out.join("setup.xml");
        std::fs::write(&setup_path, text).unwrap();
        let setup = match Setup::read(&setup_path).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        let opts = RunOptions {
            results_dir: Some(out.clone()),
            precision: Some(16),
            verbose: false,
            ..Default::default()
        };
        let summary = analyze::run(&setup, &opts).unwrap();
        let file = storage::read(&summary.files[0]).unwrap();
        let mut worst = 0.0f64;
        for (k, &i) in rows.iter().enumerate() {
            let row = file
                .time
                .iter()
                .position(|&t| (t - states.time[i]).abs() < 1e-9)
                .unwrap();
            for (a, b) in direct[k].iter().zip(&file.rows[row]) {
                worst = worst.max((a - b).abs() / (1.0 + b.abs()));
            }
        }
        println!("{case}: SO-direct vs forces-file reactions: max relative difference {worst:.2e} over {} frames", rows.len());
        assert!(worst < 1e-7, "{case}: {worst}");
    }
}
