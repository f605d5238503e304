//! `statopt-tool SETUP.xml`: run the tool an OpenSim-style setup file describes.
//!
//! Exit status: 0 success, 2 bad input (a file, element or option is wrong),
//! 1 internal failure.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;
use statopt::parse::setup::Setup;
use statopt::tools::{self, RunOptions};

#[derive(Parser, Debug)]
#[command(
    name = "statopt-tool",
    version,
    about = "Run an OpenSim-style setup file: inverse dynamics (InverseDynamicsTool) today; static optimization with contacts as it lands.",
    long_about = "Reads one XML setup file (OpenSim InverseDynamicsTool / AnalyzeTool style), runs the tool it \
describes, and writes OpenSim .sto tables. Paths inside the setup are relative to the setup file's folder, \
as in OpenSim.\n\nExit status: 0 on success, 2 when the input is wrong (the message names the file, element \
and line), 1 on an internal failure."
)]
struct Cli {
    /// The setup file (e.g. setup_ID.xml).
    setup: PathBuf,
    /// Write results here instead of the setup's <results_directory>.
    #[arg(short = 'o', long = "results-dir", value_name = "DIR")]
    results_dir: Option<PathBuf>,
    /// Digits after the decimal point in .sto files (OpenSim's default is 8).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=20))]
    precision: Option<u8>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let opts = RunOptions {
        results_dir: cli.results_dir.clone(),
        precision: cli.precision.map(usize::from),
        verbose: !cli.quiet,
    };
    let result = Setup::read(&cli.setup).and_then(|setup| match setup {
        Setup::InverseDynamics(s) => tools::inverse_dynamics::run(&s, &opts),
        Setup::Analyze(s) => tools::analyze::run(&s, &opts),
    });
    match result {
        Ok(summary) => {
            if !cli.quiet {
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
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(e.exit_code() as u8)
        }
    }
}
