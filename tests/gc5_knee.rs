//! The GC5 walking trial with an instrumented knee (../shared/models/knee_gc5,
//! trial ss1; prints SKIP when absent):
//!
//! - statopt's JointReaction of walker_knee_l against OpenSim 4.6's, fed
//!   statopt's forces, on the motion with its knee_angle_*_beta columns in
//!   radians (tests/data/gc5_ss1_jr_opensim46.sto, made by
//!   tests/reference_scripts/gc5_joint_reaction_reference.py): within 1 % of
//!   each force and moment column's peak at every frame;
//! - the knee contact method (docs/knee_contact.md) against the eTibia's
//!   measured force, with its consistency checks.

mod common;

use std::path::{Path, PathBuf};

use statopt::parse::setup::Setup;
use statopt::storage;
use statopt::tools::{analyze, knee_contact, RunOptions};

fn gc5_dir(test: &str) -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/models/knee_gc5");
    if d.join("setup_ss1.xml").is_file() {
        Some(d)
    } else {
        eprintln!("SKIP {test}: ../shared/models/knee_gc5 is absent");
        None
    }
}

/// GC5_ss1.mot with the *_beta columns converted from degrees to radians
/// (the file stays a degrees file: Coupled coordinates' columns are not
/// converted, by OpenSim or statopt).
fn radian_motion(src: &Path, dst: &Path) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut out = String::new();
    let mut beta: Vec<usize> = Vec::new();
    let mut in_data = false;
    for line in text.lines() {
        if in_data {
            let mut v: Vec<String> = line.split_whitespace().map(String::from).collect();
            for &i in &beta {
                let x = v[i].parse::<f64>().unwrap();
                v[i] = format!("{:.12}", x.to_radians());
            }
            out.push_str(&v.join("\t"));
        } else if line.starts_with("time") {
            beta = line
                .split('\t')
                .enumerate()
                .filter(|(_, l)| l.ends_with("_beta"))
                .map(|(i, _)| i)
                .collect();
            assert_eq!(beta.len(), 2, "two beta columns");
            out.push_str(line);
            in_data = true;
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    std::fs::write(dst, out).unwrap();
}

#[test]
fn joint_reaction_matches_opensim_with_beta_columns_in_radians() {
    let Some(dir) = gc5_dir("joint_reaction_matches_opensim_with_beta_columns_in_radians") else {
        return;
    };
    let out = common::out_dir("gc5_jr_radians");
    let motion = out.join("GC5_ss1_beta_radians.mot");
    radian_motion(&dir.join("GC5_ss1.mot"), &motion);
    let mut setup = match Setup::read(&dir.join("setup_ss1.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    setup.coordinates_file = Some(motion);
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        precision: Some(12),
        verbose: false,
        ..Default::default()
    };
    let summary = analyze::run(&setup, &opts).unwrap();
    assert!(
        !summary
            .warnings
            .iter()
            .any(|w| w.contains("dependent coordinate")),
        "the radian columns agree with the couplers: {:?}",
        summary.warnings
    );
    let ours = storage::read(&out.join("GC5_ss1_JR_ReactionLoads.sto")).unwrap();
    let reference = storage::read(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/gc5_ss1_jr_opensim46.sto"),
    )
    .unwrap();
    assert_eq!(reference.labels.len(), 6, "fx fy fz mx my mz");
    let errors = common::compare(&ours, &reference);
    let mut failures = Vec::new();
    for e in &errors {
        println!(
            "{}: max |diff| {:.4} ({:.4} % of the peak {:.1}) at t = {:.4}",
            e.label,
            e.max_abs,
            100.0 * e.max_abs / e.peak,
            e.peak,
            e.worst_time
        );
        if !(e.max_abs <= 0.01 * e.peak) {
            failures.push(e.label.clone());
        }
    }
    assert!(failures.is_empty(), "beyond 1 % of the peak: {failures:?}");
}

/// The eTibia's gait cycle (percent, medial, lateral, total; N).
fn etibia(dir: &Path) -> Vec<[f64; 4]> {
    std::fs::read_to_string(dir.join("eTibia_GC5_ss1.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

/// `y(t)` linearly interpolated at `p` percent of [t0, t1].
fn at_percent(time: &[f64], y: &[f64], p: f64) -> f64 {
    let (t0, t1) = (time[0], time[time.len() - 1]);
    let t = t0 + p / 100.0 * (t1 - t0);
    let i = time.partition_point(|&x| x <= t).clamp(1, time.len() - 1);
    let w = (t - time[i - 1]) / (time[i] - time[i - 1]);
    y[i - 1] + w * (y[i] - y[i - 1])
}

/// RMSE and the two peaks' errors (max over 0–50 %, max over 40–80 %), in BW.
pub struct Agreement {
    pub rmse: f64,
    pub peak1: (f64, f64),
    pub peak2: (f64, f64),
}

fn agreement(time: &[f64], y: &[f64], measured: &[(f64, f64)], bw: f64) -> Agreement {
    let ours: Vec<f64> = measured
        .iter()
        .map(|(p, _)| at_percent(time, y, *p))
        .collect();
    let n = measured.len() as f64;
    let rmse = (ours
        .iter()
        .zip(measured)
        .map(|(a, (_, m))| (a - m).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
        / bw;
    let peak = |lo: f64, hi: f64, v: &dyn Fn(usize) -> f64| {
        (0..measured.len())
            .filter(|&i| measured[i].0 >= lo && measured[i].0 <= hi)
            .map(v)
            .fold(f64::NEG_INFINITY, f64::max)
            / bw
    };
    Agreement {
        rmse,
        peak1: (
            peak(0.0, 50.0, &|i| ours[i]),
            peak(0.0, 50.0, &|i| measured[i].1),
        ),
        peak2: (
            peak(40.0, 80.0, &|i| ours[i]),
            peak(40.0, 80.0, &|i| measured[i].1),
        ),
    }
}

#[test]
fn knee_contact_on_ss1_against_the_etibia() {
    let Some(dir) = gc5_dir("knee_contact_on_ss1_against_the_etibia") else {
        return;
    };
    let out = common::out_dir("gc5_knee_contact");
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        precision: Some(10),
        verbose: false,
        ..Default::default()
    };
    let summary = knee_contact::run(&dir.join("setup_ss1.xml"), &[], &opts).unwrap();
    assert_eq!(summary.failed, 0, "every frame solved");
    let t = storage::read(&out.join("GC5_ss1_KneeContact.sto")).unwrap();
    // Both knees, every frame of the setup's range (0 to 1.0917 s at 120 Hz).
    assert_eq!(t.time.len(), 132);
    for side in ["l", "r"] {
        for c in ["flexion_deg", "total_N", "medial_N", "lateral_N"] {
            assert!(t.column_index(&format!("walker_knee_{side}_{c}")).is_some());
        }
    }
    assert!(summary
        .files
        .iter()
        .any(|f| f.to_string_lossy().ends_with("GC5_ss1_KneeContact.png")));
    let col = |l: &str| -> Vec<f64> {
        let j = t.column_index(l).unwrap();
        t.rows.iter().map(|r| r[j]).collect()
    };
    let (total, medial, lateral) = (
        col("walker_knee_l_total_N"),
        col("walker_knee_l_medial_N"),
        col("walker_knee_l_lateral_N"),
    );
    // The compartments only push, and they carry the axial part of the total.
    for i in 0..t.time.len() {
        assert!(
            medial[i] >= -1e-3 && lateral[i] >= -1e-3,
            "t = {}",
            t.time[i]
        );
        assert!(
            medial[i] + lateral[i] <= total[i] + 1e-3,
            "t = {}",
            t.time[i]
        );
    }
    let (_, model) =
        statopt::model::load::load_model(&dir.join("Rajagopal2015-scaled.osim")).unwrap();
    let bw = model.bodies.iter().map(|b| b.mass).sum::<f64>() * common::G;
    let e = etibia(&dir);
    let pick = |k: usize| -> Vec<(f64, f64)> { e.iter().map(|r| (r[0], r[k])).collect() };
    let a = agreement(&t.time, &total, &pick(3), bw);
    let m = agreement(&t.time, &medial, &pick(1), bw);
    let l = agreement(&t.time, &lateral, &pick(2), bw);
    println!(
        "knee contact, walker_knee_l vs eTibia (BW = {bw:.1} N): total RMSE {:.3} BW, first peak {:.3} vs {:.3} BW, second peak {:.3} vs {:.3} BW; medial RMSE {:.3} BW, lateral RMSE {:.3} BW",
        a.rmse, a.peak1.0, a.peak1.1, a.peak2.0, a.peak2.1, m.rmse, l.rmse
    );
    // Issue 29's bar: RMSE <= 0.5 BW and both peaks within 0.5 BW of the
    // eTibia's; medial and lateral RMSE <= 0.4 BW (reported there, held here).
    // The method with its defaults (the knee's capacity 3.46 BW, from
    // Kutzner et al. 2010, 65 % of it medial; the gastrocnemius heads at one
    // activation; not from this trial) measured RMSE 0.306 BW, peaks 2.15
    // and 2.16 BW (eTibia 2.19, 2.09), medial 0.27, lateral 0.28 BW (with
    // equal compartments and free heads: 0.29, 2.22, 2.18, 0.24, 0.27);
    // OpenSim's static optimization gives 0.91 BW and 4.26 BW.
    assert!(a.rmse <= 0.5, "total RMSE {:.3} BW", a.rmse);
    assert!(
        (a.peak1.0 - a.peak1.1).abs() <= 0.5,
        "first peak {:.3} vs {:.3} BW",
        a.peak1.0,
        a.peak1.1
    );
    assert!(
        (a.peak2.0 - a.peak2.1).abs() <= 0.5,
        "second peak {:.3} vs {:.3} BW",
        a.peak2.0,
        a.peak2.1
    );
    assert!(
        m.rmse <= 0.4 && l.rmse <= 0.4,
        "medial {:.3}, lateral {:.3} BW",
        m.rmse,
        l.rmse
    );
}

/// The compartment capacity is a parameter of the setup: a StaticOptimization's
/// `<knee_contact_capacity>` (body weights) sets it. A smaller capacity makes
/// compression dearer: in min f(a) + c·g(L) the optimal g(L) does not grow
/// with c, so at every frame g = Σ (L / s)² over the compartments (s: the
/// compartment's share of the knee's capacity, 0.65 medial and 0.35
/// lateral by default) does not grow as the capacity falls. With a capacity far above any load, the
/// method tends to OpenSim's static optimization.
#[test]
fn knee_contact_capacity_orders_the_knee_force() {
    use statopt::parse::setup::Analysis;
    let Some(dir) = gc5_dir("knee_contact_capacity_orders_the_knee_force") else {
        return;
    };
    let loads = |cap: &str, tag: &str| -> (Vec<f64>, f64) {
        let mut setup = match Setup::read(&dir.join("setup_ss1.xml")).unwrap() {
            Setup::Analyze(s) => s,
            _ => unreachable!(),
        };
        setup.final_time = 0.6;
        for a in setup.analyses.iter_mut() {
            if let Analysis::StaticOptimization(so) = a {
                so.set_knee_contact(&["walker_knee_l".to_string()]).unwrap();
                so.set_knee_contact_capacity(cap.parse().unwrap()).unwrap();
            }
        }
        let out = common::out_dir(tag);
        let opts = RunOptions {
            results_dir: Some(out.clone()),
            verbose: false,
            ..Default::default()
        };
        let summary = analyze::run(&setup, &opts).unwrap();
        assert_eq!(summary.failed, 0);
        let t = storage::read(&out.join("GC5_ss1_KneeContact.sto")).unwrap();
        let (m, l, tot) = (
            t.column_index("walker_knee_l_medial_N").unwrap(),
            t.column_index("walker_knee_l_lateral_N").unwrap(),
            t.column_index("walker_knee_l_total_N").unwrap(),
        );
        (
            t.rows
                .iter()
                .map(|r| (r[m] / 0.65).powi(2) + (r[l] / 0.35).powi(2))
                .collect(),
            t.rows.iter().map(|r| r[tot]).fold(0.0, f64::max),
        )
    };
    let (small, default, huge) = (
        loads("1", "gc5_cap_1"),
        loads("1.73", "gc5_cap_173"),
        loads("1000", "gc5_cap_1000"),
    );
    for i in 0..small.0.len() {
        let tol = 1e-6 * huge.0[i] + 1.0;
        assert!(small.0[i] <= default.0[i] + tol, "frame {i}");
        assert!(default.0[i] <= huge.0[i] + tol, "frame {i}");
    }
    let sum = |v: &[f64]| v.iter().sum::<f64>();
    assert!(sum(&small.0) < sum(&default.0) && sum(&default.0) < sum(&huge.0));
    // OpenSim's static optimization peaks at 4.26 BW (3,133 N) on ss1.
    assert!(huge.1 > 3000.0, "{}", huge.1);
}

/// The method's rows are the knee reaction the JointReaction computes
/// afterwards: at each solved frame, the optimiser's compartment loads sum to
/// the reaction's compression along the tibial axis, and their moment about
/// the joint centre is the reaction's frontal-plane moment.
#[test]
fn knee_rows_are_the_joint_reaction_at_the_solution() {
    use statopt::frame::Workspace;
    use statopt::tools::analyze::load_states;
    use statopt::tools::joint_reaction::static_optimization_reactions;
    use statopt::tools::static_optimization::{SoProblem, StaticOptimizationSetup};
    let Some(dir) = gc5_dir("knee_rows_are_the_joint_reaction_at_the_solution") else {
        return;
    };
    let setup = match Setup::read(&dir.join("setup_ss1.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    let mut so: StaticOptimizationSetup = setup.static_optimization().unwrap().clone();
    so.set_knee_contact(&["all".to_string()]).unwrap();
    let (problem, _) = SoProblem::build(&setup, &so).unwrap();
    assert_eq!(problem.knees.len(), 2);
    let states = load_states(&setup, &problem.model).unwrap();
    let udot = states
        .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
        .unwrap();
    let specs = knee_contact::reaction_specs(&problem.model, &problem.knees);
    let nvar = problem.controls.len() + 3 * problem.contacts.len();
    let mut ws = Workspace::new(&problem.model, &problem.muscles);
    let rows =
        statopt::tools::analyze::frame_rows(&states.time, setup.initial_time, setup.final_time, 1);
    assert_eq!(rows.len(), 132);
    for &i in rows.iter().step_by(9) {
        let (t, q, u) = (states.time[i], &states.q[i], &states.u[i]);
        let r = problem.solve_frame(t, q, u, &udot[i], &mut ws.data, &mut ws.muscles);
        assert!(r.relative_residual < 1e-6, "t = {t}");
        let mut o = vec![0.0; 9 * specs.len()];
        static_optimization_reactions(&problem, t, &r, &mut ws, &specs, &mut o).unwrap();
        for (ki, knee) in problem.knees.iter().enumerate() {
            let l = &r.solution.x[nvar + 2 * ki..nvar + 2 * ki + 2];
            let (med, lat) = (knee.capacity[0] * l[0], knee.capacity[1] * l[1]);
            let (fy, mx) = (o[9 * ki + 1], o[9 * ki + 3]);
            let scale = 1.0 + fy.abs();
            assert!(
                (med + lat + fy).abs() < 1e-3 * scale,
                "{} t = {t}: compartments {med} + {lat} vs compression {}",
                knee.name,
                -fy
            );
            assert!(
                (knee.z[0] * med + knee.z[1] * lat - mx).abs() < 1e-3 * (1.0 + mx.abs()),
                "{} t = {t}: frontal moment",
                knee.name
            );
            let (pm, pl) = statopt::frame::knee_contact::compartments(knee, fy, mx);
            assert!((pm - med).abs() < 1e-3 * scale && (pl - lat).abs() < 1e-3 * scale);
        }
    }
}

/// The knee compartments cost by their capacity, not by the contact weight
/// w0 (which weighs the contacts with the environment): a w0 sweep of the
/// knee contact method on a setup without contacts is solved once, writes
/// one KneeContact table without w0 in its name, and says why. (It used to
/// write one table per w0, its knee force falling with w0.)
#[test]
fn knee_contact_ignores_w0_without_machine_contacts() {
    use statopt::parse::setup::Analysis;
    let Some(dir) = gc5_dir("knee_contact_ignores_w0_without_machine_contacts") else {
        return;
    };
    let mut setup = match Setup::read(&dir.join("setup_ss1.xml")).unwrap() {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    };
    for a in setup.analyses.iter_mut() {
        if let Analysis::StaticOptimization(so) = a {
            so.set_knee_contact(&["walker_knee_l".to_string()]).unwrap();
            so.set_contact_weights(&[100.0, 1000.0]).unwrap();
        }
    }
    let out = common::out_dir("gc5_knee_contact_sweep");
    let opts = RunOptions {
        results_dir: Some(out.clone()),
        verbose: false,
        ..Default::default()
    };
    let summary = analyze::run(&setup, &opts).unwrap();
    assert_eq!(summary.failed, 0);
    let t = storage::read(&out.join("GC5_ss1_KneeContact.sto")).unwrap();
    assert_eq!(t.labels.len(), 4, "walker_knee_l only");
    assert!(!out.join("GC5_ss1_w0_100_KneeContact.sto").exists());
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("no contacts, so w0 changes nothing")),
        "{:?}",
        summary.warnings
    );
}
