//! A sweep's compiled plan (the problem, its coupled joint reactions and
//! its metrics) and its frames: each assembled once
//! ([`SoProblem::assemble`], `SoProblem::begin_candidates`, the reaction
//! bases) and solved for every candidate, each warm-started from its
//! chain's previous ones, its metrics' rows made from the outputs they
//! read (`frame::problem::Outputs`).

use std::path::PathBuf;

use crate::error::{Error, Location, Result};
use crate::forces::passive::PassiveForce;
use crate::frame::candidates::{CandidateScratch, ForceCandidate};
use crate::frame::problem::{status_code, FrameResult, Outputs, SoProblem};
use crate::frame::settings::{ConstraintMatrix, StaticOptimizationSetup};
use crate::frame::workspace::Workspace;
use crate::parse::setup::{Analysis, AnalyzeSetup};
use crate::plan::figures::FigureOrMetric;
use crate::reactions::linear::ReactionBasis;
use crate::reactions::{column_labels, resolve_reactions, ReactionSpec};
use crate::sweep::metrics::{plan_metric, MetricPlan, Source};
use crate::writers::tables::diagnostics_row;

/// A coupled JointReaction: its name, reactions and, for knee loads, the
/// sides' columns.
pub(crate) struct Coupled {
    pub(crate) name: String,
    pub(crate) specs: Vec<ReactionSpec>,
    pub(crate) knee: Option<([crate::reactions::knee_loads::Side; 2], bool)>,
    pub(crate) labels: Vec<String>,
    /// Whether a metric reads it.
    pub(crate) used: bool,
    /// The knee contact method's reactions (one spec per knee of
    /// `SoProblem::knees`, `tools::knee_contact::reaction_specs`).
    pub(crate) knee_contact: bool,
}

/// A frame assembled once: its workspace (state, muscle paths, the
/// program), the candidates' base (b, passive records) and its reaction
/// bases. Solving candidates leaves it as it is.
pub struct PreparedFrame {
    t: f64,
    ws: Workspace,
    scratch: CandidateScratch,
    bases: Vec<ReactionBasis>,
}

/// The buffers of one frame's candidates (per thread).
#[derive(Default)]
pub(crate) struct CandidateBuffers {
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
pub struct FrameValues {
    pub time: f64,
    pub iterations: u64,
    pub values: Vec<f64>,
    pub failed: Vec<bool>,
    /// With tables: per candidate, its frame result and joint reactions'
    /// rows (one per coupled JointReaction).
    pub results: Vec<(FrameResult, Vec<Vec<f64>>)>,
}

/// What a sweep of a setup shares: the compiled problem, its coupled joint
/// reactions and the metrics' plans.
pub struct SweepPlan {
    /// The setup's file (errors name it).
    pub(crate) setup_file: PathBuf,
    pub problem: SoProblem,
    pub(crate) coupled: Vec<Coupled>,
    pub(crate) metrics: Vec<MetricPlan>,
    /// Coordinates of the ExpressionBasedCoordinateForces: their
    /// generalized forces are probed in the reaction bases.
    probed: Vec<usize>,
    pub(crate) step_interval: usize,
    /// Setup warnings.
    pub warnings: Vec<String>,
    /// The StaticOptimization's name (the tables' prefix).
    pub(crate) so_name: String,
}

impl SweepPlan {
    /// Compile the sweep of `setup`: its StaticOptimization (on, the full
    /// model, analytic constraint matrix), its JointReactions without a
    /// forces file, its `<Metric>`s.
    pub fn compile(setup: &AnalyzeSetup) -> Result<SweepPlan> {
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
                crate::reactions::knee_contact::reaction_specs(&problem.model, &problem.knees);
            coupled.push(Coupled {
                name: crate::reactions::knee_contact::REACTIONS_NAME.to_string(),
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
                        Some(crate::reactions::knee_loads::sides(
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
        Ok(SweepPlan {
            setup_file: setup.setup_file.clone(),
            problem,
            coupled,
            metrics,
            probed,
            step_interval: so.common.step_interval,
            warnings,
            so_name: so.common.name.clone(),
        })
    }

    /// Make every coupled joint reaction's rows, whether a metric reads
    /// them or not (a candidate's tables are written).
    pub fn use_every_reaction(&mut self) {
        self.coupled.iter_mut().for_each(|c| c.used = true);
    }

    /// Assemble the frame at (t, q, u, u̇) into `frame` and build its
    /// reaction bases.
    pub(crate) fn prepare(
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
    pub(crate) fn outputs(&self, tables: bool) -> Outputs {
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
    pub(crate) fn solve(
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
                    crate::reactions::knee_contact::row_into(
                        &frame.ws.data,
                        &problem.knees,
                        row,
                        &mut buf.knee_rows[j],
                    );
                }
                if let Some((sides, patella)) = &c.knee {
                    crate::reactions::knee_loads::knee_row(
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

    pub(crate) fn new_frame(&self) -> PreparedFrame {
        PreparedFrame {
            t: 0.0,
            ws: Workspace::new(&self.problem.model, &self.problem.muscles),
            scratch: CandidateScratch::default(),
            bases: Vec::new(),
        }
    }
}
