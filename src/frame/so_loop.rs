//! The frame loop of a static-optimization pass and its result stream.
//!
//! [`solve_frames`] runs every frame of a motion through a solve (the frame
//! solved once per contact weight of a w0 sweep, and whatever the caller adds
//! to each weight's output, e.g. joint reactions) on the frame driver's
//! threads ([`super::driver::for_each_frame_grouped`]: groups of
//! [`super::driver::GROUP`] frames warm-started in order) and hands each
//! frame's outputs, in frame order, to its sinks: each sink on a thread of
//! its own, all taking the same frame's outputs from one shared buffer while
//! the next chunk of frames is solved (at most [`FRAMES_IN_FLIGHT`] frames
//! ahead). The buffers come back to the solving threads once every sink has
//! let go of them, so a frame allocates nothing once there are enough of
//! them. What the sinks do with the stream (tables, logs, statistics, the
//! frames' positions) is theirs: the tools give them
//! (`tools::static_optimization`).

use std::sync::{Arc, Mutex};

use super::driver::for_each_frame_grouped;
use super::problem::{FrameResult, SoProblem};
use super::workspace::Workspace;
use crate::error::{Error, Result};
use crate::motion::stream::FrameSource;

/// One run's outputs of a frame: the solution and the rows the caller's
/// solve adds to it (joint reactions: one row per coupled JointReaction).
pub type FrameOutput = (FrameResult, Vec<Vec<f64>>);

/// One frame's outputs, one per run (weight) of the pass, shared by the
/// sinks.
pub type Shared = Arc<Vec<FrameOutput>>;

/// A consumer of the stream: called with each frame's outputs in frame
/// order, on a thread of its own. An error stops the pass.
pub type Sink<'a> = &'a mut (dyn FnMut(&[FrameOutput]) -> Result<()> + Send);

/// How the pass solves a frame: fills one output per run (weight) for
/// the frame, on the given workspace.
pub type Solve<'a> =
    &'a (dyn Fn(&mut Workspace, &Frame, &mut Vec<FrameOutput>) -> Result<()> + Sync);

/// One frame as the solve gets it: its time and state, and whether the
/// frame before it in its group was solved on the same workspace (warm
/// start).
pub struct Frame<'b> {
    pub t: f64,
    pub q: &'b [f64],
    pub u: &'b [f64],
    pub udot: &'b [f64],
    pub warm: bool,
}

/// Frames handed to the sinks and not yet taken by all of them, at most:
/// the solving threads run ahead of the slowest sink by this much (memory
/// stays bounded).
pub const FRAMES_IN_FLIGHT: usize = 512;

/// Solve the frames `i0..=i1` (every `step_interval`-th) of `stream` with
/// `solve` (which fills one output per run) and hand them to `sinks` in
/// frame order. Groups of frames that end at or before `skip_until` are
/// not solved (a resumed run holds them); frames at or before it are
/// solved (for the warm starts of their group) but not handed on.
/// `on_frame` is told each frame handed on (progress). Returns whether
/// every frame was solved (false: stopped, `super::interrupt`).
#[allow(clippy::too_many_arguments)]
pub fn solve_frames(
    problem: &SoProblem,
    stream: &mut impl FrameSource,
    i0: usize,
    i1: usize,
    step_interval: usize,
    skip_until: f64,
    solve: Solve,
    sinks: Vec<Sink>,
    mut on_frame: impl FnMut(),
) -> Result<bool> {
    // Output buffers every sink has finished with, for the solving threads
    // to fill again.
    let recycled: Mutex<Vec<Shared>> = Default::default();
    // The last sink to let go of a frame's buffer hands it back. Under the
    // pool's lock: the others drop their references there, so the last one
    // sees the count fall to 1.
    let release = |results: Shared| {
        if let Ok(mut pool) = recycled.lock() {
            if Arc::strong_count(&results) == 1 {
                pool.push(results);
            } else {
                drop(results);
            }
            drop(pool);
        }
    };
    // The sinks write and read the run's outputs: on their threads they
    // work for the caller's run (its capture, `storage::results`).
    let run = crate::storage::results::context();
    std::thread::scope(|scope| -> Result<bool> {
        let release = &release;
        let run = &run;
        let mut senders = Vec::with_capacity(sinks.len());
        let mut threads = Vec::with_capacity(sinks.len());
        for sink in sinks {
            let (tx, rx) = std::sync::mpsc::sync_channel::<Shared>(FRAMES_IN_FLIGHT);
            senders.push(tx);
            threads.push(scope.spawn(move || -> Result<()> {
                let _run = run.enter();
                for results in rx {
                    sink(&results)?;
                    release(results);
                }
                Ok(())
            }));
        }
        let completed = for_each_frame_grouped(
            stream,
            i0,
            i1,
            step_interval,
            || Workspace::new(&problem.model, &problem.muscles),
            |ws, block, i, pos| {
                // Groups a resumed run already holds whole are not computed
                // again; a group the resume point falls in is solved from
                // its start (for the same warm starts as an uninterrupted
                // run), its frames handed on from that point on.
                if block.time[pos.last] <= skip_until {
                    return Ok(None);
                }
                // (A pooled buffer is held by nobody else: `release`.)
                let mut shared = recycled
                    .lock()
                    .ok()
                    .and_then(|mut pool| pool.pop())
                    .unwrap_or_default();
                let out = Arc::get_mut(&mut shared)
                    .ok_or_else(|| Error::internal("a pooled frame buffer still shared"))?;
                let frame = Frame {
                    t: block.time[i],
                    q: &block.q[i],
                    u: &block.u[i],
                    udot: &block.udot[i],
                    warm: !pos.first,
                };
                solve(ws, &frame, out)?;
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
                // The sinks take each frame in order; a closed channel
                // means one stopped on an error, reported below.
                if let Some((last, rest)) = senders.split_last() {
                    for tx in rest {
                        if tx.send(results.clone()).is_err() {
                            return Err(Error::internal("a result sink stopped"));
                        }
                    }
                    if last.send(results).is_err() {
                        return Err(Error::internal("a result sink stopped"));
                    }
                }
                on_frame();
                Ok(())
            },
        );
        drop(senders);
        // The sinks' own errors say more than the loop's closed channel.
        let mut first_error = None;
        for t in threads {
            let r = t
                .join()
                .unwrap_or_else(|_| Err(Error::internal("a result sink panicked")));
            if let (Err(e), None) = (r, &first_error) {
                first_error = Some(e);
            }
        }
        if let Some(e) = first_error {
            return Err(e);
        }
        completed
    })
}
