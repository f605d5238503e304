//! A force sweep run whole: its setup read (or given), compiled, its
//! motion streamed once on a pool and each frame solved for every
//! candidate ([`run`], [`run_file`]), each candidate's tables written on
//! request ([`SweepOptions::tables`]: those a run of its own setup writes,
//! named as it names them, `writers::names`). The entry point of callers
//! without a command line (the Python binding's `force_sweep`) and of the
//! force sweep tool, which adds its progress bar and a study's CSV.

use std::sync::Arc;

use crate::error::{Error, Location, Result};
use crate::frame::candidates::ForceCandidate;
use crate::parse::setup::AnalyzeSetup;
use crate::plan::CandidateSpec;
use crate::sweep::candidates::resolve;
use crate::sweep::metrics::SweepOutcome;
use crate::sweep::plan::{FrameValues, SweepPlan};
use crate::sweep::run::{solve_stream, Solve};
use crate::sweep::setup::{open_stream, read_setup};
use crate::writers::names::{OutputKind, RunKey, Sweep};

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

/// Told how a sweep's frames advance: (frames done, frames of the
/// motion); called with 0 once the motion is open, then after each frame
/// in frame order, on the thread that called [`run`].
pub type SweepProgress = dyn Fn(u64, u64) + Send + Sync;

/// Sweep options.
#[derive(Clone)]
pub struct SweepOptions {
    /// Warm-start each candidate from the previous one of the same w0 in
    /// the frame (answers equal cold starts up to rounding).
    pub warm: bool,
    /// Per candidate, where its tables go; empty (the default): metrics
    /// only. Every candidate's tables stay open while the motion streams:
    /// meant for tens of candidates, not thousands.
    pub tables: Vec<CandidateTables>,
    /// Worker threads (None: every core). Results do not depend on it.
    pub threads: Option<usize>,
    /// Digits after the decimal point in the tables (None: the setup's
    /// `<output_precision>`).
    pub precision: Option<usize>,
    /// Told how the frames advance ([`SweepProgress`]).
    pub progress: Option<Arc<SweepProgress>>,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            warm: true,
            tables: Vec::new(),
            threads: None,
            precision: None,
            progress: None,
        }
    }
}

impl std::fmt::Debug for SweepOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SweepOptions")
            .field("warm", &self.warm)
            .field("tables", &self.tables)
            .field("threads", &self.threads)
            .field("precision", &self.precision)
            .field("progress", &self.progress.is_some())
            .finish()
    }
}

/// Run a force sweep of the AnalyzeTool setup in `setup_file` (or `text`,
/// read as if it were that file; with `allow_unknown` elements neither
/// OpenSim nor statopt knows are read past).
pub fn run_file(
    setup_file: &std::path::Path,
    text: Option<&str>,
    allow_unknown: bool,
    candidates: &[CandidateSpec],
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let setup = read_setup(setup_file, text, allow_unknown)?;
    run(&setup, candidates, sweep)
}

/// Run a force sweep of `setup` on a pool of `sweep.threads`: the motion
/// streamed once, each frame prepared and solved for every candidate as it
/// comes (memory does not grow with the motion but for the metrics'
/// series). A stop requested meanwhile (`frame::interrupt`) ends it with
/// an error.
pub fn run(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    crate::frame::threads::in_pool(sweep.threads, || run_streamed(setup, candidates, sweep))
}

fn run_streamed(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let mut plan = SweepPlan::compile(setup)?;
    if !sweep.tables.is_empty() {
        plan.use_every_reaction();
    }
    let cands = resolve(&setup.setup_file, &plan.problem, candidates)?;
    let precision = sweep.precision.unwrap_or(setup.output_precision);
    let mut tables = if sweep.tables.is_empty() {
        None
    } else {
        Some(CandidateWriters::open(
            setup,
            &plan,
            &cands,
            &sweep.tables,
            precision,
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
        .count() as u64;
    let mut done = 0;
    if let Some(p) = &sweep.progress {
        p(0, nframes);
    }
    let mut outcome = solve_stream(&plan, &cands, &mut stream, how, warnings, |fv| {
        if let Some(t) = tables.as_mut() {
            t.write(fv)?;
        }
        done += 1;
        if let Some(p) = &sweep.progress {
            p(done, nframes);
        }
        Ok(())
    })?;
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
        cands: &[ForceCandidate],
        specs: &[CandidateTables],
        precision: usize,
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
