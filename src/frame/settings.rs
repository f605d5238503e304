//! The StaticOptimization element's settings a frame is solved with: read
//! once in the parse stage (`parse::analyses`), re-exported here.

pub use crate::parse::analyses::{
    ConstraintMatrix, StaticOptimizationSetup, CONTACT_WEIGHT_RANGE, DEFAULT_CONTACT_WEIGHT,
    DEFAULT_TOLERANCE,
};
