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
}
