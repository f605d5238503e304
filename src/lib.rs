//! statopt: static optimization of muscle and frictional contact forces for
//! OpenSim models, after Krueger & Wartzack (2017).
//!
//! The pipeline, one module per stage (docs/architecture.md): [`functions`]
//! (OpenSim Functions) → [`parse`] (XML documents) → [`plan`] (a setup read once into its typed plan) → [`model`] (compiled once, immutable) → [`motion`]
//! (coordinates filtered and splined into per-frame q, u, u̇) → per frame,
//! over a per-thread workspace ([`frame::Workspace`]): [`dynamics`]
//! (kinematics, inverse and forward dynamics) → [`paths`] and [`muscles`]
//! (muscle geometry and strength) → [`forces`] (known forces) → [`contacts`]
//! (contact geometry and friction) → [`optimize`] (the per-frame convex
//! program) → [`frame`] (the run's problem compiled once; one frame of static optimization assembled from the
//! stages before, solved and turned into outputs; the frame driver) →
//! [`reactions`] (joint reactions from the frame's forces) → [`writers`] (a
//! frame's results as the messages of the run's log and the rows of its tables) → [`tools`] (thin
//! drivers: the analyses a setup names, studies, predict-grf, bench) →
//! [`storage`], [`output`], [`plots`] (tables, logs, figures). A module
//! imports only from earlier stages; the readers and writers ([`storage`],
//! [`output`], [`plots`]) import nothing from the pipeline, and any stage
//! may use them (tests/architecture.rs checks both).
// `!(x > 0.0)` is how this crate rejects NaN along with the values a check
// excludes (and how the wrapping code keeps OpenSim's NaN behaviour); the
// `partial_cmp` form clippy suggests hides that.
#![allow(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "negated comparisons deliberately reject NaN"
)]
pub mod contacts;
pub mod dynamics;
pub mod error;
pub mod file_counts;
pub mod forces;
pub mod frame;
pub mod functions;
pub mod metrics;
pub mod model;
pub mod motion;
pub mod muscles;
pub mod optimize;
pub mod output;
pub mod parse;
pub mod paths;
pub mod plan;
pub mod plots;
pub mod reactions;
pub mod storage;
pub mod sweep;
#[cfg(test)]
pub(crate) mod test_dir;
pub mod tools;
pub mod wrapping;
pub mod writers;
pub mod xml;

pub use error::{Error, Location, Result};
