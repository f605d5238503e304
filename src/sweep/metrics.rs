//! A sweep's metrics: the setup's `<Metric>`s compiled against the problem
//! (which table's row and columns each reads: static optimization's, a
//! coupled JointReaction's, its knee loads, the knee contact method's),
//! and the candidates' series collected frame by frame into their values
//! (`metrics::series::metric_value`, the ops a study's `<Metric>`s use).

use crate::error::{Error, Result};
use crate::frame::problem::SoProblem;
use crate::metrics::series::metric_value;
use crate::parse::setup::AnalyzeSetup;
use crate::plan::figures::{MetricOp, MetricSpec};
use crate::sweep::plan::{Coupled, FrameValues, SweepPlan};
use crate::writers::names::{file_name, OutputKind, RunKey, Sweep};
use crate::writers::tables::DIAGNOSTICS_COLUMNS;

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
    /// The candidates' tables written
    /// ([`SweepOptions::tables`](crate::sweep::stream::SweepOptions::tables)).
    pub files: Vec<std::path::PathBuf>,
}

/// The tables a metric may read, by the end of their file names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Source {
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
pub(crate) struct MetricPlan {
    pub(crate) op: MetricOp,
    pub(crate) name: String,
    pub(crate) source: Source,
    pub(crate) columns: Vec<usize>,
    pub(crate) scale: f64,
    pub(crate) located: Option<usize>,
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

pub(crate) fn plan_metric(
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
            crate::reactions::knee_loads::labels(patella)
        }
        Source::KneeContact(_) => crate::reactions::knee_contact::labels(&problem.knees),
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

/// The candidates' series (frames in order) → the outcome.
pub(crate) struct Collected {
    time: Vec<f64>,
    series: Vec<Vec<(Vec<f64>, Vec<f64>)>>,
    failed: Vec<usize>,
    iterations: u64,
}

impl Collected {
    /// Buffers for `nc` candidates × `nm` metrics over about `frames`
    /// frames, allocated once (a hint: more frames still fit).
    pub(crate) fn new(nc: usize, nm: usize, frames: usize) -> Self {
        let series = || (Vec::with_capacity(frames), Vec::with_capacity(frames));
        Collected {
            time: Vec::with_capacity(frames),
            series: (0..nc)
                .map(|_| (0..nm).map(|_| series()).collect())
                .collect(),
            failed: vec![0; nc],
            iterations: 0,
        }
    }

    pub(crate) fn push(&mut self, fv: &FrameValues) {
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

    pub(crate) fn outcome(
        self,
        plan: &SweepPlan,
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
