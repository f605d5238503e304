//! statopt: static optimization of muscle and frictional contact forces for
//! OpenSim models, after Krueger & Wartzack (2017).
pub mod error;
pub mod storage;
pub mod xml;

pub use error::{Error, Location, Result};
