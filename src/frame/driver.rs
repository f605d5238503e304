//! The frame driver: every analysis that works frame by frame (static
//! optimization, joint reactions, muscle analysis, predict-grf) hands it a
//! per-thread workspace and the work of one frame. Frames run in parallel
//! chunks; results come back in frame order, so tables hold every finished
//! frame and memory stays bounded by the stream's block.

use crate::error::Result;
use crate::forces::external_loads::ExternalLoads;
use crate::motion::coordinates::find_index;
use crate::motion::stream::{FrameSource, StateBlock};

/// Rows analysed: i0 = last row with t <= initial_time, i1 = last row with
/// t <= final_time; a row is recorded when it is the first, the last, or its
/// absolute index is a multiple of `step_interval`.
pub fn frame_rows(time: &[f64], initial: f64, final_: f64, step_interval: usize) -> Vec<usize> {
    let i0 = find_index(time, initial);
    let i1 = find_index(time, final_);
    (i0..=i1)
        .filter(|&i| i == i0 || i == i1 || i % step_interval.max(1) == 0)
        .collect()
}

/// Whether row `i` is a frame: `frame_rows`' rule for rows `i0..=i1`.
pub fn is_frame(i: usize, i0: usize, i1: usize, step_interval: usize) -> bool {
    i >= i0 && i <= i1 && (i == i0 || i == i1 || i % step_interval.max(1) == 0)
}

/// Frames solved in parallel before their results go to `sink` (at least;
/// four per worker thread on larger machines): small enough that the sink (a
/// writer thread formatting tables) works beside the solving threads rather
/// than after them, large enough to keep the threads busy. (With chunks of
/// 256 a 151-frame run was solved whole before its first row was written:
/// gait2392's loop took 0.113–0.120 ms per frame on one thread, 0.074–0.09
/// ms with 32.)
const CHUNK: usize = 32;

/// Run `work` on every analysed frame of `stream` (rows `i0..=i1`, honouring
/// `step_interval`), in parallel chunks of [`CHUNK`] with a per-thread workspace
/// from `init`, and hand each result to `sink` in frame order — so tables
/// hold every finished frame and memory stays bounded by the block.
/// Workspaces are made once and kept for the whole run (rayon may run a
/// chunk as several jobs; each takes a workspace from the run's pool and
/// gives it back), and the chunk's results are collected into one reused
/// buffer: the driver allocates nothing per frame or per chunk
/// (tests/allocations.rs).
/// Returns false when a stop was requested ([`crate::frame::interrupt`]):
/// the frames handed to `sink` so far are complete, no later one is.
pub fn for_each_frame<W, T>(
    stream: &mut impl FrameSource,
    i0: usize,
    i1: usize,
    step_interval: usize,
    init: impl Fn() -> W + Sync + Send,
    work: impl Fn(&mut W, &StateBlock, usize) -> Result<T> + Sync + Send,
    sink: impl FnMut(T) -> Result<()>,
) -> Result<bool>
where
    T: Send,
    W: Send,
{
    drive(
        stream,
        i0,
        i1,
        step_interval,
        1,
        init,
        |w, b, i, _| work(w, b, i),
        sink,
    )
}

/// [`for_each_frame`] for an analysis that writes one row a frame: `work`
/// gives a frame's time and row, `write` writes them in frame order. Returns
/// the frames written and, when a signal stopped the run, the exit status it
/// asks for with the time of the last row written (a run summary's
/// `stopped`).
#[allow(clippy::type_complexity)]
pub fn write_each_frame<W, T>(
    stream: &mut impl FrameSource,
    i0: usize,
    i1: usize,
    step_interval: usize,
    init: impl Fn() -> W + Sync + Send,
    work: impl Fn(&mut W, &StateBlock, usize) -> Result<(f64, T)> + Sync + Send,
    mut write: impl FnMut(f64, T) -> Result<()>,
) -> Result<(usize, Option<(u8, Option<f64>)>)>
where
    T: Send,
    W: Send,
{
    let mut frames = 0;
    let mut last_t = None;
    let completed = for_each_frame(stream, i0, i1, step_interval, init, work, |(t, row)| {
        write(t, row)?;
        frames += 1;
        last_t = Some(t);
        Ok(())
    })?;
    let stopped = if completed {
        None
    } else {
        Some((crate::frame::interrupt::requested().unwrap_or(130), last_t))
    };
    Ok((frames, stopped))
}

/// Frames per warm-start group ([`for_each_frame_grouped`]): the first
/// frame of a group is solved cold, each other from the previous frame's
/// answer. Groups are counted by the frame's ordinal among the analysed
/// frames of its block (from the block's first analysed row), so they do
/// not depend on the thread count or the chunk size.
pub const GROUP: usize = 8;

/// Where a frame stands in its warm-start group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GroupPos {
    /// The first frame of its group: solved cold.
    pub first: bool,
    /// Index in the block of the group's last frame (the frame itself when
    /// it is the last): a resumed run re-solves a group, without writing
    /// it, up to its first frame not yet written.
    pub last: usize,
}

/// Frames per chunk for groups of `group` frames: [`CHUNK`], or four frames
/// and one group per thread when more, rounded up to a multiple of `group`
/// (chunks start at group starts).
fn chunk_len(threads: usize, group: usize) -> usize {
    CHUNK.max(4 * threads).max(group * threads).div_ceil(group) * group
}

/// As [`for_each_frame`], with the frames taken in fixed groups of [`GROUP`]
/// consecutive analysed frames of a block: a group runs in order on one
/// thread, in one workspace, so `work` may warm-start a frame from the one
/// before it (`GroupPos::first` false); the groups of a chunk run in
/// parallel. Which frames share a group depends on the stream's blocks
/// alone (a fixed number of rows from the start of the stream), never on
/// the thread count or the chunking, so warm-started results stay
/// identical for any thread count.
pub fn for_each_frame_grouped<W, T>(
    stream: &mut impl FrameSource,
    i0: usize,
    i1: usize,
    step_interval: usize,
    init: impl Fn() -> W + Sync + Send,
    work: impl Fn(&mut W, &StateBlock, usize, GroupPos) -> Result<T> + Sync + Send,
    sink: impl FnMut(T) -> Result<()>,
) -> Result<bool>
where
    T: Send,
    W: Send,
{
    drive(stream, i0, i1, step_interval, GROUP, init, work, sink)
}

/// The frame loop of both drivers, with groups of `group` frames.
#[allow(clippy::too_many_arguments)]
fn drive<W, T>(
    stream: &mut impl FrameSource,
    i0: usize,
    i1: usize,
    step_interval: usize,
    group: usize,
    init: impl Fn() -> W + Sync + Send,
    work: impl Fn(&mut W, &StateBlock, usize, GroupPos) -> Result<T> + Sync + Send,
    mut sink: impl FnMut(T) -> Result<()>,
) -> Result<bool>
where
    T: Send,
    W: Send,
{
    use rayon::prelude::*;
    let pool = Pool(std::sync::Mutex::new(Vec::new()));
    let mut sel: Vec<usize> = Vec::new();
    // One slot per frame of a chunk; a group stops at its first error, so
    // its later slots stay empty (and the error is handed on first).
    let mut results: Vec<Option<Result<T>>> = Vec::new();
    while let Some(block) = stream.next_block()? {
        sel.clear();
        sel.reserve(block.time.len());
        sel.extend(
            (0..block.time.len()).filter(|&k| is_frame(block.first + k, i0, i1, step_interval)),
        );
        for chunk in sel.chunks(chunk_len(rayon::current_num_threads(), group)) {
            if crate::frame::interrupt::requested().is_some() {
                return Ok(false);
            }
            results.clear();
            results.resize_with(chunk.len(), || None);
            chunk
                .par_chunks(group)
                .zip(results.par_chunks_mut(group))
                .for_each_init(
                    || Lease {
                        pool: &pool,
                        ws: Some(pool.take().unwrap_or_else(&init)),
                    },
                    |lease, (frames, slots)| {
                        let ws = lease.ws.as_mut().expect("leased");
                        let last = frames[frames.len() - 1];
                        for (k, (&i, slot)) in frames.iter().zip(slots).enumerate() {
                            let pos = GroupPos {
                                first: k == 0,
                                last,
                            };
                            let r = work(ws, &block, i, pos);
                            let failed = r.is_err();
                            *slot = Some(r);
                            if failed {
                                break;
                            }
                        }
                    },
                );
            for r in results.drain(..).flatten() {
                sink(r?)?;
            }
        }
    }
    Ok(true)
}

/// A source whose first block was computed ahead (while the run's output
/// files were being opened), then the rest of `source`.
pub struct Prefetched<'s, S> {
    first: Option<Option<StateBlock>>,
    source: &'s mut S,
}

impl<'s, S: FrameSource> Prefetched<'s, S> {
    /// `first`: what `source.next_block()` returned.
    pub fn new(first: Option<StateBlock>, source: &'s mut S) -> Self {
        Prefetched {
            first: Some(first),
            source,
        }
    }
}

impl<S: FrameSource> FrameSource for Prefetched<'_, S> {
    fn next_block(&mut self) -> Result<Option<StateBlock>> {
        match self.first.take() {
            Some(first) => Ok(first),
            None => self.source.next_block(),
        }
    }
}

/// A source whose blocks the external loads are prepared for
/// ([`ExternalLoads::prepare`]: a long data file's window serving the
/// block's first time fitted before its frames are computed, in parallel,
/// and the windows before it let go), and whose end checks that no frame's
/// loads failed.
pub struct PreparingLoads<'a, S> {
    source: S,
    loads: Option<&'a ExternalLoads>,
}

impl<'a, S: FrameSource> PreparingLoads<'a, S> {
    pub fn new(source: S, loads: Option<&'a ExternalLoads>) -> Self {
        PreparingLoads { source, loads }
    }
}

impl<S: FrameSource> FrameSource for PreparingLoads<'_, S> {
    fn next_block(&mut self) -> Result<Option<StateBlock>> {
        let block = self.source.next_block()?;
        if let Some(loads) = self.loads {
            match block.as_ref().and_then(|b| b.time.first()) {
                Some(&first) => loads.prepare(first)?,
                None => loads.check()?,
            }
        }
        Ok(block)
    }
}

/// The run's workspaces not in use.
struct Pool<W>(std::sync::Mutex<Vec<W>>);

impl<W> Pool<W> {
    fn take(&self) -> Option<W> {
        self.0.lock().ok()?.pop()
    }
}

/// A workspace taken from the pool for one rayon job, given back when the
/// job ends.
struct Lease<'p, W> {
    pool: &'p Pool<W>,
    ws: Option<W>,
}

impl<W> Drop for Lease<'_, W> {
    fn drop(&mut self) {
        if let (Some(ws), Ok(mut pool)) = (self.ws.take(), self.pool.0.lock()) {
            pool.push(ws);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One block of `n` rows (times only: the work below reads nothing else).
    struct Rows(Option<usize>);

    impl FrameSource for Rows {
        fn next_block(&mut self) -> Result<Option<StateBlock>> {
            Ok(self.0.take().map(|n| StateBlock {
                first: 0,
                time: (0..n).map(|i| i as f64).collect(),
                ..StateBlock::default()
            }))
        }
    }

    /// A prefetched first block comes first, then the source's own blocks,
    /// and the frames run over both as over the source alone.
    #[test]
    fn prefetched_first_block_then_the_source() {
        struct Two(usize);
        impl FrameSource for Two {
            fn next_block(&mut self) -> Result<Option<StateBlock>> {
                self.0 += 1;
                Ok((self.0 <= 2).then(|| StateBlock {
                    first: 10 * (self.0 - 1),
                    time: (0..10).map(|i| (10 * (self.0 - 1) + i) as f64).collect(),
                    ..StateBlock::default()
                }))
            }
        }
        let mut source = Two(0);
        let first = source.next_block().unwrap();
        let mut pre = Prefetched::new(first, &mut source);
        let mut seen = Vec::new();
        let done = for_each_frame(
            &mut pre,
            0,
            19,
            3,
            || (),
            |_, b, i| Ok(b.time[i]),
            |t| {
                seen.push(t);
                Ok(())
            },
        );
        assert!(done.unwrap());
        // Every third row from the first, and the last (as OpenSim steps).
        assert_eq!(seen, [0.0, 3.0, 6.0, 9.0, 12.0, 15.0, 18.0, 19.0]);
        // An exhausted source prefetched: nothing, and no second call
        // that would start it over.
        let mut empty = Two(2);
        let mut pre = Prefetched::new(None, &mut empty);
        assert!(pre.next_block().unwrap().is_none());
    }

    /// The sink (the writer thread's feed) gets the first results while
    /// frames are still being solved, not after all of them: with chunks of
    /// 256, a 151-frame run handed its first row over only once every frame
    /// was solved, so the writer never worked beside the solver.
    #[test]
    fn results_reach_the_sink_before_the_last_frame_is_solved() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let events = std::sync::Mutex::new(Vec::new());
        let n = 151;
        let done = pool.install(|| {
            for_each_frame(
                &mut Rows(Some(n)),
                0,
                n - 1,
                1,
                || (),
                |_, _, i| {
                    events.lock().unwrap().push(("solve", i));
                    Ok(i)
                },
                |i| {
                    events.lock().unwrap().push(("sink", i));
                    Ok(())
                },
            )
        });
        assert!(done.unwrap());
        let events = events.into_inner().unwrap();
        let first_sink = events.iter().position(|e| e.0 == "sink").unwrap();
        let last_solve = events.iter().rposition(|e| e.0 == "solve").unwrap();
        assert!(
            first_sink < last_solve,
            "the first result reached the sink only after every frame was solved"
        );
        // In order, every frame once.
        let sunk: Vec<usize> = events
            .iter()
            .filter(|e| e.0 == "sink")
            .map(|e| e.1)
            .collect();
        assert_eq!(sunk, (0..n).collect::<Vec<_>>());
    }

    /// Warm-start groups are fixed by the frame's ordinal in its block:
    /// with 1, 2 or 16 threads (chunks of 32 or 128 frames) the same frames
    /// start a group, every group's frames run in order on one thread, and
    /// the sink gets every frame once, in order.
    #[test]
    fn groups_do_not_depend_on_threads_or_chunks() {
        let n = 203;
        let step = 2;
        let frames = frame_rows(
            &(0..n).map(|i| i as f64).collect::<Vec<_>>(),
            0.0,
            (n - 1) as f64,
            step,
        );
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let events = std::sync::Mutex::new(Vec::new());
            let mut sunk = Vec::new();
            let done = pool.install(|| {
                for_each_frame_grouped(
                    &mut Rows(Some(n)),
                    0,
                    n - 1,
                    step,
                    || (),
                    |_, _, i, pos| {
                        let thread = std::thread::current().id();
                        events.lock().unwrap().push((i, pos, thread));
                        Ok(i)
                    },
                    |i| {
                        sunk.push(i);
                        Ok(())
                    },
                )
            });
            assert!(done.unwrap());
            assert_eq!(sunk, frames, "{threads} threads");
            let events = events.into_inner().unwrap();
            let mut positions: Vec<(usize, GroupPos)> = events.iter().map(|e| (e.0, e.1)).collect();
            positions.sort_by_key(|e| e.0);
            // Within a group: consecutive frames, one thread, in order.
            for (k, &(i, pos)) in positions.iter().enumerate() {
                assert_eq!(i, frames[k]);
                assert_eq!(pos.first, k % GROUP == 0, "frame {i}");
                assert_eq!(
                    pos.last,
                    frames[(k / GROUP * GROUP + GROUP - 1).min(frames.len() - 1)]
                );
                if !pos.first {
                    let at = |f: usize| events.iter().position(|e| e.0 == f).unwrap();
                    let (before, this) = (at(frames[k - 1]), at(i));
                    assert!(before < this, "frame {i} ran before its predecessor");
                    assert_eq!(events[before].2, events[this].2, "frame {i} changed thread");
                }
            }
            positions
        };
        let one = run(1);
        assert_eq!(run(2), one);
        assert_eq!(run(16), one);
        assert_eq!(chunk_len(1, GROUP), 32);
        assert_eq!(chunk_len(16, GROUP), 128);
        assert_eq!(chunk_len(5, GROUP), 40);
    }
}
