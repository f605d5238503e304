//! Static optimization against OpenSim 4.6 on every validation case, running
//! the case's setup_SO.xml unchanged (results redirected). Issue 4's
//! tolerances: activations max |diff| <= 0.01 at every frame and muscle and
//! RMS <= 0.002; forces within 1% of each column's peak; the equations of
//! motion hold on every frame to 1e-6 relative to the largest generalized force.

mod common;

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, RunOptions};

#[test]
fn static_optimization_matches_opensim_on_every_validation_case() {
    let Some(root) = common::validation_dir("static_optimization_matches_opensim_on_every_validation_case") else { return };
    let mut failures = Vec::new();
    for case in common::CASES {
        let dir = root.join(case);
        let setup = match Setup::read(&dir.join("setup_SO.xml")).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        let out = common::out_dir(&format!("so_{case}"));
        let opts = RunOptions { results_dir: Some(out.clone()), precision: Some(12), verbose: false };
        let summary = analyze::run(&setup, &opts).unwrap_or_else(|e| panic!("{case}: {e}"));
        for w in &summary.warnings {
            println!("{case}: warning: {w}");
        }
        let base = format!("{}_StaticOptimization_", setup.name);
        let read = |d: &std::path::Path, s: &str| storage::read(&d.join(format!("{base}{s}.sto"))).unwrap();
        let (ours, reference) = (read(&out, "activation"), read(&dir.join("results"), "activation"));
        assert_eq!(ours.time.len(), reference.time.len(), "{case}: frame count");
        let (mut worst, mut sum2, mut n) = ((0.0f64, String::new()), 0.0, 0usize);
        for (j, label) in reference.labels.iter().enumerate() {
            let k = ours.column_index(label).unwrap_or_else(|| panic!("{case}: no activation column {label}"));
            for i in 0..reference.time.len() {
                assert!((ours.time[i] - reference.time[i]).abs() < 1e-9, "{case}: time {} vs {}", ours.time[i], reference.time[i]);
                let d = (ours.rows[i][k] - reference.rows[i][j]).abs();
                sum2 += d * d;
                n += 1;
                if d > worst.0 || d.is_nan() {
                    worst = (d, format!("{label} t={:.4}", reference.time[i]));
                }
                if !(d <= 0.01) {
                    failures.push(format!("{case}: activation {label} t={}: {} vs OpenSim {}", reference.time[i], ours.rows[i][k], reference.rows[i][j]));
                }
            }
        }
        let rms = (sum2 / n as f64).sqrt();
        if rms > 0.002 {
            failures.push(format!("{case}: activation RMS {rms:.2e} > 0.002"));
        }
        // Forces (actuator columns and the rest the reporter writes).
        let (of, rf) = (read(&out, "force"), read(&dir.join("results"), "force"));
        let mut worst_f = (0.0f64, String::new());
        for (j, label) in rf.labels.iter().enumerate() {
            let Some(k) = of.column_index(label) else {
                failures.push(format!("{case}: force file lacks column {label}"));
                continue;
            };
            let peak = rf.rows.iter().map(|r| r[j].abs()).fold(0.0, f64::max);
            let rows = rf.time.len().min(of.time.len());
            for i in 0..rows {
                let d = (of.rows[i][k] - rf.rows[i][j]).abs();
                let rel = d / peak.max(1e-9);
                if rel > worst_f.0 {
                    worst_f = (rel, format!("{label} t={:.4}", rf.time[i]));
                }
                if d > 0.01 * peak + 1e-9 {
                    failures.push(format!("{case}: force {label} t={}: {} vs OpenSim {} (peak {peak})", rf.time[i], of.rows[i][k], rf.rows[i][j]));
                }
            }
        }
        // Equations of motion on every frame.
        let diag = read(&out, "diagnostics");
        let (si, ri) = (diag.column_index("status").unwrap(), diag.column_index("relative_residual").unwrap());
        let worst_res = diag.rows.iter().map(|r| r[ri]).fold(0.0, f64::max);
        let failed = diag.rows.iter().filter(|r| r[si] < 0.0).count();
        if failed > 0 {
            failures.push(format!("{case}: {failed} frames not solved"));
        }
        if worst_res > 1e-6 {
            failures.push(format!("{case}: equations of motion residual {worst_res:.2e} > 1e-6 (relative)"));
        }
        println!(
            "{case}: {} frames; activations worst |diff| {:.2e} ({}), RMS {:.2e}; forces worst {:.3}% of peak ({}); EOM residual <= {:.1e} relative",
            ours.time.len(),
            worst.0,
            worst.1,
            rms,
            100.0 * worst_f.0,
            worst_f.1,
            worst_res
        );
    }
    assert!(failures.is_empty(), "{} failures, first: {:#?}", failures.len(), &failures[..failures.len().min(10)]);
}
