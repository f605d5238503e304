//! Stopping a run cleanly on SIGINT (Ctrl-C) or SIGTERM.
//!
//! The binary calls [`install`] once. A signal only raises a flag; the frame
//! loop ([`crate::frame::driver::for_each_frame`]) looks at it between
//! chunks of frames, stops there, and the analyses then close every table
//! and the MCAP log as at the end of a run: what was solved is kept whole.
//! A second Ctrl-C while stopping ends the process at once (as a plain
//! SIGINT would; the tables then keep their complete rows).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

use crate::error::{Error, Result};

static FLAG: OnceLock<Arc<AtomicUsize>> = OnceLock::new();

/// Exit status of a run stopped by SIGINT (128 + 2), as shells report it.
pub const EXIT_SIGINT: u8 = 130;
/// Exit status of a run stopped by SIGTERM (128 + 15).
pub const EXIT_SIGTERM: u8 = 143;

fn flag() -> &'static Arc<AtomicUsize> {
    FLAG.get_or_init(|| Arc::new(AtomicUsize::new(0)))
}

/// Route SIGINT and SIGTERM to the stop flag.
pub fn install() -> Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let f = flag();
    let shutdown = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let err = |e: std::io::Error| Error::internal(format!("cannot install signal handlers: {e}"));
    // A second SIGINT while the first is being handled terminates.
    signal_hook::flag::register_conditional_shutdown(SIGINT, 130, shutdown.clone()).map_err(err)?;
    signal_hook::flag::register(SIGINT, shutdown).map_err(err)?;
    signal_hook::flag::register_usize(SIGINT, f.clone(), EXIT_SIGINT as usize).map_err(err)?;
    signal_hook::flag::register_usize(SIGTERM, f.clone(), EXIT_SIGTERM as usize).map_err(err)?;
    Ok(())
}

/// The exit status asked for by a signal received so far, if any.
pub fn requested() -> Option<u8> {
    match flag().load(Ordering::Relaxed) {
        0 => None,
        code => Some(code as u8),
    }
}

/// Raise the flag as a signal would (tests, embedding callers).
pub fn request(code: u8) {
    flag().store(code as usize, Ordering::Relaxed);
}
