//! `statopt-tool SETUP.xml`: run the tool an OpenSim-style setup file describes.
//! `statopt-tool bench SETUP.xml`: measure frames per second.
//!
//! Exit status: 0 success, 2 bad input (a file, element or option is wrong),
//! 1 internal failure.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand};
use statopt::parse::setup::Setup;
use statopt::tools::{self, bench, RunOptions};

#[derive(Parser, Debug)]
#[command(
    name = "statopt-tool",
    version,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    about = "Estimate muscle and contact forces from a motion: runs OpenSim-style setup files (InverseDynamicsTool, AnalyzeTool with MuscleAnalysis / StaticOptimization).",
    long_about = "Reads one XML setup file (OpenSim InverseDynamicsTool / AnalyzeTool style), runs the tool it \
describes, and writes OpenSim .sto tables. Paths inside the setup are relative to the setup file's folder, \
as in OpenSim.\n\nExit status: 0 on success, 2 when the input is wrong (the message names the file, element \
and line), 1 on an internal failure."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Args, Debug)]
struct RunArgs {
    /// The setup file (e.g. setup_SO.xml).
    #[arg(required = true)]
    setup: Option<PathBuf>,
    /// Write results here instead of the setup's <results_directory>.
    #[arg(short = 'o', long = "results-dir", value_name = "DIR")]
    results_dir: Option<PathBuf>,
    /// Digits after the decimal point in .sto files (default: the setup's output_precision, or 8).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=20))]
    precision: Option<u8>,
    /// Worker threads for the per-frame work (default: all cores). Results do not depend on it.
    #[arg(short = 'j', long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    threads: Option<u16>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run an AnalyzeTool setup repeatedly and report frames per second and peak memory.
    Bench {
        /// The setup file.
        setup: PathBuf,
        /// Thread counts to measure, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "1,2")]
        threads: Vec<usize>,
        /// Runs per thread count (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Repeat the motion this many times end to end first (trial length scaling).
        #[arg(long, default_value_t = 1)]
        tile: usize,
        /// Override the setup's coordinate low-pass cut-off (Hz; -1: no filtering).
        #[arg(long, allow_hyphen_values = true)]
        lowpass: Option<f64>,
    },
}

fn run_setup(a: &RunArgs) -> statopt::Result<tools::RunSummary> {
    let opts = RunOptions {
        results_dir: a.results_dir.clone(),
        precision: a.precision.map(usize::from),
        verbose: !a.quiet,
        threads: a.threads.map(usize::from),
    };
    let setup = a
        .setup
        .as_ref()
        .ok_or_else(|| statopt::Error::msg("no setup file given"))?;
    match Setup::read(setup)? {
        Setup::InverseDynamics(s) => tools::inverse_dynamics::run(&s, &opts),
        Setup::Analyze(s) => tools::analyze::run(&s, &opts),
    }
}

fn fail(e: statopt::Error) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(e.exit_code() as u8)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match &cli.command {
        Some(Command::Bench {
            setup,
            threads,
            repeat,
            tile,
            lowpass,
        }) => {
            let opts = bench::BenchOptions {
                threads: threads.clone(),
                repeat: *repeat,
                tile: *tile,
                lowpass: *lowpass,
            };
            match bench::run(setup, &opts) {
                Ok(rows) => {
                    println!("setup\tthreads\tframes\tloop_s\tframes_per_s\tms_per_frame\ttotal_s\tpeak_MiB");
                    let mem = bench::peak_memory_mib()
                        .map(|m| format!("{m:.1}"))
                        .unwrap_or_else(|| "n/a".into());
                    for r in rows {
                        println!(
                            "{}\t{}\t{}\t{:.4}\t{:.0}\t{:.4}\t{:.3}\t{}",
                            setup.display(),
                            r.threads,
                            r.frames,
                            r.loop_seconds,
                            r.frames as f64 / r.loop_seconds,
                            1e3 * r.loop_seconds / r.frames as f64,
                            r.total_seconds,
                            mem
                        );
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => fail(e),
            }
        }
        None => match run_setup(&cli.run) {
            Ok(summary) => {
                if !cli.run.quiet {
                    for w in &summary.warnings {
                        eprintln!("warning: {w}");
                    }
                    eprintln!("{} frames", summary.frames);
                    for f in &summary.files {
                        eprintln!("wrote {}", f.display());
                    }
                }
                ExitCode::SUCCESS
            }
            Err(e) => fail(e),
        },
    }
}
