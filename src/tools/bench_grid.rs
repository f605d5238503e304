//! `statopt-tool bench SETUP.xml --grid`: speed against accuracy of the
//! method choices of static optimization.
//!
//! A setup runs once per [`Choice`] — a name, a thread count and a typed
//! edit of the setup's plan (a field of its StaticOptimization such as the
//! constraint matrix, friction model or solver tolerance, or of the
//! AnalyzeTool such as the coordinate spline or the low-pass cut-off) — and
//! each run's time per frame (the whole per-frame loop, best of the repeats)
//! is set against its error relative to a reference run of the same frames
//! ([`reference_choice`]: exact friction cone, the dual Newton solver,
//! analytic constraint matrix, OpenSim's quintic spline, the setup's
//! filtering). [`run_grid`] takes any list of choices, so other options (a
//! reduced model, …) are one more [`Choice`]; [`default_choices`] is the
//! one-factor-at-a-time grid around the setup's own options plus a few
//! combinations. [`write_csv`] and [`write_chart`] write `bench_grid.csv`
//! and `bench_grid.png`/`.svg` (max |Δactivation| on a log axis, the Pareto
//! front marked, OpenSim 4.6's time per frame as a vertical line when given).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Location, Result};
use crate::parse::analyses::{
    ConstraintMatrix, FrictionModel, SolverChoice, StaticOptimizationSetup,
};
use crate::parse::setup::{Analysis, AnalyzeSetup, Setup};
use crate::plots::{self, RefLine, Scatter, ScatterPoint};
use crate::storage::{self, Storage};
use crate::tools::{analyze, RunOptions};
use crate::writers::names::{OutputKind, RunKey, Sweep};

/// An edit of a setup that makes one method choice.
pub type Edit = Arc<dyn Fn(&mut AnalyzeSetup) -> Result<()> + Send + Sync>;

/// One point of the grid.
#[derive(Clone)]
pub struct Choice {
    /// Row name in the table and label in the chart.
    pub name: String,
    /// Worker threads of the run.
    pub threads: usize,
    pub edit: Edit,
}

impl Choice {
    pub fn new(
        name: impl Into<String>,
        threads: usize,
        edit: impl Fn(&mut AnalyzeSetup) -> Result<()> + Send + Sync + 'static,
    ) -> Choice {
        Choice {
            name: name.into(),
            threads,
            edit: Arc::new(edit),
        }
    }

    /// An edit of the setup's StaticOptimization (the one that is on).
    pub fn so(
        name: impl Into<String>,
        threads: usize,
        edit: impl Fn(&mut StaticOptimizationSetup) -> Result<()> + Send + Sync + 'static,
    ) -> Choice {
        Choice::new(name, threads, move |s| edit(so_analysis(s)?))
    }
}

/// Options of a grid run.
#[derive(Debug, Clone, Default)]
pub struct GridOptions {
    /// Where `bench_grid.csv`/`.png`/`.svg` go (and the runs, removed after).
    pub out: PathBuf,
    /// Runs per choice; the best time is kept.
    pub repeat: usize,
    /// OpenSim 4.6's time per frame (ms), drawn as a vertical line.
    pub opensim_ms: Option<f64>,
    /// An OpenSim `*_StaticOptimization_activation.sto` of the same setup.
    pub opensim_activations: Option<PathBuf>,
    /// The contact weight w0 of every run (default: the setup's first).
    pub contact_weight: Option<f64>,
}

/// One row of the grid table.
#[derive(Debug, Clone, PartialEq)]
pub struct GridRow {
    pub choice: String,
    pub threads: usize,
    pub frames: usize,
    /// Best time per frame of the per-frame loop, ms.
    pub ms_per_frame: f64,
    /// Against the reference run: max and RMS |Δactivation| over the
    /// muscles (every actuator when the model has none) and frames.
    pub max_dactivation: f64,
    pub rms_dactivation: f64,
    /// Max |Δ contact force| (N, vector norm), when the model has contacts.
    pub max_dcontact: Option<f64>,
    /// Max |Δ reaction force| (N, vector norm) of the knee (or first)
    /// reaction, when the setup runs a JointReaction with static optimization.
    pub max_dreaction: Option<f64>,
    /// Max |Δactivation| against OpenSim's activations: the same columns,
    /// common times.
    pub max_dactivation_opensim: Option<f64>,
    /// Failed frames (solver status not solved) of the run.
    pub failed_frames: usize,
}

/// CSV columns, in order.
pub const CSV_COLUMNS: [&str; 11] = [
    "choice",
    "threads",
    "frames",
    "ms_per_frame",
    "max_dactivation",
    "rms_dactivation",
    "max_dcontact_force_N",
    "max_dreaction_force_N",
    "max_dactivation_vs_opensim",
    "failed_frames",
    "pareto",
];

/// The active StaticOptimization analysis of the setup.
fn so_analysis(setup: &mut AnalyzeSetup) -> Result<&mut StaticOptimizationSetup> {
    let file = setup.setup_file.clone();
    setup
        .analyses
        .iter_mut()
        .find_map(|a| match a {
            Analysis::StaticOptimization(so) if so.common.on => Some(&mut **so),
            _ => None,
        })
        .ok_or_else(|| {
            Error::input(
                Location::file(&file).with_element("<AnalysisSet>"),
                "bench --grid needs a StaticOptimization analysis that is on",
            )
        })
}

/// The reference: exact friction cone, the dual Newton solver (solver
/// tolerance 1e-10 for Clarabel where it falls back), analytic matrix,
/// OpenSim's quintic spline, the setup's filtering, one thread.
pub fn reference_choice() -> Choice {
    Choice::new("reference", 1, |s| {
        s.set_coordinate_spline(5)?;
        let so = so_analysis(s)?;
        so.set_friction(FrictionModel::Cone);
        so.set_solver(SolverChoice::Auto);
        so.set_solver_tolerance(1e-10)?;
        so.set_constraint_matrix(ConstraintMatrix::Analytic);
        Ok(())
    })
}

/// The default grid: the setup as it is (one thread), then one factor at a
/// time — constraint matrix, friction model (with contacts), Clarabel and
/// its tolerance, spline, filter, threads — and a few combinations.
pub fn default_choices(setup: &AnalyzeSetup, has_contacts: bool) -> Vec<Choice> {
    let mut v = vec![Choice::new("default", 1, |_| Ok(()))];
    v.push(Choice::so("perturbation", 1, |so| {
        so.set_constraint_matrix(ConstraintMatrix::Perturbation);
        Ok(())
    }));
    if has_contacts {
        for (name, f) in [
            ("pyramid4", FrictionModel::Pyramid4),
            ("pyramid8", FrictionModel::Pyramid8),
            ("cone", FrictionModel::Cone),
        ] {
            v.push(Choice::so(name, 1, move |so| {
                so.set_friction(f);
                Ok(())
            }));
        }
    }
    // Clarabel instead of the dual Newton solver, at several tolerances
    // (the Newton solver always solves to 1e-12 relative).
    v.push(Choice::so("clarabel", 1, |so| {
        so.set_solver(SolverChoice::Clarabel);
        Ok(())
    }));
    for (name, tol) in [
        ("1e-3", 1e-3),
        ("1e-4", 1e-4),
        ("1e-5", 1e-5),
        ("1e-6", 1e-6),
        ("1e-8", 1e-8),
        ("1e-10", 1e-10),
    ] {
        v.push(Choice::so(format!("clarabel tol {name}"), 1, move |so| {
            so.set_solver(SolverChoice::Clarabel);
            so.set_solver_tolerance(tol)
        }));
    }
    v.push(Choice::new("cubic spline", 1, |s| {
        s.set_coordinate_spline(3)
    }));
    if setup.lowpass_cutoff >= 0.0 {
        v.push(Choice::new("filter off", 1, |s| s.set_lowpass_cutoff(-1.0)));
    } else {
        v.push(Choice::new("filter 6 Hz", 1, |s| s.set_lowpass_cutoff(6.0)));
    }
    v.push(Choice::new("threads 2", 2, |_| Ok(())));
    if !setup.reduce_model {
        // Full versus reduced model (`<reduce_model>`, tools::reduce): the
        // errors cover the kept muscles, contacts and joints only.
        v.push(Choice::new("reduced model", 1, |s| {
            s.set_reduce_model(true);
            Ok(())
        }));
    }
    // Combinations.
    v.push(Choice::so(
        "perturbation, clarabel tol 1e-4 (OpenSim-like)",
        1,
        |so| {
            so.set_constraint_matrix(ConstraintMatrix::Perturbation);
            so.set_solver(SolverChoice::Clarabel);
            so.set_solver_tolerance(1e-4)
        },
    ));
    let name = if has_contacts {
        "clarabel tol 1e-4, pyramid4, 2 threads"
    } else {
        "clarabel tol 1e-4, 2 threads"
    };
    v.push(Choice::so(name, 2, move |so| {
        so.set_solver(SolverChoice::Clarabel);
        so.set_solver_tolerance(1e-4)?;
        if has_contacts {
            so.set_friction(FrictionModel::Pyramid4);
        }
        Ok(())
    }));
    v.push(Choice::so("cubic, clarabel tol 1e-6, 2 threads", 2, |so| {
        so.set_solver(SolverChoice::Clarabel);
        so.set_solver_tolerance(1e-6)
    }));
    if let Some(c) = v.last_mut() {
        let so = c.edit.clone();
        c.edit = Arc::new(move |s| {
            so(s)?;
            s.set_coordinate_spline(3)
        });
    }
    v
}

/// Tables of one run.
struct RunTables {
    activation: Storage,
    contacts: Option<Storage>,
    reaction: Option<(String, Storage)>,
    failed: usize,
}

/// Only static optimization (with its coupled joint reactions) runs, with
/// one contact weight (`w0`, else the setup's first) and no figures.
fn bench_setup(setup: &AnalyzeSetup, w0: Option<f64>) -> Result<AnalyzeSetup> {
    let mut s = setup.clone();
    s.figures.clear();
    for a in s.analyses.iter_mut() {
        match a {
            Analysis::MuscleAnalysis(m) => m.common.on = false,
            Analysis::Kinematics(k) => k.common_mut().on = false,
            Analysis::StaticOptimization(_) => {}
            // Joint reactions from a forces file run on their own.
            Analysis::JointReaction(jr) => {
                if jr.forces_file.is_some() {
                    jr.common.on = false;
                }
            }
            Analysis::Unsupported { common, .. } => common.on = false,
        }
    }
    let so = so_analysis(&mut s)?;
    let w = w0.unwrap_or(so.contact_weights[0]);
    so.set_contact_weights(&[w])?;
    Ok(s)
}

fn so_name(setup: &AnalyzeSetup) -> String {
    setup
        .analyses
        .iter()
        .find_map(|a| match a {
            Analysis::StaticOptimization(so) if so.common.on => Some(so.common.name.clone()),
            _ => None,
        })
        .unwrap_or_default()
}

/// The JointReaction analyses computed inside static optimization.
fn coupled_reactions(setup: &AnalyzeSetup) -> Vec<String> {
    setup
        .joint_reactions()
        .filter(|jr| jr.common.on)
        .map(|jr| jr.common.name.clone())
        .collect()
}

/// Run one choice `repeat` times; best ms per frame and the last run's tables.
fn run_choice(
    base: &AnalyzeSetup,
    choice: &Choice,
    dir: &Path,
    repeat: usize,
) -> Result<(usize, f64, RunTables)> {
    let mut s = base.clone();
    (choice.edit)(&mut s)
        .map_err(|e| e.context(format!("bench --grid: choice '{}'", choice.name)))?;
    let _ = std::fs::remove_dir_all(dir);
    let opts = RunOptions {
        results_dir: Some(dir.to_path_buf()),
        threads: Some(choice.threads.max(1)),
        verbose: false,
        precision: Some(16),
        ..Default::default()
    };
    let mut best = f64::INFINITY;
    let mut frames = 0;
    for _ in 0..repeat.max(1) {
        let summary = analyze::run(&s, &opts)
            .map_err(|e| e.context(format!("bench --grid: choice '{}'", choice.name)))?;
        frames = summary.frames;
        best = best.min(summary.loop_seconds);
    }
    let run_of = |analysis: &str| RunKey::analysis(&s.name, analysis, Sweep::Single);
    let run = run_of(&so_name(&s));
    let activation = storage::read(&dir.join(run.file(OutputKind::Activation)))?;
    let cpath = dir.join(run.file(OutputKind::ContactForces));
    let contacts = if cpath.exists() {
        Some(storage::read(&cpath)?)
    } else {
        None
    };
    // Activation errors cover the muscles (MusclePower's columns), or every
    // actuator when the model has no muscle.
    let muscles = storage::read(&dir.join(run.file(OutputKind::MusclePower)))?.labels;
    let activation = if muscles.is_empty() {
        activation
    } else {
        let cols: Vec<usize> = muscles
            .iter()
            .filter_map(|m| activation.column_index(m))
            .collect();
        Storage {
            labels: cols.iter().map(|&j| activation.labels[j].clone()).collect(),
            rows: activation
                .rows
                .iter()
                .map(|r| cols.iter().map(|&j| r[j]).collect())
                .collect(),
            ..activation
        }
    };
    let diag = storage::read(&dir.join(run.file(OutputKind::Diagnostics)))?;
    let failed = match diag.column_index("status") {
        Some(j) => diag.rows.iter().filter(|r| r[j] < 0.0).count(),
        None => 0,
    };
    let mut reaction = None;
    for name in coupled_reactions(&s) {
        let p = dir.join(run_of(&name).file(OutputKind::ReactionLoads));
        if p.exists() {
            let t = storage::read(&p)?;
            let root = t
                .labels
                .iter()
                .filter_map(|l| l.strip_suffix("_fx"))
                .find(|r| r.to_ascii_lowercase().contains("knee"))
                .or_else(|| t.labels.iter().find_map(|l| l.strip_suffix("_fx")))
                .map(str::to_string);
            if let Some(root) = root {
                reaction = Some((root, t));
                break;
            }
        }
    }
    let ms = if frames > 0 {
        1e3 * best / frames as f64
    } else {
        f64::NAN
    };
    Ok((
        frames,
        ms,
        RunTables {
            activation,
            contacts,
            reaction,
            failed,
        },
    ))
}

/// The row of `reference` at time `t`: the row with that time (within
/// 1e-9 s), else linear interpolation between the neighbouring rows (runs
/// whose frames differ, e.g. a filter that resamples a non-uniform motion);
/// None outside the reference's time range.
fn row_at(reference: &Storage, t: f64) -> Option<Vec<f64>> {
    let n = reference.time.len();
    let i = reference.time.partition_point(|&x| x < t - 1e-9);
    if i < n && (reference.time[i] - t).abs() <= 1e-9 {
        return Some(reference.rows[i].clone());
    }
    if i == 0 || i >= n {
        return None;
    }
    let (t0, t1) = (reference.time[i - 1], reference.time[i]);
    let w = (t - t0) / (t1 - t0);
    Some(
        reference.rows[i - 1]
            .iter()
            .zip(&reference.rows[i])
            .map(|(a, b)| a + w * (b - a))
            .collect(),
    )
}

/// (max, RMS) of |Δ| over the common columns and times.
fn scalar_errors(ours: &Storage, reference: &Storage) -> (f64, f64) {
    let cols: Vec<(usize, usize)> = reference
        .labels
        .iter()
        .enumerate()
        .filter_map(|(j, l)| ours.column_index(l).map(|k| (k, j)))
        .collect();
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
    for (i, &t) in ours.time.iter().enumerate() {
        let Some(r) = row_at(reference, t) else {
            continue;
        };
        for &(k, j) in &cols {
            let d = (ours.rows[i][k] - r[j]).abs();
            let d = if d.is_nan() { f64::INFINITY } else { d };
            max = max.max(d);
            sum += d * d;
            n += 1;
        }
    }
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    (max, (sum / n as f64).sqrt())
}

/// Max norm of Δ of the vectors `<root>_fx/_fy/_fz` for the given roots.
fn vector_error(ours: &Storage, reference: &Storage, roots: &[String]) -> f64 {
    let mut max = 0.0f64;
    let mut any = false;
    for root in roots {
        let idx = |t: &Storage| -> Option<[usize; 3]> {
            Some([
                t.column_index(&format!("{root}_fx"))?,
                t.column_index(&format!("{root}_fy"))?,
                t.column_index(&format!("{root}_fz"))?,
            ])
        };
        let (Some(a), Some(b)) = (idx(ours), idx(reference)) else {
            continue;
        };
        for (i, &t) in ours.time.iter().enumerate() {
            let Some(r) = row_at(reference, t) else {
                continue;
            };
            any = true;
            let d: f64 = (0..3)
                .map(|c| (ours.rows[i][a[c]] - r[b[c]]).powi(2))
                .sum::<f64>()
                .sqrt();
            max = max.max(if d.is_nan() { f64::INFINITY } else { d });
        }
    }
    if any {
        max
    } else {
        f64::NAN
    }
}

/// Run the setup under the reference choice and every choice (the
/// reference first, and as a row of its own named as it is).
pub fn run_grid(
    setup: &AnalyzeSetup,
    reference: &Choice,
    choices: &[Choice],
    opts: &GridOptions,
) -> Result<Vec<GridRow>> {
    let base = bench_setup(setup, opts.contact_weight)?;
    let runs = opts.out.join("bench_grid_runs");
    let opensim = match &opts.opensim_activations {
        Some(p) => Some(storage::read(p)?),
        None => None,
    };
    let (ref_frames, ref_ms, ref_tables) =
        run_choice(&base, reference, &runs.join("reference"), opts.repeat)?;
    let contact_roots: Vec<String> = ref_tables
        .contacts
        .as_ref()
        .map(|t| {
            t.labels
                .iter()
                .filter_map(|l| l.strip_suffix("_lambda_n"))
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default();
    let row = |name: &str, threads: usize, frames: usize, ms: f64, t: &RunTables| {
        let (max_da, rms_da) = scalar_errors(&t.activation, &ref_tables.activation);
        GridRow {
            choice: name.to_string(),
            threads,
            frames,
            ms_per_frame: ms,
            max_dactivation: max_da,
            rms_dactivation: rms_da,
            max_dcontact: match (&t.contacts, &ref_tables.contacts) {
                (Some(a), Some(b)) => Some(vector_error(a, b, &contact_roots)),
                _ => None,
            },
            max_dreaction: match (&t.reaction, &ref_tables.reaction) {
                (Some((_, a)), Some((root, b))) => {
                    Some(vector_error(a, b, std::slice::from_ref(root)))
                }
                _ => None,
            },
            max_dactivation_opensim: opensim.as_ref().map(|o| scalar_errors(&t.activation, o).0),
            failed_frames: t.failed,
        }
    };
    let mut rows = vec![row(
        &reference.name,
        reference.threads,
        ref_frames,
        ref_ms,
        &ref_tables,
    )];
    for (k, c) in choices.iter().enumerate() {
        let dir = runs.join(format!("choice{k}"));
        let (frames, ms, tables) = run_choice(&base, c, &dir, opts.repeat)?;
        rows.push(row(&c.name, c.threads, frames, ms, &tables));
        let _ = std::fs::remove_dir_all(&dir);
    }
    let _ = std::fs::remove_dir_all(&runs);
    Ok(rows)
}

/// Indices of the rows on the Pareto front of (ms per frame, max |Δa|).
pub fn pareto_rows(rows: &[GridRow]) -> Vec<usize> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r.ms_per_frame, r.max_dactivation))
        .collect();
    plots::pareto_front(&pts)
}

/// `bench_grid.csv`: one row per choice, [`CSV_COLUMNS`]; empty cells where
/// a column does not apply.
pub fn write_csv(rows: &[GridRow], path: &Path) -> Result<()> {
    let front = pareto_rows(rows);
    let err = |e: csv::Error| Error::input(Location::file(path), format!("cannot write CSV: {e}"));
    let mut w = csv::Writer::from_path(path).map_err(err)?;
    w.write_record(CSV_COLUMNS).map_err(err)?;
    let opt = |v: Option<f64>| v.map(|x| format!("{x:e}")).unwrap_or_default();
    for (i, r) in rows.iter().enumerate() {
        w.write_record([
            r.choice.clone(),
            r.threads.to_string(),
            r.frames.to_string(),
            format!("{}", r.ms_per_frame),
            format!("{:e}", r.max_dactivation),
            format!("{:e}", r.rms_dactivation),
            opt(r.max_dcontact),
            opt(r.max_dreaction),
            opt(r.max_dactivation_opensim),
            r.failed_frames.to_string(),
            front.contains(&i).to_string(),
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| Error::io(path, e))
}

/// Smallest error drawn on the log axis; a zero error (the reference) is
/// drawn there and labelled so.
pub const CHART_FLOOR: f64 = 1e-12;

/// `<stem>.png` and `<stem>.svg`: time per frame against max |Δactivation|.
pub fn write_chart(
    rows: &[GridRow],
    stem: &Path,
    title: &str,
    opensim_ms: Option<f64>,
) -> Result<Vec<PathBuf>> {
    // Points are numbered as the CSV's rows (1 = the reference); the key
    // right of the plot names them, and points on the Pareto front also
    // carry their name.
    let front = pareto_rows(rows);
    let key: Vec<String> = rows
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let zero = if r.max_dactivation == 0.0 {
                " (error 0)"
            } else {
                ""
            };
            format!("{}  {}{zero}", k + 1, r.choice)
        })
        .collect();
    let points = rows
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let y = if r.max_dactivation > 0.0 || r.max_dactivation.is_nan() {
                // NaN (no common frames) is not drawn.
                r.max_dactivation
            } else {
                CHART_FLOOR
            };
            let label = if front.contains(&k) {
                format!("{} {}", k + 1, r.choice)
            } else {
                format!("{}", k + 1)
            };
            ScatterPoint {
                label,
                x: r.ms_per_frame,
                y: if y.is_nan() { y } else { y.max(CHART_FLOOR) },
                color: r.threads.saturating_sub(1),
            }
        })
        .collect();
    let s = Scatter {
        title: title.to_string(),
        x_label: "time per frame (ms, best of repeats)".into(),
        y_label: "max |Δactivation| vs reference".into(),
        points,
        log_x: true,
        log_y: true,
        pareto: true,
        key,
        size: (1400, 800),
        reference: opensim_ms
            .map(|v| {
                vec![RefLine::Vertical {
                    value: v,
                    label: "OpenSim 4.6".into(),
                }]
            })
            .unwrap_or_default(),
    };
    plots::write_scatter(&s, stem)
}

/// Whether the setup's model has contacts (the friction choices apply).
fn has_contacts(setup: &AnalyzeSetup) -> Result<bool> {
    let mut s = setup.clone();
    let so = so_analysis(&mut s)?.clone();
    let (p, _) = crate::tools::static_optimization::SoProblem::build(&s, &so)?;
    Ok(!p.contacts.is_empty())
}

/// The command: the default grid on a setup file; writes the CSV and the
/// chart into `opts.out`; returns the rows and the files.
pub fn run(setup_file: &Path, opts: &GridOptions) -> Result<(Vec<GridRow>, Vec<PathBuf>)> {
    let setup = match Setup::read(setup_file)? {
        Setup::Analyze(s) => s,
        Setup::InverseDynamics(_) => {
            return Err(Error::input(
                Location::file(setup_file),
                "bench --grid runs AnalyzeTool setups with static optimization",
            ))
        }
    };
    std::fs::create_dir_all(&opts.out).map_err(|e| Error::io(&opts.out, e))?;
    let choices = default_choices(&setup, has_contacts(&setup)?);
    let rows = run_grid(&setup, &reference_choice(), &choices, opts)?;
    let csv = opts.out.join("bench_grid.csv");
    write_csv(&rows, &csv)?;
    let file_name = setup_file
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    let title = if setup.name.is_empty() {
        format!("{file_name}: speed against accuracy")
    } else {
        format!("{} ({file_name}): speed against accuracy", setup.name)
    };
    let mut files = vec![csv];
    files.extend(write_chart(
        &rows,
        &opts.out.join("bench_grid"),
        &title,
        opts.opensim_ms,
    )?);
    Ok((rows, files))
}
