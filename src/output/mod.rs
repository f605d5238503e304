//! Result files other than OpenSim's `.sto` tables (those are in
//! [`crate::storage`]).
//!
//! - [`mcap_log`]: a streaming MCAP log of every solved frame, for viewing
//!   in Foxglove or reading with any MCAP library.
pub mod mcap_log;
