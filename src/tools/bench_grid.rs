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
//! front marked, OpenSim 4.6's time per frame as a vertical line when given;
//! `writers::bench_grid`). The errors are `metrics::differences`. This
//! driver edits the plan per choice, runs it and reads its tables.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::error::{Error, Location, Result};
use crate::metrics::differences::{scalar_errors, vector_error};
use crate::parse::analyses::{
    ConstraintMatrix, FrictionModel, SolverChoice, StaticOptimizationSetup,
};
use crate::parse::setup::{Analysis, AnalyzeSetup, Setup};
use crate::storage::{self, Storage};
use crate::tools::{analyze, RunOptions};
use crate::writers::names::{OutputKind, RunKey, Sweep};

pub use crate::writers::bench_grid::{
    pareto_rows, write_chart, write_csv, GridRow, CHART_FLOOR, CSV_COLUMNS,
};

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
