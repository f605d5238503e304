//! Static optimization behaviour beyond matching OpenSim: results identical
//! for any thread count; frames that cannot be solved are reported and the run
//! goes on; optional reserve actuators solve every frame and say how much
//! they carried.

mod common;

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, RunOptions};

/// arm26's SO setup, written to `out` with absolute paths, the muscles'
/// max_isometric_force scaled by `strength` and extra StaticOptimization
/// properties inserted.
fn arm26_setup(root: &Path, out: &Path, strength: f64, extra: &str) -> PathBuf {
    let dir = root.join("arm26");
    let model = std::fs::read_to_string(dir.join("inputs/arm26.osim")).unwrap();
    let mut scaled = String::new();
    for line in model.lines() {
        if let (Some(a), Some(b)) = (
            line.find("<max_isometric_force>"),
            line.find("</max_isometric_force>"),
        ) {
            let v: f64 = line[a + 21..b].trim().parse().unwrap();
            scaled.push_str(&format!(
                "{}<max_isometric_force>{}</max_isometric_force>{}\n",
                &line[..a],
                v * strength,
                &line[b + 22..]
            ));
        } else {
            scaled.push_str(line);
            scaled.push('\n');
        }
    }
    std::fs::write(out.join("arm26_scaled.osim"), scaled).unwrap();
    let setup = std::fs::read_to_string(dir.join("setup_SO.xml")).unwrap();
    let setup = setup
        .replace(
            "<model_file>inputs/arm26.osim</model_file>",
            &format!(
                "<model_file>{}</model_file>",
                out.join("arm26_scaled.osim").display()
            ),
        )
        .replace(">inputs/", &format!(">{}/inputs/", dir.display()))
        .replace(
            "<use_muscle_physiology>true</use_muscle_physiology>",
            &format!("<use_muscle_physiology>true</use_muscle_physiology>{extra}"),
        );
    let p = out.join("setup_SO.xml");
    std::fs::write(&p, setup).unwrap();
    p
}

fn run(setup: &Path, out: &Path, threads: Option<usize>) -> statopt::tools::RunSummary {
    let s = match Setup::read(setup).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    analyze::run(
        &s,
        &RunOptions {
            results_dir: Some(out.to_path_buf()),
            threads,
            ..Default::default()
        },
    )
    .unwrap()
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let Some(root) = common::validation_dir("results_do_not_depend_on_thread_count") else {
        return;
    };
    let out = common::out_dir("so_threads");
    let setup = arm26_setup(&root, &out, 1.0, "");
    let mut files = Vec::new();
    let mut diagnostics = Vec::new();
    for threads in [1, 2] {
        let o = out.join(format!("t{threads}"));
        run(&setup, &o, Some(threads));
        files.push(std::fs::read(o.join("arm26_StaticOptimization_activation.sto")).unwrap());
        // Every column but the solve time: the Newton iterations show
        // which frames were warm-started, and from which frame.
        let t = storage::read(&o.join("arm26_StaticOptimization_diagnostics.sto")).unwrap();
        let j = t.column_index("solve_time_ms").unwrap();
        let rows: Vec<Vec<f64>> = t
            .rows
            .iter()
            .map(|r| {
                r.iter()
                    .enumerate()
                    .filter(|e| e.0 != j)
                    .map(|e| *e.1)
                    .collect()
            })
            .collect();
        diagnostics.push((t.time.clone(), rows));
    }
    assert!(
        files[0] == files[1],
        "activation files differ between 1 and 2 threads"
    );
    assert!(
        diagnostics[0] == diagnostics[1],
        "diagnostics differ between 1 and 2 threads"
    );
    // Frames beyond the first group, so warm-started frames took part.
    assert!(diagnostics[0].0.len() > 2 * statopt::frame::driver::GROUP);
}

#[test]
fn weak_muscles_fail_frames_are_reported_and_reserves_carry_the_deficit() {
    let Some(root) = common::validation_dir(
        "weak_muscles_fail_frames_are_reported_and_reserves_carry_the_deficit",
    ) else {
        return;
    };
    let out = common::out_dir("so_weak");
    // 2% strength: the elbow flexors cannot hold the forearm late in the motion.
    let setup = arm26_setup(&root, &out, 0.02, "");
    let s = run(&setup, &out, None);
    let diag = storage::read(&out.join("arm26_StaticOptimization_diagnostics.sto")).unwrap();
    let si = diag.column_index("status").unwrap();
    let failed = diag.rows.iter().filter(|r| r[si] < 0.0).count();
    assert!(failed > 0, "expected failed frames at 2% strength");
    // Infeasible frames are handed to Clarabel (solver 1), which certifies
    // them; the others are Newton's (solver 0).
    let vi = diag.column_index("solver").unwrap();
    for r in &diag.rows {
        assert_eq!(r[vi], if r[si] < 0.0 { 1.0 } else { 0.0 }, "{r:?}");
    }
    assert_eq!(diag.time.len(), 121, "every frame has a row, failed or not");
    let act = storage::read(&out.join("arm26_StaticOptimization_activation.sto")).unwrap();
    assert_eq!(act.time.len(), 121);
    assert!(
        act.rows.iter().flatten().all(|v| v.is_finite()),
        "no NaN in activations of failed frames"
    );
    let msg = s.warnings.join("\n");
    assert!(
        msg.contains(&format!("failed on {failed} of 121 frames")),
        "{msg}"
    );

    // With reserves every frame solves, and the reserves carry what muscles cannot.
    let out2 = common::out_dir("so_weak_reserves");
    let setup = arm26_setup(
        &root,
        &out2,
        0.02,
        "<reserve_actuators>1</reserve_actuators>",
    );
    let s = run(&setup, &out2, None);
    let diag = storage::read(&out2.join("arm26_StaticOptimization_diagnostics.sto")).unwrap();
    assert!(
        diag.rows.iter().all(|r| r[si] >= 0.0),
        "all frames solved with reserves"
    );
    let forces = storage::read(&out2.join("arm26_StaticOptimization_force.sto")).unwrap();
    let ri = forces
        .column_index("r_elbow_flex_reserve")
        .expect("reserve column");
    let peak = forces.rows.iter().map(|r| r[ri].abs()).fold(0.0, f64::max);
    assert!(peak > 0.1, "the elbow reserve carried {peak} N m");
    // The summary reports the largest |force| of any reserve column.
    let all_reserves = forces
        .labels
        .iter()
        .enumerate()
        .filter(|(_, l)| l.ends_with("_reserve"))
        .flat_map(|(j, _)| forces.rows.iter().map(move |r| r[j].abs()))
        .fold(0.0, f64::max);
    let (reported, _) = s
        .reserve_peak
        .clone()
        .expect("the run reports what reserves carried");
    assert!(
        (reported - all_reserves).abs() < 1e-6 * (1.0 + all_reserves),
        "reported {reported} vs table {all_reserves}"
    );
    assert_eq!((s.solves, s.failed), (121, 0));
}

/// `<solver>`: by default (auto) the dual Newton solver answers every arm26
/// frame (diagnostics column `solver` 0); with `<solver>clarabel</solver>`
/// Clarabel answers every frame (1), and the activations agree to
/// Clarabel's accuracy at its default tolerance.
#[test]
fn solver_choice_is_honoured_and_reported() {
    let Some(root) = common::validation_dir("solver_choice_is_honoured_and_reported") else {
        return;
    };
    let mut tables = Vec::new();
    for (choice, code) in [
        ("", 0.0),
        ("<solver>newton</solver>", 0.0),
        ("<solver>Clarabel</solver>", 1.0),
    ] {
        let out = common::out_dir(&format!("so_solver_{code}_{}", choice.len()));
        let setup = arm26_setup(&root, &out, 1.0, choice);
        run(&setup, &out, None);
        let diag = storage::read(&out.join("arm26_StaticOptimization_diagnostics.sto")).unwrap();
        let vi = diag.column_index("solver").unwrap();
        assert!(
            diag.rows.iter().all(|r| r[vi] == code),
            "{choice}: solver column"
        );
        tables.push(storage::read(&out.join("arm26_StaticOptimization_activation.sto")).unwrap());
    }
    let worst = tables[0]
        .rows
        .iter()
        .zip(&tables[2].rows)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0, f64::max);
    assert!(
        tables[0].rows == tables[1].rows,
        "auto and newton are the same"
    );
    assert!(worst < 1e-5, "Newton vs Clarabel: {worst:e}");
    println!("arm26 activations, Newton vs Clarabel (default tolerance): {worst:.2e}");
}
