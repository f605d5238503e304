//! The frame driver: every analysis that works frame by frame (static
//! optimization, joint reactions, muscle analysis, predict-grf) hands it a
//! per-thread workspace and the work of one frame. Frames run in parallel
//! chunks; results come back in frame order, so tables hold every finished
//! frame and memory stays bounded by the stream's block.

use crate::error::Result;
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
    mut sink: impl FnMut(T) -> Result<()>,
) -> Result<bool>
where
    T: Send,
    W: Send,
{
    use rayon::prelude::*;
    let pool = Pool(std::sync::Mutex::new(Vec::new()));
    let mut sel: Vec<usize> = Vec::new();
    let mut results: Vec<Result<T>> = Vec::new();
    while let Some(block) = stream.next_block()? {
        sel.clear();
        sel.reserve(block.time.len());
        sel.extend(
            (0..block.time.len()).filter(|&k| is_frame(block.first + k, i0, i1, step_interval)),
        );
        for chunk in sel.chunks(CHUNK.max(4 * rayon::current_num_threads())) {
            if crate::frame::interrupt::requested().is_some() {
                return Ok(false);
            }
            chunk
                .par_iter()
                .map_init(
                    || Lease {
                        pool: &pool,
                        ws: Some(pool.take().unwrap_or_else(&init)),
                    },
                    |lease, &i| work(lease.ws.as_mut().expect("leased"), &block, i),
                )
                .collect_into_vec(&mut results);
            for r in results.drain(..) {
                sink(r?)?;
            }
        }
    }
    Ok(true)
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
}
