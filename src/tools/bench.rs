//! `statopt-tool bench SETUP.xml`: run a setup repeatedly with several thread
//! counts and report frames per second, the CPU time a frame costs (every
//! thread, mean over the repeats), and the process's peak memory.
//! `--tile N` repeats the setup's motion N times end to end first, to show how
//! time and memory grow with trial length.

use std::path::PathBuf;
use std::time::Instant;

use crate::error::{Error, Location, Result};
use crate::parse::setup::{AnalyzeSetup, Setup};
use crate::storage::{self, StoWriter};
use crate::tools::{analyze, RunOptions};

#[derive(Debug, Clone)]
pub struct BenchOptions {
    pub threads: Vec<usize>,
    pub repeat: usize,
    pub tile: usize,
    /// Overrides the setup's `lowpass_cutoff_frequency_for_coordinates`
    /// (a negative value: no filtering).
    pub lowpass: Option<f64>,
}

#[derive(Debug, Clone)]
pub struct BenchRow {
    pub threads: usize,
    pub frames: usize,
    /// Best per-frame loop time over the repeats (solving + writing), seconds.
    pub loop_seconds: f64,
    /// Best whole-run time (reading, splining, compiling included), seconds.
    pub total_seconds: f64,
    /// CPU time of the process (every thread: solving, writers, setup)
    /// over all the repeats, divided by their frames, seconds: the work a
    /// frame costs, which a busy host inflates far less than wall time.
    pub cpu_seconds_per_frame: Option<f64>,
}

/// CPU time this process (all its threads) has used so far, seconds;
/// None where the OS does not tell.
pub fn process_cpu_seconds() -> Option<f64> {
    use nix::time::{clock_gettime, ClockId};
    let t = clock_gettime(ClockId::CLOCK_PROCESS_CPUTIME_ID).ok()?;
    Some(t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9)
}

/// Peak resident memory of this process so far (VmHWM), in MiB, when the OS tells.
pub fn peak_memory_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// The setup's motion repeated `n` times (time shifted), written to `dir`
/// row by row (the tiled motion is never held in memory, so the peak memory
/// reported is the run's).
fn tiled(setup: &AnalyzeSetup, n: usize, dir: &std::path::Path) -> Result<AnalyzeSetup> {
    let file = setup.coordinates_file.as_ref().ok_or_else(|| {
        Error::input(
            Location::file(&setup.setup_file),
            "bench --tile needs a <coordinates_file>",
        )
    })?;
    let t = storage::read(file)?;
    let len = t.time.len();
    if len < 2 {
        return Err(Error::input(Location::file(file), "too few rows to tile"));
    }
    let dt = t.time[len - 1] - t.time[len - 2];
    let period = t.time[len - 1] - t.time[0] + dt;
    let path = dir.join("tiled_motion.sto");
    let mut description = String::new();
    for (k, v) in &t.metadata {
        if k != "header" {
            description.push_str(&format!("{k}={v}\n"));
        }
    }
    if let Some(h) = t.meta("header") {
        description.push_str(h);
    }
    let mut w = StoWriter::create(&path, &t.name, &description, &t.labels, 10, t.in_degrees)?;
    let mut last = t.time[0];
    for k in 0..n {
        for i in 0..len {
            last = t.time[i] + k as f64 * period;
            w.write_row(last, &t.rows[i])?;
        }
    }
    w.finish()?;
    let mut s = setup.clone();
    s.set_motion(path, t.time[0].min(setup.initial_time), last)?;
    Ok(s)
}

pub fn run(setup_file: &std::path::Path, opts: &BenchOptions) -> Result<Vec<BenchRow>> {
    let setup = match Setup::read(setup_file)? {
        Setup::Analyze(s) => s,
        Setup::InverseDynamics(_) => {
            return Err(Error::input(
                Location::file(setup_file),
                "bench runs AnalyzeTool setups (static optimization)",
            ))
        }
    };
    let dir: PathBuf = std::env::temp_dir().join(format!("statopt-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let mut setup = if opts.tile > 1 {
        tiled(&setup, opts.tile, &dir)?
    } else {
        setup
    };
    if let Some(c) = opts.lowpass {
        setup.set_lowpass_cutoff(c)?;
    }
    let mut rows = Vec::new();
    for &threads in &opts.threads {
        let mut best = BenchRow {
            threads,
            frames: 0,
            loop_seconds: f64::INFINITY,
            total_seconds: f64::INFINITY,
            cpu_seconds_per_frame: None,
        };
        let cpu_start = process_cpu_seconds();
        let mut frames_run = 0;
        for _ in 0..opts.repeat.max(1) {
            let run_opts = RunOptions {
                results_dir: Some(dir.clone()),
                threads: Some(threads),
                verbose: false,
                ..Default::default()
            };
            let start = Instant::now();
            let s = analyze::run(&setup, &run_opts)?;
            let total = start.elapsed().as_secs_f64();
            best.frames = s.frames;
            best.loop_seconds = best.loop_seconds.min(s.loop_seconds);
            best.total_seconds = best.total_seconds.min(total);
            frames_run += s.frames;
        }
        if let (Some(a), Some(b)) = (cpu_start, process_cpu_seconds()) {
            best.cpu_seconds_per_frame = (frames_run > 0).then(|| (b - a) / frames_run as f64);
        }
        rows.push(best);
    }
    let _ = std::fs::remove_dir_all(&dir);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::process_cpu_seconds;

    /// The process CPU clock counts every thread, those that have ended
    /// included (a clock of the main thread alone, which only waits here,
    /// would show about nothing): two threads that each spin until their
    /// own CPU clock shows 30 ms add at least 60 ms. (Spinning for 60 ms of
    /// wall time, as this test did, failed on a loaded host, where a thread
    /// gets less CPU than wall time.)
    #[test]
    fn process_cpu_time_counts_threads_that_ended() {
        use nix::time::{clock_gettime, ClockId};
        let thread_cpu = || {
            let t = clock_gettime(ClockId::CLOCK_THREAD_CPUTIME_ID).unwrap();
            t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9
        };
        let spin = || {
            let start = thread_cpu();
            let mut x = 0u64;
            while thread_cpu() - start < 0.03 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                std::hint::black_box(x);
            }
        };
        let before = process_cpu_seconds().expect("Linux tells a process's CPU time");
        std::thread::scope(|s| {
            s.spawn(spin);
            s.spawn(spin);
        });
        let used = process_cpu_seconds().unwrap() - before;
        assert!((0.06..5.0).contains(&used), "{used} s of CPU");
    }
}
