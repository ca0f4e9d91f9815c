//! `lidarsim`: command-line front end of the airborne LiDAR simulator.
//!
//! A thin layer over the `lidarsim` library: it parses arguments
//! ([`args`]), loads and checks the survey, runs it with a progress bar
//! and reports errors with a non-zero exit status (2 for a bad survey, 1
//! for a failed run). Each command has its module: [`simulate`] (`demo`
//! and `run`, with [`summary`] printing a finished run), [`check`],
//! [`waveform`], [`render`], [`mod@bench`], [`twin`] and [`compare`];
//! [`console`] holds how the program prints (and the progress of long
//! steps), [`cpu`] the processor check.

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;

#[macro_use]
mod console;
mod args;
mod bench;
mod check;
mod compare;
mod cpu;
mod parts;
mod progress;
mod render;
mod simulate;
mod summary;
mod twin;
mod waveform;

use args::{Cli, Command};

/// Set by the first Ctrl-C (SIGINT) or SIGTERM: the run stops at the next
/// block of pulses and finishes its files.
static STOP: AtomicBool = AtomicBool::new(false);

/// Exit status of a run stopped by a signal (128 + SIGINT).
const INTERRUPTED: u8 = 130;

fn main() -> ExitCode {
    // Before anything built for x86-64-v3 runs (see cpu.rs).
    if let Some(feature) = cpu::missing() {
        cpu::refuse(feature);
        return ExitCode::from(1);
    }
    let cli = Cli::parse();
    // A second signal while the files are being finished ends the program
    // at once (leaving only `.partial` files behind).
    let handler = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            note!("\nstopped without finishing the files");
            std::process::exit(i32::from(INTERRUPTED));
        }
        note!("\ninterrupted: finishing the files for the pulses simulated so far…");
    });
    if let Err(e) = handler {
        note!("warning: Ctrl-C will not stop runs cleanly: {e}");
    }
    match cli.command {
        Command::Demo(args) => simulate::demo(args),
        Command::Run(args) => simulate::run(args),
        Command::Check(args) => check::command(args),
        Command::Waveform(args) => waveform::command(args),
        Command::Render(args) => render::command(args),
        Command::Bench(args) => bench::command(args),
        Command::Merge(args) => parts::merge(args),
        Command::Twin(args) => twin::command(args),
        Command::Compare(args) => compare::command(args),
    }
}
