//! Progress of long runs: a bar on stderr when it is a terminal, and a hook
//! an embedding caller (the Python package) can pass in [`RunOptions`].

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use std::sync::OnceLock;

use indicatif::{MultiProgress, ProgressBar, ProgressStyle};

/// Every bar of the process: loops that run side by side (a study's setups)
/// stack their bars instead of drawing over each other.
static BARS: OnceLock<MultiProgress> = OnceLock::new();

use crate::tools::RunOptions;
pub use crate::tools::{ProgressFn, ProgressHook};

/// The progress of one frame loop.
pub struct Progress {
    bar: ProgressBar,
    hook: Option<(ProgressHook, String)>,
    done: u64,
    total: u64,
    last: Instant,
}

const HOOK_INTERVAL: Duration = Duration::from_millis(100);

impl Progress {
    pub fn inc(&mut self, n: u64) {
        self.bar.inc(n);
        self.done += n;
        if let Some((h, label)) = &self.hook {
            if self.last.elapsed() >= HOOK_INTERVAL {
                (h.0)(label, self.done, self.total);
                self.last = Instant::now();
            }
        }
    }

    pub fn finish_and_clear(&mut self) {
        self.bar.finish_and_clear();
        if let Some((h, label)) = &self.hook {
            (h.0)(label, self.done, self.total);
        }
    }
}

/// A frame counter for a loop of `len` frames: a bar on stderr when it is a
/// terminal and `opts.verbose`, and `opts.progress` called as it advances.
pub fn bar(len: u64, opts: &RunOptions, label: &str) -> Progress {
    let bar = if !opts.verbose || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let pb = BARS
            .get_or_init(MultiProgress::new)
            .add(ProgressBar::new(len));
        if let Ok(style) =
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames {per_sec} eta {eta}")
        {
            pb.set_style(style);
        }
        pb
    };
    let hook = opts.progress.clone().map(|h| (h, label.to_string()));
    if let Some((h, label)) = &hook {
        (h.0)(label, 0, len);
    }
    Progress {
        bar,
        hook,
        done: 0,
        total: len,
        last: Instant::now(),
    }
}
