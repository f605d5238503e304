//! Shared input loading for the tools, where the stages keep it: model
//! files ([`crate::model::load`]), coordinates files filtered as OpenSim
//! filters them ([`crate::motion::filter`]), the analysis model with its
//! force set and the force kinds ([`crate::forces::analysis_model`]). These
//! paths stay for users.

pub use crate::forces::analysis_model::{
    applies_force, force_kind, load_analysis_model, AnalysisModel, ForceKind,
};
pub use crate::model::load::{load_composed_model, load_model};
pub use crate::motion::filter::{filter_coordinates, load_coordinates, load_coordinates_in};
