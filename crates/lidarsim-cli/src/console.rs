//! How the program speaks: lines on standard output and standard error
//! that ignore a closed pipe, errors with their exit status, and a
//! survey's warnings.

use std::process::ExitCode;

use lidarsim::{Error, Flight, Survey};

/// Prints a line to standard error, ignoring a closed pipe (`2>&1 | head`).
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

/// Prints a line to standard output, ignoring a closed pipe (`| head`).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// Prints `message` as an error; the exit status is `code`.
pub fn fail(code: u8, message: &str) -> ExitCode {
    note!("error: {message}");
    ExitCode::from(code)
}

/// Reports every problem of a survey file, exit status 2.
pub fn fail_survey(e: &lidarsim::survey::SurveyError) -> ExitCode {
    for (i, d) in e.diagnostics.iter().enumerate() {
        if i > 0 {
            note!("");
        }
        note!("error: {d}");
    }
    if e.diagnostics.len() > 1 {
        note!("\n{} problems found", e.diagnostics.len());
    }
    ExitCode::from(2)
}

/// The survey's file name for messages (`<demo>` for the built-in one).
pub fn source_name(survey: &Survey) -> String {
    survey
        .source
        .as_ref()
        .map_or_else(|| "<demo>".to_string(), |p| p.display().to_string())
}

/// Prints the flight's warnings (the survey's, its world's, its plan's)
/// to standard error.
pub fn warn(flight: &Flight) {
    let file = source_name(flight.survey());
    for w in flight.warnings() {
        note!("warning: {file}: {w}");
    }
}

/// Reports a library error: a survey's problems with exit status 2
/// ([`fail_survey`]), anything else with exit status 1.
pub fn fail_with(e: &Error) -> ExitCode {
    match e {
        Error::Survey(s) => fail_survey(s),
        _ => fail(1, &e.to_string()),
    }
}

/// The progress of a command's long steps on standard error: a bar on a
/// terminal, else one line per step as it starts.
pub struct Steps {
    bar: indicatif::ProgressBar,
    step: std::sync::Mutex<String>,
}

impl Steps {
    /// A display for a command's steps.
    pub fn new() -> Self {
        use std::io::IsTerminal;
        let bar = if std::io::stderr().is_terminal() {
            let b = indicatif::ProgressBar::new(1000);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {msg:12} {bar:40} {percent:>3}%",
            ) {
                b.set_style(style);
            }
            b
        } else {
            indicatif::ProgressBar::hidden()
        };
        Self {
            bar,
            step: std::sync::Mutex::new(String::new()),
        }
    }

    /// Step `step` is `done` (0 to 1) through.
    pub fn report(&self, step: &str, done: f64) {
        let mut last = self.step.lock().unwrap_or_else(|e| e.into_inner());
        if *last != step {
            if self.bar.is_hidden() {
                note!("{step}…");
            }
            self.bar.set_message(step.to_string());
            *last = step.to_string();
        }
        self.bar
            .set_position((done.clamp(0.0, 1.0) * 1000.0) as u64);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
