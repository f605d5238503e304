//! A force sweep: many candidates of one AnalyzeTool setup that differ only
//! in forces — w0, an `ExpressionBasedCoordinateForce`'s expression (a
//! machine's resistance torque), an actuator's optimal force, an external
//! load's scale — share one compiled scene, with or without the knee
//! contact method (`<knee_contact>`: its rows are affine in those forces,
//! `frame::candidates`; its `<setup>_KneeContact.sto` columns can be
//! metrics). The setup is compiled once and the motion (with its
//! contact closure) streamed once; each frame is assembled once
//! ([`SoProblem::assemble`]) and solved for every candidate
//! ([`SoProblem::solve_candidate_into`], `frame::candidates`), each
//! candidate warm-started from the previous candidate of the same w0 in
//! the frame (the same answers as a cold start, up to rounding), its joint
//! reactions from the frame's affine reaction basis
//! ([`ReactionBasis`]). Each candidate's values of the setup's `<Metric>`
//! elements are computed from the rows it would have written (the same
//! `op`s, [`metric_value`]), with the candidate's own w0 whatever w0 tag a
//! metric's file names; its tables are written only on request
//! ([`SweepOptions::tables`]: those a run of its own setup writes).
//!
//! Candidates' metrics equal those of runs of each candidate's own setup
//! (tests/force_sweep.rs: 1e-9 relative), as the frames are those runs'
//! frames: the setup's `<Metric>`s read tables written to
//! `output_precision` decimals, this sweep the unrounded values.

use std::time::Instant;

use crate::error::{Error, Location, Result};
use crate::forces::lepton::Expression;
use crate::forces::passive::PassiveForce;
use crate::frame::candidates::{CandidateScratch, ForceCandidate};
use crate::frame::driver::{for_each_frame, Prefetched, PreparingLoads};
use crate::frame::problem::{status_code, Control, FrameResult, Outputs, SoProblem};
use crate::frame::settings::{ConstraintMatrix, StaticOptimizationSetup, CONTACT_WEIGHT_RANGE};
use crate::frame::threads::in_pool;
use crate::frame::workspace::Workspace;
use crate::parse::setup::{Analysis, AnalyzeSetup, Setup};
use crate::plan::figures::{FigureOrMetric, MetricOp, MetricSpec};
use crate::reactions::linear::ReactionBasis;
use crate::reactions::{column_labels, resolve_reactions, ReactionSpec};
use crate::tools::figures::metric_value;
use crate::tools::inputs::open_state_stream_with;
use crate::tools::RunOptions;
use crate::writers::names::{file_name, OutputKind, RunKey, Sweep};
use crate::writers::tables::{diagnostics_row, DIAGNOSTICS_COLUMNS};

pub use crate::plan::force_sweep::CandidateSpec;

/// What a sweep computed.
#[derive(Debug, Clone, Default)]
pub struct SweepOutcome {
    /// The setup's `<Metric>` names, in its order.
    pub metric_names: Vec<String>,
    /// Per candidate: the metrics' values (in `metric_names`' order).
    pub values: Vec<Vec<f64>>,
    /// Per candidate: frames the solver could not solve.
    pub failed: Vec<usize>,
    /// Frames of the motion.
    pub frames: usize,
    /// Seconds spent in the frame loop (every candidate).
    pub loop_seconds: f64,
    /// Setup and motion warnings.
    pub warnings: Vec<String>,
    /// Solver iterations over every candidate and frame (Newton's linear
    /// solves, see the diagnostics table's `iterations`).
    pub iterations: u64,
    /// The candidates' tables written ([`SweepOptions::tables`]).
    pub files: Vec<std::path::PathBuf>,
}

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

/// The tables a metric may read, by the end of their file names.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Source {
    Activation,
    Force,
    Diagnostics,
    ContactForces,
    ContactBodyForces,
    GeneralizedForces,
    MusclePower,
    /// A coupled JointReaction's ReactionLoads (index into the sweep's).
    Reactions(usize),
    /// Its KneeLoads.
    Knee(usize),
    /// The knee contact method's `<setup>_KneeContact.sto` (the coupled
    /// reactions of the method's knees).
    KneeContact(usize),
}

/// A `<Metric>` compiled against the problem: its columns in the row of
/// its table.
struct MetricPlan {
    op: MetricOp,
    name: String,
    source: Source,
    columns: Vec<usize>,
    scale: f64,
    located: Option<usize>,
}

/// A coupled JointReaction: its name, reactions and, for knee loads, the
/// sides' columns.
struct Coupled {
    name: String,
    specs: Vec<ReactionSpec>,
    knee: Option<([crate::tools::knee_loads::Side; 2], bool)>,
    labels: Vec<String>,
    /// Whether a metric reads it.
    used: bool,
    /// The knee contact method's reactions (one spec per knee of
    /// `SoProblem::knees`, `tools::knee_contact::reaction_specs`).
    knee_contact: bool,
}

/// The metric source of a static-optimization table.
fn so_source(kind: &OutputKind) -> Option<Source> {
    Some(match kind {
        OutputKind::Activation => Source::Activation,
        OutputKind::Force => Source::Force,
        OutputKind::Diagnostics => Source::Diagnostics,
        OutputKind::ContactForces => Source::ContactForces,
        OutputKind::ContactBodyForces => Source::ContactBodyForces,
        OutputKind::GeneralizedForcesBySource => Source::GeneralizedForces,
        OutputKind::MusclePower => Source::MusclePower,
        _ => return None,
    })
}

fn plan_metric(
    m: &MetricSpec,
    setup: &AnalyzeSetup,
    so_name: &str,
    problem: &SoProblem,
    coupled: &mut [Coupled],
) -> Result<MetricPlan> {
    let err = |msg: String| Error::input(m.loc.clone(), msg);
    let name = m.name.clone();
    let file = m.file.as_str();
    let base = file.rsplit(['/', '\\']).next().unwrap_or(file);
    // The tables a run of this setup writes, each with its source: the
    // metric's file is one of their names (any w0 the setup runs: a
    // candidate's own tables are read).
    let sweeps = crate::writers::names::Planned::sweeps(setup);
    let mut keys = Vec::new();
    let mut sources = Vec::new();
    for &sweep in &sweeps {
        let so = RunKey::analysis(&setup.name, so_name, sweep);
        for kind in OutputKind::SO_TABLES {
            sources.push(so_source(&kind).expect("a static-optimization table"));
            keys.push(so.key(kind));
        }
        for (j, c) in coupled.iter().enumerate() {
            let jr = RunKey::analysis(&setup.name, &c.name, sweep);
            keys.push(jr.key(OutputKind::ReactionLoads));
            sources.push(Source::Reactions(j));
            if c.knee.is_some() {
                keys.push(jr.key(OutputKind::KneeLoads));
                sources.push(Source::Knee(j));
            }
            if c.knee_contact {
                keys.push(RunKey::setup(&setup.name, sweep).key(OutputKind::KneeContact));
                sources.push(Source::KneeContact(j));
            }
        }
    }
    let source = keys
        .iter()
        .position(|k| file_name(k) == base)
        .map(|i| sources[i]);
    let Some(source) = source else {
        let single = |kind| RunKey::analysis(&setup.name, so_name, Sweep::Single).file(kind);
        return Err(err(format!(
            "file=\"{file}\": a force sweep computes metrics of the tables of this setup's static optimization ({}, ...; {}), of its coupled joint reactions (ReactionLoads, KneeLoads) and of the knee contact method ({}), with the w0 it runs in their names",
            single(OutputKind::Force),
            OutputKind::SO_TABLES.map(|k| k.table()).join("|"),
            RunKey::setup(&setup.name, Sweep::Single).file(OutputKind::KneeContact)
        )));
    };
    let labels: Vec<String> = match source {
        Source::Activation => problem.labels.clone(),
        Source::Force => problem.force_labels.clone(),
        Source::Diagnostics => DIAGNOSTICS_COLUMNS.iter().map(|s| s.to_string()).collect(),
        Source::ContactForces => problem.contact_labels(),
        Source::ContactBodyForces => problem.contact_body_labels(),
        Source::GeneralizedForces => problem.by_source_labels(),
        Source::MusclePower => problem.muscle_labels(),
        Source::Reactions(j) => coupled[j].labels.clone(),
        Source::Knee(j) => {
            let patella = coupled[j].knee.as_ref().is_some_and(|k| k.1);
            crate::tools::knee_loads::labels(patella)
        }
        Source::KneeContact(_) => crate::tools::knee_contact_table::labels(&problem.knees),
    };
    if let Source::Reactions(j) | Source::Knee(j) | Source::KneeContact(j) = source {
        coupled[j].used = true;
    }
    let column = |c: &str| {
        labels
            .iter()
            .position(|l| l == c)
            .ok_or_else(|| err(format!("{file} has no column '{c}'")))
    };
    let columns = m
        .columns
        .split_whitespace()
        .map(&column)
        .collect::<Result<Vec<_>>>()?;
    let located = m.where_column.as_deref().map(&column).transpose()?;
    Ok(MetricPlan {
        op: m.op,
        name,
        source,
        columns,
        scale: m.scale,
        located,
    })
}

/// Resolve the candidates against the problem.
fn resolve_candidates(
    setup: &AnalyzeSetup,
    problem: &SoProblem,
    specs: &[CandidateSpec],
) -> Result<Vec<ForceCandidate>> {
    let err = |k: usize, msg: String| {
        Error::input(
            Location::file(&setup.setup_file),
            format!("force sweep, candidate {k}: {msg}"),
        )
    };
    specs
        .iter()
        .enumerate()
        .map(|(k, s)| {
            if !(s.w0.is_finite()
                && (CONTACT_WEIGHT_RANGE.0..=CONTACT_WEIGHT_RANGE.1).contains(&s.w0))
            {
                return Err(err(
                    k,
                    format!(
                        "w0 = {} lies outside [{:e}, {:e}]",
                        s.w0, CONTACT_WEIGHT_RANGE.0, CONTACT_WEIGHT_RANGE.1
                    ),
                ));
            }
            let mut passive = Vec::new();
            for (name, text) in &s.expressions {
                let j = problem
                    .passive
                    .iter()
                    .position(|p| p.name() == name)
                    .ok_or_else(|| {
                        err(k, format!("the model has no passive force '{name}' (an ExpressionBasedCoordinateForce whose expression the sweep sets)"))
                    })?;
                let PassiveForce::ExpressionBasedCoordinate {
                    name: n,
                    coordinate,
                    ..
                } = &problem.passive[j]
                else {
                    return Err(err(
                        k,
                        format!("'{name}' is not an ExpressionBasedCoordinateForce: only their expressions can be swept"),
                    ));
                };
                let expr = Expression::compile(text).map_err(|m| {
                    err(k, format!("the expression of '{name}' ({text}): {m}"))
                })?;
                passive.push((
                    j,
                    PassiveForce::ExpressionBasedCoordinate {
                        name: n.clone(),
                        coordinate: *coordinate,
                        expr: Box::new(expr),
                    },
                ));
            }
            let mut optimal_force = Vec::new();
            for (name, f) in &s.optimal_forces {
                let v = problem
                    .controls
                    .iter()
                    .position(|c| matches!(c, Control::Actuator(a) if &a.name == name))
                    .ok_or_else(|| {
                        err(k, format!("the model has no actuator '{name}' (optimal forces of actuators other than muscles can be swept)"))
                    })?;
                let Control::Actuator(a) = &problem.controls[v] else {
                    unreachable!("matched an actuator")
                };
                if a.optimal_force == 0.0 || !f.is_finite() {
                    return Err(err(
                        k,
                        format!("optimal force {f} of '{name}' (its own is {}): both must be finite and the model's non-zero", a.optimal_force),
                    ));
                }
                optimal_force.push((v, *f));
            }
            let mut external = Vec::new();
            for (name, f) in &s.external_scales {
                let Some(loads) = &problem.loads else {
                    return Err(err(k, format!("external load scale of '{name}': the setup has no external loads")));
                };
                if !f.is_finite() {
                    return Err(err(k, format!("external load scale {f} of '{name}' is not a finite number")));
                }
                external.resize(loads.forces.len(), 1.0);
                if name == "*" {
                    external.iter_mut().for_each(|x| *x *= f);
                    continue;
                }
                let e = loads.forces.iter().position(|ef| &ef.name == name).ok_or_else(|| {
                    err(k, format!("the external loads have no ExternalForce '{name}' (names: {}; '*' scales them all)",
                        loads.forces.iter().map(|ef| ef.name.as_str()).collect::<Vec<_>>().join(", ")))
                })?;
                external[e] *= f;
            }
            Ok(ForceCandidate {
                w0: s.w0,
                passive,
                optimal_force,
                external,
            })
        })
        .collect()
}

/// A frame assembled once: its workspace (state, muscle paths, the
/// program), the candidates' base (b, passive records) and its reaction
/// bases. Solving candidates leaves it as it is.
struct PreparedFrame {
    t: f64,
    ws: Workspace,
    scratch: CandidateScratch,
    bases: Vec<ReactionBasis>,
}

/// The buffers of one frame's candidates (per thread).
#[derive(Default)]
struct CandidateBuffers {
    result: FrameResult,
    reaction_rows: Vec<Vec<f64>>,
    /// Per coupled JointReaction with knee loads: the candidate's row.
    knee_rows: Vec<Vec<f64>>,
    /// Per warm-start chain (a w0): the last three candidates' multipliers
    /// (the last one last), and the start handed to the next.
    chains: Vec<[Vec<f64>; 3]>,
    start: Vec<f64>,
}

/// One frame's values: time, then per candidate and metric (y, where).
struct FrameValues {
    time: f64,
    iterations: u64,
    values: Vec<f64>,
    failed: Vec<bool>,
    /// With tables: per candidate, its frame result and joint reactions'
    /// rows (one per coupled JointReaction).
    results: Vec<(FrameResult, Vec<Vec<f64>>)>,
}

/// What a sweep of a setup shares: the compiled problem, its coupled joint
/// reactions and the metrics' plans.
struct Plan {
    problem: SoProblem,
    coupled: Vec<Coupled>,
    metrics: Vec<MetricPlan>,
    /// Coordinates of the ExpressionBasedCoordinateForces: their
    /// generalized forces are probed in the reaction bases.
    probed: Vec<usize>,
    step_interval: usize,
    warnings: Vec<String>,
    /// The StaticOptimization's name (the tables' prefix).
    so_name: String,
}

impl Plan {
    fn compile(setup: &AnalyzeSetup) -> Result<Plan> {
        let at = || Location::file(&setup.setup_file);
        let so: StaticOptimizationSetup = setup
            .analyses
            .iter()
            .find_map(|a| match a {
                Analysis::StaticOptimization(so) if so.common.on => Some((**so).clone()),
                _ => None,
            })
            .ok_or_else(|| {
                Error::input(
                    at(),
                    "a force sweep needs a StaticOptimization analysis that is on",
                )
            })?;
        if setup.reduce_model {
            return Err(Error::input(
                at().with_element("<reduce_model>"),
                "a force sweep runs the full model: turn reduce_model off",
            ));
        }
        if so.constraint_matrix == ConstraintMatrix::Perturbation {
            return Err(Error::input(
                at().with_element("<constraint_matrix>"),
                "a force sweep needs the analytic constraint matrix (perturbation rows are accelerations: a candidate's forces would change every row)",
            ));
        }
        let (problem, mut warnings) = SoProblem::build(setup, &so)?;
        let mut coupled = Vec::new();
        if !problem.knees.is_empty() {
            // The knee contact method's rows are affine in the candidates'
            // forces (frame::candidates); its table's reactions as a coupled
            // joint reaction's.
            let specs =
                crate::tools::knee_contact_table::reaction_specs(&problem.model, &problem.knees);
            coupled.push(Coupled {
                name: crate::tools::knee_contact_table::REACTIONS_NAME.to_string(),
                labels: column_labels(&specs),
                specs,
                knee: None,
                used: false,
                knee_contact: true,
            });
        }
        for jr in setup.joint_reactions() {
            {
                if jr.common.on {
                    if jr.forces_file.is_some() {
                        continue;
                    }
                    let (specs, w) = resolve_reactions(&problem.model, jr)?;
                    warnings.extend(w);
                    let labels = column_labels(&specs);
                    let knee = if jr.knee_loads {
                        let table = crate::storage::Storage {
                            labels: labels.clone(),
                            ..Default::default()
                        };
                        Some(crate::tools::knee_loads::sides(
                            &problem.model,
                            &table,
                            &setup.setup_file,
                        )?)
                    } else {
                        None
                    };
                    coupled.push(Coupled {
                        name: jr.common.name.clone(),
                        specs,
                        knee,
                        labels,
                        used: false,
                        knee_contact: false,
                    });
                }
            }
        }
        let metrics = setup
            .figures
            .iter()
            .filter_map(|e| match e {
                FigureOrMetric::Metric(m) => Some(m),
                FigureOrMetric::Figure(_) => None,
            })
            .map(|m| plan_metric(m, setup, &so.common.name, &problem, &mut coupled))
            .collect::<Result<Vec<_>>>()?;
        let mut probed: Vec<usize> = Vec::new();
        for p in &problem.passive {
            if let PassiveForce::ExpressionBasedCoordinate { coordinate, .. } = p {
                if !probed.contains(coordinate) {
                    probed.push(*coordinate);
                }
            }
        }
        Ok(Plan {
            problem,
            coupled,
            metrics,
            probed,
            step_interval: so.common.step_interval,
            warnings,
            so_name: so.common.name.clone(),
        })
    }

    /// Assemble the frame at (t, q, u, u̇) into `frame` and build its
    /// reaction bases.
    fn prepare(
        &self,
        t: f64,
        q: &[f64],
        u: &[f64],
        udot: &[f64],
        frame: &mut PreparedFrame,
    ) -> Result<()> {
        let problem = &self.problem;
        frame.t = t;
        let ws = &mut frame.ws;
        let m_r = problem.assemble(
            t,
            q,
            u,
            udot,
            &mut ws.data,
            &mut ws.muscles,
            &mut ws.assembly,
        );
        if m_r.is_some() {
            return Err(Error::internal("force sweep: perturbation rows"));
        }
        problem.begin_candidates(t, ws, &mut frame.scratch)?;
        frame
            .bases
            .resize_with(self.coupled.len(), Default::default);
        for (c, basis) in self.coupled.iter().zip(frame.bases.iter_mut()) {
            if c.used {
                basis.build(
                    problem,
                    t,
                    ws,
                    &c.specs,
                    &self.probed,
                    &frame.scratch.external_forces,
                )?;
            }
        }
        Ok(())
    }

    /// The outputs of a candidate's frame result its metrics read, or
    /// every output when its tables are written.
    fn outputs(&self, tables: bool) -> Outputs {
        if tables {
            return Outputs::ALL;
        }
        let mut want = Outputs::NONE;
        for m in &self.metrics {
            match m.source {
                Source::Force => want.force_row = true,
                Source::ContactForces | Source::ContactBodyForces => want.contacts = true,
                Source::GeneralizedForces => want.by_source = true,
                Source::MusclePower => want.muscle_power = true,
                Source::Activation
                | Source::Diagnostics
                | Source::Reactions(_)
                | Source::Knee(_)
                | Source::KneeContact(_) => {}
            }
        }
        want
    }

    /// Every candidate of a prepared frame: its metrics' values.
    fn solve(
        &self,
        cands: &[ForceCandidate],
        chain_of: &[usize],
        warm: bool,
        tables: bool,
        frame: &mut PreparedFrame,
        buf: &mut CandidateBuffers,
    ) -> FrameValues {
        let problem = &self.problem;
        let (nm, nc) = (self.metrics.len(), cands.len());
        let nchains = chain_of.iter().max().map_or(0, |m| m + 1);
        buf.chains.resize_with(nchains, Default::default);
        buf.chains.iter_mut().flatten().for_each(Vec::clear);
        buf.reaction_rows.resize_with(self.coupled.len(), Vec::new);
        buf.knee_rows.resize_with(self.coupled.len(), Vec::new);
        let t = frame.t;
        let mut out = FrameValues {
            time: t,
            iterations: 0,
            values: Vec::with_capacity(2 * nm * nc),
            failed: Vec::with_capacity(nc),
            results: Vec::new(),
        };
        let nv = problem.controls.len();
        let want = self.outputs(tables);
        for (k, cand) in cands.iter().enumerate() {
            let chain = chain_of[k];
            // Warm start: the previous candidate's multipliers, or their
            // extrapolation from the two or three before (candidates along a
            // line of designs move their multipliers along a smooth curve,
            // and where it is smooth enough Newton has nothing left to do);
            // the answer is the same either way.
            let [oldest, older, last] = &buf.chains[chain];
            let y0 = if !warm || last.is_empty() {
                None
            } else {
                buf.start.clear();
                if oldest.len() == last.len() && older.len() == last.len() {
                    // Quadratic through the last three.
                    buf.start.extend(
                        oldest
                            .iter()
                            .zip(older)
                            .zip(last)
                            .map(|((a, b), c)| 3.0 * (c - b) + a),
                    );
                } else if older.len() == last.len() {
                    buf.start
                        .extend(older.iter().zip(last).map(|(a, b)| b + (b - a)));
                } else {
                    buf.start.extend_from_slice(last);
                }
                Some(buf.start.as_slice())
            };
            problem.solve_candidate_into(
                t,
                &mut frame.ws,
                cand,
                y0,
                want,
                &mut frame.scratch,
                &mut buf.result,
            );
            let r = &buf.result;
            let kept = &mut buf.chains[chain];
            kept.rotate_left(1);
            kept[2].clear();
            kept[2].extend_from_slice(&r.solution.y);
            out.failed.push(status_code(r.solution.status) < 0.0);
            out.iterations += r.solution.iterations as u64;
            for (j, c) in self.coupled.iter().enumerate() {
                if !c.used {
                    continue;
                }
                let row = &mut buf.reaction_rows[j];
                row.resize(9 * c.specs.len(), 0.0);
                frame.bases[j].reactions_into(
                    &r.forces,
                    &r.solution.x[nv..],
                    &frame.scratch.dg,
                    &cand.external,
                    row,
                );
                if c.knee_contact {
                    let kr = &mut buf.knee_rows[j];
                    kr.clear();
                    for (ki, knee) in problem.knees.iter().enumerate() {
                        let r = &row[9 * ki..9 * ki + 9];
                        let (med, lat) = crate::frame::knee_contact::compartments(knee, r[1], r[3]);
                        kr.push(crate::tools::knee_loads::flexion_degrees(
                            &frame.ws.data,
                            knee.femur,
                            knee.tibia,
                        ));
                        kr.push((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt());
                        kr.push(med);
                        kr.push(lat);
                    }
                }
                if let Some((sides, patella)) = &c.knee {
                    crate::tools::knee_loads::knee_row(
                        &frame.ws.data,
                        sides,
                        *patella,
                        row,
                        &mut buf.knee_rows[j],
                    );
                }
            }
            if tables {
                let rows = self
                    .coupled
                    .iter()
                    .enumerate()
                    .map(|(j, _)| buf.reaction_rows[j].clone())
                    .collect();
                out.results.push((buf.result.clone(), rows));
            }
            let mut diag = None;
            for m in self.metrics.iter() {
                let row: &[f64] = match m.source {
                    Source::Activation => &r.solution.x[..nv],
                    Source::Force => &r.force_row,
                    Source::Diagnostics => diag.get_or_insert_with(|| diagnostics_row(r)),
                    Source::ContactForces => &r.contacts.contact,
                    Source::ContactBodyForces => &r.contacts.bodies,
                    Source::GeneralizedForces => &r.by_source,
                    Source::MusclePower => &r.muscle_power,
                    Source::Reactions(j) => &buf.reaction_rows[j],
                    Source::Knee(j) | Source::KneeContact(j) => &buf.knee_rows[j],
                };
                // As a study's table column: the columns summed, scaled.
                let mut y = 0.0;
                for &c in &m.columns {
                    y += row[c];
                }
                out.values.push(y * m.scale);
                out.values.push(m.located.map_or(f64::NAN, |c| row[c]));
            }
        }
        out
    }

    /// The candidates' warm-start chains (one per w0, in the given order).
    fn chains(cands: &[ForceCandidate]) -> Vec<usize> {
        let mut chain_w0: Vec<f64> = Vec::new();
        cands
            .iter()
            .map(|c| match chain_w0.iter().position(|w| *w == c.w0) {
                Some(k) => k,
                None => {
                    chain_w0.push(c.w0);
                    chain_w0.len() - 1
                }
            })
            .collect()
    }

    fn new_frame(&self) -> PreparedFrame {
        PreparedFrame {
            t: 0.0,
            ws: Workspace::new(&self.problem.model, &self.problem.muscles),
            scratch: CandidateScratch::default(),
            bases: Vec::new(),
        }
    }
}

/// The candidates' series (frames in order) → the outcome.
struct Collected {
    time: Vec<f64>,
    series: Vec<Vec<(Vec<f64>, Vec<f64>)>>,
    failed: Vec<usize>,
    iterations: u64,
}

impl Collected {
    fn new(nc: usize, nm: usize) -> Self {
        Collected {
            time: Vec::new(),
            series: vec![vec![(Vec::new(), Vec::new()); nm]; nc],
            failed: vec![0; nc],
            iterations: 0,
        }
    }

    fn push(&mut self, fv: &FrameValues) {
        let nm = self.series.first().map_or(0, Vec::len);
        self.time.push(fv.time);
        self.iterations += fv.iterations;
        for (k, per) in self.series.iter_mut().enumerate() {
            for (m, s) in per.iter_mut().enumerate() {
                let at = 2 * (k * nm + m);
                s.0.push(fv.values[at]);
                s.1.push(fv.values[at + 1]);
            }
            if fv.failed[k] {
                self.failed[k] += 1;
            }
        }
    }

    fn outcome(
        self,
        plan: &Plan,
        loop_seconds: f64,
        warnings: Vec<String>,
    ) -> Result<SweepOutcome> {
        let time = &self.time;
        let values = self
            .series
            .iter()
            .map(|per| {
                plan.metrics
                    .iter()
                    .zip(per)
                    .map(|(m, (y, w))| metric_value(m.op, time, y, || Ok(w.clone())))
                    .collect::<Result<Vec<f64>>>()
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(SweepOutcome {
            metric_names: plan.metrics.iter().map(|m| m.name.clone()).collect(),
            values,
            failed: self.failed,
            frames: time.len(),
            loop_seconds,
            warnings,
            iterations: self.iterations,
            files: Vec::new(),
        })
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

fn read_setup(
    setup_file: &std::path::Path,
    text: Option<&str>,
    allow_unknown: bool,
) -> Result<AnalyzeSetup> {
    let setup = match text {
        Some(t) => Setup::parse_with(t, setup_file, allow_unknown)?,
        None => Setup::read_with(setup_file, allow_unknown)?,
    };
    match setup {
        Setup::Analyze(s) => Ok(s),
        _ => Err(Error::input(
            Location::file(setup_file),
            "a force sweep runs an AnalyzeTool setup with a StaticOptimization",
        )),
    }
}

/// Run a force sweep of `setup` (see the module documentation): the
/// motion streamed once, each frame prepared and solved for every
/// candidate as it comes (memory does not grow with the motion but for
/// the metrics' series).
pub fn run(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    in_pool(opts.threads, || {
        run_streamed(setup, candidates, opts, sweep)
    })
}

fn open_stream<'m>(
    setup: &AnalyzeSetup,
    plan: &'m Plan,
    warnings: &mut Vec<String>,
) -> Result<crate::motion::stream::StateStream<'m>> {
    let stream = open_state_stream_with(setup, &plan.problem.model, &plan.problem.contacts)?;
    warnings.extend(stream.motion_warnings(&[]));
    if !stream.missing.is_empty() {
        warnings.push(format!(
            "the coordinates file lacks {:?}; they are set to 0 as OpenSim's AnalyzeTool does",
            stream.missing
        ));
    }
    Ok(stream)
}

fn run_streamed(
    setup: &AnalyzeSetup,
    candidates: &[CandidateSpec],
    opts: &RunOptions,
    sweep: &SweepOptions,
) -> Result<SweepOutcome> {
    let mut plan = Plan::compile(setup)?;
    if !sweep.tables.is_empty() {
        // Every reaction table is written.
        plan.coupled.iter_mut().for_each(|c| c.used = true);
    }
    let cands = resolve_candidates(setup, &plan.problem, candidates)?;
    let chain_of = Plan::chains(&cands);
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
    let with_tables = tables.is_some();
    let mut warnings = plan.warnings.clone();
    let mut stream = open_stream(setup, &plan, &mut warnings)?;
    let (i0, i1, step) = (stream.first_row, stream.last_row, plan.step_interval);
    let nframes = (i0..=i1)
        .filter(|&i| crate::frame::driver::is_frame(i, i0, i1, step))
        .count();
    let mut progress =
        crate::tools::progress::bar(nframes as u64, opts, &format!("{}_force_sweep", setup.name));
    let mut collected = Collected::new(cands.len(), plan.metrics.len());
    let started = Instant::now();
    let first = stream.next_block()?;
    let mut source = PreparingLoads::new(
        Prefetched::new(first, &mut stream),
        plan.problem.loads.as_ref(),
    );
    let (plan_ref, cands, chain_of) = (&plan, &cands, &chain_of);
    let completed = for_each_frame(
        &mut source,
        i0,
        i1,
        step,
        || (plan_ref.new_frame(), CandidateBuffers::default()),
        |(frame, buf), block, i| {
            plan_ref.prepare(
                block.time[i],
                &block.q[i],
                &block.u[i],
                &block.udot[i],
                frame,
            )?;
            Ok(plan_ref.solve(cands, chain_of, sweep.warm, with_tables, frame, buf))
        },
        |fv| {
            collected.push(&fv);
            if let Some(t) = tables.as_mut() {
                t.write(&fv)?;
            }
            progress.inc(1);
            Ok(())
        },
    )?;
    let loop_seconds = started.elapsed().as_secs_f64();
    progress.finish_and_clear();
    if !completed {
        return Err(Error::msg("the force sweep was stopped"));
    }
    let files = match tables {
        Some(t) => t.finish(setup, &plan, opts)?,
        None => Vec::new(),
    };
    let mut outcome = collected.outcome(&plan, loop_seconds, warnings)?;
    outcome.files = files;
    Ok(outcome)
}

/// Every candidate's open tables ([`SweepOptions::tables`]).
struct CandidateWriters {
    tables: Vec<crate::writers::so_tables::SoTables>,
    /// Per candidate: its folder and its runs' naming.
    runs: Vec<(std::path::PathBuf, crate::writers::names::Sweep)>,
    /// The frames' times and positions (for the knee loads' flexion), as
    /// a run keeps them from its pass.
    time: Vec<f64>,
    q: Vec<Vec<f64>>,
}

impl CandidateWriters {
    fn open(
        setup: &AnalyzeSetup,
        plan: &Plan,
        cands: &[ForceCandidate],
        specs: &[CandidateTables],
        opts: &RunOptions,
    ) -> Result<CandidateWriters> {
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
        Ok(CandidateWriters {
            tables,
            runs,
            time: Vec::new(),
            q: Vec::new(),
        })
    }

    /// One frame's rows of every candidate (frames in order).
    fn write(&mut self, fv: &FrameValues) -> Result<()> {
        if let Some((r, _)) = fv.results.first() {
            self.time.push(r.time);
            self.q.push(r.q.clone());
        }
        for (t, (r, rows)) in self.tables.iter_mut().zip(&fv.results) {
            t.write(r, rows)?;
        }
        Ok(())
    }

    /// Close the tables and write each candidate's KneeLoads and
    /// KneeContact tables from its reactions, as a run does.
    fn finish(
        self,
        setup: &AnalyzeSetup,
        plan: &Plan,
        opts: &RunOptions,
    ) -> Result<Vec<std::path::PathBuf>> {
        let precision = opts.precision.unwrap_or(setup.output_precision);
        let problem = &plan.problem;
        let mut files = Vec::new();
        for (t, (dir, run)) in self.tables.into_iter().zip(&self.runs) {
            files.extend(t.finish()?);
            for c in &plan.coupled {
                let jr = RunKey::analysis(&setup.name, &c.name, *run);
                let table = dir.join(jr.file(OutputKind::ReactionLoads));
                if c.knee.is_some() {
                    files.push(crate::tools::knee_loads::write(
                        &problem.model,
                        &self.time,
                        &self.q,
                        &table,
                        &dir.join(jr.file(OutputKind::KneeLoads)),
                        &setup.setup_file,
                        precision,
                    )?);
                }
                if c.knee_contact {
                    files.push(crate::tools::knee_contact_table::write(
                        &problem.model,
                        &problem.knees,
                        &self.time,
                        &self.q,
                        &table,
                        &dir.join(RunKey::setup(&setup.name, *run).file(OutputKind::KneeContact)),
                        &setup.setup_file,
                        precision,
                    )?);
                }
            }
        }
        Ok(files)
    }
}

/// A setup compiled and every frame of its motion assembled once, kept in
/// memory, to solve batch after batch of candidates (an optimiser's
/// iterates): each [`Scene::run`] only solves. Memory grows with the
/// frames (each keeps its workspace and reaction bases).
pub struct Scene {
    plan: Plan,
    setup: AnalyzeSetup,
    frames: Vec<PreparedFrame>,
    threads: Option<usize>,
    /// Setup and motion warnings.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Compile the setup in `setup_file` (or `text`, read as if it were
    /// that file) and prepare every frame; `threads` as `RunOptions`'.
    pub fn compile(
        setup_file: &std::path::Path,
        text: Option<&str>,
        threads: Option<usize>,
    ) -> Result<Scene> {
        let setup = read_setup(setup_file, text, false)?;
        in_pool(threads, move || {
            let plan = Plan::compile(&setup)?;
            let mut warnings = plan.warnings.clone();
            let mut frames = Vec::new();
            {
                let mut stream = open_stream(&setup, &plan, &mut warnings)?;
                let (i0, i1) = (stream.first_row, stream.last_row);
                let first = stream.next_block()?;
                let mut source = PreparingLoads::new(
                    Prefetched::new(first, &mut stream),
                    plan.problem.loads.as_ref(),
                );
                let plan_ref = &plan;
                let completed = for_each_frame(
                    &mut source,
                    i0,
                    i1,
                    plan.step_interval,
                    || (),
                    |_, block, i| {
                        let mut frame = plan_ref.new_frame();
                        plan_ref.prepare(
                            block.time[i],
                            &block.q[i],
                            &block.u[i],
                            &block.udot[i],
                            &mut frame,
                        )?;
                        Ok(frame)
                    },
                    |f| {
                        frames.push(f);
                        Ok(())
                    },
                )?;
                if !completed {
                    return Err(Error::msg("compiling the scene was stopped"));
                }
            }
            Ok(Scene {
                plan,
                setup,
                frames,
                threads,
                warnings,
            })
        })
    }

    /// The frames kept.
    pub fn frames(&self) -> usize {
        self.frames.len()
    }

    /// Solve every frame for `candidates` (frames in parallel); writes no
    /// tables (`sweep.tables` must be empty: [`run`] writes them).
    pub fn run(
        &mut self,
        candidates: &[CandidateSpec],
        sweep: &SweepOptions,
    ) -> Result<SweepOutcome> {
        if !sweep.tables.is_empty() {
            return Err(Error::msg(
                "a Scene solves metrics only: write candidates' tables with a force sweep (tools::force_sweep::run)",
            ));
        }
        let Scene {
            plan,
            setup,
            frames,
            threads,
            warnings,
        } = self;
        let (plan, setup, warnings) = (&*plan, &*setup, &*warnings);
        in_pool(*threads, move || {
            use rayon::prelude::*;
            let cands = resolve_candidates(setup, &plan.problem, candidates)?;
            let chain_of = Plan::chains(&cands);
            let started = Instant::now();
            let values: Vec<FrameValues> = frames
                .par_iter_mut()
                .map_init(CandidateBuffers::default, |buf, frame| {
                    plan.solve(&cands, &chain_of, sweep.warm, false, frame, buf)
                })
                .collect();
            let mut collected = Collected::new(cands.len(), plan.metrics.len());
            for fv in &values {
                collected.push(fv);
            }
            collected.outcome(plan, started.elapsed().as_secs_f64(), warnings.clone())
        })
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
