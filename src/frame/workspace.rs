//! The per-thread buffers a frame is evaluated in: created once per worker
//! thread and reused for every frame it solves (the frame driver's `init`).
//! Everything that changes from frame to frame lives here; the compiled
//! model, muscles and problem stay immutable and shared.

use crate::dynamics::Data;
use crate::frame::problem::Assembly;
use crate::model::Model;
use crate::muscles::set::{MuscleFrame, MuscleSet};

pub struct Workspace {
    /// Kinematics, dynamics and applied forces of the current frame.
    pub data: Data,
    /// Muscle path states, lengths, speeds, strength and unit forces.
    pub muscles: MuscleFrame,
    /// The buffers static optimization assembles a frame's problem in.
    pub assembly: Assembly,
    /// Per contact weight of a sweep: the multipliers of the last frame
    /// solved here by dual Newton (empty when it was not), the next frame's
    /// warm start ([`SoProblem::solve_frame_into`](crate::frame::SoProblem::solve_frame_into)).
    pub warm: Vec<Vec<f64>>,
}

impl Workspace {
    pub fn new(model: &Model, muscles: &MuscleSet) -> Workspace {
        Workspace {
            data: Data::new(model),
            muscles: MuscleFrame::new(muscles, model),
            assembly: Assembly::default(),
            warm: Vec::new(),
        }
    }
}
