//! A run's progress on standard error: a bar of pulses on a terminal, and
//! the test hook that holds a run at a known pulse.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::{ProgressBar, ProgressStyle};

use crate::STOP;

/// A progress bar of `total` pulses on a terminal, hidden otherwise.
pub fn pulse_bar(total: u64) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total);
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} pulses ({per_sec}, eta {eta})",
    ) {
        b.set_style(style);
    }
    b
}

/// Test hook: `LIDARSIM_TEST_HOLD_AT_PULSE=N` makes a run wait, once N
/// pulses are written, until it is stopped (Ctrl-C or SIGTERM), after
/// printing "holding after K pulses" to standard error: tests interrupt a
/// run at a known point instead of after a guessed time.
pub fn hold_at_pulse() -> Option<u64> {
    std::env::var("LIDARSIM_TEST_HOLD_AT_PULSE")
        .ok()?
        .parse()
        .ok()
}

/// Waits for the stop flag (see [`hold_at_pulse`]).
pub fn hold_until_stopped(done: u64) {
    static ANNOUNCED: AtomicBool = AtomicBool::new(false);
    if !ANNOUNCED.swap(true, Ordering::SeqCst) {
        note!("holding after {done} pulses");
    }
    while !STOP.load(Ordering::SeqCst) {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}
