//! The force sweep tool: reads a sweep's setup (or a study's
//! `<ForceSweep>` plan), opens its motion, hands both to the engine
//! (`sweep`: the candidates resolved, each frame solved for every
//! candidate, the metrics collected) and its results to the writers: each
//! candidate's tables on request ([`SweepOptions::tables`]: those a run of
//! its own setup writes, named as it names them) and a study's
//! `<name>_force_sweep.csv`.

use crate::error::{Error, Location, Result};
use crate::parse::setup::AnalyzeSetup;
use crate::sweep::candidates::resolve;
use crate::sweep::setup::{open_stream, read_setup};
use crate::sweep::{solve_stream, FrameValues, Solve, SweepPlan};
use crate::tools::RunOptions;
use crate::writers::names::{OutputKind, RunKey, Sweep};

pub use crate::plan::force_sweep::CandidateSpec;
pub use crate::sweep::{Scene, SweepOutcome};

/// Where one candidate's tables go ([`SweepOptions::tables`]): the tables
/// a run of the candidate's own setup writes (static optimization, joint
/// reactions, KneeLoads, KneeContact; not its log or statistics), named as
/// that run names them (`writers::names`).
#[derive(Debug, Clone)]
pub struct CandidateTables {
    /// Its folder.
    pub dir: std::path::PathBuf,
    /// Whether the names carry the candidate's w0 tag (as the runs of a w0
    /// sweep of several weights), or not (a run of one weight).
    pub w0_tag: bool,
}

/// Sweep options.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Warm-start each candidate from the previous one of the same w0 in
    /// the frame (answers equal cold starts up to rounding).
    pub warm: bool,
    /// Per candidate, where its tables go; empty (the default): metrics
    /// only. Every candidate's tables stay open while the motion streams:
    /// meant for tens of candidates, not thousands.
    pub tables: Vec<CandidateTables>,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            warm: true,
            tables: Vec::new(),
        }
    }
}

/// Run a force sweep of the AnalyzeTool setup in `setup_file` (or `text`,
/// read as if it were that file).
pub fn run_file(
    setup_file: &std::path::Path,
    text: Option<&str>,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let setup = read_setup(setup_file, text, opts.allow_unknown)?;
    run(&setup, candidates, opts, sweep)
}

/// Run a force sweep of `setup` (see the `sweep` stage): the motion
/// streamed once, each frame prepared and solved for every candidate as it
/// comes (memory does not grow with the motion but for the metrics'
/// series).
pub fn run(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    crate::frame::threads::in_pool(opts.threads, || {
        run_streamed(setup, candidates, opts, sweep)
    })
}

fn run_streamed(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let mut plan = SweepPlan::compile(setup)?;
    if !sweep.tables.is_empty() {
        plan.use_every_reaction();
    }
    let cands = resolve(&setup.setup_file, &plan.problem, candidates)?;
    let mut tables = if sweep.tables.is_empty() {
        None
    } else {
        Some(CandidateWriters::open(
            setup,
            &plan,
            &cands,
            &sweep.tables,
            opts,
        )?)
    };
    let how = Solve {
        warm: sweep.warm,
        keep_results: tables.is_some(),
    };
    let mut warnings = plan.warnings.clone();
    let mut stream = open_stream(setup, &plan, &mut warnings)?;
    let (i0, i1, step) = (stream.first_row, stream.last_row, plan.step_interval);
    let nframes = (i0..=i1)
        .filter(|&i| crate::frame::driver::is_frame(i, i0, i1, step))
        .count();
    let mut progress =
        crate::tools::progress::bar(nframes as u64, opts, &format!("{}_force_sweep", setup.name));
    let outcome = solve_stream(&plan, &cands, &mut stream, how, warnings, |fv| {
        if let Some(t) = tables.as_mut() {
            t.write(fv)?;
        }
        progress.inc(1);
        Ok(())
    });
    progress.finish_and_clear();
    let mut outcome = outcome?;
    if let Some(t) = tables {
        outcome.files = t.finish()?;
    }
    Ok(outcome)
}

/// Every candidate's open tables ([`SweepOptions::tables`]).
struct CandidateWriters<'a> {
    tables: Vec<crate::writers::so_tables::SoTables>,
    /// Every candidate's KneeLoads and KneeContact tables, made from each
    /// frame's reactions as a run makes them (`writers::knee_tables`).
    knees: crate::writers::knee_tables::KneeTables<'a>,
}

impl<'a> CandidateWriters<'a> {
    fn open(
        setup: &AnalyzeSetup,
        plan: &'a SweepPlan,
        cands: &[crate::frame::candidates::ForceCandidate],
        specs: &[CandidateTables],
        opts: &RunOptions,
    ) -> Result<CandidateWriters<'a>> {
        use crate::writers::so_tables::{SoTables, TablesSpec};
        if specs.len() != cands.len() {
            return Err(Error::input(
                Location::file(&setup.setup_file),
                format!(
                    "force sweep: {} candidates but {} table folders",
                    cands.len(),
                    specs.len()
                ),
            ));
        }
        let precision = opts.precision.unwrap_or(setup.output_precision);
        let mut tables = Vec::with_capacity(cands.len());
        let mut runs = Vec::with_capacity(cands.len());
        for (c, spec) in cands.iter().zip(specs) {
            let run = Sweep::of(c.w0, spec.w0_tag);
            std::fs::create_dir_all(&spec.dir).map_err(|e| Error::io(&spec.dir, e))?;
            let reactions: Vec<(RunKey, &[crate::reactions::ReactionSpec])> = plan
                .coupled
                .iter()
                .map(|cp| {
                    (
                        RunKey::analysis(&setup.name, &cp.name, run),
                        cp.specs.as_slice(),
                    )
                })
                .collect();
            let so_run = RunKey::analysis(&setup.name, &plan.so_name, run);
            tables.push(SoTables::open(
                &plan.problem,
                &TablesSpec {
                    setup_file: &setup.setup_file,
                    dir: &spec.dir,
                    run: &so_run,
                    w0: c.w0,
                    reactions: &reactions,
                    precision,
                    keep: None,
                },
            )?);
            runs.push((spec.dir.clone(), run));
        }
        // Per candidate, in the order of the coupled reactions: the
        // KneeLoads of each with knee loads, the KneeContact of the knee
        // contact method's.
        use crate::writers::knee_tables::{KneeKind, KneeTables};
        let problem = &plan.problem;
        let mut knees = KneeTables::new(
            &problem.model,
            &problem.knees,
            &setup.setup_file,
            &[],
            precision,
        );
        let no_stats = |_| std::path::PathBuf::new();
        for (j, c) in plan.coupled.iter().enumerate() {
            let jr = |run| RunKey::analysis(&setup.name, &c.name, run);
            if c.knee.is_some() {
                let (dir, run) = &runs[0];
                let table = crate::storage::Storage {
                    labels: crate::reactions::column_labels(&c.specs),
                    ..Default::default()
                };
                let path = dir.join(jr(*run).file(OutputKind::KneeLoads));
                let (sides, patella) =
                    crate::reactions::knee_loads::sides(&problem.model, &table, &path)?;
                let paths = runs
                    .iter()
                    .map(|(dir, run)| dir.join(jr(*run).file(OutputKind::KneeLoads)))
                    .collect();
                knees.add(
                    KneeKind::Loads {
                        reaction: j,
                        sides: Box::new(sides),
                        patella,
                    },
                    paths,
                    &no_stats,
                    "",
                );
            }
            if c.knee_contact {
                let paths = runs
                    .iter()
                    .map(|(dir, run)| {
                        dir.join(RunKey::setup(&setup.name, *run).file(OutputKind::KneeContact))
                    })
                    .collect();
                knees.add(KneeKind::Contact { reaction: j }, paths, &no_stats, "");
            }
        }
        Ok(CandidateWriters { tables, knees })
    }

    /// One frame's rows of every candidate (frames in order).
    fn write(&mut self, fv: &FrameValues) -> Result<()> {
        for (t, (r, rows)) in self.tables.iter_mut().zip(&fv.results) {
            t.write(r, rows)?;
        }
        self.knees.push(&fv.results)
    }

    /// Close the tables: per candidate, its tables, then its KneeLoads and
    /// KneeContact tables, as a run lists them.
    fn finish(self) -> Result<Vec<std::path::PathBuf>> {
        let (knees, _) = self.knees.finish()?;
        let mut files = Vec::new();
        for (i, t) in self.tables.into_iter().enumerate() {
            files.extend(t.finish()?);
            if let Some(k) = knees.get(i) {
                files.extend(k.iter().cloned());
            }
        }
        Ok(files)
    }
}

/// A study's `<ForceSweep>` element (see `tools::study`):
///
/// ```xml
/// <ForceSweep name="cam_shapes" setup="leg_extension_rajagopal_cam2.xml">
///   <contact_weight>1 500 1000</contact_weight>   (default: the setup's)
///   <write_tables>false</write_tables>   (default: metrics only)
///   <Candidate name="circular">
///     <expression force="cam_torque">-50</expression>
///     <optimal_force actuator="knee_angle_r_reserve">50</optimal_force>
///     <external_scale force="plate1_left">1.2</external_scale>  (no force: all)
///   </Candidate>
///   ...
/// </ForceSweep>
/// ```
///
/// Every candidate runs at every w0; the metrics (the setup's `<Metric>`s)
/// go to `<out>/<name>_force_sweep.csv`, one row per (candidate, w0):
/// `candidate`, `w0`, `frames`, `failed`, then the metrics (unrounded).
/// With `<write_tables>true</write_tables>` each candidate's tables go to
/// `<out>/<name>_force_sweep/<candidate>/`, named as a run of its own setup
/// names them (w0-tagged when the element has several w0).
/// The sweep was read with the study (`plan::ForceSweepPlan`).
pub fn run_plan(
    sweep: &crate::plan::ForceSweepPlan,
    out: &std::path::Path,
    opts: &RunOptions,
) -> Result<Vec<std::path::PathBuf>> {
    let (specs, names) = (&sweep.specs, &sweep.names);
    let name = &sweep.name;
    let own = RunKey::setup(name, Sweep::Single);
    let mut options = SweepOptions::default();
    if sweep.write_tables {
        let n_w0 = names.iter().filter(|n| *n == &names[0]).count();
        let mut seen = std::collections::HashSet::new();
        for n in names.iter().step_by(n_w0.max(1)) {
            if !seen.insert(n) {
                return Err(Error::input(
                    sweep.loc.clone(),
                    format!("write_tables: two candidates are named '{n}' (their tables would share a folder)"),
                ));
            }
        }
        options.tables = names
            .iter()
            .map(|n| CandidateTables {
                dir: out.join(own.file(OutputKind::ForceSweepDir(n.clone()))),
                w0_tag: n_w0 > 1,
            })
            .collect();
    }
    let outcome = run(&sweep.setup, specs, opts, &options)?;
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let path = out.join(own.file(OutputKind::ForceSweep));
    let csv_err = |e: csv::Error| Error::input(Location::file(&path), e.to_string());
    let mut w = csv::Writer::from_path(&path).map_err(csv_err)?;
    let mut header = vec![
        "candidate".to_string(),
        "w0".into(),
        "frames".into(),
        "failed".into(),
    ];
    header.extend(outcome.metric_names.iter().cloned());
    w.write_record(&header).map_err(csv_err)?;
    for (((n, spec), values), failed) in names
        .iter()
        .zip(specs.iter())
        .zip(&outcome.values)
        .zip(&outcome.failed)
    {
        let mut rec = vec![
            n.clone(),
            format!("{}", spec.w0),
            outcome.frames.to_string(),
            failed.to_string(),
        ];
        rec.extend(values.iter().map(|v| format!("{v:e}")));
        w.write_record(&rec).map_err(csv_err)?;
    }
    w.flush().map_err(|e| Error::io(&path, e))?;
    let mut files = vec![path];
    files.extend(outcome.files);
    Ok(files)
}
