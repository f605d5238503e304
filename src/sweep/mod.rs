//! Stage: force sweeps. Many candidates of one AnalyzeTool setup that
//! differ only in forces — w0, an `ExpressionBasedCoordinateForce`'s
//! expression (a machine's resistance torque), an actuator's optimal
//! force, an external load's scale — share one compiled scene, with or
//! without the knee contact method (`<knee_contact>`: its rows are affine
//! in those forces, `frame::candidates`; its `<setup>_KneeContact.sto`
//! columns can be metrics). The setup is compiled once ([`SweepPlan`]) and
//! the motion (with its contact closure) streamed once; each frame is
//! assembled once (`SoProblem::assemble`) and solved for every candidate
//! (`SoProblem::solve_candidate_into`), each candidate warm-started from
//! the previous ones of the same w0 in the frame (the same answers as a
//! cold start, up to rounding), its joint reactions from the frame's
//! affine reaction basis (`reactions::linear::ReactionBasis`), its knee
//! rows by `reactions::knee_loads` and `reactions::knee_contact`. Each
//! candidate's values of the setup's `<Metric>` elements are computed from
//! the rows it would have written (the same `op`s,
//! `metrics::series::metric_value`), with the candidate's own w0 whatever
//! w0 tag a metric's file names; only the outputs its metrics read are
//! made (`frame::problem::Outputs`) unless its tables are kept
//! ([`Solve::keep_results`]: [`stream`] writes them).
//!
//! Candidates' metrics equal those of runs of each candidate's own setup
//! (tests/force_sweep.rs: 1e-9 relative), as the frames are those runs'
//! frames: the setup's `<Metric>`s read tables written to
//! `output_precision` decimals, this sweep the unrounded values.
//!
//! - [`candidates`]: specifications resolved against the problem, their
//!   warm-start chains;
//! - [`plan`]: the compiled sweep, a frame prepared and solved for every
//!   candidate;
//! - [`metrics`]: the `<Metric>`s compiled, the candidates' series
//!   collected into their values ([`SweepOutcome`]);
//! - [`run`]: the motion streamed ([`solve_stream`]) or kept ([`Scene`]);
//! - [`setup`]: the setup read and its motion opened, a [`Scene`] compiled
//!   and solved on a pool ([`compile_scene`], [`run_scene`]);
//! - [`stream`]: a sweep run whole on a pool, its candidates' tables
//!   written on request ([`stream::run_file`], [`stream::SweepOptions`]).
pub mod candidates;
pub mod metrics;
pub mod plan;
pub mod run;
pub mod setup;
pub mod stream;

pub use metrics::SweepOutcome;
pub use plan::{FrameValues, SweepPlan};
pub use run::{solve_stream, Scene, Solve};
pub use setup::{compile_scene, run_scene};
