//! Ctrl-C and SIGTERM for the commands that run missions: the first asks
//! the run to end at the next frame boundary, with its recording
//! finalised and its report written; a second ends the process at once.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use signal_hook::consts::{SIGINT, SIGTERM};

/// The exit status of a run a signal cut short (128 + SIGINT, as shells
/// report a process that Ctrl-C ended).
pub const INTERRUPTED_STATUS: u8 = 130;

static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
static NEVER: AtomicBool = AtomicBool::new(false);

/// Catch SIGINT and SIGTERM from now on (again is harmless): the first sets
/// [`stop_flag`]; a second, with the flag set, exits with
/// [`INTERRUPTED_STATUS`] at once.
pub fn install() -> std::io::Result<()> {
    if STOP.get().is_some() {
        return Ok(());
    }
    let flag = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Registered first, so it sees the flag as it was before this signal.
        signal_hook::flag::register_conditional_shutdown(
            sig,
            i32::from(INTERRUPTED_STATUS),
            Arc::clone(&flag),
        )?;
        signal_hook::flag::register(sig, Arc::clone(&flag))?;
    }
    let _ = STOP.set(flag);
    Ok(())
}

/// Set once a signal asked the run to end; never set unless [`install`]
/// was called (tests, library use).
pub fn stop_flag() -> &'static AtomicBool {
    STOP.get().map_or(&NEVER, |f| f.as_ref())
}

/// Whether a signal asked the run to end.
pub fn interrupted() -> bool {
    stop_flag().load(Ordering::Relaxed)
}
