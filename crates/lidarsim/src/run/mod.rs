//! A whole run into an output directory: points, trajectories, report and
//! summary, in three stages.
//!
//! 1. **Prepare** ([`prepare`]): the directory checked against the
//!    flight's inputs and claimed ([`outdir`]), the budget checked, the
//!    point files opened — created afresh, continued from an interrupted
//!    run ([`resume`]) or, for a merge, holding the parts' points already —
//!    and the survey written.
//! 2. **Drive** ([`drive`]): a source of blocks of points — the simulator,
//!    or the parts of a split run ([`merge`]) — hands them, in pulse
//!    order, to the point files and the report, while the trajectories are
//!    written beside it.
//! 3. **Finish** ([`finish`]): the files finished and renamed, the report
//!    and `summary.json` written; or, when the run was stopped, the files
//!    kept under their `.partial` names with the record a resumed run
//!    checks.
//!
//! [`run`] walks the three stages with the simulator (afresh, or resuming
//! an interrupted run), [`merge::Merge::finish`] with the parts; a part
//! of a split run ([`part`]) writes a directory of its own. The names of every file
//! are in [`names`]; the report's sample waveforms are pulses simulated
//! again ([`replay`]).

pub mod drive;
pub mod finish;
pub mod merge;
pub mod names;
pub mod outdir;
pub mod part;
pub mod prepare;
pub mod replay;
pub mod resume;
mod sinks;

pub use crate::summary::Summary;
pub use names::REPORT_STATE;
pub use resume::NextPulse;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::error::Error;
use crate::flight::Flight;

/// How to run.
pub struct RunOptions<'a> {
    /// Threads (≥ 1), the calling thread among them: it writes the
    /// blocks in order and simulates blocks in between.
    pub threads: usize,
    /// Called with the number of pulses simulated so far (those of an
    /// interrupted run included when resuming).
    pub progress: &'a (dyn Fn(u64) + Sync),
    /// When set (by a Ctrl-C handler, say), the run stops at the next block
    /// of pulses, finishes every point file for what was simulated (under
    /// its `.partial` name) and writes a `summary.json` with
    /// `"complete": false` and the next pulse.
    pub stop: Option<&'a AtomicBool>,
    /// Continue the interrupted run in the output directory instead of
    /// starting afresh (the survey must be the one it ran: its
    /// `survey.toml`).
    pub resume: bool,
    /// Write into a non-empty directory that no run wrote, replacing only
    /// the files a run writes ([`outdir::prepare_fresh`]).
    pub overwrite: bool,
    /// Run even when the expected output does not fit the free space of
    /// the output's file system or the expected memory is not available
    /// ([`crate::budget`]); otherwise such a run is refused before it
    /// starts.
    pub no_space_check: bool,
    /// Stop (as if interrupted) once this many pulses were simulated in
    /// this call, rounded up to a whole block of 2048: long runs in slices.
    pub pulse_budget: Option<u64>,
    /// Called with each warning that arises while a merge runs (a part's
    /// directory kept because it holds files no part wrote). The flight's
    /// own warnings ([`Flight::warnings`]) are the caller's to show; they
    /// go into the summary.
    pub on_warning: Option<&'a (dyn Fn(&str) + Sync)>,
}

impl<'a> RunOptions<'a> {
    /// A fresh, uninterruptible run on `threads` threads.
    pub fn new(threads: usize, progress: &'a (dyn Fn(u64) + Sync)) -> Self {
        Self {
            threads,
            progress,
            stop: None,
            resume: false,
            overwrite: false,
            no_space_check: false,
            pulse_budget: None,
            on_warning: None,
        }
    }
}

/// Simulates `flight` and writes the point files of `[output] formats`
/// (`points.las` with `points.wdp` for full waveforms, `points.laz`,
/// `points.ply`, `points.xyz`, strips or tiles), the trajectories,
/// `report.html` and `summary.json` into `out_dir` (see [`outdir`] for
/// which directories it accepts). Files appear under their final names
/// only when complete. When `options.stop` interrupts the run, the point
/// files are finished for the pulses simulated so far but keep their
/// `.partial` names, and `summary.json` says `"complete": false` and where
/// to go on; with `options.resume` such a run is continued, and its files
/// end up byte for byte those of an uninterrupted run (apart from the
/// timings). A fresh run that fails leaves none of its files behind.
pub fn run(flight: &Flight, out_dir: &Path, options: &RunOptions<'_>) -> Result<Summary, Error> {
    let mut prepared = if options.resume {
        prepare::resumed(flight, out_dir, options)?
    } else {
        prepare::fresh(flight, out_dir, options)?
    };
    let simulation = drive::Simulation::new(flight, &prepared, options);
    let driven = drive::drive(flight, &mut prepared, simulation, options)?;
    finish::finish(flight, prepared, driven, options)
}
