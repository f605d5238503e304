//! Stage: one frame of static optimization, and the driver that runs frames.
//!
//! - [`settings`]: the StaticOptimization element as the plan holds it;
//!   [`options`]: the numbers a run is solved with, compiled from it.
//! - [`compile`]: [`SoProblem::build`], the run's model and force set sorted
//!   into controls, passive forces, contacts and external loads, once.
//! - [`problem`]: [`SoProblem`], compiled once per run, and per frame its
//!   convex program (kinematics → muscle paths and strength → contacts → the
//!   equations of motion) and outputs ([`FrameResult`]).
//! - [`knee_contact`]: statopt's knee contact method, the knee's two
//!   compartments as unknown contact forces of the frame's program.
//! - [`candidates`]: one assembled frame solved for many candidates that
//!   differ only in forces (w0, a passive force, an optimal force).
//! - [`perturbation`]: the constraint matrix by forward-dynamics perturbation.
//! - [`reduce`]: `<reduce_model>`, the run's model reduced to what the
//!   motion moves.
//! - [`workspace`]: the per-thread buffers a frame is evaluated in.
//! - [`inputs`]: the setup's motion opened for the frames (read once,
//!   filtered, its contacts closed, streamed or kept).
//! - [`driver`]: frames in parallel chunks over per-thread workspaces,
//!   results in frame order; [`interrupt`]: stopping it cleanly;
//!   [`threads`]: the run's worker pool, started in one place.
//! - [`so_loop`]: a static-optimization pass's frame loop: every frame
//!   solved (once per contact weight) on the driver's threads and its
//!   results streamed, in frame order, to sinks on threads of their own.
pub mod candidates;
pub mod compile;
pub mod driver;
pub mod inputs;
pub mod interrupt;
pub mod knee_contact;
pub mod options;
pub mod perturbation;
pub mod problem;
pub mod reduce;
pub mod settings;
pub mod so_loop;
pub mod threads;
pub mod workspace;

pub use options::SoOptions;
pub use problem::{Control, FrameResult, SoProblem};
pub use settings::StaticOptimizationSetup;
pub use workspace::Workspace;
