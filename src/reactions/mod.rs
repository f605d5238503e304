//! Stage: joint reactions of a frame from the forces acting in it.
//!
//! - [`joint`]: a frame's reactions (Simbody's mobilizer reactions) from
//!   the forces applied in it, and static optimization's reactions.
//! - [`linear`]: a frame's reactions as an affine function of its forces,
//!   for many solutions of one frame (force sweeps).
//! - [`knee_loads`]: a frame's knee loads (flexion, tibiofemoral and
//!   patellofemoral) from its reactions; [`knee_contact`]: the knee
//!   contact method's reactions and its table's row.
//! - [`setup`]: the JointReaction element and the reactions it asks for.
//! - [`forces_file`]: a JointReaction's forces file, read as frames need it.
//! - [`problem`]: a JointReaction run compiled once, and one frame of it.
pub mod forces_file;
pub mod joint;
pub mod knee_contact;
pub mod knee_loads;
pub mod linear;
pub mod problem;
pub mod setup;

pub use joint::{
    apply_forces, column_labels, forward_dynamics, reactions, reactions_at_accelerations,
    static_optimization_reactions, ReactionSpec,
};
pub use problem::JointReactionProblem;
pub use setup::{resolve_reactions, JointReactionSetup};
