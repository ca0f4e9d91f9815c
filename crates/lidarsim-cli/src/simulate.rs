//! `lidarsim demo` and `lidarsim run`: a survey simulated into an output
//! directory behind a progress bar. Ctrl-C stops a run with valid files
//! (see `main`); `run --resume DIR` continues it.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::{ProgressBar, ProgressStyle};
use lidarsim::Survey;
use lidarsim::run::{RunOptions, run_world_to_dir};
use lidarsim::world::{World, load};

use crate::args::{DemoArgs, RunArgs};
use crate::console::{fail, fail_survey, source_name, warn};
use crate::{INTERRUPTED, STOP};

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
    let world = match World::build(&survey) {
        Ok(w) => w,
        Err(e) => return fail_survey(&e),
    };
    let how = How {
        resume: false,
        overwrite,
        no_space_check,
    };
    simulate(&survey, &world, &output, threads, how)
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
    let (survey, world) = match load(&path, seed) {
        Ok(loaded) => loaded,
        Err(e) => return fail_survey(&e),
    };
    let code = match part {
        Some(part) => crate::parts::run_part(&survey, &world, &output, threads, part, overwrite),
        None => {
            let how = How {
                resume: resuming,
                overwrite,
                no_space_check,
            };
            simulate(&survey, &world, &output, threads, how)
        }
    };
    // The process ends here: its memory goes back whole, faster than the
    // world's millions of primitives are dropped one by one (0.3 s for a
    // stand of 1.5 M trees). Every file is written and closed by now.
    std::mem::forget(world);
    code
}

/// Test hook: `LIDARSIM_TEST_HOLD_AT_PULSE=N` makes a run wait, once N
/// pulses are written, until it is stopped (Ctrl-C or SIGTERM), after
/// printing "holding after K pulses" to standard error: tests interrupt a
/// run at a known point instead of after a guessed time.
fn hold_at_pulse() -> Option<u64> {
    std::env::var("LIDARSIM_TEST_HOLD_AT_PULSE")
        .ok()?
        .parse()
        .ok()
}

/// Waits for the stop flag (see [`hold_at_pulse`]).
fn hold_until_stopped(done: u64) {
    static ANNOUNCED: AtomicBool = AtomicBool::new(false);
    if !ANNOUNCED.swap(true, Ordering::SeqCst) {
        note!("holding after {done} pulses");
    }
    while !STOP.load(Ordering::SeqCst) {
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
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

/// `threads`, or every core; a zero is refused.
pub(crate) fn threads_or_all(threads: Option<usize>) -> Result<usize, ExitCode> {
    match threads {
        Some(0) => Err(fail(2, "--threads must be at least 1")),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
    }
}

/// A progress bar of `total` pulses on a terminal, hidden otherwise.
pub(crate) fn pulse_bar(total: u64) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total);
    // `per_sec:0`: the rate in whole pulses (indicatif's default shows
    // four decimals, "42,255.3096/s").
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} pulses ({per_sec:0}, eta {eta})",
    ) {
        b.set_style(style);
    }
    b
}

/// Runs the survey into `output` and says how it went.
fn simulate(
    survey: &Survey,
    world: &World,
    output: &Path,
    threads: Option<usize>,
    how: How,
) -> ExitCode {
    let How {
        resume,
        overwrite,
        no_space_check,
    } = how;
    warn(survey, world);
    if survey.output.formats.laz && !resume {
        note!(
            "note: this run writes LAZ, which cannot be continued: if it is stopped, run the \
             survey again"
        );
    }
    let threads = match threads_or_all(threads) {
        Ok(n) => n,
        Err(code) => return code,
    };
    let total: u64 = world.lines.iter().map(|l| survey.pulses_of(l)).sum();
    let bar = pulse_bar(total);
    let hold = hold_at_pulse();
    let progress = |done: u64| {
        bar.set_position(done);
        if hold.is_some_and(|h| done >= h) {
            hold_until_stopped(done);
        }
    };
    let name = source_name(survey);
    let result = run_world_to_dir(
        survey,
        world,
        output,
        &RunOptions {
            threads,
            progress: &progress,
            stop: Some(&STOP),
            resume,
            overwrite,
            no_space_check,
            pulse_budget: None,
            on_warning: Some(&|w: &str| {
                bar.suspend(|| note!("warning: {name}: {w}"));
            }),
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
        Err(e) => fail(1, &e.to_string()),
    }
}
