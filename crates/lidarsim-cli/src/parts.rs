//! `lidarsim run SURVEY --part K/N` (one part of a split run into its own
//! directory) and `lidarsim merge PART_DIR... -o DIR` (the parts joined
//! into the files of the unsplit run).

use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use lidarsim::Flight;
use lidarsim::run::RunOptions;
use lidarsim::run::merge::{Follow, Parts, merge as merge_parts, merge_following};
use lidarsim::run::part::{part_ranges, run_part as simulate_part};

use crate::INTERRUPTED;
use crate::STOP;
use crate::args::MergeArgs;
use crate::args::threads_or_all;
use crate::console::{fail_with, warn};
use crate::progress::pulse_bar;

/// Simulates part `k` of `n` into `output`.
pub fn run_part(
    flight: &Flight,
    output: &Path,
    threads: Option<usize>,
    (k, n): (usize, usize),
    overwrite: bool,
) -> ExitCode {
    warn(flight);
    let threads = match threads_or_all(threads) {
        Ok(t) => t,
        Err(code) => return code,
    };
    let total: u64 = part_ranges(flight, k, n).iter().map(|r| r.len()).sum();
    let bar = pulse_bar(total);
    let progress = |done: u64| bar.set_position(done);
    let options = RunOptions {
        stop: Some(&STOP),
        overwrite,
        ..RunOptions::new(threads, &progress)
    };
    let result = simulate_part(flight, (k, n), output, &options);
    bar.finish_and_clear();
    match result {
        Ok(r) if !r.complete => {
            note!(
                "part {k}/{n} interrupted: {} holds no points; run the part again",
                output.display()
            );
            ExitCode::from(INTERRUPTED)
        }
        Ok(r) => {
            note!(
                "part {k}/{n}: {} pulses → {} points in {:.2} s on {} thread(s), in {}",
                r.pulses,
                r.points,
                r.wall_time_s,
                r.threads,
                output.display()
            );
            note!("join the parts with: lidarsim merge PART_DIR... -o DIR");
            ExitCode::SUCCESS
        }
        Err(e) => fail_with(&e),
    }
}

/// `lidarsim merge`.
pub fn merge(args: MergeArgs) -> ExitCode {
    let MergeArgs {
        parts,
        output,
        threads,
        overwrite,
        no_space_check,
        take_parts,
        follow,
        poll_seconds,
        give_up_after,
    } = args;
    let threads = match threads_or_all(threads) {
        Ok(t) => t,
        Err(code) => return code,
    };
    let bar = pulse_bar(0);
    let progress = |done: u64| bar.set_position(done);
    let warn = |w: &str| bar.suspend(|| note!("warning: {w}"));
    let options = RunOptions {
        stop: follow.then_some(&STOP),
        overwrite,
        no_space_check,
        on_warning: Some(&warn),
        ..RunOptions::new(threads, &progress)
    };
    let taken = if take_parts { Parts::Take } else { Parts::Keep };
    let result = if follow {
        let follow = Follow {
            poll: Duration::from_secs_f64(poll_seconds),
            give_up_after: give_up_after.map(Duration::from_secs_f64),
        };
        let added = |k: usize, n: usize| bar.suspend(|| note!("part {k} of {n} joined"));
        merge_following(&parts, &output, &options, taken, &follow, &added)
    } else {
        merge_parts(&parts, &output, &options, taken)
    };
    bar.finish_and_clear();
    match result {
        Ok(summary) => {
            note!("merged {} parts", parts.len());
            crate::summary::print(&summary, &output);
            ExitCode::SUCCESS
        }
        Err(e) => fail_with(&e),
    }
}
