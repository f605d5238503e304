//! The dispatcher of `statopt-tool SETUP.xml`: a setup document read once
//! into its plan and handed to the tool it names (a study, the
//! InverseDynamicsTool, the AnalyzeTool). Re-exported as
//! `tools::run_setup`; no tool imports it.

use crate::tools::{analyze, inverse_dynamics, study, synced, with_read_on_note};
use crate::tools::{RunOptions, RunSummary};

/// Run the tool a setup file describes, as `statopt-tool SETUP.xml` does: a
/// study document, an InverseDynamicsTool or an AnalyzeTool setup, read
/// once into its plan (`plan::Plan`).
pub fn run_setup(setup: &std::path::Path, opts: &RunOptions) -> crate::Result<RunSummary> {
    let _outputs = keep_outputs(opts);
    let plan = crate::plan::Plan::read(setup, opts.allow_unknown)?;
    let read_on = plan.unknown_elements_read_on();
    if let Some(hook) = opts.read_on_hook {
        read_on.iter().for_each(|w| hook(w));
    }
    let summary = match plan {
        crate::plan::Plan::Study(s) => study::run(&s, opts),
        crate::plan::Plan::Tool(s) => run_parsed(*s, opts),
    }
    .map_err(|e| with_read_on_note(e, &read_on))?;
    synced(summary, opts)
}

/// [`run_setup`] for a tool setup (not a study) given as text, read as if it
/// were the file `setup` (see `Setup::parse`).
pub fn run_setup_text(
    setup: &std::path::Path,
    text: &str,
    opts: &RunOptions,
) -> crate::Result<RunSummary> {
    let _outputs = keep_outputs(opts);
    let parsed = crate::parse::setup::Setup::parse_with(text, setup, opts.allow_unknown)?;
    let read_on = parsed.warnings().to_vec();
    synced(
        run_parsed(parsed, opts).map_err(|e| with_read_on_note(e, &read_on))?,
        opts,
    )
}

/// The run's outputs kept in memory while it runs, for its own consumers
/// (`storage::results`: no run reads back a file it wrote): those under
/// `-o DIR`, or every output; none when a caller already keeps them (the
/// Python binding's run in memory).
fn keep_outputs(opts: &RunOptions) -> Option<crate::storage::results::Capture> {
    use crate::storage::results::{captured, Capture};
    match opts.results_dir.as_deref() {
        Some(dir) if captured(dir) => None,
        dir => Some(Capture::new(dir)),
    }
}

/// Run a setup already read (the Python binding's, after its setters),
/// its outputs kept in memory for its own consumers as [`run_setup`] keeps them.
pub fn run_parsed(
    setup: crate::parse::setup::Setup,
    opts: &RunOptions,
) -> crate::Result<RunSummary> {
    use crate::parse::setup::Setup;
    let _outputs = keep_outputs(opts);
    match setup {
        Setup::InverseDynamics(s) => inverse_dynamics::run(&s, opts),
        Setup::Analyze(mut s) => {
            s.set_reduce_model(s.reduce_model || opts.reduce);
            analyze::run(&s, opts)
        }
    }
}
