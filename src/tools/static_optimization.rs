//! The StaticOptimization analysis (opensim-semantics.md §6) as a driver:
//! it compiles the run's problem ([`SoProblem::build`], in
//! [`crate::frame::compile`]: the model's forces
//! sorted into controls, passive forces, contacts and reserves), streams the
//! states and has the frame stage solve every frame
//! ([`crate::frame::so_loop`]: the frame loop and its threads, each frame
//! through [`crate::frame::problem`]), its joint reactions added by
//! [`crate::reactions`]; the loop streams each frame's results to this
//! driver's sinks, the tables ([`crate::writers::so_tables`], with the run's
//! statistics, [`crate::writers::run_statistics`]) and the MCAP log
//! ([`crate::writers::frame_log`]), each on a thread of its own; a w0 sweep solves
//! each frame's physics once
//! (its mean, min and max tables: [`crate::writers::sweep_statistics`]);
//! a run can resume where an earlier one stopped
//! ([`crate::writers::resume`]).

use std::time::Instant;

use crate::error::{Error, Result};
use crate::forces::analysis_model::{load_analysis_model, AnalysisModel};
use crate::frame::driver::is_frame;
use crate::frame::so_loop::{solve_frames, Frame, Sink};
use crate::frame::workspace::Workspace;
use crate::parse::setup::AnalyzeSetup;
use crate::reactions::{
    resolve_reactions, static_optimization_reactions, JointReactionSetup, ReactionSpec,
};
use crate::storage::TableFile;
use crate::tools::inputs::{open_motion_stream, results_dir};
use crate::tools::{RunOptions, RunSummary};
use crate::writers::frame_log::{FrameLog, LogNames};
use crate::writers::knee_tables::{KneeKind, KneeTables};
use crate::writers::resume::resume_point;
use crate::writers::run_statistics::RunStatistics;
use crate::writers::so_tables::{SoTables, TablesSpec};
use crate::writers::sweep_statistics::{write_sweep_statistics, SweepStatistics};

// The per-frame stage (`frame`) holds the problem; these paths stay for users.
pub use crate::frame::problem::{
    force_file_row, status_code, ContactRows, Control, FrameResult, SoProblem, CONTACT_COLUMNS,
};
pub use crate::frame::settings::{
    ConstraintMatrix, StaticOptimizationSetup, CONTACT_WEIGHT_RANGE, DEFAULT_CONTACT_WEIGHT,
    DEFAULT_TOLERANCE,
};

pub use crate::writers::run_statistics::ROOT_RESIDUAL_WARNING;

pub use crate::writers::names::w0_tag;
use crate::writers::names::{self, OutputKind, RunKey, Sweep};

pub fn run(
    setup: &AnalyzeSetup,
    so: &StaticOptimizationSetup,
    reactions: &[JointReactionSetup],
    motion: &TableFile,
    model: Option<&AnalysisModel>,
    opts: &RunOptions,
) -> Result<RunSummary> {
    let (problem, mut warnings, reduction) = if setup.reduce_model {
        let am = match model {
            Some(am) => am.clone(),
            None => load_analysis_model(setup)?,
        };
        let (am, r) = crate::tools::reduce::reduce(
            setup,
            motion,
            &am,
            so.common.step_interval,
            so.passive_fiber_forces,
            reactions,
        )?;
        let (p, w) = SoProblem::build_from(setup, so, am)?;
        (p, w, Some(r))
    } else if let Some(am) = model {
        let (p, w) = SoProblem::build_from(setup, so, am.clone())?;
        (p, w, None)
    } else {
        // The motion's rows are parsed on the external loads' thread while
        // the model is read (the stream below takes them), and the frames'
        // worker threads are started there.
        let global = crate::frame::threads::frames_in_global_pool();
        let (p, w) = SoProblem::build_beside(setup, so, || {
            motion.parse_rows_ahead();
            crate::frame::threads::warm_global_pool(global);
        })?;
        (p, w, None)
    };
    // The states are streamed block by block (motion::stream): memory stays
    // flat however long the trial. Opened once: for the checks, the missing
    // coordinates and the frame count, then streamed by the one pass below.
    let stream = open_motion_stream(setup, motion, &problem.model, &problem.contacts)?;
    // Columns of coordinates a reduction removed are not the user's typos.
    let dropped = reduction
        .as_ref()
        .map(|r| r.coordinates_dropped.clone())
        .unwrap_or_default();
    warnings.extend(stream.motion_warnings(&dropped));
    warnings.extend(crate::tools::inputs::missing_columns_warning(
        setup,
        &stream.missing,
    ));
    let step_interval = so.common.step_interval;
    let dir = results_dir(setup, opts)?;
    let so_name = so.common.name.as_str();
    // Frames come from the runs' summaries: after a stop, those written.
    let mut summary = RunSummary {
        warnings: Vec::new(),
        ..Default::default()
    };
    if let Some(r) = &reduction {
        let path = dir.join(
            RunKey::analysis(&setup.name, so_name, Sweep::Single).file(OutputKind::Reduction),
        );
        r.write(&path)?;
        summary.files.push(path);
        warnings.extend(r.summary_lines());
    }
    // w0 weighs the contacts with the environment only (the knee
    // compartments of the knee contact method cost by their capacity): a
    // setup without contacts is solved once.
    let weights: Vec<f64> = if problem.contacts.is_empty() {
        if so.contact_weights.len() > 1 {
            warnings.push(format!(
                "{}: <contact_weight> gives {} values of w0, but the model has no contacts, so w0 changes nothing: the setup is solved once, without w0 in the file names",
                so.element.loc(),
                so.contact_weights.len()
            ));
        }
        vec![so.contact_weights[0]]
    } else {
        so.contact_weights.clone()
    };
    let sweep = weights.len() > 1;
    let mut jr_specs = Vec::new();
    for jr in reactions {
        let (specs, w) = resolve_reactions(&problem.model, jr)?;
        warnings.extend(w);
        jr_specs.push((jr.common.name.clone(), specs));
    }
    // The knee contact method reports each knee's reaction on its tibia
    // (tibia frame) besides the setup's own reactions; `<name>_KneeContact.sto`
    // is made from it.
    if !problem.knees.is_empty() {
        jr_specs.push((
            crate::tools::knee_contact_table::REACTIONS_NAME.to_string(),
            crate::tools::knee_contact_table::reaction_specs(&problem.model, &problem.knees),
        ));
    }
    let mut runs = Vec::new();
    let mut knee_files = Vec::new();
    let specs: Vec<RunSpec> = weights
        .iter()
        .map(|&w0| {
            let place = Sweep::of(w0, sweep);
            RunSpec {
                w0,
                run: RunKey::analysis(&setup.name, so_name, place),
                reactions: jr_specs
                    .iter()
                    .map(|(n, s)| (RunKey::analysis(&setup.name, n, place), s.as_slice()))
                    .collect(),
            }
        })
        .collect();
    // The tables this run's own consumers read (the knee tables, the
    // sweep's statistics): the run keeps them in memory until read
    // (`storage::results::want`), the others are in their files only.
    // A sweep's statistics of the runs' own tables are a sink of the frame
    // stream (a resumed sweep's are made of its tables, which hold the
    // frames it does not solve again).
    let precision = opts.precision.unwrap_or(setup.output_precision);
    let mut stats = (sweep && !opts.resume).then(|| {
        sweep_statistics_sink(
            setup,
            &problem,
            &specs,
            reactions.len(),
            &weights,
            &dir,
            precision,
        )
    });
    // The knee tables are a sink of the frame stream too (a resumed run's
    // are fed from its tables, which hold the frames it does not solve
    // again).
    let mut knees = knee_tables_sink(
        setup, &problem, &specs, reactions, &weights, &dir, precision,
    )?;
    let knees_from_tables = opts.resume && knees.is_some();
    let read_later = read_by_this_run(
        &specs,
        reactions,
        &problem,
        sweep,
        stats.is_none(),
        knees_from_tables,
        &dir,
    );
    read_later
        .iter()
        .for_each(|p| crate::storage::results::want(p));
    let swept = run_sweep(
        &problem,
        stream,
        setup,
        step_interval,
        &dir,
        &specs,
        opts,
        &RunKey::analysis(&setup.name, so_name, Sweep::Single).label(),
        stats.as_mut(),
        if knees_from_tables {
            None
        } else {
            knees.as_mut()
        },
    );
    let summaries = match swept {
        Ok(s) => s,
        Err(e) => {
            if let Some(stats) = stats {
                stats.abandon();
            }
            if let Some(knees) = knees {
                knees.abandon();
            }
            return Err(e);
        }
    };
    // A statement about a contact that every w0 of a sweep makes alike is
    // said once, for all of them (summary.contacts keeps one per w0).
    let mut summaries = summaries;
    let common = common_contact_lines(&mut summaries);
    for (spec, s) in specs.iter().zip(summaries) {
        let label = format!("w0 = {}", spec.w0);
        summary.absorb(s, sweep.then_some(label.as_str()));
        runs.push(spec.run.clone());
    }
    let all: Vec<String> = specs.iter().map(|r| r.w0.to_string()).collect();
    summary.warnings.extend(
        common
            .into_iter()
            .map(|m| format!("every w0 ({}): {m}", all.join(", "))),
    );
    if summary.stopped.is_some() {
        // The sweep's statistics need every w0: none are written.
        if let Some(stats) = stats {
            stats.abandon();
        }
        if let Some(knees) = knees {
            knees.abandon();
        }
        warnings.extend(std::mem::take(&mut summary.warnings));
        summary.warnings = warnings;
        return Ok(summary);
    }
    // The statistics the frame stream made, per kind in the order below.
    let mut streamed = match stats {
        Some(s) => s.finish()?.into_iter(),
        None => Vec::new().into_iter(),
    };
    // A resumed run's knee tables are made from its ReactionLoads tables,
    // which hold the frames it did not solve again.
    if let (true, Some(k)) = (knees_from_tables, knees.as_mut()) {
        knees_from_reaction_tables(k, setup, motion, &problem, &specs, &dir)?;
    }
    // The knee tables: per run, and their statistics (KneeLoads per
    // JointReaction, then KneeContact).
    let mut knee_stats = match knees {
        Some(k) => {
            let (per_run, stats) = k.finish()?;
            knee_files.extend(per_run.into_iter().flatten());
            Some(stats.into_iter())
        }
        None => None,
    };
    if sweep {
        for kind in OutputKind::SWEEP_TABLES {
            // A sweep of the knee contact method alone has no contact tables.
            if problem.contacts.is_empty() && kind.needs_contacts() {
                continue;
            }
            if let Some(files) = streamed.next() {
                summary.files.extend(files);
                continue;
            }
            let files: Vec<std::path::PathBuf> = runs
                .iter()
                .map(|r| dir.join(r.file(kind.clone())))
                .collect();
            let stat_path =
                |stat| dir.join(runs[0].with_sweep(Sweep::Stat(stat)).file(kind.clone()));
            summary.files.extend(write_sweep_statistics(
                &setup.setup_file,
                &files,
                &stat_path,
                &kind.table(),
                &weights,
                precision,
            )?);
            files.iter().for_each(|f| crate::storage::results::done(f));
        }
        for (jr_setup, (name, _)) in reactions.iter().zip(&jr_specs) {
            let kinds: &[OutputKind] = if jr_setup.knee_loads {
                &[OutputKind::ReactionLoads, OutputKind::KneeLoads]
            } else {
                &[OutputKind::ReactionLoads]
            };
            for kind in kinds {
                // (The KneeLoads' statistics are the knee tables'.)
                let made = match kind {
                    OutputKind::ReactionLoads => streamed.next(),
                    _ => knee_stats.as_mut().and_then(|k| k.next()),
                };
                if let Some(files) = made {
                    summary.files.extend(files);
                    continue;
                }
                if *kind != OutputKind::ReactionLoads {
                    return Err(Error::internal("a sweep's KneeLoads statistics not made"));
                }
                let run = |sweep| RunKey::analysis(&setup.name, name, sweep);
                let files: Vec<std::path::PathBuf> = weights
                    .iter()
                    .map(|w0| dir.join(run(Sweep::Weight(*w0)).file(kind.clone())))
                    .collect();
                let stat_path = |stat| dir.join(run(Sweep::Stat(stat)).file(kind.clone()));
                summary.files.extend(write_sweep_statistics(
                    &setup.setup_file,
                    &files,
                    &stat_path,
                    &kind.table(),
                    &weights,
                    precision,
                )?);
                files.iter().for_each(|f| crate::storage::results::done(f));
            }
        }
    }
    // The knee contact method's table: mean, min and max over w0 too.
    if let Some(files) = knee_stats.as_mut().and_then(|k| k.next()) {
        summary.files.extend(files);
    }
    summary.files.extend(knee_files);
    warnings.extend(summary.warnings);
    summary.warnings = warnings;
    Ok(summary)
}

/// The contact statements (writers::contact_findings) that every run of a
/// sweep makes with the same words, taken out of each run's warnings and
/// returned (none for a single run).
fn common_contact_lines(summaries: &mut [RunSummary]) -> Vec<String> {
    use crate::writers::contact_findings::FindingKind;
    if summaries.len() < 2 {
        return Vec::new();
    }
    let mut common: Vec<String> = summaries[0]
        .contacts
        .iter()
        .map(|f| f.message.clone())
        .filter(|m| {
            summaries[1..]
                .iter()
                .all(|s| s.contacts.iter().any(|f| &f.message == m))
        })
        .collect();
    // A contact that carried nothing at every w0, for the same reason, is
    // said once too: with the largest force of any w0, which bounds every
    // w0's (its reach is the motion's, the same at every w0).
    let mut merged = Vec::new();
    let mut said: Vec<Vec<String>> = Vec::new();
    for f in &summaries[0].contacts {
        if f.kind != FindingKind::CarriedNothing || common.contains(&f.message) {
            continue;
        }
        let alike: Option<Vec<&crate::writers::contact_findings::ContactFinding>> = summaries
            .iter()
            .map(|s| {
                s.contacts.iter().find(|g| {
                    g.kind == FindingKind::CarriedNothing
                        && g.contact == f.contact
                        && g.frames == f.frames
                        && g.reserve_body == f.reserve_body
                })
            })
            .collect();
        if let Some(alike) = alike {
            let most = alike
                .iter()
                .max_by(|a, b| a.value.total_cmp(&b.value))
                .expect("two or more runs");
            merged.push(most.message.clone());
            said.push(alike.iter().map(|g| g.message.clone()).collect::<Vec<_>>());
        }
    }
    for texts in said {
        for (s, text) in summaries.iter_mut().zip(texts) {
            s.warnings.retain(|w| *w != text);
        }
    }
    for s in summaries.iter_mut() {
        s.warnings.retain(|w| !common.contains(w));
    }
    common.extend(merged);
    common
}

/// A resumed run's knee tables (`knees`) fed from its runs' ReactionLoads
/// tables (which hold the frames it did not solve again) and the motion's
/// positions at their times; each table read is then done with.
fn knees_from_reaction_tables(
    knees: &mut KneeTables,
    setup: &AnalyzeSetup,
    motion: &TableFile,
    problem: &SoProblem,
    specs: &[RunSpec],
    dir: &std::path::Path,
) -> Result<()> {
    let states =
        crate::tools::inputs::load_motion_states(setup, motion, &problem.model, &problem.contacts)?;
    let used = knees.reactions();
    let mut paths = Vec::new();
    // Per run, per joint reaction: its table (the ones the knees use).
    let mut tables: Vec<Vec<Option<crate::storage::Storage>>> = Vec::new();
    for spec in specs {
        let mut run = Vec::new();
        for (k, (jr, _)) in spec.reactions.iter().enumerate() {
            if used.contains(&k) {
                let path = dir.join(jr.file(OutputKind::ReactionLoads));
                run.push(Some(crate::storage::read(&path)?));
                paths.push(path);
            } else {
                run.push(None);
            }
        }
        tables.push(run);
    }
    let first = tables
        .iter()
        .flatten()
        .flatten()
        .next()
        .ok_or_else(|| Error::internal("knee tables without reactions"))?;
    let times = first.time.clone();
    let mut rows: Vec<Vec<Vec<f64>>> = tables
        .iter()
        .map(|run| vec![Vec::new(); run.len()])
        .collect();
    for (i, &t) in times.iter().enumerate() {
        for (run, out) in tables.iter().zip(rows.iter_mut()) {
            for (table, row) in run.iter().zip(out.iter_mut()) {
                if let Some(table) = table {
                    let r = table.rows.get(i).ok_or_else(|| {
                        Error::internal("a resumed run's ReactionLoads tables differ in length")
                    })?;
                    row.clone_from(r);
                }
            }
        }
        let q = &states.q[crate::motion::coordinates::find_index(&states.time, t)];
        let refs: Vec<&[Vec<f64>]> = rows.iter().map(|r| r.as_slice()).collect();
        knees.push_rows(t, q, &refs)?;
    }
    paths.iter().for_each(|p| crate::storage::results::done(p));
    Ok(())
}

fn frame_count(i0: usize, i1: usize, step_interval: usize) -> usize {
    if i1 < i0 {
        return 0;
    }
    (i0..=i1)
        .filter(|&i| is_frame(i, i0, i1, step_interval))
        .count()
}

/// One run's outputs of a frame: the solution and its joint-reaction rows
/// (one per coupled JointReaction; `frame::so_loop`).
pub use crate::frame::so_loop::FrameOutput;

/// The work of one frame of a static optimization run: the frame solved
/// once per contact weight in `weights` ([`SoProblem::solve_frame_into`],
/// warm-started from the workspace's previous frame with `warm`) and, for
/// each weight, the joint reactions of each set of `reactions`
/// (`static_optimization_reactions`), into `out` (one entry per weight;
/// its buffers are reused, so that a frame allocates nothing once they
/// have their sizes: tests/allocations.rs).
#[allow(clippy::too_many_arguments)]
pub fn frame_outputs(
    problem: &SoProblem,
    weights: &[f64],
    reactions: &[&[ReactionSpec]],
    ws: &mut Workspace,
    t: f64,
    q: &[f64],
    u: &[f64],
    udot: &[f64],
    warm: bool,
    out: &mut Vec<FrameOutput>,
) -> Result<()> {
    if out.len() != weights.len() {
        out.resize_with(weights.len(), Default::default);
    }
    problem.solve_frame_into(
        t,
        q,
        u,
        udot,
        ws,
        weights,
        out.iter_mut().map(|(r, _)| r),
        warm,
    );
    for (r, rows) in out.iter_mut() {
        rows.resize_with(reactions.len(), Vec::new);
        for (row, specs) in rows.iter_mut().zip(reactions) {
            row.clear();
            row.resize(9 * specs.len(), 0.0);
            static_optimization_reactions(problem, t, r, ws, specs, row)?;
        }
    }
    Ok(())
}

/// A sweep's statistics of its runs' tables (the SO tables, then each
/// JointReaction's ReactionLoads) as a sink of the frame stream, in the
/// order the sweep lists them.
fn sweep_statistics_sink(
    setup: &AnalyzeSetup,
    problem: &SoProblem,
    specs: &[RunSpec],
    n_reactions: usize,
    weights: &[f64],
    dir: &std::path::Path,
    precision: usize,
) -> SweepStatistics {
    use crate::writers::sweep_statistics::Source;
    let mut stats = SweepStatistics::new(
        &setup.setup_file,
        weights,
        problem.controls.len(),
        precision,
    );
    let first = &specs[0];
    for kind in OutputKind::SWEEP_TABLES {
        if problem.contacts.is_empty() && kind.needs_contacts() {
            continue;
        }
        let (source, labels) = match kind {
            OutputKind::Activation => (Source::Activation, problem.labels.clone()),
            OutputKind::Force => (Source::Force, problem.force_labels.clone()),
            OutputKind::ContactForces => (Source::ContactForces, problem.contact_labels()),
            OutputKind::ContactBodyForces => {
                (Source::ContactBodyForces, problem.contact_body_labels())
            }
            OutputKind::GeneralizedForcesBySource => (
                Source::GeneralizedForcesBySource,
                problem.by_source_labels(),
            ),
            OutputKind::MusclePower => (Source::MusclePower, problem.muscle_labels()),
            _ => unreachable!("OutputKind::SWEEP_TABLES lists the SO tables"),
        };
        let path = |stat| dir.join(first.run.with_sweep(Sweep::Stat(stat)).file(kind.clone()));
        stats.add(source, &kind.table(), &labels, &path);
    }
    for (k, (jr, specs)) in first.reactions.iter().enumerate().take(n_reactions) {
        let kind = OutputKind::ReactionLoads;
        let path = |stat| dir.join(jr.with_sweep(Sweep::Stat(stat)).file(kind.clone()));
        stats.add(
            Source::Reaction(k),
            &kind.table(),
            &crate::reactions::column_labels(specs),
            &path,
        );
    }
    stats
}

/// The knee tables of a run (each JointReaction's KneeLoads, then the
/// knee contact method's KneeContact) as a sink of the frame stream, with
/// their statistics in a sweep; None when the run has none.
fn knee_tables_sink<'a>(
    setup: &AnalyzeSetup,
    problem: &'a SoProblem,
    specs: &[RunSpec],
    reactions: &[JointReactionSetup],
    weights: &[f64],
    dir: &std::path::Path,
    precision: usize,
) -> Result<Option<KneeTables<'a>>> {
    let mut knees = KneeTables::new(
        &problem.model,
        &problem.knees,
        &setup.setup_file,
        weights,
        precision,
    );
    let Some(first) = specs.first() else {
        return Ok(None);
    };
    for (k, (jr_setup, (jr, jr_specs))) in reactions.iter().zip(&first.reactions).enumerate() {
        if !jr_setup.knee_loads {
            continue;
        }
        // The sides' columns in the ReactionLoads table (its path in errors).
        let table = crate::storage::Storage {
            labels: crate::reactions::column_labels(jr_specs),
            ..Default::default()
        };
        let path = dir.join(jr.file(OutputKind::ReactionLoads));
        let (sides, patella) = crate::reactions::knee_loads::sides(&problem.model, &table, &path)?;
        let paths = specs
            .iter()
            .map(|s| dir.join(s.reactions[k].0.file(OutputKind::KneeLoads)))
            .collect();
        let stat_path =
            |stat| dir.join(jr.with_sweep(Sweep::Stat(stat)).file(OutputKind::KneeLoads));
        knees.add(
            KneeKind::Loads {
                reaction: k,
                sides: Box::new(sides),
                patella,
            },
            paths,
            &stat_path,
            &OutputKind::KneeLoads.table(),
        );
    }
    if !problem.knees.is_empty() {
        let reaction = first.reactions.len() - 1;
        let paths = specs
            .iter()
            .map(|s| {
                dir.join(RunKey::setup(&setup.name, s.run.sweep).file(OutputKind::KneeContact))
            })
            .collect();
        let stat_path = |stat| {
            dir.join(RunKey::setup(&setup.name, Sweep::Stat(stat)).file(OutputKind::KneeContact))
        };
        knees.add(
            KneeKind::Contact { reaction },
            paths,
            &stat_path,
            &OutputKind::KneeContact.table(),
        );
    }
    Ok((!knees.is_empty()).then_some(knees))
}

/// The tables of a run's `specs` that the run's own consumers read after
/// writing them, once per consumer (`storage::results::want`): each
/// JointReaction's ReactionLoads for its knee loads, the knee contact
/// reactions for the knee contact table, and in a w0 sweep every table
/// the statistics average. [`run`] reads exactly these.
fn read_by_this_run(
    specs: &[RunSpec],
    reactions: &[JointReactionSetup],
    problem: &SoProblem,
    sweep: bool,
    stats_from_tables: bool,
    knees_from_tables: bool,
    dir: &std::path::Path,
) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for spec in specs {
        for (jr_setup, (jr, _)) in reactions.iter().zip(&spec.reactions) {
            let mut kinds = Vec::new();
            let knee_loads = jr_setup.knee_loads && knees_from_tables;
            if knee_loads {
                kinds.push(OutputKind::ReactionLoads);
            }
            if sweep && stats_from_tables {
                kinds.push(OutputKind::ReactionLoads);
            }
            out.extend(kinds.into_iter().map(|k| dir.join(jr.file(k))));
        }
        if knees_from_tables && !problem.knees.is_empty() {
            if let Some((jr, _)) = spec.reactions.last() {
                out.push(dir.join(jr.file(OutputKind::ReactionLoads)));
            }
        }
        if sweep && stats_from_tables {
            for kind in OutputKind::SWEEP_TABLES {
                if !(problem.contacts.is_empty() && kind.needs_contacts()) {
                    out.push(dir.join(spec.run.file(kind.clone())));
                }
            }
        }
    }
    out
}

/// One run of a sweep: its contact weight, its tables' run and its
/// joint-reaction tables' runs (`writers::names`).
struct RunSpec<'a> {
    w0: f64,
    run: RunKey,
    reactions: Vec<(RunKey, &'a [ReactionSpec])>,
}

/// The tables, log and running statistics of one run.
struct RunWriters<'a> {
    problem: &'a SoProblem,
    tables: SoTables,
    log_path: std::path::PathBuf,
    /// The log (lent to the thread that writes it while the frames run).
    log: Option<FrameLog>,
    /// Frames a resumed run already holds (t <= this) are not written again.
    skip_until: f64,
    stats: RunStatistics,
}

impl<'a> RunWriters<'a> {
    fn open(
        problem: &'a SoProblem,
        setup: &AnalyzeSetup,
        dir: &std::path::Path,
        spec: &RunSpec,
        log_names: &LogNames,
        opts: &RunOptions,
    ) -> Result<RunWriters<'a>> {
        let run = &spec.run;
        let reactions = &spec.reactions;
        let precision = opts.precision.unwrap_or(setup.output_precision);
        let resume = if opts.resume {
            resume_point(dir, run, problem, reactions)?
        } else {
            None
        };
        let mut stats = RunStatistics::new(problem);
        if let Some(r) = &resume {
            // The frames an earlier run wrote count in this run's summary:
            // read back before the tables are reopened.
            stats.observe_tables(problem, dir, run, r.keep)?;
        }
        let tables = SoTables::open(
            problem,
            &TablesSpec {
                setup_file: &setup.setup_file,
                dir,
                run,
                w0: spec.w0,
                reactions,
                precision,
                keep: resume.as_ref().map(|r| r.keep),
            },
        )?;
        let log_path = dir.join(run.file(OutputKind::Log));
        // A run kept in memory (storage::results) logs nothing: the log is
        // a file's.
        let log = if crate::storage::results::writes_file(&log_path) {
            let mut log = FrameLog::create(&log_path, log_names)?;
            if let Some(r) = &resume {
                log.replay(&r.messages)?;
            }
            Some(log)
        } else {
            None
        };
        let skip_until = resume.as_ref().map_or(f64::NEG_INFINITY, |r| r.last_time);
        Ok(RunWriters {
            problem,
            tables,
            log_path,
            log,
            skip_until,
            stats,
        })
    }

    /// Write one frame's tables (in frame order; the log thread writes
    /// the log, [`FrameLog::write_frame`]).
    fn write(&mut self, r: &FrameResult, jr_rows: &[Vec<f64>]) -> Result<()> {
        if r.time <= self.skip_until {
            return Ok(());
        }
        self.tables.write(r, jr_rows)?;
        self.stats.observe(self.problem, r);
        Ok(())
    }

    fn finish(
        self,
        nframes: usize,
        loop_seconds: f64,
        completed: bool,
        shared: usize,
    ) -> Result<RunSummary> {
        let problem = self.problem;
        let diag_path = self.tables.diag_path.clone();
        let mut files = self.tables.finish()?;
        if let Some(log) = self.log {
            log.finish()?;
            files.push(self.log_path);
        }
        let mut stats = self.stats;
        // A stopped run counts the frames its tables hold (a resumed run's
        // earlier frames included), not the frames it meant to solve.
        let nframes = if completed { nframes } else { stats.frames };
        let warnings = stats.warnings(problem, nframes, &diag_path);
        let root_body_weight = stats.root_body_weight(problem);
        let note = if shared > 1 {
            // One line for the sweep (the first run's; see sweep_note).
            String::new()
        } else {
            format!(
                "static optimization: {} frames in {:.3} s ({:.0} frames/s)",
                nframes,
                loop_seconds,
                nframes as f64 / loop_seconds.max(1e-12)
            )
        };
        Ok(RunSummary {
            frames: nframes,
            files,
            warnings,
            loop_seconds,
            solves: nframes,
            failed: stats.failures.len(),
            first_failure: stats
                .failures
                .first()
                .map(|f| format!("{f}; see {}", diag_path.display())),
            worst_residual: stats.worst_residual,
            reserve_peak: stats.reserve_peak(),
            root_body_weight,
            root_force_peak: stats.root_peaks[0].clone(),
            root_moment_peak: stats.root_peaks[1].clone(),
            root_force_series: std::mem::take(&mut stats.root_force_series),
            contacts: stats.contact_findings(problem),
            notes: vec![note],
            results_dirs: Vec::new(),
            unused_properties: Vec::new(),
            stopped: (!completed).then(|| {
                (
                    crate::tools::interrupt::requested().unwrap_or(130),
                    stats.last,
                )
            }),
        })
    }
}

/// Static optimization over the motion for every run of `runs` (the
/// weights of a w0 sweep): one pass over the frames; per frame the physics
/// is assembled once and the problem solved once per weight
/// ([`SoProblem::solve_frame_weights`]), each run's joint reactions and
/// tables written from its own solution. One summary per run.
/// `label` names the pass in progress reports (`<setup>_<analysis>`: one
/// pass serves every w0).
#[allow(clippy::too_many_arguments)]
fn run_sweep(
    problem: &SoProblem,
    mut stream: crate::motion::stream::StateStream,
    setup: &AnalyzeSetup,
    step_interval: usize,
    dir: &std::path::Path,
    runs: &[RunSpec],
    opts: &RunOptions,
    label: &str,
    mut stats: Option<&mut SweepStatistics>,
    mut knees: Option<&mut KneeTables>,
) -> Result<Vec<RunSummary>> {
    let log_names: Vec<LogNames> = runs
        .iter()
        .map(|r| LogNames::new(problem, r.reactions.first().map(|(_, s)| *s)))
        .collect();
    let (i0, i1) = (stream.first_row, stream.last_row);
    let nframes = frame_count(i0, i1, step_interval);
    // The output files are created (an existing file's truncation waits on
    // the disk) and their headers and the log's schemas written on a thread
    // of their own while the first block of states is computed. The loop's
    // time counts that block, not the wait for the files.
    // With `<close_contacts>` the first block (which closes the contacts on
    // the rows up to it, and says where a closure fails) is computed before
    // any output file is touched.
    let early = if stream.transforms_rows() {
        let t = Instant::now();
        Some((stream.next_block()?, t.elapsed()))
    } else {
        None
    };
    let run = crate::storage::results::context();
    let (writers, first, first_block) = std::thread::scope(|scope| {
        let opening = scope.spawn(|| {
            let _run = run.enter();
            runs.iter()
                .zip(&log_names)
                .map(|(r, names)| RunWriters::open(problem, setup, dir, r, names, opts))
                .collect::<Result<Vec<_>>>()
        });
        let t = Instant::now();
        let (first, first_block) = match early {
            Some((block, took)) => (Ok(block), took),
            None => (stream.next_block(), t.elapsed()),
        };
        let writers = opening
            .join()
            .unwrap_or_else(|_| Err(Error::internal("opening the output files panicked")));
        (writers, first, first_block)
    });
    let now = Instant::now();
    let start = now.checked_sub(first_block).unwrap_or(now);
    let writers = writers?;
    let mut stream = crate::frame::driver::PreparingLoads::new(
        crate::frame::driver::Prefetched::new(first?, &mut stream),
        problem.loads.as_ref(),
    );
    let skip_until = writers
        .iter()
        .map(|w| w.skip_until)
        .fold(f64::INFINITY, f64::min);
    let weights: Vec<f64> = runs.iter().map(|r| r.w0).collect();
    let mut progress = crate::tools::progress::bar(nframes as u64, opts, label);
    // Every run has the same joint reactions (only their tables differ).
    let reactions: Vec<&[ReactionSpec]> = runs
        .first()
        .map(|r| r.reactions.iter().map(|(_, s)| *s).collect())
        .unwrap_or_default();
    // The frame stage solves the frames (frame::so_loop: in parallel
    // groups, in frame order) and hands each frame's results to two sinks,
    // each on a thread of its own (on gait2392 each about as much work,
    // together about as much as the solving; one thread doing both ran on
    // alone for a third of the loop): the tables (with the run's
    // statistics, and the frames' positions for the knee tables) and the
    // log, which encodes each frame's messages.
    let solve = |ws: &mut Workspace, f: &Frame, out: &mut Vec<FrameOutput>| {
        frame_outputs(
            problem, &weights, &reactions, ws, f.t, f.q, f.u, f.udot, f.warm, out,
        )
    };
    let mut writers = writers;
    let mut logs: RunLogs = writers
        .iter_mut()
        .filter_map(|w| w.log.take().map(|log| (log, w.skip_until)))
        .collect();
    let mut tables = |results: &[FrameOutput]| -> Result<()> {
        for (w, (r, rows)) in writers.iter_mut().zip(results.iter()) {
            w.write(r, rows)?;
        }
        if let Some(stats) = stats.as_deref_mut() {
            stats.push(results)?;
        }
        if let Some(knees) = knees.as_deref_mut() {
            knees.push(results)?;
        }
        Ok(())
    };
    // (A run kept in memory has no log: storage::results.)
    let logging = !logs.is_empty();
    let mut log = |results: &[FrameOutput]| write_logs(&mut logs, &log_names, problem, results);
    let mut sinks: Vec<Sink> = vec![&mut tables];
    if logging {
        sinks.push(&mut log);
    }
    let completed = solve_frames(
        problem,
        &mut stream,
        i0,
        i1,
        step_interval,
        skip_until,
        &solve,
        sinks,
        || progress.inc(1),
    );
    let completed = completed?;
    // Each log back to its run, finished with its tables.
    for (w, (log, _)) in writers.iter_mut().zip(logs) {
        w.log = Some(log);
    }
    progress.finish_and_clear();
    let shared = runs.len();
    let loop_seconds = start.elapsed().as_secs_f64() / shared as f64;
    let sweep = (shared > 1).then(|| sweep_note(runs, nframes, loop_seconds * shared as f64));
    let summaries = writers
        .into_iter()
        .enumerate()
        .map(|(i, w)| {
            let mut s = w.finish(nframes, loop_seconds, completed, shared)?;
            s.results_dirs = vec![dir.to_path_buf()];
            s.notes.retain(|n| !n.is_empty());
            if i == 0 {
                s.notes.extend(sweep.clone());
            }
            Ok(s)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(summaries)
}

/// The one line that says how long a w0 sweep took (it used to be said
/// once per weight, the same time each).
fn sweep_note(runs: &[RunSpec], nframes: usize, seconds: f64) -> String {
    let name = runs[0].run.label();
    let weights: Vec<String> = runs.iter().map(|r| names::w0_tag(r.w0)).collect();
    format!(
        "static optimization ({}, w0 = {}): {} frames in {:.3} s for the {} weights (the physics assembled once per frame)",
        name,
        weights.join(", "),
        nframes,
        seconds,
        runs.len()
    )
}

/// Each run's log and the time up to which a resumed run already holds
/// its frames.
type RunLogs = Vec<(FrameLog, f64)>;

/// Each run's log messages of one frame (runs a resumed run already holds
/// up to its `skip_until` are not logged again).
fn write_logs(
    logs: &mut [(FrameLog, f64)],
    names: &[LogNames],
    problem: &SoProblem,
    results: &[FrameOutput],
) -> Result<()> {
    for (((log, skip_until), names), (r, rows)) in logs.iter_mut().zip(names).zip(results) {
        if r.time > *skip_until {
            log.write_frame(names, problem, r, rows)?;
        }
    }
    Ok(())
}
