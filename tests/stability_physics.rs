//! Stability suite, physics and solver (issue 8): each test drives static
//! optimization to where a method fails and checks what the tool does there.
//! Expected values are closed-form optima (KKT of the small convex problems)
//! or invariants (equations of motion, friction limits, monotonicity in w0).
//! Numbers quoted in docs/failure_modes.md are printed by these tests
//! (`cargo test --test stability_physics -- --nocapture`).
//!
//! - infeasible frames: a muscle too weak for the motion (closed form per
//!   frame, with and without reserve actuators);
//! - a contact-weight sweep from 1e-6 to 1e9 (monotone objective parts);
//! - regime chattering at v_trans: the hard switch's force jump and the
//!   `<regime_blend>` option that removes it;
//! - disengaging, coincident, near-parallel and surplus contacts.

mod common;
use common::col;

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use statopt::parse::setup::Setup;
use statopt::storage::{self, Storage};
use statopt::tools::{analyze, RunOptions, RunSummary};

use common::G;

const MASS: f64 = 10.0;
/// Thelen2003Muscle's minimum activation (and min_control floor).
const A_MIN: f64 = 0.01;

/// A motion file: `names` columns, `rows` of (time, values).
fn motion(names: &[&str], rows: &[(f64, Vec<f64>)]) -> String {
    let mut s = format!(
        "motion\nversion=1\nnRows={}\nnColumns={}\ninDegrees=no\nendheader\ntime\t{}\n",
        rows.len(),
        names.len() + 1,
        names.join("\t")
    );
    for (t, q) in rows {
        s.push_str(&format!("{t:.6}"));
        for v in q {
            s.push_str(&format!("\t{v:.15}"));
        }
        s.push('\n');
    }
    s
}

/// Rows of the block's (tx, ty, tz) motion at `n` samples over [0, t_end].
fn block_rows(n: usize, t_end: f64, f: impl Fn(f64) -> [f64; 3]) -> Vec<(f64, Vec<f64>)> {
    (0..n)
        .map(|k| {
            let t = t_end * k as f64 / (n - 1) as f64;
            (t, f(t).to_vec())
        })
        .collect()
}

/// Write model, motion and an AnalyzeTool setup (SO with `so_extra`) into a
/// fresh folder and run it in-process.
fn run_case(
    name: &str,
    model: &str,
    motion_text: &str,
    t_end: f64,
    so_extra: &str,
) -> (PathBuf, RunSummary) {
    let dir = common::out_dir(&format!("stability_{name}"));
    std::fs::write(dir.join("model.osim"), model).unwrap();
    std::fs::write(dir.join("motion.mot"), motion_text).unwrap();
    let setup = format!(
        r#"<?xml version="1.0"?>
<OpenSimDocument Version="40000"><AnalyzeTool name="case">
<model_file>model.osim</model_file><results_directory>out</results_directory><output_precision>14</output_precision>
<initial_time>0</initial_time><final_time>{t_end}</final_time>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO">{so_extra}</StaticOptimization></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates>
</AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    let s = match Setup::read(&dir.join("setup.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let summary = analyze::run(&s, &RunOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    (dir, summary)
}

fn read(dir: &Path, file: &str) -> Storage {
    storage::read(&dir.join("out").join(file)).unwrap_or_else(|e| panic!("{file}: {e}"))
}

fn all_finite(t: &Storage) -> bool {
    t.rows.iter().flatten().all(|v| v.is_finite())
}

/// A floor contact on the block's origin (plane through the ground origin,
/// normal +y), with extra properties.
fn floor(name: &str, extra: &str) -> String {
    format!(
        r#"<PointOnPlaneContact name="{name}"><point_body>block</point_body><point_location>0 0 0</point_location><plane_body>ground</plane_body><plane_normal>0 1 0</plane_normal><optimal_force>100</optimal_force>{extra}</PointOnPlaneContact>"#
    )
}

// ---------------------------------------------------------------------------
// 1. Infeasible frames
// ---------------------------------------------------------------------------

/// A 10 kg block on one slider (tx) pulled along +x by one Thelen muscle from
/// a ground anchor 10 m away: with `use_muscle_physiology` off its force is
/// a · F_max along +x exactly (moment arm 1).
fn one_muscle_model(f_max: f64) -> String {
    let t = |name: &str, c: &str, ax: &str| {
        format!(
            r#"<TransformAxis name="{name}"><coordinates>{c}</coordinates><axis>{ax}</axis><LinearFunction name="function"><coefficients>1 0</coefficients></LinearFunction></TransformAxis>"#
        )
    };
    let r = |name: &str, ax: &str| {
        format!(r#"<TransformAxis name="{name}"><coordinates/><axis>{ax}</axis></TransformAxis>"#)
    };
    format!(
        r#"<OpenSimDocument Version="40000"><Model name="slider"><gravity>0 -{G} 0</gravity>
<BodySet><objects><Body name="block"><mass>{MASS}</mass><mass_center>0 0 0</mass_center><inertia>0.1 0.1 0.1 0 0 0</inertia></Body></objects></BodySet>
<JointSet><objects><CustomJoint name="slide"><socket_parent_frame>/ground</socket_parent_frame><socket_child_frame>/bodyset/block</socket_child_frame>
<coordinates><Coordinate name="tx"><range>-100 100</range></Coordinate></coordinates>
<SpatialTransform>{}{}{}{}{}{}</SpatialTransform></CustomJoint></objects></JointSet>
<ForceSet><objects><Thelen2003Muscle name="puller">
  <GeometryPath name="path"><PathPointSet><objects>
    <PathPoint name="o"><location>10 0 0</location><socket_parent_frame>/ground</socket_parent_frame></PathPoint>
    <PathPoint name="i"><location>0 0 0</location><socket_parent_frame>/bodyset/block</socket_parent_frame></PathPoint>
  </objects></PathPointSet></GeometryPath>
  <max_control>1</max_control>
  <max_isometric_force>{f_max}</max_isometric_force><optimal_fiber_length>9</optimal_fiber_length><tendon_slack_length>0.5</tendon_slack_length>
</Thelen2003Muscle></objects></ForceSet></Model></OpenSimDocument>"#,
        r("rotation1", "1 0 0"),
        r("rotation2", "0 1 0"),
        r("rotation3", "0 0 1"),
        t("translation1", "tx", "1 0 0"),
        r("translation2", "0 1 0"),
        r("translation3", "0 0 1"),
    )
}

/// The muscle (F_max = 100 N) must supply m ẍ = 10 · 20 t N, which passes
/// F_max at t = 0.5: every later frame is infeasible, and so is t = 0
/// (F_req = 0 but Thelen's activation floor is 0.01). Without reserves each
/// such frame is reported (status −1) with the elastic answer a = 1 and an
/// equation residual of exactly F_req − F_max, the run finishes (exit 0,
/// one warning) and the feasible frames are the exact a = F_req / F_max.
/// With reserves of optimal force r0 the KKT optimum of
/// min a² + x_r² s.t. F_max a + r0 x_r = F_req, 0 ≤ a ≤ 1 is
/// a = F_max F_req / (F_max² + r0²) clamped into [0.01, 1]: above
/// F_req = F_max + r0²/F_max the muscle saturates and the reserve carries
/// exactly F_req − F_max.
#[test]
fn infeasible_frames_are_reported_per_frame_and_reserves_carry_the_exact_deficit() {
    let f_max = 100.0;
    let rows: Vec<(f64, Vec<f64>)> = block_rows(21, 1.0, |t| [20.0 * t * t * t / 6.0, 0.0, 0.0])
        .into_iter()
        .map(|(t, q)| (t, vec![q[0]]))
        .collect();
    let mot = motion(&["tx"], &rows);
    let model = one_muscle_model(f_max);
    let so = "<use_muscle_physiology>false</use_muscle_physiology>";

    // Through the CLI: exit code and message.
    let (dir, summary) = run_case("infeasible", &model, &mot, 1.0, so);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("setup.xml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    // Unsolved frames: every output written, exit status 3 (it was 0).
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    // --quiet silences progress and the summary, never the failures.
    let quiet = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
        .arg(dir.join("setup.xml"))
        .arg("-q")
        .output()
        .unwrap();
    let quiet_err = String::from_utf8_lossy(&quiet.stderr);
    assert_eq!(quiet.status.code(), Some(3), "{quiet_err}");
    assert!(
        quiet_err.contains("could not solve") && quiet_err.contains("case_SO_diagnostics.sto"),
        "{quiet_err}"
    );
    assert!(!quiet_err.contains("warning:"), "{quiet_err}");
    let diag = read(&dir, "case_SO_diagnostics.sto");
    let src = read(&dir, "case_SO_GeneralizedForcesBySource.sto");
    let act = read(&dir, "case_SO_activation.sto");
    assert_eq!(diag.time.len(), 21);
    assert!(all_finite(&diag) && all_finite(&act));
    let (status, resid) = (col(&diag, "status"), col(&diag, "equation_residual"));
    let (req, a) = (col(&src, "tx_required"), col(&act, "puller"));
    let mut failed = 0;
    for i in 0..21 {
        let t = diag.time[i];
        // The spline of the cubic motion gives m ẍ to 1 % away from its ends
        // (the quintic spline's end conditions bend the first and last rows).
        assert!(
            !(2..19).contains(&i) || (req[i] - 200.0 * t).abs() < 0.01 * 200.0,
            "t={t}: required {}",
            req[i]
        );
        // The elastic answer: the activation within [0.01, 1] nearest to
        // F_req / F_max, and the rest of F_req as residual.
        let a_want = (req[i] / f_max).clamp(A_MIN, 1.0);
        let deficit = (req[i] - f_max * a_want).abs();
        if deficit > 1e-3 * f_max {
            failed += 1;
            assert_eq!(status[i], -1.0, "t={t}: infeasible frame not reported");
            assert!((a[i] - a_want).abs() < 1e-6, "t={t}: elastic a = {}", a[i]);
            assert!(
                (resid[i] - deficit).abs() < 1e-5 * f_max,
                "t={t}: residual {} vs deficit {deficit}",
                resid[i]
            );
        } else if req[i] < f_max * 0.999 && req[i] > f_max * A_MIN * 1.001 {
            assert_eq!(status[i], 0.0, "t={t}: feasible frame not solved");
            assert!((a[i] - a_want).abs() < 1e-7, "t={t}: a = {}", a[i]);
            assert!(resid[i] < 1e-6 * f_max);
        }
    }
    assert!(failed >= 10, "frames t = 0.55 ... 1.0 are infeasible");
    assert_eq!(failed, status.iter().filter(|s| **s < 0.0).count());
    let msg = summary.warnings.join("\n");
    let line = format!("failed on {failed} of 21 frames");
    assert!(msg.contains(&line), "{msg}");
    assert!(stderr.contains(&line), "{stderr}");
    assert_eq!((summary.solves, summary.failed), (21, failed));
    assert!(
        stderr.contains(&format!(
            "{} of 21 frame problems solved, {failed} failed",
            21 - failed
        )),
        "{stderr}"
    );
    assert!(
        !stderr.contains("wrote "),
        "one summary, not a line per file: {stderr}"
    );
    println!("infeasible: {failed} of 21 frames reported (status -1), residual = F_req - F_max, peak deficit {:.3} N", req[20] - f_max);

    // Reserves: expensive (r0 = 1 N) and cheap (r0 = 50 N).
    for r0 in [1.0, 50.0] {
        let (dir, summary) = run_case(
            &format!("infeasible_reserve_{r0}"),
            &model,
            &mot,
            1.0,
            &format!("{so}<reserve_actuators>{r0}</reserve_actuators>"),
        );
        let diag = read(&dir, "case_SO_diagnostics.sto");
        let force = read(&dir, "case_SO_force.sto");
        let src = read(&dir, "case_SO_GeneralizedForcesBySource.sto");
        let req = col(&src, "tx_required");
        let (muscle, reserve) = (col(&force, "puller"), col(&force, "tx_reserve"));
        let mut worst = 0.0f64;
        for i in 0..21 {
            assert_eq!(
                col(&diag, "status")[i],
                0.0,
                "r0 {r0}: frame {i} not solved"
            );
            let f = req[i];
            // x_r = (f − F_max a)/r0 leaves a 1-D convex quadratic in a: its
            // minimiser clamped into [0.01, 1].
            let a = (f_max * f / (f_max * f_max + r0 * r0)).clamp(A_MIN, 1.0);
            let (m_want, r_want) = (f_max * a, f - f_max * a);
            worst = worst
                .max((muscle[i] - m_want).abs())
                .max((reserve[i] - r_want).abs());
        }
        println!("reserves r0 = {r0} N: worst deviation from the KKT optimum {worst:.2e} N; peak reserve {:.4} N", reserve[20]);
        assert!(worst < 1e-5, "r0 {r0}: reserve split off by {worst} N");
        let (peak, _) = summary
            .reserve_peak
            .clone()
            .expect("the run reports what reserves carried");
        assert!(
            (peak - reserve[20].abs()).abs() < 1e-6 * (1.0 + peak),
            "reported {peak} vs table {}",
            reserve[20]
        );
        assert!(summary
            .report()
            .iter()
            .any(|l| l.contains("reserve actuators carried at most")));
    }
}

// ---------------------------------------------------------------------------
// 2. Contact weight sweep
// ---------------------------------------------------------------------------

/// w0 from 1e-6 to 1e9 on a block wiggling on the floor (static regime,
/// three actuators, one contact). Every frame is solved or reported; per
/// frame the activation cost a'a falls and the multiplier cost λ'λ rises with
/// w0 (for exact optima J(w) = A + L/w, optimality at w1 < w2 gives
/// (L1 − L2)(1/w1 − 1/w2) ≤ 0 and A2 ≤ A1; with ε-optimal points each
/// inequality gets 2ε, ε = the solver's relative tolerance × the objective).
/// The contact's share of the generalized forces rises towards 1.
#[test]
fn contact_weight_sweep_is_monotone_over_fifteen_decades() {
    let weights: Vec<f64> = (-6..=9).map(|e| 10f64.powi(e)).collect();
    let list = weights
        .iter()
        .map(|w| format!("{w:e}"))
        .collect::<Vec<_>>()
        .join(" ");
    let model = common::block_model(&floor("floor", ""));
    let rows = block_rows(41, 2.0, |t| {
        let w = 2.0 * std::f64::consts::PI * t;
        [
            0.01 * w.sin(),
            0.002 * (2.0 * w).sin(),
            0.005 * (2.0 * w).sin(),
        ]
    });
    let (dir, summary) = run_case(
        "w0_sweep",
        &model,
        &motion(&["tx", "ty", "tz"], &rows),
        2.0,
        &format!("<contact_weight>{list}</contact_weight>"),
    );
    let tag = |w: f64| {
        let t = format!("{w}");
        if t.len() <= 8 {
            t
        } else {
            format!("{w:e}")
        }
    };
    let mut per_w = Vec::new();
    let mut unsolved = 0;
    for &w in &weights {
        let diag = read(&dir, &format!("case_SO_w0_{}_diagnostics.sto", tag(w)));
        let act = read(&dir, &format!("case_SO_w0_{}_activation.sto", tag(w)));
        let cf = read(&dir, &format!("case_SO_w0_{}_ContactForces.sto", tag(w)));
        let src = read(
            &dir,
            &format!("case_SO_w0_{}_GeneralizedForcesBySource.sto", tag(w)),
        );
        assert!(all_finite(&act) && all_finite(&cf) && all_finite(&diag));
        let status = col(&diag, "status");
        unsolved += status.iter().filter(|s| **s < 0.0).count();
        for i in 0..diag.time.len() {
            if status[i] >= 0.0 {
                assert!(col(&diag, "relative_residual")[i] < 1e-6, "w0 {w}: EOM");
                assert!(
                    col(&diag, "friction_violation")[i] < 1e-6,
                    "w0 {w}: friction"
                );
            }
        }
        let a_cost: Vec<f64> = act
            .rows
            .iter()
            .map(|r| r.iter().map(|x| x * x).sum())
            .collect();
        let l_cost: Vec<f64> = (0..cf.time.len())
            .map(|i| {
                ["lambda_n", "lambda_s1", "lambda_s2"]
                    .iter()
                    .map(|s| col(&cf, &format!("floor_{s}"))[i].powi(2))
                    .sum()
            })
            .collect();
        let (mut c, mut r) = (0.0, 0.0);
        for ax in ["tx", "ty", "tz"] {
            c += col(&src, &format!("{ax}_contacts"))
                .iter()
                .map(|v| v.abs())
                .sum::<f64>();
            r += col(&src, &format!("{ax}_required"))
                .iter()
                .map(|v| v.abs())
                .sum::<f64>();
        }
        let objective = col(&diag, "objective");
        per_w.push((w, status, a_cost, l_cost, c / r, objective));
    }
    assert_eq!(
        unsolved, 0,
        "frames not solved in the sweep (would be reported in diagnostics and warnings: {:?})",
        summary.warnings
    );
    println!("w0 sweep: w0 | mean a'a | mean l'l | contact share of |generalized force|");
    for (w, _, a, l, share, _) in &per_w {
        let n = a.len() as f64;
        println!(
            "  {w:8.0e} | {:.6e} | {:.6e} | {share:.9}",
            a.iter().sum::<f64>() / n,
            l.iter().sum::<f64>() / n
        );
    }
    let tol = 1e-8; // Clarabel's relative gap/feasibility tolerance (DEFAULT_TOLERANCE)
    let mut worst_a: f64 = 0.0;
    let mut worst_l: f64 = 0.0;
    for pair in per_w.windows(2) {
        let (w1, _, a1, l1, s1, j1) = &pair[0];
        let (w2, _, a2, l2, s2, j2) = &pair[1];
        for i in 0..a1.len() {
            let eps = 2.0 * tol * (1.0 + j1[i].abs() + j2[i].abs()) * 10.0;
            worst_a = worst_a.max(a2[i] - a1[i]);
            assert!(
                a2[i] <= a1[i] + eps,
                "a'a rises from w0 {w1} to {w2} at frame {i}: {} -> {}",
                a1[i],
                a2[i]
            );
            let eps_l = eps / (1.0 / w1 - 1.0 / w2);
            worst_l = worst_l.max(l1[i] - l2[i]);
            assert!(
                l2[i] >= l1[i] - eps_l,
                "l'l falls from w0 {w1} to {w2} at frame {i}: {} -> {}",
                l1[i],
                l2[i]
            );
        }
        assert!(
            s2 >= &(s1 - 1e-7),
            "contact share falls from w0 {w1} to {w2}: {s1} -> {s2}"
        );
    }
    println!(
        "largest rise of a'a between neighbours {worst_a:.2e}, largest fall of l'l {worst_l:.2e}"
    );
    let (first, last) = (&per_w[0], &per_w[per_w.len() - 1]);
    assert!(first.4 < 1e-3, "w0 1e-6: contacts carry {}", first.4);
    assert!(
        last.4 > 1.0 - 1e-3,
        "w0 1e9: contacts carry only {}",
        last.4
    );
}

// ---------------------------------------------------------------------------
// 3. Regime chattering and the regime blend
// ---------------------------------------------------------------------------

const MU_S: f64 = 0.8;
const MU_K: f64 = 0.5;
const V_TRANS: f64 = 0.1;

/// The block sliding along x at v(t) = 0.1 + 0.05 sin(2π (t − 0.123)) m/s: its slip
/// speed crosses v_trans four times in 2 s.
fn chatter_run(name: &str, blend: f64, n: usize) -> (Storage, Storage, Storage, Storage) {
    let contact = floor(
        "floor",
        &format!("<static_friction>{MU_S}</static_friction><kinetic_friction>{MU_K}</kinetic_friction><v_trans>{V_TRANS}</v_trans><regime_blend>{blend}</regime_blend>"),
    );
    let model = common::block_model(&contact);
    let w = 2.0 * std::f64::consts::PI;
    // Phase 0.123 s keeps the four crossings off the frame grid.
    let rows = block_rows(n, 2.0, |t| {
        [0.1 * t - 0.05 / w * (w * (t - 0.123)).cos(), 0.0, 0.0]
    });
    let (dir, _) = run_case(
        name,
        &model,
        &motion(&["tx", "ty", "tz"], &rows),
        2.0,
        "<contact_weight>1000</contact_weight>",
    );
    (
        read(&dir, "case_SO_diagnostics.sto"),
        read(&dir, "case_SO_force.sto"),
        read(&dir, "case_SO_ContactForces.sto"),
        read(&dir, "case_SO_GeneralizedForcesBySource.sto"),
    )
}

fn smoothstep(s: f64, h: f64) -> f64 {
    let x = ((s - V_TRANS + h / 2.0) / h).clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// The hard switch (the paper) makes the pushing force and the friction jump
/// by about μk N between consecutive frames wherever the slip speed crosses
/// v_trans. With `<regime_blend>` h = 0.08 m/s: the regime column is the
/// smoothstep β of the slip speed; frames with β = 0 or β = 1 equal the hard
/// switch's static or kinetic answer exactly; the friction limit
/// ‖λs‖ ≤ (1 − β) μs λn holds; and every frame-to-frame change of the push
/// force is within the Lipschitz bound (μs + μk) N |Δβ| + |ΔF_req| (the
/// kinetic shear βμkN and the static limit (1 − β)μsN both move by at most
/// that), so the jumps shrink with the frame step.
#[test]
fn regime_blend_removes_the_force_jump_of_the_hard_switch() {
    let h = 0.08;
    let n_normal = MASS * G;
    let mut summary = Vec::new();
    for n in [201, 401] {
        let (d_hard, f_hard, c_hard, _) = chatter_run(&format!("chatter_hard_{n}"), 0.0, n);
        let (d_soft, f_soft, c_soft, s_soft) = chatter_run(&format!("chatter_blend_{n}"), h, n);
        for d in [&d_hard, &d_soft] {
            assert!(
                col(d, "status").iter().all(|s| *s == 0.0),
                "unsolved frames"
            );
            assert!(col(d, "relative_residual").iter().all(|r| *r < 1e-6));
            assert!(col(d, "friction_violation").iter().all(|r| *r < 1e-6));
        }
        let slip = col(&c_soft, "floor_slip_speed");
        let beta = col(&c_soft, "floor_regime");
        let hard_regime = col(&c_hard, "floor_regime");
        let (push_h, push_s) = (col(&f_hard, "push"), col(&f_soft, "push"));
        let req = col(&s_soft, "tx_required");
        let mut switches = 0;
        let (mut jump_hard, mut jump_soft) = (0.0f64, 0.0f64);
        let mut blended = 0;
        for i in 0..slip.len() {
            assert!(
                (beta[i] - smoothstep(slip[i], h)).abs() < 1e-12,
                "beta at frame {i}"
            );
            assert_eq!(hard_regime[i], if slip[i] > V_TRANS { 1.0 } else { 0.0 });
            if beta[i] == 0.0 || beta[i] == 1.0 {
                // Identical problem, identical answer.
                for c in ["push", "lift", "side"] {
                    assert!(
                        (col(&f_hard, c)[i] - col(&f_soft, c)[i]).abs() < 1e-9,
                        "beta {}: {c} differs from the hard switch at frame {i}",
                        beta[i]
                    );
                }
            } else {
                blended += 1;
            }
            if i > 0 {
                if hard_regime[i] != hard_regime[i - 1] {
                    switches += 1;
                    jump_hard = jump_hard.max((push_h[i] - push_h[i - 1]).abs());
                }
                let d = (push_s[i] - push_s[i - 1]).abs();
                jump_soft = jump_soft.max(d);
                let bound = (MU_S + MU_K) * n_normal * (beta[i] - beta[i - 1]).abs()
                    + (req[i] - req[i - 1]).abs();
                assert!(
                    d <= 1.01 * bound + 1e-6,
                    "n {n}: push jumps {d} N between frames {} and {i}, bound {bound}",
                    i - 1
                );
            }
        }
        assert_eq!(switches, 4, "the slip speed crosses v_trans four times");
        assert!(blended >= 8, "only {blended} frames inside the blend");
        summary.push((n, jump_hard, jump_soft));
        println!("chattering, {n} frames (dt = {:.4} s): hard switch max push jump {jump_hard:.3} N (mu_k N = {:.3} N); blend h = {h} m/s: max jump {jump_soft:.3} N",
            2.0 / (n - 1) as f64, MU_K * n_normal);
        assert!(
            jump_hard > 0.8 * MU_K * n_normal,
            "the hard switch should jump by about mu_k N"
        );
        assert!(
            jump_soft < 0.25 * jump_hard,
            "the blend should remove the jump"
        );
    }
    // The hard jump stays, the blended one halves with the frame step.
    let (h1, s1) = (summary[0].1, summary[0].2);
    let (h2, s2) = (summary[1].1, summary[1].2);
    assert!(h2 > 0.8 * h1, "hard jump {h1} -> {h2}");
    assert!(
        s2 < 0.65 * s1,
        "blended jump {s1} -> {s2} does not shrink with dt"
    );
}

/// A `regime_blend` outside [0, 2 v_trans] is refused with a clear message.
#[test]
fn regime_blend_out_of_range_is_an_input_error() {
    for bad in ["-0.01", "0.25", "nan"] {
        let dir = common::out_dir(&format!("stability_blend_bad_{}", bad.replace('.', "_")));
        let model = common::block_model(&floor(
            "floor",
            &format!("<regime_blend>{bad}</regime_blend>"),
        ));
        std::fs::write(dir.join("model.osim"), model).unwrap();
        let rows = block_rows(3, 1.0, |_| [0.0; 3]);
        std::fs::write(dir.join("motion.mot"), motion(&["tx", "ty", "tz"], &rows)).unwrap();
        std::fs::write(dir.join("setup.xml"), format!(r#"<OpenSimDocument Version="40000"><AnalyzeTool name="case"><model_file>model.osim</model_file><results_directory>out</results_directory><initial_time>0</initial_time><final_time>1</final_time><AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet><coordinates_file>motion.mot</coordinates_file></AnalyzeTool></OpenSimDocument>"#)).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_statopt-tool"))
            .arg(dir.join("setup.xml"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {err}");
        assert!(
            err.contains("regime_blend") && err.contains("model.osim") && err.contains("line"),
            "{bad}: {err}"
        );
    }
}

// ---------------------------------------------------------------------------
// 5. Degenerate contact sets
// ---------------------------------------------------------------------------

/// Checks shared by the degenerate cases: finite tables, every frame solved,
/// equations of motion and friction limits met.
fn assert_clean(dir: &Path, what: &str) -> (Storage, Storage, Storage) {
    let diag = read(dir, "case_SO_diagnostics.sto");
    let act = read(dir, "case_SO_activation.sto");
    let cf = read(dir, "case_SO_ContactForces.sto");
    assert!(
        all_finite(&diag) && all_finite(&act) && all_finite(&cf),
        "{what}: NaN"
    );
    for (i, t) in diag.time.iter().enumerate() {
        assert_eq!(col(&diag, "status")[i], 0.0, "{what} t={t}: not solved");
        assert!(
            col(&diag, "relative_residual")[i] < 1e-6,
            "{what} t={t}: EOM residual"
        );
        assert!(
            col(&diag, "friction_violation")[i] < 1e-6,
            "{what} t={t}: friction"
        );
    }
    (diag, act, cf)
}

/// A contact that lifts off mid-motion (the block rises 30 mm, w(d) → 0):
/// the weight falls smoothly to exactly 0, the contact force with it, and
/// the lift actuator takes over m (g + ÿ) with no NaN and no failed frame.
#[test]
fn contact_disengaging_mid_motion_hands_the_load_over() {
    let model = common::block_model(&floor(
        "floor",
        "<contact_tolerance>0.002</contact_tolerance><contact_transition_zone>0.01</contact_transition_zone>",
    ));
    // ty: 0 until t = 0.5, a smooth (minimum-jerk) rise of 30 mm until t = 1.5.
    let rows = block_rows(41, 2.0, |t| {
        let s = ((t - 0.5) / 1.0).clamp(0.0, 1.0);
        [0.0, 0.03 * s * s * s * (10.0 - 15.0 * s + 6.0 * s * s), 0.0]
    });
    let (dir, _) = run_case(
        "disengage",
        &model,
        &motion(&["tx", "ty", "tz"], &rows),
        2.0,
        "<contact_weight>1000</contact_weight>",
    );
    let (_, act, cf) = assert_clean(&dir, "disengage");
    let src = read(&dir, "case_SO_GeneralizedForcesBySource.sto");
    let w = col(&cf, "floor_weight");
    let fy = col(&cf, "floor_fy");
    let req = col(&src, "ty_required");
    let lift = col(&act, "lift");
    assert!(w[0] > 0.99 && *w.last().unwrap() == 0.0);
    assert!(
        w.iter().any(|x| *x > 0.01 && *x < 0.99),
        "no frame in the transition zone"
    );
    for i in 0..w.len() {
        if w[i] == 0.0 {
            assert_eq!(fy[i], 0.0);
            assert!((lift[i] * 100.0 - req[i]).abs() < 1e-6 * req[i].abs().max(1.0));
        }
        // Vertical balance: contact + lift = requirement.
        assert!((fy[i] + lift[i] * 100.0 - req[i]).abs() < 1e-6 * MASS * G);
    }
}

/// n contacts on a block that can only translate have identical generalized
/// force columns, so the equations cannot tell them apart; the strictly
/// convex objective does: each carries the same normal multiplier, the
/// min-norm split. Held still, min a² + n λ²/w0 s.t. 100 a + n 100 λ = m g
/// gives a = m g / (100 (1 + n w0)) and λ = w0 a. Covers two coincident
/// contacts (same point, same plane) and more contacts (5, 15 multipliers)
/// than degrees of freedom (3).
#[test]
fn coincident_and_surplus_contacts_share_the_load_equally() {
    let w0 = 10.0;
    for (what, points) in [
        ("coincident", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        (
            "surplus",
            vec![
                [0.1, 0.0, 0.1],
                [-0.1, 0.0, 0.1],
                [0.1, 0.0, -0.1],
                [-0.1, 0.0, -0.1],
                [0.0, 0.0, 0.0],
            ],
        ),
    ] {
        let contacts: String = points
            .iter()
            .enumerate()
            .map(|(k, p)| {
                floor(&format!("c{k}"), "").replace(
                    "<point_location>0 0 0</point_location>",
                    &format!(
                        "<point_location>{} {} {}</point_location>",
                        p[0], p[1], p[2]
                    ),
                )
            })
            .collect();
        let model = common::block_model(&contacts);
        let rows = block_rows(6, 1.0, |_| [0.0; 3]);
        let (dir, _) = run_case(
            what,
            &model,
            &motion(&["tx", "ty", "tz"], &rows),
            1.0,
            &format!("<contact_weight>{w0}</contact_weight>"),
        );
        let (_, act, cf) = assert_clean(&dir, what);
        let n = points.len() as f64;
        let a_want = MASS * G / (100.0 * (1.0 + n * w0));
        for i in 0..act.time.len() {
            assert!(
                (col(&act, "lift")[i] - a_want).abs() < 1e-7,
                "{what}: lift {}",
                col(&act, "lift")[i]
            );
            for k in 0..points.len() {
                let l = col(&cf, &format!("c{k}_lambda_n"))[i];
                assert!(
                    (l - w0 * a_want).abs() < 1e-6,
                    "{what}: c{k} lambda_n {l} vs {}",
                    w0 * a_want
                );
                for s in ["s1", "s2"] {
                    assert!(col(&cf, &format!("c{k}_lambda_{s}"))[i].abs() < 1e-7);
                }
            }
        }
        println!(
            "{what}: {} contacts, lambda_n = {:.6} each (closed form {:.6})",
            points.len(),
            col(&cf, "c0_lambda_n")[0],
            w0 * a_want
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, failure_persistence: None, ..ProptestConfig::default() })]

    /// Two contacts on nearly the same plane (normals tilted by up to 1e-3
    /// rad, down to 1e-12) at nearly the same point, on a block sliding
    /// slowly: no NaN, every frame solved, equations of motion and friction
    /// limits met, the vertical load fully balanced, and the two normal
    /// multipliers nearly equal (the split moves continuously from the
    /// coincident case's equal split).
    #[test]
    fn near_parallel_contact_planes_give_a_defined_split(
        log_tilt in -12.0f64..-3.0,
        dx in 0.0f64..1e-3,
        friction in prop_oneof![Just("cone"), Just("pyramid")],
    ) {
        let tilt = 10f64.powf(log_tilt);
        let c0 = floor("c0", "");
        let c1 = floor("c1", "")
            .replace("<point_location>0 0 0</point_location>", &format!("<point_location>{dx} 0 0</point_location>"))
            .replace("<plane_normal>0 1 0</plane_normal>", &format!("<plane_normal>{} {} 0</plane_normal>", -tilt.sin(), tilt.cos()));
        let model = common::block_model(&(c0 + &c1));
        let rows = block_rows(11, 1.0, |t| [0.02 * t * t, 0.0, 0.0]);
        let (dir, _) = run_case(
            "near_parallel",
            &model,
            &motion(&["tx", "ty", "tz"], &rows),
            1.0,
            &format!("<contact_weight>1000</contact_weight><friction_cone>{friction}</friction_cone>"),
        );
        let (_, act, cf) = assert_clean(&dir, "near parallel");
        for i in 0..act.time.len() {
            let fy = col(&cf, "c0_fy")[i] + col(&cf, "c1_fy")[i];
            prop_assert!((fy + col(&act, "lift")[i] * 100.0 - MASS * G).abs() < 1e-6 * MASS * G);
            let (l0, l1) = (col(&cf, "c0_lambda_n")[i], col(&cf, "c1_lambda_n")[i]);
            prop_assert!((l0 - l1).abs() < 1e-3 * (l0 + l1), "split {l0} / {l1} at tilt {tilt}");
        }
    }
}
