//! Writers: a frame's results turned into the files a user reads, after
//! the reactions and before the tools that drive a run. The file formats
//! themselves (`.sto` tables, MCAP) are in [`crate::storage`] and
//! [`crate::output`]; this stage decides what of a frame goes where.
//!
//! - [`frame_log`]: a static-optimization run's MCAP log (channels,
//!   messages per frame);
//! - [`tables`]: the layout of its force, diagnostics and joint-reaction
//!   tables;
//! - [`so_tables`]: its tables opened, written frame by frame and finished.
pub mod frame_log;
pub mod so_tables;
pub mod tables;
