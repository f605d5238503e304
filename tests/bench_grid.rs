//! The method options of static optimization and `bench --grid`:
//! the constraint matrix by unit perturbation through forward dynamics equals
//! the analytic one scaled by the inverse constraint-reduced mass matrix (so
//! both give the same optimum), the cubic coordinate spline is the natural
//! cubic interpolant, and the grid table has its rows, columns and error
//! orderings.

mod common;

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;
use statopt::dynamics::Data;
use statopt::muscles::set::MuscleFrame;
use statopt::parse::analyses::{FrictionModel, SolverChoice};
use statopt::parse::setup::{AnalyzeSetup, Setup};
use statopt::tools::bench_grid::{self, Choice, GridOptions, GridRow};
use statopt::tools::static_optimization::{ConstraintMatrix, SoProblem, StaticOptimizationSetup};

fn read_setup(p: &Path) -> AnalyzeSetup {
    match Setup::read(p).unwrap_or_else(|e| panic!("{e}")) {
        Setup::Analyze(s) => s,
        _ => unreachable!(),
    }
}

fn so_setup(setup: &AnalyzeSetup) -> StaticOptimizationSetup {
    setup.static_optimization().unwrap().clone()
}

/// A block on a level floor (n = +y, so the contact's e1 = +z, e2 = +x)
/// with μs = 0.1, moved slowly (slip below v_trans: static regime) along
/// the diagonal of x and z with an acceleration whose required shear
/// (≈ 10 kg × 1.7 m/s²) exceeds μs × weight (≈ 9.8 N): friction binds along
/// a direction where the four-sided pyramid admits √2 times the cone's shear.
fn contact_case(name: &str, so_extra: &str) -> PathBuf {
    let dir = common::out_dir(name);
    let model = common::block_model(
        r#"<PointOnPlaneContact name="floor"><point_body>block</point_body><point_location>0 0 0</point_location><plane_body>ground</plane_body><plane_normal>0 1 0</plane_normal><static_friction>0.1</static_friction><kinetic_friction>0.1</kinetic_friction></PointOnPlaneContact>"#,
    );
    std::fs::write(dir.join("block.osim"), model).unwrap();
    let mut m = String::from(
        "block\nversion=1\nnRows=31\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n",
    );
    for k in 0..31 {
        let t = k as f64 * 0.01;
        let x = 0.003 * (20.0 * t).sin();
        m.push_str(&format!("{t:.4}\t{x:.15}\t0\t{x:.15}\n"));
    }
    std::fs::write(dir.join("motion.mot"), m).unwrap();
    let setup = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>0.3</final_time><output_precision>14</output_precision>
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"><contact_weight>1000</contact_weight>{so_extra}</StaticOptimization>
<JointReaction name="JR"><joint_names>slide</joint_names><apply_on_bodies>child</apply_on_bodies><express_in_frame>ground</express_in_frame></JointReaction></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates></AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    dir.join("setup.xml")
}

fn row<'a>(rows: &'a [GridRow], name: &str) -> &'a GridRow {
    rows.iter()
        .find(|r| r.choice == name)
        .unwrap_or_else(|| panic!("no row {name}"))
}

/// Per frame: A_pert = M_r⁻¹ A_analytic and b_pert = M_r⁻¹ b_analytic (the
/// analytic rows are C_kᵀ M u̇, the perturbation rows u̇ of the free
/// coordinates), and both solve to the same activations.
fn compare_matrices(setup_file: &Path, frames: usize) -> (f64, f64, f64) {
    let setup = read_setup(setup_file);
    let mut so = so_setup(&setup);
    so.solver_tolerance = Some(1e-10);
    let (analytic, _) = SoProblem::build(&setup, &so).unwrap();
    so.constraint_matrix = ConstraintMatrix::Perturbation;
    let (perturb, _) = SoProblem::build(&setup, &so).unwrap();
    let states = statopt::tools::analyze::load_states(&setup, &analytic.model).unwrap();
    let udot = states
        .speed_derivatives(setup.coordinates_file.as_ref().unwrap())
        .unwrap();
    let n = states.time.len();
    let mut data = Data::new(&analytic.model);
    let mut mf = MuscleFrame::new(&analytic.muscles, &analytic.model);
    let (mut worst_a, mut worst_x, mut worst_j) = (0.0f64, 0.0f64, 0.0f64);
    for f in 0..frames {
        let i = n / 4 + f * (n / 2) / frames.max(1);
        let (t, q, u) = (states.time[i], &states.q[i], &states.u[i]);
        let (pa, _, _, _, none) =
            analytic.frame_problem_scaled(t, q, u, &udot[i], &mut data, &mut mf);
        assert!(none.is_none());
        let target_after_analytic = data.udot.clone();
        let (pp, _, _, _, m_r) =
            perturb.frame_problem_scaled(t, q, u, &udot[i], &mut data, &mut mf);
        assert_eq!(
            data.udot, target_after_analytic,
            "the perturbation path leaves the target accelerations in data"
        );
        let m_r: DMatrix<f64> = m_r.expect("perturbation rows come with M_r");
        let lu = m_r.clone().lu();
        let a_expected = lu.solve(&pa.a).unwrap();
        let b_expected = lu.solve(&pa.b).unwrap();
        let scale = pp.a.amax().max(pp.b.amax());
        let da = (&pp.a - &a_expected)
            .amax()
            .max((&pp.b - &b_expected).amax())
            / scale;
        worst_a = worst_a.max(da);
        let (xa, xp) = (statopt::optimize::solve(&pa), statopt::optimize::solve(&pp));
        assert!(
            xa.status.is_ok() && xp.status.is_ok(),
            "{:?} {:?}",
            xa.status,
            xp.status
        );
        // Muscle activations absolutely; other actuators' controls (reserves
        // with small optimal forces reach hundreds) and contact multipliers
        // relative to the largest |x|.
        let xmax = xa.x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let dx =
            xa.x.iter()
                .zip(&xp.x)
                .enumerate()
                .map(|(v, (a, b))| match analytic.controls.get(v) {
                    Some(statopt::tools::static_optimization::Control::Muscle(_)) => (a - b).abs(),
                    _ => (a - b).abs() / xmax,
                })
                .fold(0.0, f64::max);
        if dx > 1e-6 {
            println!("t={t}: dx {dx:.2e}: analytic {:?} it {} obj {:.12e} res {:.1e}; perturbation {:?} it {} obj {:.12e} res {:.1e}; obj of pert x in analytic {:.12e}", xa.status, xa.iterations, xa.objective, xa.eq_residual, xp.status, xp.iterations, xp.objective, xp.eq_residual, pa.objective(&xp.x));
        }
        worst_x = worst_x.max(dx);
        worst_j = worst_j
            .max((pa.objective(&xp.x) - xa.objective).abs() / xa.objective.abs().max(1e-300));
    }
    (worst_a, worst_x, worst_j)
}

#[test]
fn perturbation_matrix_is_the_analytic_one_through_the_reduced_mass_matrix() {
    // Contacts (three multipliers each, static regime) on the block.
    let setup = contact_case("grid_matrix_block", "");
    let (da, dx, dj) = compare_matrices(&setup, 6);
    println!("block with contact: relative |A_pert - M_r^-1 A| {da:.1e}, max |dx| {dx:.1e}, objective {dj:.1e}");
    assert!(da < 1e-9, "{da}");
    assert!(dx < 1e-6, "{dx}");
    let Some(root) = common::validation_dir("perturbation_matrix_validation") else {
        return;
    };
    // arm26 (muscles only) and leg6dof9musc (a coupled patella coordinate:
    // the constraint-reduced forward dynamics, with the coupler's curvature
    // term in u̇_0). In leg6dof9musc reserve actuators with small optimal
    // forces dominate the objective (~1e5 against ≤ 9 for the activations),
    // so the solver's relative tolerance leaves the activations determined
    // to ~1e-4 only, whichever matrix: there the objectives are compared.
    for (case, tol_x) in [("arm26", 1e-6), ("leg6dof9musc_stance", 1e-3)] {
        let (da, dx, dj) = compare_matrices(&root.join(case).join("setup_SO.xml"), 5);
        println!(
            "{case}: relative |A_pert - M_r^-1 A| {da:.1e}, max |dx| {dx:.1e}, objective {dj:.1e}"
        );
        assert!(da < 1e-9, "{case}: {da}");
        assert!(dx < tol_x, "{case}: {dx}");
        assert!(dj < 1e-7, "{case}: {dj}");
    }
}

/// Through the whole tool: both matrices give the same activations and
/// contact forces; the four-sided pyramid differs from the cone where
/// friction binds; a loose solver tolerance errs more than a tight one; the
/// reference run has zero error against itself.
#[test]
fn grid_errors_on_a_contact_case() {
    let setup = read_setup(&contact_case("grid_contact", ""));
    let out = common::out_dir("grid_contact_out");
    let choices = vec![
        Choice::so("perturbation", 1, |so| {
            so.constraint_matrix = ConstraintMatrix::Perturbation;
            so.set_solver_tolerance(1e-10)
        }),
        Choice::so("pyramid4", 1, |so| {
            so.friction = FrictionModel::Pyramid4;
            Ok(())
        }),
        Choice::so("tol 1e-2", 1, |so| {
            so.solver = SolverChoice::Clarabel;
            so.set_solver_tolerance(1e-2)
        }),
        Choice::so("tol 1e-9", 1, |so| {
            so.solver = SolverChoice::Clarabel;
            so.set_solver_tolerance(1e-9)
        }),
        Choice::new("threads 2", 2, |_| Ok(())),
    ];
    let opts = GridOptions {
        out: out.clone(),
        repeat: 1,
        ..Default::default()
    };
    let rows = bench_grid::run_grid(&setup, &bench_grid::reference_choice(), &choices, &opts)
        .unwrap_or_else(|e| panic!("{e}"));
    for r in &rows {
        println!("{r:?}");
    }
    assert_eq!(rows.len(), 1 + choices.len());
    let reference = row(&rows, "reference");
    assert_eq!(reference.frames, 31);
    assert_eq!(reference.max_dactivation, 0.0);
    assert_eq!(reference.max_dcontact, Some(0.0));
    assert_eq!(reference.max_dreaction, Some(0.0));
    let p = row(&rows, "perturbation");
    assert!(p.max_dactivation < 1e-6, "{p:?}");
    assert!(p.max_dcontact.unwrap() < 1e-4, "{p:?}");
    let pyr = row(&rows, "pyramid4");
    assert!(pyr.max_dactivation > 1e-3, "{pyr:?}");
    assert!(pyr.max_dcontact.unwrap() > 0.1, "{pyr:?}");
    let (loose, tight) = (row(&rows, "tol 1e-2"), row(&rows, "tol 1e-9"));
    assert!(
        loose.max_dactivation > tight.max_dactivation,
        "{loose:?} {tight:?}"
    );
    assert!(loose.max_dactivation > 0.0);
    // Threads change nothing but the time.
    let th = row(&rows, "threads 2");
    let default_tol = row(&rows, "reference");
    assert_eq!(th.frames, default_tol.frames);
}

/// The command's default grid writes the CSV (one row per choice, every
/// column) and the chart.
#[test]
fn grid_command_writes_table_and_chart() {
    let setup_file = contact_case("grid_cli", "");
    let out = common::out_dir("grid_cli_out");
    let opts = GridOptions {
        out: out.clone(),
        repeat: 1,
        opensim_ms: Some(1.0),
        opensim_activations: None,
        contact_weight: None,
    };
    let (rows, files) = bench_grid::run(&setup_file, &opts).unwrap_or_else(|e| panic!("{e}"));
    let setup = read_setup(&setup_file);
    let expected = 1 + bench_grid::default_choices(&setup, true).len();
    assert_eq!(rows.len(), expected);
    for name in [
        "pyramid4",
        "pyramid8",
        "cone",
        "perturbation",
        "cubic spline",
        "filter 6 Hz",
        "threads 2",
        "clarabel tol 1e-3",
        "clarabel tol 1e-10",
    ] {
        row(&rows, name);
    }
    let mut r = csv::Reader::from_path(out.join("bench_grid.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(str::to_string).collect();
    assert_eq!(header, bench_grid::CSV_COLUMNS);
    let records: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(records.len(), expected);
    assert_eq!(&records[0][0], "reference");
    assert_eq!(records[0][4].parse::<f64>().unwrap(), 0.0);
    for rec in &records {
        assert_eq!(rec.len(), header.len());
        assert!(rec[3].parse::<f64>().unwrap() > 0.0, "{rec:?}");
        // Contacts and a joint reaction: those columns are filled.
        assert!(
            rec[6].parse::<f64>().is_ok() && rec[7].parse::<f64>().is_ok(),
            "{rec:?}"
        );
        assert_eq!(&rec[8], "", "no OpenSim activations given");
    }
    assert!(records.iter().any(|r| &r[10] == "true"));
    for f in ["bench_grid.png", "bench_grid.svg"] {
        assert!(files.contains(&out.join(f)));
        assert!(std::fs::metadata(out.join(f)).unwrap().len() > 1000);
    }
}

/// A setup that sweeps w0 runs the grid at one w0 (its first): the
/// choices edit the typed plan, so the reference's edits keep the single
/// w0. (Editing by re-reading a copy of the StaticOptimization element
/// brought the sweep back: the reference run wrote w0-tagged tables and
/// the grid failed to find `<setup>_SO_activation.sto`.)
#[test]
fn grid_runs_one_w0_of_a_sweeping_setup() {
    let file = contact_case("grid_sweep", "");
    let text = std::fs::read_to_string(&file).unwrap().replace(
        "<contact_weight>1000</contact_weight>",
        "<contact_weight>1000 1</contact_weight>",
    );
    std::fs::write(&file, text).unwrap();
    let setup = read_setup(&file);
    assert_eq!(
        setup.static_optimization().unwrap().contact_weights,
        [1000.0, 1.0]
    );
    let out = common::out_dir("grid_sweep_out");
    let choices = vec![Choice::so("clarabel", 1, |so| {
        so.set_solver(SolverChoice::Clarabel);
        Ok(())
    })];
    let opts = GridOptions {
        out: out.clone(),
        repeat: 1,
        ..Default::default()
    };
    let rows = bench_grid::run_grid(&setup, &bench_grid::reference_choice(), &choices, &opts)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rows.len(), 2);
    assert_eq!(row(&rows, "reference").frames, 31);
    assert!(row(&rows, "clarabel").max_dactivation < 1e-6, "{rows:?}");
}

/// A typed edit is checked as the value read from a setup is, and its
/// error names the StaticOptimization element.
#[test]
fn typed_edits_are_checked_as_when_read() {
    let setup = read_setup(&contact_case("grid_edit_checks", ""));
    let mut so = setup.static_optimization().unwrap().clone();
    let e = so.set_solver_tolerance(2.0).unwrap_err().to_string();
    assert!(
        e.contains("solver_tolerance must lie in (0, 1)")
            && e.contains("<StaticOptimization name=\"SO\">"),
        "{e}"
    );
    let e = so.set_contact_weights(&[1e13]).unwrap_err().to_string();
    assert!(e.contains("lies outside"), "{e}");
    let e = so.set_knee_contact(&[]).unwrap_err().to_string();
    assert!(e.contains("knee_contact is empty"), "{e}");
    so.set_knee_contact(&["axial".to_string()]).unwrap();
    assert!(!so.knee_contact_frontal);
    so.set_contact_weights(&[1.0, 500.0]).unwrap();
    assert!(so.contact_weights_given);
    assert_eq!(so.contact_weights, [1.0, 500.0]);
    // The AnalyzeTool plan's setters (bench, bench --grid, predict-grf).
    let mut s = setup.clone();
    let e = s.set_coordinate_spline(4).unwrap_err().to_string();
    assert!(
        e.contains("coordinate_spline") && e.contains("setup.xml"),
        "{e}"
    );
    let e = s.set_lowpass_cutoff(f64::NAN).unwrap_err().to_string();
    assert!(
        e.contains("lowpass_cutoff_frequency_for_coordinates"),
        "{e}"
    );
    let e = s
        .set_motion("m.mot".into(), 1.0, 0.5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("time range"), "{e}");
    s.set_coordinate_spline(3).unwrap();
    s.set_lowpass_cutoff(-1.0).unwrap();
    assert_eq!((s.coordinate_spline, s.lowpass_cutoff), (3, -1.0));
}

/// The grid's own w0 (`--w0`) is checked as the setup's is: a weight
/// outside the range is an error naming the StaticOptimization element,
/// before any run (it was written into the plan unchecked).
#[test]
fn the_grids_contact_weight_is_checked() {
    let setup = read_setup(&contact_case("grid_w0_check", ""));
    let out = common::out_dir("grid_w0_check_out");
    for bad in [-1.0, 0.0, f64::NAN, 1e13] {
        let opts = GridOptions {
            out: out.clone(),
            repeat: 1,
            contact_weight: Some(bad),
            ..Default::default()
        };
        let e = bench_grid::run_grid(&setup, &bench_grid::reference_choice(), &[], &opts)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("contact_weight") && e.contains("<StaticOptimization name=\"SO\">"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn bad_method_options_are_located_errors() {
    // The StaticOptimization element is read once, with the setup: its
    // bad values are errors of reading the setup.
    let setup = contact_case("grid_bad", "<constraint_matrix>numeric</constraint_matrix>");
    let e = Setup::read(&setup).unwrap_err().to_string();
    assert!(
        e.contains("setup.xml") && e.contains("constraint_matrix") && e.contains("numeric"),
        "{e}"
    );
    let setup = contact_case("grid_bad_tol", "<solver_tolerance>2</solver_tolerance>");
    let e = Setup::read(&setup).unwrap_err().to_string();
    assert!(e.contains("solver_tolerance"), "{e}");
    let text = std::fs::read_to_string(&setup)
        .unwrap()
        .replace("<solver_tolerance>2</solver_tolerance>", "");
    std::fs::write(&setup, text).unwrap();
    let text = std::fs::read_to_string(&setup).unwrap().replace(
        "<coordinates_file>",
        "<coordinate_spline>quartic</coordinate_spline><coordinates_file>",
    );
    std::fs::write(&setup, text).unwrap();
    let e = Setup::read(&setup).unwrap_err().to_string();
    assert!(
        e.contains("coordinate_spline") && e.contains("quartic") && e.contains("setup.xml"),
        "{e}"
    );
}

/// Derivatives at the knots of the natural cubic interpolating spline
/// through (t, y) (second derivative zero at both ends), from its
/// tridiagonal system for the knot second derivatives M_i.
fn natural_cubic_slopes(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = t.len();
    let h: Vec<f64> = (0..n - 1).map(|i| t[i + 1] - t[i]).collect();
    let mut a = DMatrix::<f64>::zeros(n, n);
    let mut r = nalgebra::DVector::<f64>::zeros(n);
    a[(0, 0)] = 1.0;
    a[(n - 1, n - 1)] = 1.0;
    for i in 1..n - 1 {
        a[(i, i - 1)] = h[i - 1] / 6.0;
        a[(i, i)] = (h[i - 1] + h[i]) / 3.0;
        a[(i, i + 1)] = h[i] / 6.0;
        r[i] = (y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1];
    }
    let m = a.lu().solve(&r).unwrap();
    (0..n)
        .map(|i| {
            if i < n - 1 {
                (y[i + 1] - y[i]) / h[i] - h[i] * (2.0 * m[i] + m[i + 1]) / 6.0
            } else {
                (y[i] - y[i - 1]) / h[i - 1] + h[i - 1] * (m[i - 1] + 2.0 * m[i]) / 6.0
            }
        })
        .collect()
}

/// Write the block model and a setup moving tx along `f` on `rows` rows of
/// step `dt`, with `<coordinate_spline>` as given.
fn spline_case(name: &str, spline: &str, rows: usize, dt: f64, f: impl Fn(f64) -> f64) -> PathBuf {
    let dir = common::out_dir(name);
    std::fs::write(dir.join("block.osim"), common::block_model("")).unwrap();
    let mut m = format!(
        "block\nversion=1\nnRows={rows}\nnColumns=4\ninDegrees=no\nendheader\ntime\ttx\tty\ttz\n"
    );
    for k in 0..rows {
        let t = k as f64 * dt;
        m.push_str(&format!("{t:.10}\t{:.17e}\t0\t0\n", f(t)));
    }
    std::fs::write(dir.join("motion.mot"), m).unwrap();
    let setup = format!(
        r#"<OpenSimDocument Version="40000"><AnalyzeTool name="block"><model_file>block.osim</model_file><results_directory>out</results_directory>
<initial_time>0</initial_time><final_time>1000</final_time>{spline}
<AnalysisSet name="Analyses"><objects><StaticOptimization name="SO"/></objects></AnalysisSet>
<coordinates_file>motion.mot</coordinates_file><lowpass_cutoff_frequency_for_coordinates>-1</lowpass_cutoff_frequency_for_coordinates></AnalyzeTool></OpenSimDocument>"#
    );
    std::fs::write(dir.join("setup.xml"), setup).unwrap();
    dir.join("setup.xml")
}

/// (time, u of tx, u̇ of tx) of the setup's states, from the in-memory path
/// and from the streamed path (which must agree).
fn tx_states(setup_file: &Path) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let setup = read_setup(setup_file);
    let (_, model) = statopt::tools::loading::load_model(&setup.model_file).unwrap();
    let file = setup.coordinates_file.clone().unwrap();
    let states = statopt::tools::analyze::load_states(&setup, &model).unwrap();
    let udot = states.speed_derivatives(&file).unwrap();
    let u: Vec<f64> = states.u.iter().map(|r| r[0]).collect();
    let a: Vec<f64> = udot.iter().map(|r| r[0]).collect();
    let mut stream = statopt::tools::analyze::open_state_stream(&setup, &model).unwrap();
    let (mut su, mut sa) = (Vec::new(), Vec::new());
    while let Some(b) = stream.next_block().unwrap() {
        su.extend(b.u.iter().map(|r| r[0]));
        sa.extend(b.udot.iter().map(|r| r[0]));
    }
    assert_eq!(su.len(), u.len());
    for i in 0..u.len() {
        assert!(
            (su[i] - u[i]).abs() <= 1e-9 * (1.0 + u[i].abs()),
            "u row {i}"
        );
        assert!(
            (sa[i] - a[i]).abs() <= 1e-7 * (1.0 + a[i].abs()),
            "udot row {i}"
        );
    }
    (states.time.clone(), u, a)
}

/// `<coordinate_spline>cubic</coordinate_spline>`: speeds are the slopes of
/// the natural cubic interpolant of the coordinates and accelerations the
/// slopes of the natural cubic interpolant of the speeds, on a cubic
/// polynomial motion; a straight line is reproduced exactly by both splines.
#[test]
fn cubic_spline_is_the_natural_cubic_interpolant() {
    let p = |t: f64| 0.1 + 0.3 * t - 0.8 * t * t + 0.5 * t * t * t;
    let setup = spline_case(
        "spline_cubic_poly",
        "<coordinate_spline>cubic</coordinate_spline>",
        41,
        0.05,
        p,
    );
    let (time, u, a) = tx_states(&setup);
    let y: Vec<f64> = time.iter().map(|&t| p(t)).collect();
    let u_exp = natural_cubic_slopes(&time, &y);
    let a_exp = natural_cubic_slopes(&time, &u_exp);
    for i in 0..time.len() {
        assert!(
            (u[i] - u_exp[i]).abs() < 1e-9,
            "u at {}: {} vs {}",
            time[i],
            u[i],
            u_exp[i]
        );
        assert!(
            (a[i] - a_exp[i]).abs() < 1e-7,
            "udot at {}: {} vs {}",
            time[i],
            a[i],
            a_exp[i]
        );
    }
    // Inside (away from the natural ends) the cubic interpolant is close to
    // the polynomial's own derivatives.
    let mid = time.len() / 2;
    assert!((u[mid] - (0.3 - 1.6 * time[mid] + 1.5 * time[mid].powi(2))).abs() < 1e-4);
    for spline in [
        "<coordinate_spline>cubic</coordinate_spline>",
        "<coordinate_spline>gcv5</coordinate_spline>",
        "",
    ] {
        let setup = spline_case("spline_line", spline, 21, 0.1, |t| 0.2 - 0.7 * t);
        let (_, u, a) = tx_states(&setup);
        assert!(u.iter().all(|v| (v + 0.7).abs() < 1e-10), "{spline}: {u:?}");
        assert!(a.iter().all(|v| v.abs() < 1e-8), "{spline}: {a:?}");
    }
}

/// On a smooth motion the cubic and quintic accelerations differ, by a
/// truncation error that shrinks at least quadratically with the step
/// (away from the natural end conditions).
#[test]
fn cubic_differs_from_quintic_within_its_order() {
    let f = |t: f64| 0.5 * (3.0 * t).sin();
    let mut diffs = Vec::new();
    for (k, rows) in [(0, 41usize), (1, 81)] {
        let dt = 2.0 / (rows - 1) as f64;
        let c = spline_case(
            &format!("spline_order_c{k}"),
            "<coordinate_spline>cubic</coordinate_spline>",
            rows,
            dt,
            f,
        );
        let q = spline_case(&format!("spline_order_q{k}"), "", rows, dt, f);
        let (time, _, ac) = tx_states(&c);
        let (_, _, aq) = tx_states(&q);
        let d = (0..time.len())
            .filter(|&i| time[i] > 0.6 && time[i] < 1.4)
            .map(|i| (ac[i] - aq[i]).abs())
            .fold(0.0, f64::max);
        // Both approximate the exact acceleration −4.5 sin 3t.
        let exact_err = (0..time.len())
            .filter(|&i| time[i] > 0.6 && time[i] < 1.4)
            .map(|i| (ac[i] + 4.5 * (3.0 * time[i]).sin()).abs())
            .fold(0.0, f64::max);
        println!("rows {rows}: interior max |udot cubic - quintic| {d:.3e}, cubic vs exact {exact_err:.3e}");
        assert!(d > 0.0);
        assert!(d < 0.05 * 4.5, "{d}");
        diffs.push(d);
    }
    assert!(diffs[0] / diffs[1] > 3.5, "{diffs:?}");
}
