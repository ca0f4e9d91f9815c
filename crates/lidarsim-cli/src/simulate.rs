//! `lidarsim demo` and `lidarsim run`: a survey simulated into an output
//! directory behind a progress bar. Ctrl-C stops a run with valid files
//! (see `main`); `run --resume DIR` continues it.

use std::path::Path;
use std::process::ExitCode;

use lidarsim::run::{RunOptions, run as run_flight};
use lidarsim::{Flight, Survey};

use crate::INTERRUPTED;
use crate::STOP;
use crate::args::threads_or_all;
use crate::args::{DemoArgs, RunArgs};
use crate::console::{fail, fail_survey, fail_with, warn};
use crate::progress::{hold_at_pulse, hold_until_stopped, pulse_bar};

/// `lidarsim demo`: the built-in survey, optionally exported as TOML.
pub fn demo(args: DemoArgs) -> ExitCode {
    let DemoArgs {
        output,
        threads,
        seed,
        overwrite,
        no_space_check,
        export_survey,
    } = args;
    let mut raw = lidarsim::demo::demo_survey();
    if seed.is_some() {
        raw.seed = seed;
    }
    if let Some(path) = export_survey {
        use lidarsim::output::own::{Mark, check_replaceable};
        const HEAD: &str = "# lidarsim demo survey";
        let text = match toml::to_string(&raw) {
            Ok(t) => {
                format!("{HEAD}: the built-in town and forest (lidarsim demo --export-survey)\n{t}")
            }
            Err(e) => return fail(1, &format!("cannot serialise the demo survey: {e}")),
        };
        let written = check_replaceable(&path, Mark::FirstLine(HEAD))
            .and_then(|()| lidarsim::output::write_atomic(&path, text.as_bytes()));
        if let Err(e) = written {
            return fail(1, &format!("{}: {e}", path.display()));
        }
        note!("wrote the demo survey to {}", path.display());
    }
    let survey = match Survey::from_raw(raw, None) {
        Ok(s) => s,
        Err(problems) => {
            let list: Vec<String> = problems
                .iter()
                .map(|(k, m)| format!("<demo>: key `{k}`: {m}"))
                .collect();
            return fail(1, &list.join("\n"));
        }
    };
    let flight = match Flight::build(survey) {
        Ok(f) => f,
        Err(e) => return fail_survey(&e),
    };
    let how = How {
        resume: false,
        overwrite,
        no_space_check,
    };
    simulate(&flight, &output, threads, how)
}

/// `lidarsim run`: a survey file, or the interrupted run of a directory.
pub fn run(args: RunArgs) -> ExitCode {
    let RunArgs {
        survey,
        output,
        threads,
        seed,
        overwrite,
        no_space_check,
        resume,
        part,
    } = args;
    let (path, output, resuming) = match (resume, survey) {
        (Some(dir), _) => (dir.join("survey.toml"), dir, true),
        (None, Some(survey)) => (survey, output, false),
        (None, None) => return fail(2, "give a survey file or --resume DIR"),
    };
    if resuming && !path.exists() {
        return fail(
            2,
            &format!(
                "{}: no such file: {} does not hold a run to resume",
                path.display(),
                output.display()
            ),
        );
    }
    let flight = match Flight::load(&path, seed) {
        Ok(f) => f,
        Err(e) => return fail_survey(&e),
    };
    let code = match part {
        Some(part) => crate::parts::run_part(&flight, &output, threads, part, overwrite),
        None => {
            let how = How {
                resume: resuming,
                overwrite,
                no_space_check,
            };
            simulate(&flight, &output, threads, how)
        }
    };
    // The process ends here: its memory goes back whole, faster than the
    // world's millions of primitives are dropped one by one (0.3 s for a
    // stand of 1.5 M trees). Every file is written and closed by now.
    std::mem::forget(flight);
    code
}

/// How `simulate` treats the output directory and the machine's limits.
struct How {
    /// Continue the interrupted run in the directory.
    resume: bool,
    /// Write into a foreign non-empty directory.
    overwrite: bool,
    /// Run even when the estimate exceeds disk or memory.
    no_space_check: bool,
}

/// Runs the flight into `output` and says how it went.
fn simulate(flight: &Flight, output: &Path, threads: Option<usize>, how: How) -> ExitCode {
    let How {
        resume,
        overwrite,
        no_space_check,
    } = how;
    warn(flight);
    if flight.survey().output.formats.laz && !resume {
        note!(
            "note: this run writes LAZ, which cannot be continued: if it is stopped, run the \
             survey again"
        );
    }
    let threads = match threads_or_all(threads) {
        Ok(n) => n,
        Err(code) => return code,
    };
    let bar = pulse_bar(flight.pulses());
    let hold = hold_at_pulse();
    let progress = |done: u64| {
        bar.set_position(done);
        if hold.is_some_and(|h| done >= h) {
            hold_until_stopped(done);
        }
    };
    let result = run_flight(
        flight,
        output,
        &RunOptions {
            stop: Some(&STOP),
            resume,
            overwrite,
            no_space_check,
            ..RunOptions::new(threads, &progress)
        },
    );
    bar.finish_and_clear();
    match result {
        Ok(summary) if !summary.complete => {
            let next = summary.next_pulse.unwrap_or_default();
            note!(
                "interrupted after {} pulses: the .partial files in {} hold them and are valid; \
                 summary.json says \"complete\": false, next pulse {} of line {}",
                summary.pulses,
                output.display(),
                next.pulse,
                next.line
            );
            if summary.resumable {
                note!("continue with: lidarsim run --resume {}", output.display());
            } else {
                note!("this run wrote LAZ, which cannot be continued: run the survey again");
            }
            ExitCode::from(INTERRUPTED)
        }
        Ok(summary) => {
            crate::summary::print(&summary, output);
            ExitCode::SUCCESS
        }
        Err(e) => fail_with(&e),
    }
}
