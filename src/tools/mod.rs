//! The tools a setup file can name. Each `run_*` reads its inputs, processes
//! every frame and writes OpenSim-format results.
pub mod analyze;
pub mod bench;
pub mod bench_grid;
pub mod inverse_dynamics;
pub mod joint_reaction;
pub mod loading;
pub mod motion_gen;
pub mod muscle_analysis;
pub mod perturbation;
pub mod progress;
pub mod reduce;
pub mod static_optimization;
pub mod study;

use std::path::PathBuf;

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
}

/// What a run produced.
#[derive(Debug, Clone, Default)]
pub struct RunSummary {
    pub frames: usize,
    pub files: Vec<PathBuf>,
    pub warnings: Vec<String>,
    /// Wall time of the per-frame loop (solving and writing), seconds.
    pub loop_seconds: f64,
}
