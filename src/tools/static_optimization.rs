//! The StaticOptimization analysis (opensim-semantics.md §6) as a driver:
//! it compiles the run's problem ([`SoProblem::build`], in
//! [`crate::frame::compile`]: the model's forces
//! sorted into controls, passive forces, contacts and reserves), streams the
//! states, hands each frame to the frame stage
//! ([`crate::frame::problem`], through [`crate::frame::driver`]) and joint
//! reactions to [`crate::reactions`], and has the tables
//! ([`crate::writers::so_tables`]) and the MCAP log
//! ([`crate::writers::frame_log`]) written on threads of their own, with the
//! run's statistics ([`crate::writers::run_statistics`]); a w0 sweep solves
//! each frame's physics once
//! (its mean, min and max tables: [`crate::writers::sweep_statistics`]);
//! a run can resume where an earlier one stopped
//! ([`crate::writers::resume`]).

use std::time::Instant;

use crate::error::{Error, Result};
use crate::forces::analysis_model::{load_analysis_model, AnalysisModel};
use crate::frame::driver::for_each_frame_grouped;
use crate::frame::driver::is_frame;
use crate::frame::workspace::Workspace;
use crate::parse::setup::AnalyzeSetup;
use crate::reactions::{
    resolve_reactions, static_optimization_reactions, JointReactionSetup, ReactionSpec,
};
use crate::storage::TableFile;
use crate::tools::inputs::{open_motion_stream, results_dir};
use crate::tools::{RunOptions, RunSummary};
use crate::writers::frame_log::{FrameLog, LogNames};
use crate::writers::resume::resume_point;
use crate::writers::run_statistics::RunStatistics;
use crate::writers::so_tables::{SoTables, TablesSpec};
use crate::writers::sweep_statistics::write_sweep_statistics;

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
use crate::writers::names::{self, Sweep};

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
        let (p, w) = SoProblem::build(setup, so)?;
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
        let path = dir.join(names::file_name(
            &setup.name,
            so_name,
            Sweep::Single,
            "reduction.txt",
        ));
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
    let mut prefixes = Vec::new();
    let mut knee_files = Vec::new();
    let specs: Vec<RunSpec> = weights
        .iter()
        .map(|&w0| {
            let run = if sweep {
                Sweep::Weight(w0)
            } else {
                Sweep::Single
            };
            let prefix = names::prefix(&setup.name, so_name, run);
            let jr_prefix = |name: &str| names::prefix(&setup.name, name, run);
            RunSpec {
                w0,
                prefix,
                reactions: jr_specs
                    .iter()
                    .map(|(n, s)| (jr_prefix(n), s.as_slice()))
                    .collect(),
            }
        })
        .collect();
    // The knee loads and the knee contact table take the knee angles of
    // the frames the pass solved (the motion is read once); a resumed pass
    // solves only its remaining frames, and they read the motion again.
    let wants_positions = reactions.iter().any(|jr| jr.knee_loads) || !problem.knees.is_empty();
    let (summaries, positions) = run_sweep(
        &problem,
        stream,
        setup,
        step_interval,
        &dir,
        &specs,
        opts,
        &format!("{}_{so_name}", setup.name),
        wants_positions,
    )?;
    let mut knee_states = positions;
    // A statement about a contact that every w0 of a sweep makes alike is
    // said once, for all of them (summary.contacts keeps one per w0).
    let mut summaries = summaries;
    let common = common_contact_lines(&mut summaries);
    for (spec, s) in specs.iter().zip(summaries) {
        let stopped = s.stopped.is_some();
        if !stopped {
            for (jr_setup, (p, _)) in reactions.iter().zip(&spec.reactions) {
                if jr_setup.knee_loads {
                    let states = knee_states_of(&mut knee_states, setup, motion, &problem)?;
                    let table = dir.join(format!("{p}ReactionLoads.sto"));
                    knee_files.push(crate::tools::knee_loads::write(
                        &problem.model,
                        &states.0,
                        &states.1,
                        &table,
                        &crate::tools::knee_loads::output_path(&table),
                        &setup.setup_file,
                        opts.precision.unwrap_or(setup.output_precision),
                    )?);
                }
            }
        }
        if !stopped && !problem.knees.is_empty() {
            let states = knee_states_of(&mut knee_states, setup, motion, &problem)?;
            let (p, _) = spec.reactions.last().expect("the knee contact reactions");
            let out = names::setup_file_name(
                &setup.name,
                if sweep {
                    Sweep::Weight(spec.w0)
                } else {
                    Sweep::Single
                },
                "KneeContact.sto",
            );
            knee_files.push(crate::tools::knee_contact_table::write(
                &problem.model,
                &problem.knees,
                &states.0,
                &states.1,
                &dir.join(format!("{p}ReactionLoads.sto")),
                &dir.join(out),
                &setup.setup_file,
                opts.precision.unwrap_or(setup.output_precision),
            )?);
        }
        let label = format!("w0 = {}", spec.w0);
        summary.absorb(s, sweep.then_some(label.as_str()));
        prefixes.push(spec.prefix.clone());
    }
    let all: Vec<String> = specs.iter().map(|r| r.w0.to_string()).collect();
    summary.warnings.extend(
        common
            .into_iter()
            .map(|m| format!("every w0 ({}): {m}", all.join(", "))),
    );
    if summary.stopped.is_some() {
        // The sweep's statistics need every w0: none are written.
        warnings.extend(std::mem::take(&mut summary.warnings));
        summary.warnings = warnings;
        return Ok(summary);
    }
    if sweep {
        let precision = opts.precision.unwrap_or(setup.output_precision);
        for kind in [
            "activation",
            "force",
            "ContactForces",
            "ContactBodyForces",
            "GeneralizedForcesBySource",
            "MusclePower",
        ] {
            // A sweep of the knee contact method alone has no contact tables.
            if problem.contacts.is_empty() && kind.starts_with("Contact") {
                continue;
            }
            let files: Vec<std::path::PathBuf> = prefixes
                .iter()
                .map(|p| dir.join(format!("{p}{kind}.sto")))
                .collect();
            let stat_path = |stat: &str| {
                dir.join(names::file_name(
                    &setup.name,
                    so_name,
                    Sweep::Stat(stat),
                    &format!("{kind}.sto"),
                ))
            };
            summary.files.extend(write_sweep_statistics(
                &setup.setup_file,
                &files,
                &stat_path,
                kind,
                &weights,
                precision,
            )?);
        }
        for (jr_setup, (name, _)) in reactions.iter().zip(&jr_specs) {
            let kinds: &[&str] = if jr_setup.knee_loads {
                &["ReactionLoads", "KneeLoads"]
            } else {
                &["ReactionLoads"]
            };
            for kind in kinds {
                let files: Vec<std::path::PathBuf> = weights
                    .iter()
                    .map(|w0| {
                        dir.join(names::file_name(
                            &setup.name,
                            name,
                            Sweep::Weight(*w0),
                            &format!("{kind}.sto"),
                        ))
                    })
                    .collect();
                let stat_path = |stat: &str| {
                    dir.join(names::file_name(
                        &setup.name,
                        name,
                        Sweep::Stat(stat),
                        &format!("{kind}.sto"),
                    ))
                };
                summary.files.extend(write_sweep_statistics(
                    &setup.setup_file,
                    &files,
                    &stat_path,
                    kind,
                    &weights,
                    precision,
                )?);
            }
        }
    }
    if sweep && !problem.knees.is_empty() {
        // The knee contact method's table: mean, min and max over w0 too.
        let precision = opts.precision.unwrap_or(setup.output_precision);
        let files: Vec<std::path::PathBuf> = weights
            .iter()
            .map(|w0| {
                dir.join(names::setup_file_name(
                    &setup.name,
                    Sweep::Weight(*w0),
                    "KneeContact.sto",
                ))
            })
            .collect();
        let stat_path = |stat: &str| {
            dir.join(names::setup_file_name(
                &setup.name,
                Sweep::Stat(stat),
                "KneeContact.sto",
            ))
        };
        summary.files.extend(write_sweep_statistics(
            &setup.setup_file,
            &files,
            &stat_path,
            "KneeContact",
            &weights,
            precision,
        )?);
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

/// The frames' times and positions (`q`) for the knee loads and the knee
/// contact table: those the pass solved (`cache`), or, when it did not keep
/// them all (a resumed run), the run's states read from the motion once.
#[allow(clippy::type_complexity)]
fn knee_states_of<'a>(
    cache: &'a mut Option<Positions>,
    setup: &AnalyzeSetup,
    motion: &TableFile,
    problem: &crate::frame::problem::SoProblem,
) -> Result<&'a Positions> {
    if cache.is_none() {
        let states = crate::tools::inputs::load_motion_states(
            setup,
            motion,
            &problem.model,
            &problem.contacts,
        )?;
        *cache = Some((states.time, states.q));
    }
    Ok(cache.as_ref().expect("just read"))
}

/// Frames' times and generalized coordinates, in frame order.
type Positions = (Vec<f64>, Vec<Vec<f64>>);

fn frame_count(i0: usize, i1: usize, step_interval: usize) -> usize {
    if i1 < i0 {
        return 0;
    }
    (i0..=i1)
        .filter(|&i| is_frame(i, i0, i1, step_interval))
        .count()
}

/// One run's outputs of a frame: the solution and its joint-reaction rows
/// (one per coupled JointReaction).
pub type FrameOutput = (FrameResult, Vec<Vec<f64>>);

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

/// One run of a sweep: its contact weight, the prefix of its tables and the
/// prefixes of its joint-reaction tables.
struct RunSpec<'a> {
    w0: f64,
    prefix: String,
    reactions: Vec<(String, &'a [ReactionSpec])>,
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
        let prefix = spec.prefix.as_str();
        let reactions = &spec.reactions;
        let precision = opts.precision.unwrap_or(setup.output_precision);
        let resume = if opts.resume {
            resume_point(dir, prefix, problem, reactions)?
        } else {
            None
        };
        let mut stats = RunStatistics::new(problem);
        if let Some(r) = &resume {
            // The frames an earlier run wrote count in this run's summary:
            // read back before the tables are reopened.
            stats.observe_tables(problem, dir, prefix, r.keep)?;
        }
        let tables = SoTables::open(
            problem,
            &TablesSpec {
                setup_file: &setup.setup_file,
                dir,
                prefix,
                w0: spec.w0,
                reactions,
                precision,
                keep: resume.as_ref().map(|r| r.keep),
            },
        )?;
        let log_path = dir.join(format!("{prefix}log.mcap"));
        let mut log = FrameLog::create(&log_path, log_names)?;
        if let Some(r) = &resume {
            log.replay(&r.messages)?;
        }
        let skip_until = resume.as_ref().map_or(f64::NEG_INFINITY, |r| r.last_time);
        Ok(RunWriters {
            problem,
            tables,
            log_path,
            log: Some(log),
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
        files.push(self.log_path);
        if let Some(log) = self.log {
            log.finish()?;
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
    keep_positions: bool,
) -> Result<(Vec<RunSummary>, Option<Positions>)> {
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
    let (writers, first, first_block) = std::thread::scope(|scope| {
        let opening = scope.spawn(|| {
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
    // States block by block; frames in chunks: solved in parallel, written
    // in order, so the output holds every finished frame and memory stays
    // bounded by the block.
    // Tables and the log are formatted and written off the solving threads,
    // on two threads of their own (on gait2392 each about as much work,
    // together about as much as the solving; one writer thread doing both
    // ran on alone for a third of the loop): the table writer owns the
    // tables, the log thread encodes each frame's messages and owns the
    // logs. Both take each frame's results in order, while the next chunk
    // of frames is solved, from one shared buffer.
    let (tx, rx) = std::sync::mpsc::sync_channel::<Shared>(FRAMES_IN_FLIGHT);
    let (log_tx, log_rx) = std::sync::mpsc::sync_channel::<Shared>(FRAMES_IN_FLIGHT);
    // Every run has the same joint reactions (only their tables differ).
    let reactions: Vec<&[ReactionSpec]> = runs
        .first()
        .map(|r| r.reactions.iter().map(|(_, s)| *s).collect())
        .unwrap_or_default();
    // Output buffers both writers have finished with, for the solving
    // threads to fill again: a frame's results allocate nothing once there
    // are enough of them (at most the frames in flight).
    let recycled: std::sync::Mutex<Vec<Shared>> = Default::default();
    // The last of the two writers to let go of a frame's buffer hands it
    // back. Under the pool's lock: the first one drops its reference there,
    // so the second sees the count fall to 1.
    let release = |results: Shared| {
        if let Ok(mut pool) = recycled.lock() {
            if std::sync::Arc::strong_count(&results) == 1 {
                pool.push(results);
            } else {
                drop(results);
            }
            drop(pool);
        }
    };
    let mut writers = writers;
    let mut logs: RunLogs = writers
        .iter_mut()
        .filter_map(|w| w.log.take().map(|log| (log, w.skip_until)))
        .collect();
    let (completed, writers) =
        std::thread::scope(|scope| -> Result<(bool, (Vec<RunWriters>, Positions))> {
            let log_names = &log_names;
            let release = &release;
            let writer = scope.spawn(move || -> Result<(Vec<RunWriters>, Positions)> {
                let mut positions: Positions = Default::default();
                for results in rx {
                    if keep_positions {
                        if let Some((r, _)) = results.first() {
                            positions.0.push(r.time);
                            positions.1.push(r.q.clone());
                        }
                    }
                    for (w, (r, rows)) in writers.iter_mut().zip(results.iter()) {
                        w.write(r, rows)?;
                    }
                    release(results);
                }
                Ok((writers, positions))
            });
            let log_writer = scope.spawn(move || -> Result<RunLogs> {
                for results in log_rx {
                    write_logs(&mut logs, log_names, problem, &results)?;
                    release(results);
                }
                Ok(logs)
            });
            // Frames in fixed groups (frame::driver::GROUP): the first of a
            // group solved cold, the others warm-started from the frame before.
            let completed = for_each_frame_grouped(
                &mut stream,
                i0,
                i1,
                step_interval,
                || Workspace::new(&problem.model, &problem.muscles),
                |ws, block, i, pos| {
                    // Groups every resumed run already holds whole are not
                    // computed again; a group the resume point falls in is solved
                    // from its start (for the same warm starts as an
                    // uninterrupted run), its frames written from that point on.
                    if block.time[pos.last] <= skip_until {
                        return Ok(None);
                    }
                    // (A pooled buffer is held by nobody else: `release`.)
                    let mut shared = recycled
                        .lock()
                        .ok()
                        .and_then(|mut pool| pool.pop())
                        .unwrap_or_default();
                    let out = std::sync::Arc::get_mut(&mut shared)
                        .ok_or_else(|| Error::internal("a pooled frame buffer still shared"))?;
                    frame_outputs(
                        problem,
                        &weights,
                        &reactions,
                        ws,
                        block.time[i],
                        &block.q[i],
                        &block.u[i],
                        &block.udot[i],
                        !pos.first,
                        out,
                    )?;
                    if block.time[i] <= skip_until {
                        release(shared);
                        return Ok(None);
                    }
                    Ok(Some(shared))
                },
                |item| {
                    let Some(results) = item else {
                        return Ok(());
                    };
                    // The writers format and write in frame order; a closed
                    // channel means one stopped on an error, reported below.
                    if log_tx.send(results.clone()).is_err() || tx.send(results).is_err() {
                        return Err(Error::internal("the table writer stopped"));
                    }
                    progress.inc(1);
                    Ok(())
                },
            );
            drop(tx);
            drop(log_tx);
            let written = writer
                .join()
                .unwrap_or_else(|_| Err(Error::internal("the table writer panicked")));
            let logged = log_writer
                .join()
                .unwrap_or_else(|_| Err(Error::internal("the log writer panicked")));
            // The writers' own errors say more than the loop's closed channel.
            let (mut writers, positions) = written?;
            // Each log back to its run, finished with its tables.
            for (w, (log, _)) in writers.iter_mut().zip(logged?) {
                w.log = Some(log);
            }
            Ok((completed?, (writers, positions)))
        })?;
    let (writers, positions) = writers;
    // Every frame's, unless a resumed run skipped those it held.
    let positions = (keep_positions && skip_until == f64::NEG_INFINITY).then_some(positions);
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
    Ok((summaries, positions))
}

/// The one line that says how long a w0 sweep took (it used to be said
/// once per weight, the same time each).
fn sweep_note(runs: &[RunSpec], nframes: usize, seconds: f64) -> String {
    let name = names::without_w0(&runs[0].prefix);
    let weights: Vec<String> = runs.iter().map(|r| names::w0_tag(r.w0)).collect();
    format!(
        "static optimization ({}, w0 = {}): {} frames in {:.3} s for the {} weights (the physics assembled once per frame)",
        name.trim_end_matches('_'),
        weights.join(", "),
        nframes,
        seconds,
        runs.len()
    )
}

/// One frame's results, shared by the table writer and the log thread.
type Shared = std::sync::Arc<Vec<FrameOutput>>;

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

/// Frames handed to the table writer and not yet written, at most: the
/// solving threads run ahead of the formatting by this much (memory stays
/// bounded).
const FRAMES_IN_FLIGHT: usize = 512;
