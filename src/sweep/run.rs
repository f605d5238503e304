//! A sweep's frames solved: streamed from the motion, each prepared and
//! solved for every candidate as it comes ([`solve_stream`]), or prepared
//! once and kept to solve batch after batch ([`Scene`]).

use std::time::Instant;

use crate::error::{Error, Result};
use crate::frame::candidates::ForceCandidate;
use crate::frame::driver::{for_each_frame, Prefetched, PreparingLoads};
use crate::motion::stream::StateStream;
use crate::plan::CandidateSpec;
use crate::sweep::candidates::{chains, resolve};
use crate::sweep::metrics::{Collected, SweepOutcome};
use crate::sweep::plan::{CandidateBuffers, FrameValues, PreparedFrame, SweepPlan};

/// How candidates are solved.
#[derive(Debug, Clone, Copy)]
pub struct Solve {
    /// Warm-start each candidate from the previous ones of the same w0 in
    /// the frame (answers equal cold starts up to rounding).
    pub warm: bool,
    /// Keep each candidate's frame result and reaction rows in
    /// [`FrameValues::results`] (to write its tables).
    pub keep_results: bool,
}

/// Solve every frame of `stream` for `candidates` (resolved by
/// [`resolve`](crate::sweep::candidates::resolve)), frames in parallel on
/// the current pool; `sink` receives each frame's values in frame order
/// (a tool's tables and progress). The outcome's `files` are empty.
pub fn solve_stream(
    plan: &SweepPlan,
    candidates: &[ForceCandidate],
    stream: &mut StateStream<'_>,
    how: Solve,
    warnings: Vec<String>,
    mut sink: impl FnMut(&FrameValues) -> Result<()>,
) -> Result<SweepOutcome> {
    let chain_of = chains(candidates);
    let (i0, i1, step) = (stream.first_row, stream.last_row, plan.step_interval);
    let frames = i1.saturating_sub(i0) / step.max(1) + 1;
    let mut collected = Collected::new(candidates.len(), plan.metrics.len(), frames);
    let started = Instant::now();
    let first = stream.next_block()?;
    let mut source =
        PreparingLoads::new(Prefetched::new(first, stream), plan.problem.loads.as_ref());
    let chain_of = &chain_of;
    let completed = for_each_frame(
        &mut source,
        i0,
        i1,
        step,
        || (plan.new_frame(), CandidateBuffers::default()),
        |(frame, buf), block, i| {
            plan.prepare(
                block.time[i],
                &block.q[i],
                &block.u[i],
                &block.udot[i],
                frame,
            )?;
            Ok(plan.solve(candidates, chain_of, how.warm, how.keep_results, frame, buf))
        },
        |fv| {
            collected.push(&fv);
            sink(&fv)
        },
    )?;
    let loop_seconds = started.elapsed().as_secs_f64();
    if !completed {
        return Err(Error::msg("the force sweep was stopped"));
    }
    collected.outcome(plan, loop_seconds, warnings)
}

/// A setup compiled and every frame of its motion assembled once, kept in
/// memory, to solve batch after batch of candidates (an optimiser's
/// iterates): each [`Scene::run`] only solves. Memory grows with the
/// frames (each keeps its workspace and reaction bases).
pub struct Scene {
    plan: SweepPlan,
    frames: Vec<PreparedFrame>,
    /// Setup and motion warnings.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Prepare every frame of the motion `open` streams (on the current
    /// pool); `warnings` are the setup's and the motion's.
    pub fn prepare(
        plan: SweepPlan,
        open: impl for<'a> FnOnce(&'a SweepPlan, &mut Vec<String>) -> Result<StateStream<'a>>,
    ) -> Result<Scene> {
        let mut warnings = plan.warnings.clone();
        let mut frames = Vec::new();
        {
            let mut stream = open(&plan, &mut warnings)?;
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
            frames,
            warnings,
        })
    }

    /// The frames kept.
    pub fn frames(&self) -> usize {
        self.frames.len()
    }

    /// Solve every frame for `candidates` (frames in parallel, on the
    /// current pool); metrics only.
    pub fn run(&mut self, candidates: &[CandidateSpec], warm: bool) -> Result<SweepOutcome> {
        use rayon::prelude::*;
        let Scene {
            plan,
            frames,
            warnings,
        } = self;
        let plan = &*plan;
        let cands = resolve(&plan.setup_file, &plan.problem, candidates)?;
        let chain_of = chains(&cands);
        let started = Instant::now();
        let values: Vec<FrameValues> = frames
            .par_iter_mut()
            .map_init(CandidateBuffers::default, |buf, frame| {
                plan.solve(&cands, &chain_of, warm, false, frame, buf)
            })
            .collect();
        let mut collected = Collected::new(cands.len(), plan.metrics.len(), values.len());
        for fv in &values {
            collected.push(fv);
        }
        collected.outcome(plan, started.elapsed().as_secs_f64(), warnings.clone())
    }
}
