//! What an AnalyzeTool run reads, shared by the tools: the motion, its
//! states and state streams (opened by the frame stage,
//! `frame::inputs`, re-exported here), the results folder, and the
//! JointReactions coupled to a static optimization. The dispatcher that
//! runs a setup's analyses is `tools::analyze`; the tools take these
//! helpers from here, so that no tool imports the dispatcher that imports
//! it.

use crate::error::Result;
use crate::parse::setup::{Analysis, AnalyzeSetup};
use crate::tools::RunOptions;

pub use crate::frame::inputs::{
    load_motion_states, load_states, load_states_with, missing_columns_warning, open_motion_stream,
    open_state_stream, open_state_stream_with, read_motion,
};

/// The JointReactions of `analyses` that take each frame's
/// StaticOptimization solution directly: those without a forces_file, when
/// the setup runs a StaticOptimization (`has_so`).
pub fn coupled_reactions<'a>(
    analyses: impl IntoIterator<Item = &'a Analysis>,
    has_so: bool,
) -> Vec<crate::reactions::setup::JointReactionSetup> {
    analyses
        .into_iter()
        .filter_map(|a| match a {
            Analysis::JointReaction(jr) if has_so && jr.forces_file.is_none() => {
                Some((**jr).clone())
            }
            _ => None,
        })
        .collect()
}

/// The results directory: the command-line override or the setup's.
pub fn results_dir(setup: &AnalyzeSetup, opts: &RunOptions) -> Result<std::path::PathBuf> {
    let dir = opts
        .results_dir
        .clone()
        .unwrap_or_else(|| setup.results_directory.clone());
    crate::parse::setup::create_results_dir(
        &dir,
        &setup.results_directory_loc,
        opts.results_dir.is_some(),
    )?;
    Ok(dir)
}
