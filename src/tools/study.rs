//! A study: several setups run one after the other, then figures and summary
//! metrics drawn from their output tables — e.g. two machine designs
//! compared (the leg-extension study of Krüger & Wartzack 2017, section 3).
//!
//! ```xml
//! <OpenSimDocument Version="40000">
//!   <StatoptStudy name="leg_extension">
//!     <setups>leg_extension_cam1.xml leg_extension_cam2.xml</setups>
//!     <results_directory>../output/leg_extension</results_directory>
//!     <Figure name="fig09_hip_flexion" title="..." x_label="time (s)" y_label="moment (N m)">
//!       <Series file="../output/leg_extension_cam1/x_SO_w0_1_GeneralizedForcesBySource.sto"
//!               column="hip_flexion_r_muscles" label="muscles, w0 = 1" scale="1"/>
//!       <Band mean="..._w0_mean_ReactionLoads.sto" min="..._w0_min_..." max="..._w0_max_..."
//!             column="knee_r_on_tibia_r_in_tibia_r_fx" label="cam 1" scale="-1"/>
//!       <fill_between>0 1</fill_between>   (shade between series 0 and 1)
//!       <panel/>                            (start a new panel to the right)
//!     </Figure>
//!     <Metric name="quadriceps_work_cam1" file="..." columns="rect_fem_r vas_med_r" op="integral"/>
//!   </StatoptStudy>
//! </OpenSimDocument>
//! ```
//! A `<ForceSweep name="..." setup="...">` element runs candidates of one
//! setup that differ only in forces on one compiled scene and writes their
//! metrics to `<name>_force_sweep.csv` (`tools::force_sweep`; a study may
//! hold only sweeps).
//! File paths are relative to the study file. Metrics (`max`, `min`,
//! `absmax`, `integral` of the sum of the columns over time, `mean`; and,
//! with `where="COLUMN"` naming a column of the same file, `argmax`/`argmin`
//! (that column at the maximum/minimum), `at` with `value="X"` (the value
//! where that column first equals X, interpolated) and `crossing` (that
//! column where the value first changes sign): e.g. the knee flexion angle
//! at which the shear turns from PCL-type to ACL-type) are written to
//! `<name>_metrics.csv`; figures as PNG and SVG.

use std::path::{Path, PathBuf};

use crate::error::{Error, Location, Result};
use crate::parse::setup::{resolve, Setup};
use crate::plan::figures::{self, FigureOrMetric, TableRef};
use crate::plan::StudyPlan;
use crate::tools::figures::normalise;
pub use crate::tools::figures::{draw, metric_value, Moved};
use crate::tools::{analyze, inverse_dynamics, RunOptions, RunSummary};

/// What the study knows of one of its setups before running it: where its
/// tables go and which w0 runs it makes (for checking figure references).
struct PlannedRun<'a> {
    file: PathBuf,
    setup: &'a Setup,
    /// The setup's own results folder, and where this run writes (moved
    /// under the study's `-o` folder when one is given).
    own_dir: PathBuf,
    out_dir: PathBuf,
    name: String,
    /// w0 tags in file names (`1`, `500`, `mean`, ...); empty without a sweep.
    w0_tags: Vec<String>,
    /// The outputs the setup's plan writes (`writers::names`).
    planned: crate::writers::names::Planned,
    /// The one table an InverseDynamicsTool writes (its names are not
    /// prefixed by the setup's name).
    only_file: Option<String>,
}

fn plan<'a>(file: &Path, setup: &'a Setup, moved_to: Option<&Path>) -> PlannedRun<'a> {
    use crate::writers::names::Planned;
    let mut only_file = None;
    let mut planned = Planned::default();
    let (own_dir, name, w0_tags) = match setup {
        Setup::Analyze(a) => {
            planned = Planned::of(a);
            (
                a.results_directory.clone(),
                a.name.clone(),
                Planned::w0_tags(a),
            )
        }
        Setup::InverseDynamics(i) => {
            only_file = Some(i.output_gen_force_file.clone());
            (i.results_directory.clone(), i.name.clone(), Vec::new())
        }
    };
    let out_dir = moved_results_dir(&own_dir, &name, moved_to);
    PlannedRun {
        file: file.to_path_buf(),
        setup,
        own_dir,
        out_dir,
        name,
        w0_tags,
        planned,
        only_file,
    }
}

/// Where a study's setup writes: its own results folder, or with the
/// study's `-o DIR` the folder of that name under DIR (the setup's name
/// when its folder has none).
pub fn moved_results_dir(own_dir: &Path, name: &str, moved_to: Option<&Path>) -> PathBuf {
    match moved_to {
        Some(o) => o.join(own_dir.file_name().unwrap_or(std::ffi::OsStr::new(name))),
        None => own_dir.to_path_buf(),
    }
}

/// Check every table a figure or metric names against the planned runs,
/// before anything is computed, and say where the run will write it. A
/// table in a setup's results folder must be one that setup writes (its
/// name, a w0 it runs); any other table must exist already. Returns the
/// tables the runs must write (with the element naming each) and where
/// references point ([`Moved`]).
fn check_references(
    elements: &[FigureOrMetric],
    dir: &Path,
    runs: &[PlannedRun],
) -> Result<(Vec<(PathBuf, Location)>, Moved)> {
    let mut from_runs = Vec::new();
    let mut moved_refs = Moved::new();
    let mut visit = |r: TableRef| -> Result<()> {
        let (attr, value) = (r.attr, r.value);
        let err = |msg: String| figures::error(r.loc, msg);
        let path = normalise(&resolve(dir, value));
        let run = runs
            .iter()
            .find(|p| path.parent() == Some(normalise(&p.own_dir).as_path()));
        let Some(run) = run else {
            if !path.is_file() {
                return Err(err(format!(
                    "{attr}=\"{value}\": {} does not exist and no setup of the study writes to its folder",
                    path.display()
                )));
            }
            return Ok(());
        };
        let file = path.file_name().and_then(|f| f.to_str()).unwrap_or("");
        if let Some(only) = &run.only_file {
            if file != only {
                return Err(err(format!(
                    "{attr}=\"{value}\": {} writes only {only} to that folder",
                    run.file.display()
                )));
            }
        } else if run.planned.find(file).is_none() {
            let ours = file.starts_with(&format!("{}_", run.name));
            if let Some(tag) = crate::writers::names::w0_tag_in(file).filter(|_| ours) {
                if !run.w0_tags.iter().any(|t| t == tag) {
                    return Err(err(format!(
                        "{attr}=\"{value}\": names w0 = {tag}, but {} runs {}",
                        run.file.display(),
                        if run.w0_tags.is_empty() {
                            "a single w0 (its tables carry no w0 in their names)".to_string()
                        } else {
                            format!("w0 = {}", run.w0_tags[..run.w0_tags.len() - 3].join(", "))
                        }
                    )));
                }
            }
            return Err(err(if ours {
                format!(
                    "{attr}=\"{value}\": {} writes no table {file} (its tables: {}, ...)",
                    run.file.display(),
                    run.planned
                        .keys
                        .iter()
                        .skip(1)
                        .take(3)
                        .map(crate::writers::names::file_name)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            } else {
                format!(
                    "{attr}=\"{value}\": {} is in the results folder of {}, whose tables are named {}_...",
                    file,
                    run.file.display(),
                    run.name
                )
            }));
        }
        // Absolute, so that drawing (which resolves against the
        // study's folder) finds it wherever the study was started.
        let moved =
            std::path::absolute(run.out_dir.join(file)).map_err(|e| Error::io(&run.out_dir, e))?;
        from_runs.push((moved.clone(), r.loc.clone()));
        moved_refs.insert(path, moved);
        Ok(())
    };
    for r in elements.iter().flat_map(FigureOrMetric::tables) {
        visit(r)?;
    }
    Ok((from_runs, moved_refs))
}

/// Everything [`run`] checks before its first run (figure and metric
/// references against the runs, metric ops).
pub fn check(plan: &StudyPlan) -> Result<()> {
    check_in(plan, None)
}

/// [`check`] for a run whose outputs go under `moved_to` (the study's `-o`).
pub fn check_in(plan: &StudyPlan, moved_to: Option<&Path>) -> Result<()> {
    prepare(plan, moved_to).map(|_| ())
}

/// Plan the runs, check every reference and metric, and say where figure
/// references point once the runs have written.
#[allow(clippy::type_complexity)]
fn prepare<'a>(
    study: &'a StudyPlan,
    moved_to: Option<&Path>,
) -> Result<(Vec<PlannedRun<'a>>, Vec<(PathBuf, Location)>, Moved)> {
    let runs: Vec<PlannedRun> = study
        .runs
        .iter()
        .map(|r| plan(&r.file, &r.setup, moved_to))
        .collect();
    // (Every figure's and metric's attributes, its op among them, were
    // checked when the study was read: `plan::figures`.)
    let (expected, moved) = check_references(&study.figures, &study.dir, &runs)?;
    Ok((runs, expected, moved))
}

/// Run a study document. Everything it names is checked before the first
/// run starts; its figures and metrics draw only tables its own runs wrote;
/// with `-o DIR` every output goes under DIR (each setup's tables in
/// DIR/<its results folder's name>).
pub fn run(plan: &StudyPlan, opts: &RunOptions) -> Result<RunSummary> {
    // `--threads N` bounds the whole study: one pool of N threads runs the
    // setups side by side and, nested in it, each setup's frames and the
    // figures (the setups' own runs then use that pool instead of each
    // starting one of N threads).
    let inner = RunOptions {
        threads: None,
        ..opts.clone()
    };
    crate::frame::threads::in_pool(opts.threads, || run_study(plan, &inner))
}

fn run_study(study: &StudyPlan, opts: &RunOptions) -> Result<RunSummary> {
    let (runs, expected, moved) = prepare(study, opts.results_dir.as_deref())?;
    // The tables the figures and metrics draw: kept in memory until drawn
    // (`storage::results::want`; the study's capture ends with the run).
    expected
        .iter()
        .for_each(|(f, _)| crate::storage::results::want(f));
    let out = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| study.results_directory.clone());
    crate::parse::setup::create_results_dir(
        &out,
        &study.results_directory_loc,
        opts.results_dir.is_some(),
    )?;
    // Every setup's results folder before the first run writes anything.
    for r in &runs {
        if let Some(p) = crate::parse::setup::results_dir_problem(&r.out_dir) {
            let loc = match r.setup {
                Setup::Analyze(a) => a.results_directory_loc.clone(),
                Setup::InverseDynamics(i) => i.results_directory_loc.clone(),
            };
            return Err(Error::input(
                loc,
                format!(
                    "<results_directory> names {}, which {p}",
                    r.out_dir.display()
                ),
            ));
        }
    }
    // The setups are independent: they run side by side (each one's frames in
    // parallel too), so that one setup's serial parts (loading, closing the
    // contacts, sweep statistics) overlap another's frames. Summaries are
    // taken in the study's order, whatever order the setups finish in; the
    // first error in that order is the study's.
    use rayon::prelude::*;
    // Each setup's work is the study run's (its capture) on whichever
    // worker thread runs it.
    let study_run = crate::storage::results::context();
    let done: Vec<Result<RunSummary>> = runs
        .par_iter()
        .map(|r| {
            let _run = study_run.enter();
            let run_opts = RunOptions {
                results_dir: opts.results_dir.as_ref().map(|_| r.out_dir.clone()),
                ..opts.clone()
            };
            match r.setup {
                Setup::Analyze(a) => analyze::run(a, &run_opts),
                Setup::InverseDynamics(i) => inverse_dynamics::run(i, &run_opts),
            }
        })
        .collect();
    let mut summary = RunSummary {
        warnings: study.warnings.clone(),
        ..Default::default()
    };
    for (r, done) in runs.iter().zip(done) {
        let s = r.file.display().to_string();
        summary.absorb(done?, Some(s.as_str()));
        if summary.stopped.is_some() {
            return Ok(summary);
        }
    }
    // Only what this run wrote: a table left from an earlier run is stale.
    let key = |p: &Path| normalise(&std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf()));
    let written: Vec<PathBuf> = summary.files.iter().map(|f| key(f)).collect();
    for (file, loc) in &expected {
        if !written.contains(&key(file)) {
            return Err(Error::input(
                loc.clone(),
                format!(
                    "{} was not written by this run of the study (a table left from an earlier run is stale); check the setup's analyses and names",
                    file.display()
                ),
            ));
        }
    }
    // Force sweeps: candidates of one setup on one compiled scene, their
    // metrics in <name>_force_sweep.csv (tools::force_sweep).
    for sw in &study.sweeps {
        summary
            .files
            .extend(crate::tools::force_sweep::run_plan(sw, &out, opts)?);
    }
    summary
        .files
        .extend(draw(&study.figures, &study.dir, &out, &study.name, &moved)?);
    if !summary.results_dirs.contains(&out) {
        summary.results_dirs.push(out);
    }
    Ok(summary)
}
