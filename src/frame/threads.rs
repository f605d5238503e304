//! The run's worker threads, started in one place: `--threads N` (a
//! setup's, a study's, a force sweep's) runs its work in a rayon pool of N
//! threads; without it the work runs in rayon's global pool (one thread
//! per core). Nested runs (a study's setups) find the pool they run in and
//! start none of their own.

use crate::error::{Error, Result};

/// `f` in a pool of `threads` worker threads (at least one), or in the
/// pool the caller runs in when `threads` is None.
/// The work runs for the caller's run (its outputs' capture,
/// `storage::results::context`) on whichever thread runs it.
pub fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    match threads {
        Some(n) => {
            let run = crate::storage::results::context();
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.max(1))
                .build()
                .map_err(|e| Error::internal(format!("cannot start {n} worker threads: {e}")))?
                .install(move || run.run(f))
        }
        None => f(),
    }
}

/// Start the worker threads of the pool a run's frames will use, when
/// it is rayon's global pool (the caller is in no pool: no `--threads`),
/// and have each worker allocate once, so that its thread and its malloc
/// arena (glibc gives each thread that allocates one of its own) exist
/// before the first frames. Meant for a thread with time to spare during
/// the run's serial start (static optimization: the external loads'
/// thread while the model is read); `in_global_pool` is what the run's
/// thread saw ([`frames_in_global_pool`]). Returns once every worker has
/// allocated.
pub fn warm_global_pool(in_global_pool: bool) {
    if in_global_pool {
        rayon::broadcast(|_| drop(std::hint::black_box(Vec::<u64>::with_capacity(16))));
    }
}

/// Whether work started on this thread runs in rayon's global pool (the
/// thread is in no pool of its own: [`in_pool`] with None).
pub fn frames_in_global_pool() -> bool {
    rayon::current_thread_index().is_none()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// N threads when asked (0 counts as 1), the caller's pool otherwise.
    #[test]
    fn runs_in_a_pool_of_the_threads_asked_for() {
        assert_eq!(
            in_pool(Some(3), || Ok(rayon::current_num_threads())).unwrap(),
            3
        );
        assert_eq!(
            in_pool(Some(0), || Ok(rayon::current_num_threads())).unwrap(),
            1
        );
        let outer = in_pool(Some(2), || {
            in_pool(None, || Ok(rayon::current_num_threads()))
        });
        assert_eq!(outer.unwrap(), 2);
        let e = in_pool::<()>(Some(2), || Err(Error::msg("inner"))).unwrap_err();
        assert!(e.to_string().contains("inner"), "{e}");
    }

    /// The global pool is warmed only for a run in it: a run in a pool of
    /// its own says so, and warming from another thread starts rayon's
    /// global workers, each of which then has run once.
    #[test]
    fn warms_the_global_pool_only_for_runs_in_it() {
        assert!(!in_pool(Some(2), || Ok(frames_in_global_pool())).unwrap());
        let outside = std::thread::spawn(frames_in_global_pool).join().unwrap();
        assert!(outside);
        let ran = std::sync::atomic::AtomicUsize::new(0);
        std::thread::scope(|s| {
            s.spawn(|| {
                warm_global_pool(true);
                rayon::broadcast(|_| ran.fetch_add(1, std::sync::atomic::Ordering::Relaxed));
            });
        });
        assert_eq!(
            ran.load(std::sync::atomic::Ordering::Relaxed),
            rayon::current_num_threads()
        );
        warm_global_pool(false);
    }
}
