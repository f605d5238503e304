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

/// A JointReaction of one setup of the study (`consumer`) whose
/// `<forces_file>` is a table another setup (`producer`) writes; `moved`:
/// where that setup writes it in this run (its own folder, or under
/// `-o DIR`).
struct CrossReference {
    consumer: usize,
    producer: usize,
    /// The `<forces_file>` as the setup names it (normalised).
    named: PathBuf,
    moved: PathBuf,
}

/// The study's cross references and each setup's wave: a setup runs after
/// the setups whose tables its JointReactions read (wave 0 reads none).
fn cross_references(runs: &[PlannedRun]) -> Result<(Vec<usize>, Vec<CrossReference>)> {
    use crate::plan::Analysis;
    let mut crossed = Vec::new();
    for (i, r) in runs.iter().enumerate() {
        let Setup::Analyze(a) = r.setup else {
            continue;
        };
        for an in a.analyses.iter().filter(|an| an.common().on) {
            let Analysis::JointReaction(jr) = an else {
                continue;
            };
            let Some(f) = &jr.forces_file else {
                continue;
            };
            let path = normalise(f);
            let file = path.file_name().and_then(|f| f.to_str()).unwrap_or("");
            let producer = runs.iter().enumerate().find(|(j, p)| {
                *j != i
                    && path.parent() == Some(normalise(&p.own_dir).as_path())
                    && p.planned.find(file).is_some()
            });
            if let Some((j, p)) = producer {
                let moved = std::path::absolute(p.out_dir.join(file))
                    .map_err(|e| Error::io(&p.out_dir, e))?;
                crossed.push(CrossReference {
                    consumer: i,
                    producer: j,
                    named: path.clone(),
                    moved,
                });
            }
        }
    }
    let mut levels = vec![0usize; runs.len()];
    for _ in 0..=runs.len() {
        let mut changed = false;
        for c in &crossed {
            if levels[c.consumer] <= levels[c.producer] {
                levels[c.consumer] = levels[c.producer] + 1;
                changed = true;
            }
        }
        if !changed {
            return Ok((levels, crossed));
        }
    }
    let c = crossed
        .iter()
        .max_by_key(|c| levels[c.consumer])
        .expect("a cross reference");
    Err(Error::input(
        Location::file(&runs[c.consumer].file).with_element("<JointReaction>"),
        format!(
            "its <forces_file> {} is written by {}, a setup that waits, in turn, for this one's tables",
            c.moved.display(),
            runs[c.producer].file.display()
        ),
    ))
}

/// `setup` with each JointReaction that reads another setup's table
/// reading it where this run writes it (None: nothing moved).
fn redirect<'c>(setup: &Setup, crossed: impl Iterator<Item = &'c CrossReference>) -> Option<Setup> {
    use crate::plan::Analysis;
    let mut out = None;
    for c in crossed {
        let Setup::Analyze(a) = out.get_or_insert_with(|| setup.clone()) else {
            return None;
        };
        for an in a.analyses.iter_mut() {
            if let Analysis::JointReaction(jr) = an {
                let reads = jr.common.on
                    && jr
                        .forces_file
                        .as_deref()
                        .is_some_and(|f| normalise(f) == c.named);
                if reads && c.named != c.moved {
                    jr.set_forces_file(c.moved.clone());
                }
            }
        }
    }
    out
}

/// Everything [`run`] checks before its first run (figure and metric
/// references against the runs, metric ops).
pub fn check(plan: &StudyPlan) -> Result<()> {
    check_in(plan, None)
}

/// [`check`] for a run whose outputs go under `moved_to` (the study's `-o`).
/// The setups' order too: a cycle among cross-setup JointReaction
/// references is the error the run gives ([`cross_references`], called by
/// [`prepare`] for both).
pub fn check_in(plan: &StudyPlan, moved_to: Option<&Path>) -> Result<()> {
    prepare(plan, moved_to).map(|_| ())
}

/// What [`prepare`] finds before the first run: the planned runs, the
/// tables the figures and metrics draw, where references point, and the
/// setups' waves with the cross references that order them.
struct Prepared<'a> {
    runs: Vec<PlannedRun<'a>>,
    expected: Vec<(PathBuf, Location)>,
    moved: Moved,
    levels: Vec<usize>,
    crossed: Vec<CrossReference>,
}

/// Plan the runs, check every reference and metric, order the setups whose
/// JointReactions read another's tables (a cycle is an input error), and
/// say where figure references point once the runs have written. `--check`
/// and a run call this same function.
fn prepare<'a>(study: &'a StudyPlan, moved_to: Option<&Path>) -> Result<Prepared<'a>> {
    let runs: Vec<PlannedRun> = study
        .runs
        .iter()
        .map(|r| plan(&r.file, &r.setup, moved_to))
        .collect();
    // (Every figure's and metric's attributes, its op among them, were
    // checked when the study was read: `plan::figures`.)
    let (expected, moved) = check_references(&study.figures, &study.dir, &runs)?;
    let (levels, crossed) = cross_references(&runs)?;
    Ok(Prepared {
        runs,
        expected,
        moved,
        levels,
        crossed,
    })
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
    let Prepared {
        runs,
        expected,
        moved,
        levels,
        crossed,
    } = prepare(study, opts.results_dir.as_deref())?;
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
    // A JointReaction that takes its forces from a table another setup of
    // the study writes is declared ahead: that setup runs first, keeps the
    // table in memory until the JointReaction has read it, and with
    // `-o DIR` the JointReaction reads it where it was moved.
    crossed
        .iter()
        .for_each(|c| crate::storage::results::want(&c.moved));
    let redirected: Vec<Option<Setup>> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| redirect(r.setup, crossed.iter().filter(|c| c.consumer == i)))
        .collect();
    use rayon::prelude::*;
    // Each setup's work is the study run's (its capture) on whichever
    // worker thread runs it.
    let study_run = crate::storage::results::context();
    let mut done: Vec<Option<Result<RunSummary>>> = runs.iter().map(|_| None).collect();
    for level in 0..=levels.iter().copied().max().unwrap_or(0) {
        let wave: Vec<usize> = (0..runs.len()).filter(|&i| levels[i] == level).collect();
        let results: Vec<(usize, Result<RunSummary>)> = wave
            .par_iter()
            .map(|&i| {
                let _run = study_run.enter();
                let r = &runs[i];
                let run_opts = RunOptions {
                    results_dir: opts.results_dir.as_ref().map(|_| r.out_dir.clone()),
                    ..opts.clone()
                };
                let done = match redirected[i].as_ref().unwrap_or(r.setup) {
                    Setup::Analyze(a) => analyze::run(a, &run_opts),
                    Setup::InverseDynamics(s) => inverse_dynamics::run(s, &run_opts),
                };
                (i, done)
            })
            .collect();
        // A setup that failed or was stopped: the setups that wait for its
        // tables do not run.
        let go_on = results
            .iter()
            .all(|(_, r)| r.as_ref().is_ok_and(|s| s.stopped.is_none()));
        for (i, r) in results {
            for c in crossed.iter().filter(|c| c.consumer == i) {
                crate::storage::results::done(&c.moved);
            }
            done[i] = Some(r);
        }
        if !go_on {
            break;
        }
    }
    let mut summary = RunSummary {
        warnings: study.warnings.clone(),
        ..Default::default()
    };
    for (r, done) in runs.iter().zip(done) {
        // (Runs after one that failed or stopped did not run.)
        let Some(done) = done else {
            continue;
        };
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
