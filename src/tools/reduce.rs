//! `<reduce_model>` (`statopt-tool SETUP --reduce`): static optimization on
//! the model reduced to what the setup's motion moves. The reduction is the
//! frame stage's (`frame::reduce`, which documents the rules); this driver
//! opens the motion's states as the run streams them and names the joints of
//! the setup's JointReactions, which are never treated as rigid.

use crate::error::Result;
use crate::parse::setup::AnalyzeSetup;
use crate::reactions::{resolve_reactions, JointReactionSetup};
use crate::storage::TableFile;
use crate::tools::inputs::open_motion_stream;
use crate::tools::loading::AnalysisModel;

pub use crate::frame::reduce::{Reduction, STATIC_TOLERANCE};

/// The model an AnalyzeTool's static optimization needs for the setup's
/// motion, and what was removed (`frame::reduce::reduce`).
pub fn reduce(
    setup: &AnalyzeSetup,
    motion: &TableFile,
    am: &AnalysisModel,
    step_interval: usize,
    passive_fiber_forces: bool,
    reactions: &[JointReactionSetup],
) -> Result<(AnalysisModel, Reduction)> {
    let model = &am.model;
    crate::frame::reduce::reduce(
        setup,
        am,
        step_interval,
        passive_fiber_forces,
        || open_motion_stream(setup, motion, model, &[]),
        || {
            let mut joints = Vec::new();
            for jr in reactions {
                let (specs, _) = resolve_reactions(model, jr)?;
                joints.extend(specs.iter().map(|s| (s.joint, s.frame_body)));
            }
            Ok(joints)
        },
    )
}
