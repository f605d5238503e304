//! Forces that are known at a frame (not optimisation unknowns): external
//! loads from data files.
pub mod external_loads;
