//! statopt: static optimization of muscle and frictional contact forces for
//! OpenSim models, after Krueger & Wartzack (2017).
//!
//! The pipeline, one module per stage: [`parse`] (XML documents) →
//! [`model`] (compiled, immutable model) → [`motion`] (coordinates filtered
//! and splined into per-frame q, u, u̇) → per frame: [`dynamics`]
//! (kinematics, inverse dynamics) → [`paths`] and [`muscles`] (muscle
//! geometry and strength) → [`tools`] (the analyses users run) →
//! [`storage`] (OpenSim `.sto` tables).
pub mod contacts;
pub mod dynamics;
pub mod error;
pub mod forces;
pub mod functions;
pub mod model;
pub mod motion;
pub mod muscles;
pub mod optimize;
pub mod output;
pub mod parse;
pub mod paths;
pub mod plots;
pub mod storage;
pub mod tools;
pub mod wrapping;
pub mod xml;

pub use error::{Error, Location, Result};
