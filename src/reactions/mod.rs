//! Stage: joint reactions of a frame from the forces acting in it.
pub mod joint;

pub use joint::{
    apply_forces, column_labels, forward_dynamics, reactions, reactions_at_accelerations,
    static_optimization_reactions, ReactionSpec,
};
