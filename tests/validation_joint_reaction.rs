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
                "{case} {which}: worst column {} max |diff| {:.4} (peak {:.2}, tolerance {:.3}) at t={:.4}",
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
