//! Reading user files: model documents and tool setups.
pub mod osim;
pub mod setup;
