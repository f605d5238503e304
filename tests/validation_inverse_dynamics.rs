//! statopt's InverseDynamicsTool against OpenSim 4.6 on every validation case,
//! running the case's setup_ID.xml unchanged (only the results directory is
//! redirected). Tolerance per column: max |difference| <= 0.5% of the
//! column's peak |value| + 0.01.

mod common;

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{inverse_dynamics, RunOptions};

#[test]
fn inverse_dynamics_matches_opensim_on_every_validation_case() {
    let Some(root) =
        common::validation_dir("inverse_dynamics_matches_opensim_on_every_validation_case")
    else {
        return;
    };
    let mut failures = Vec::new();
    for case in common::CASES {
        let dir = root.join(case);
        let setup = match Setup::read(&dir.join("setup_ID.xml")).unwrap() {
            Setup::InverseDynamics(s) => s,
            #[allow(unreachable_patterns)]
            _ => panic!("setup_ID.xml is not an InverseDynamicsTool setup"),
        };
        let out = common::out_dir(&format!("id_{case}"));
        let opts = RunOptions {
            results_dir: Some(out.clone()),
            precision: Some(12),
            verbose: false,
            ..Default::default()
        };
        let summary =
            inverse_dynamics::run(&setup, &opts).unwrap_or_else(|e| panic!("{case}: {e}"));
        let ours = storage::read(&summary.files[0]).unwrap();
        let reference =
            storage::read(&dir.join("results").join(&setup.output_gen_force_file)).unwrap();
        let errors = common::compare(&ours, &reference);
        let worst = errors
            .iter()
            .max_by(|a, b| {
                (a.max_abs / (0.005 * a.peak + 0.01))
                    .total_cmp(&(b.max_abs / (0.005 * b.peak + 0.01)))
            })
            .unwrap();
        println!(
            "{case}: {} frames; worst column {} max|diff| {:.3e} (peak {:.3}, {:.2}% of peak) at t={:.4}",
            ours.time.len(),
            worst.label,
            worst.max_abs,
            worst.peak,
            100.0 * worst.max_abs / worst.peak.max(1e-300),
            worst.worst_time
        );
        for e in &errors {
            if e.max_abs > 0.005 * e.peak + 0.01 {
                failures.push(format!(
                    "{case}/{}: max|diff| {:.4e} > tol {:.4e} (t={})",
                    e.label,
                    e.max_abs,
                    0.005 * e.peak + 0.01,
                    e.worst_time
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "columns out of tolerance:\n{}",
        failures.join("\n")
    );
}
