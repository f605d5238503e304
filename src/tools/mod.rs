//! The tools a setup file can name. Each `run_*` reads its inputs, processes
//! every frame and writes OpenSim-format results.
pub mod analyze;
pub mod bench;
pub mod bench_grid;
pub mod check;
pub mod dispatch;
pub mod emg_compare;
pub mod figures;
pub mod force_sweep;
pub use crate::frame::interrupt;
pub mod inputs;
pub mod inverse_dynamics;
pub mod joint_reaction;
pub mod kinematics;
pub mod knee_contact;
pub mod knee_contact_table;
pub mod knee_loads;
pub mod loading;
pub mod motion_gen;
pub mod muscle_analysis;
pub mod predict_grf;
pub mod progress;
pub mod reduce;
pub mod scene;
pub mod static_optimization;
pub mod study;

use std::path::PathBuf;

pub use dispatch::{run_parsed, run_setup, run_setup_text};

/// Called with a label (the table prefix of the frame loop, e.g.
/// `walk_SO_w0_500`), the frames done and the frames of that loop: once with
/// 0 when a loop starts, at most every 0.1 s while it runs, and once with
/// done = total when it ends.
#[derive(Clone)]
pub struct ProgressHook(pub std::sync::Arc<ProgressFn>);

/// What a [`ProgressHook`] calls: (label, frames done, frames of the loop).
pub type ProgressFn = dyn Fn(&str, u64, u64) + Send + Sync;

impl std::fmt::Debug for ProgressHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressHook")
    }
}

/// Options from the command line that override or extend a setup.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Overrides the setup's results directory.
    pub results_dir: Option<PathBuf>,
    /// Digits after the decimal point in `.sto` output (OpenSim's default 8).
    pub precision: Option<usize>,
    /// Print progress and warnings.
    pub verbose: bool,
    /// Worker threads for per-frame work (None: all cores). Results do not
    /// depend on it.
    pub threads: Option<usize>,
    /// Continue static-optimization runs from the last frame their tables
    /// and log hold completely (`--resume`).
    pub resume: bool,
    /// Run static optimization on the model reduced to what the motion
    /// needs, whatever the setup's `<reduce_model>` says (`--reduce`;
    /// AnalyzeTool setups).
    pub reduce: bool,
    /// Wait, before returning, until every output file is on the disk
    /// itself (`fsync`, `--sync`): they survive a power cut from then on.
    /// Without it files are closed as OpenSim closes them; a killed or
    /// failed process loses nothing either way.
    pub sync: bool,
    /// Told how frame loops advance (embedding callers; see [`progress`]).
    pub progress: Option<ProgressHook>,
    /// Read on past elements of a setup document neither OpenSim nor
    /// statopt knows, with a warning (`--allow-unknown`); without it they
    /// are errors (see `parse::known::setup_elements`).
    pub allow_unknown: bool,
    /// Told each unknown element `allow_unknown` read on past, as soon as
    /// the setup is read, before the run (the command line prints them as
    /// warnings then, so that a run that later fails has said them too).
    /// They are in the run's summary as well.
    pub read_on_hook: Option<fn(&str)>,
}

/// A failed run's error, with the unknown elements `--allow-unknown` read
/// on past named after it: a misspelt element that took its default is the
/// likeliest cause of what went wrong, and the run's warnings are not
/// printed when it fails.
pub fn with_read_on_note(e: crate::Error, read_on: &[String]) -> crate::Error {
    match read_on {
        [] => e,
        [one] => e.with_note(format!("the setup was read with an unknown element: {one}")),
        [first, rest @ ..] => e.with_note(format!(
            "the setup was read with {} unknown elements, the first: {first}",
            rest.len() + 1
        )),
    }
}

/// The summary, once its files are on the disk when `opts.sync` asks.
pub fn synced(summary: RunSummary, opts: &RunOptions) -> crate::Result<RunSummary> {
    if opts.sync {
        sync_files(&summary.files)?;
    }
    Ok(summary)
}

/// Wait until every file of `files` is on the disk itself (`fsync`; the
/// `--sync` option), each on a thread of its own so that the syncs overlap
/// (the file system commits them together) instead of queueing. A stopped
/// run's files are left as they are (they are complete up to their last
/// row either way).
pub fn sync_files(files: &[std::path::PathBuf]) -> crate::Result<()> {
    use crate::error::Error;
    std::thread::scope(|scope| {
        let handles: Vec<_> = files
            .iter()
            .map(|f| {
                scope.spawn(move || {
                    std::fs::File::open(f)
                        .and_then(|file| file.sync_all())
                        .map_err(|e| Error::io(f, e))
                })
            })
            .collect();
        let mut result = Ok(());
        for h in handles {
            let r = h
                .join()
                .unwrap_or_else(|_| Err(Error::internal("syncing a file panicked")));
            if result.is_ok() {
                result = r;
            }
        }
        result
    })
}

/// What a run produced.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    /// Motion frames analysed (the most of any analysis of the run).
    pub frames: usize,
    pub files: Vec<PathBuf>,
    pub warnings: Vec<String>,
    /// Wall time of the per-frame loop (solving and writing), seconds.
    pub loop_seconds: f64,
    /// Static-optimization frame problems of the run, every w0 and setup
    /// counted, and how many of them the optimiser could not solve.
    pub solves: usize,
    pub failed: usize,
    /// The first unsolved frame and where its diagnostics are.
    pub first_failure: Option<String>,
    /// Largest equation-of-motion residual of a solved frame (N or N·m).
    pub worst_residual: f64,
    /// What reserve actuators carried at most (N or N·m) and where.
    pub reserve_peak: Option<(f64, String)>,
    /// What non-muscle actuators (residuals) supplied at most on the root
    /// joint's coordinates: force (N) and moment (N·m), with where.
    pub root_force_peak: Option<(f64, String)>,
    pub root_moment_peak: Option<(f64, String)>,
    /// Per frame solved: time (s) and the size of the summed force (N) that
    /// non-muscle actuators (residuals and reserves) apply on the root
    /// joint's translations.
    pub root_force_series: Vec<(f64, f64)>,
    /// Weight (N) of what the root joint carries: the body weight residual
    /// forces are compared with.
    pub root_body_weight: Option<f64>,
    /// Information lines (timings), not warnings.
    pub notes: Vec<String>,
    /// Folders the outputs went to.
    pub results_dirs: Vec<PathBuf>,
    /// Set when a signal stopped the run: the exit status it asks for and
    /// the time of the last frame written (None: none was).
    pub stopped: Option<(u8, Option<f64>)>,
    /// OpenSim properties the setups hold that statopt accepts but does not
    /// use (listed once in the report).
    pub unused_properties: Vec<String>,
    /// What the contacts did that the user must know (each also a warning):
    /// slid or more than 1 mm into their plane while loaded, carried
    /// nothing (`writers::contact_findings`); `run` names the w0 of a sweep
    /// or the setup of a study.
    pub contacts: Vec<crate::writers::contact_findings::ContactFinding>,
}

/// Exit status of a run in which some frames could not be solved (the
/// outputs are complete; those rows hold the solver's best point), or whose
/// prediction the physics rejects.
pub use crate::metrics::EXIT_FRAMES_FAILED;

fn keep_max(a: &mut Option<(f64, String)>, b: Option<(f64, String)>) {
    if let Some(b) = b {
        if a.as_ref().is_none_or(|a| b.0 > a.0) {
            *a = Some(b);
        }
    }
}

impl RunSummary {
    /// Add another run's summary (an analysis of the same setup, a w0 of a
    /// sweep, a setup of a study); its warnings get `label` in front.
    pub fn absorb(&mut self, other: RunSummary, label: Option<&str>) {
        self.frames = self.frames.max(other.frames);
        self.files.extend(other.files);
        self.warnings
            .extend(other.warnings.into_iter().map(|w| match label {
                Some(l) => format!("{l}: {w}"),
                None => w,
            }));
        self.loop_seconds += other.loop_seconds;
        self.solves += other.solves;
        self.failed += other.failed;
        if self.first_failure.is_none() {
            self.first_failure = other.first_failure.map(|f| match label {
                Some(l) => format!("{l}: {f}"),
                None => f,
            });
        }
        self.worst_residual = self.worst_residual.max(other.worst_residual);
        keep_max(&mut self.reserve_peak, other.reserve_peak);
        keep_max(&mut self.root_force_peak, other.root_force_peak);
        keep_max(&mut self.root_moment_peak, other.root_moment_peak);
        self.root_force_series.extend(other.root_force_series);
        self.contacts
            .extend(other.contacts.into_iter().map(|mut f| {
                if let Some(l) = label {
                    f.run = Some(match f.run {
                        Some(r) => format!("{l}: {r}"),
                        None => l.to_string(),
                    });
                }
                f
            }));
        self.root_body_weight = self.root_body_weight.or(other.root_body_weight);
        self.notes.extend(other.notes);
        for d in other.results_dirs {
            if !self.results_dirs.contains(&d) {
                self.results_dirs.push(d);
            }
        }
        if self.stopped.is_none() {
            self.stopped = other.stopped;
        }
        for p in other.unused_properties {
            if !self.unused_properties.contains(&p) {
                self.unused_properties.push(p);
            }
        }
    }

    /// The line that says where a stopped run stopped, if it was stopped.
    pub fn stopped_line(&self) -> Option<String> {
        self.stopped.map(|(_, t)| {
            format!(
                "stopped by a signal {}; every table and the MCAP log hold the {} frames solved so far and are closed; run the same command again with --resume to compute the rest (the tables then equal an uninterrupted run's)",
                match t {
                    Some(t) => format!("after the frame at t = {}", crate::storage::fmt_time(t)),
                    None => "before the first frame".to_string(),
                },
                self.frames
            )
        })
    }

    /// The lines that end a run: frames, solves and failures, the worst
    /// residual, what reserves and root residuals carried, where the
    /// outputs are.
    pub fn report(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut first = format!("{} frames", self.frames);
        if self.solves > 0 {
            first.push_str(&format!(
                "; static optimization: {} of {} frame problems solved, {} failed; worst equation residual of a solved frame {:.3e} (N or N m)",
                self.solves - self.failed,
                self.solves,
                self.failed,
                self.worst_residual
            ));
        }
        out.push(first);
        if let Some((v, at)) = &self.reserve_peak {
            out.push(format!(
                "reserve actuators carried at most {} (N or N m), {at}",
                amount(*v)
            ));
        }
        if let Some((v, at)) = &self.root_force_peak {
            let share = match self.root_body_weight {
                Some(bw) if bw > 0.0 => format!(" ({:.1} % of body weight)", 100.0 * v / bw),
                _ => String::new(),
            };
            out.push(format!(
                "residual actuators on the root joint carried at most {} N{share}, {at}",
                amount(*v)
            ));
        }
        if let Some((v, at)) = &self.root_moment_peak {
            out.push(format!(
                "residual actuators on the root joint carried at most {} N m, {at}",
                amount(*v)
            ));
        }
        if !self.unused_properties.is_empty() {
            out.push(format!(
                "accepted but not used by statopt (OpenSim 4.6 properties): {}",
                self.unused_properties.join(", ")
            ));
        }
        let dirs: Vec<String> = self
            .results_dirs
            .iter()
            .map(|d| d.display().to_string())
            .collect();
        out.push(format!(
            "{} files written to {}",
            self.files.len(),
            if dirs.is_empty() {
                "-".to_string()
            } else {
                dirs.join(", ")
            }
        ));
        out
    }

    /// The line that says frames failed, if any (printed even with --quiet).
    pub fn failure_line(&self) -> Option<String> {
        (self.failed > 0).then(|| {
            format!(
                "static optimization could not solve {} of {} frame problems (first: {}); their rows hold the solver's best point; exit status {EXIT_FRAMES_FAILED}",
                self.failed,
                self.solves,
                self.first_failure.as_deref().unwrap_or("?")
            )
        })
    }
}

/// A force or moment in a summary line: three decimals (millinewtons), or
/// four significant digits below that, so that neither 165.510778 nor 0.000
/// is printed.
fn amount(v: f64) -> String {
    if v == 0.0 || v.abs() >= 1e-3 {
        format!("{v:.3}")
    } else {
        format!("{v:.3e}")
    }
}

#[cfg(test)]
mod summary_tests {
    use super::*;

    /// The summary's peaks print as amounts, not float noise: the reserve
    /// peak read "165.510778" beside "165.511 N" for the same force.
    #[test]
    fn peaks_print_three_decimals_or_significant_digits() {
        let s = RunSummary {
            reserve_peak: Some((165.510778, "pelvis_ty_reserve at t=2.93".into())),
            root_force_peak: Some((3.2e-8, "pelvis_ty at t=0.5".into())),
            ..Default::default()
        };
        let r = s.report();
        assert!(
            r.iter().any(|l| l.contains("at most 165.511 (N or N m)")),
            "{r:?}"
        );
        assert!(r.iter().any(|l| l.contains("at most 3.200e-8 N")), "{r:?}");
    }
}
