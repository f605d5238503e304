//! Reading user files: model documents and tool setups.
pub mod compose;
pub mod osim;
pub mod scene;
pub mod setup;
