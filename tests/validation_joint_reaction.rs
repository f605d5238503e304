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
        };
        let err = analyze::run(&setup, &opts)
            .expect_err("must refuse")
            .to_string();
        assert!(err.contains(expect), "error should name {expect}: {err}");
        println!("{err}");
    }
}
