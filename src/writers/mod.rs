//! Writers: a frame's results turned into the files a user reads, after
//! the reactions and before the tools that drive a run. The file formats
//! themselves (`.sto` tables, MCAP) are in [`crate::storage`] and
//! [`crate::output`]; this stage decides what of a frame goes where.
//!
//! - [`frame_log`]: a static-optimization run's MCAP log (channels,
//!   messages per frame);
//! - [`tables`]: the layout of its force, diagnostics and joint-reaction
//!   tables;
//! - [`so_tables`]: its tables opened, written frame by frame and finished;
//! - [`resume`]: where a run an earlier one left unfinished goes on (the
//!   frames its tables and log hold completely);
//! - [`sweep_statistics`]: a contact-weight sweep's mean, minimum and
//!   maximum tables;
//! - [`kinematics_tables`]: the BodyKinematics and PointKinematics
//!   analyses' position, velocity and acceleration tables;
//! - [`run_statistics`]: what a run reports besides its tables (unsolved
//!   frames, worst residual, bounds reached, reserve and root residual
//!   peaks) and the warnings made from it;
//! - [`contact_findings`]: what the run's contacts did that the summary
//!   names (slid or too deep while loaded, carried nothing, at a limit on
//!   an unsolved frame), from the rows the ContactForces table holds;
//! - [`grf`]: predict-grf's predicted ground reactions, root residual,
//!   comparison metrics and ExternalLoads pair;
//! - [`emg`]: emg-compare's table and figure;
//! - [`bench_grid`]: bench --grid's table and chart.
pub mod bench_grid;
pub mod contact_findings;
pub mod emg;
pub mod frame_log;
pub mod grf;
pub mod kinematics_tables;
pub mod knee_tables;
pub mod names;
pub mod resume;
pub mod run_statistics;
pub mod so_tables;
pub mod sweep_statistics;
pub mod tables;
