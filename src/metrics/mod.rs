//! Statistics of a run's results and the rules that accept or reject them,
//! computed from the results in memory (a stage of its own: tools report
//! them, writers write them).
//!
//! - [`grf`]: predict-grf's agreement with the measured plates and its
//!   acceptance by the physics (root residual, mean support of the feet);
//! - [`differences`]: a results table against a reference run's (max and
//!   RMS |Δ|, vector norms; bench --grid);
//! - [`emg`]: activations against measured EMG (emg-compare: Pearson r,
//!   on/off agreement, the best electromechanical delay);
//! - [`series`]: a `<Metric>`'s statistic of a series (max, integral,
//!   argmax, crossing, ...).
pub mod differences;
pub mod emg;
pub mod grf;
pub mod series;

/// The exit status of a run whose results are not a result: static
/// optimization left frames unsolved, or the physics rejects a prediction
/// ([`grf::judge_root_residual`], [`grf::judge_support`]).
pub const EXIT_FRAMES_FAILED: u8 = 3;
