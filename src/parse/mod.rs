//! Reading user files: model documents and tool setups.
pub mod analyses;
pub mod compose;
pub mod figures;
pub mod kinematics;
pub mod known;
mod known_properties;
pub mod osim;
pub mod setup;
