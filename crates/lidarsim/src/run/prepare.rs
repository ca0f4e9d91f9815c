//! The first stage of a run: everything checked before anything is
//! touched — the flight's inputs against the output directory, the
//! directory's own files, the interrupted run's record, the budget — then
//! the directory claimed, the point files opened and the survey written.
//! What comes out is a [`Prepared`] run, for [`super::drive`].

use std::path::{Path, PathBuf};

use super::names::{REPORT_STATE, SUMMARY, SURVEY};
use super::outdir::{self, Rollback};
use super::sinks::{self, Opening};
use super::{RunOptions, resume};
use crate::budget::Budget;
use crate::error::{BudgetError, Error, PathError};
use crate::files::{data_files, input_files, point_files, replayable_with_data};
use crate::flight::Flight;
use crate::output::{AtFile, FileSink, LasWriter, write_atomic};
use crate::report::ReportSink;
use crate::sim::{PulsePosition, RunCounts};
use crate::survey::Survey;

/// A run ready to be driven: its directory claimed, its point files open.
pub struct Prepared {
    /// The output directory.
    pub(super) out_dir: PathBuf,
    /// The point files' writers.
    pub(super) sinks: Vec<Box<FileSink>>,
    /// What the report gathers (restored, when resuming).
    pub(super) report: ReportSink,
    /// What the run's earlier sessions did (nothing, for a fresh run).
    pub(super) before: Before,
    /// Whether the trajectories are still to be written (not when
    /// resuming: the run wrote them when it began).
    pub(super) trajectories: bool,
    /// What the run is expected to cost.
    pub(super) estimate: Budget,
    /// Removes what a fresh run or merge wrote if it fails; `None` when
    /// resuming (what the interrupted run left is what resumes it).
    pub(super) rollback: Option<Rollback>,
}

/// What the sessions of an interrupted run did before this one.
#[derive(Clone, Debug, Default)]
pub struct Before {
    /// Their counts.
    pub counts: RunCounts,
    /// The first pulse they did not simulate.
    pub start: PulsePosition,
    /// Their simulation time, s.
    pub wall_time_s: f64,
}

/// Prepares a fresh run of `flight` into `out_dir`: refused if the run
/// would write over one of its inputs, if the directory holds files no
/// run wrote (unless `options.overwrite`) or if the run would not fit;
/// otherwise the directory is cleared of an earlier run's files.
pub fn fresh(flight: &Flight, out_dir: &Path, options: &RunOptions<'_>) -> Result<Prepared, Error> {
    outdir::check_inputs(out_dir, &input_files(flight.survey()))?;
    outdir::prepare_fresh(out_dir, options.overwrite)?;
    // From here on, a run that fails leaves nothing of its own behind.
    let rollback = Rollback::new(out_dir, None);
    let estimate = check_budget(flight, out_dir, options, 1.0)?;
    let sinks = sinks::open(flight, out_dir, Opening::Fresh)?;
    write_survey(flight.survey(), out_dir)?;
    Ok(Prepared {
        out_dir: out_dir.to_path_buf(),
        sinks,
        report: new_report(flight),
        before: Before::default(),
        trajectories: true,
        estimate,
        rollback: Some(rollback),
    })
}

/// Prepares the interrupted run in `out_dir` to go on: its record and
/// files checked against `flight` ([`resume::read`]), its point files
/// reopened where it stopped and its report restored.
pub fn resumed(
    flight: &Flight,
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Prepared, Error> {
    let survey = flight.survey();
    let cannot = |what: String| {
        Error::Resume(PathError::new(
            &out_dir.join(SUMMARY),
            format!("this run wrote {what}, which cannot be continued: run the survey again"),
        ))
    };
    if survey.output.formats.laz {
        return Err(cannot("LAZ".into()));
    }
    if let Some(dir) = crate::files::layout_dir(survey) {
        return Err(cannot(dir.into()));
    }
    let (prev, state) = resume::read(out_dir, flight, &point_files(survey))?;
    let before = Before {
        counts: prev.counts(),
        start: prev.start(),
        wall_time_s: prev.wall_time_s,
    };
    let share = 1.0 - before.counts.pulse_slots as f64 / flight.pulses().max(1) as f64;
    let estimate = check_budget(flight, out_dir, options, share)?;
    let sinks = sinks::open(flight, out_dir, Opening::Continued(&prev))?;
    let mut report = new_report(flight);
    report
        .restore(&state)
        .map_err(|e| Error::Resume(PathError::new(&out_dir.join(REPORT_STATE), e.to_string())))?;
    Ok(Prepared {
        out_dir: out_dir.to_path_buf(),
        sinks,
        report,
        before,
        trajectories: false,
        estimate,
        rollback: None,
    })
}

/// Prepares a merge's run into `out_dir`, claimed and cleared by the
/// merge already; `joined`, the writer of `points.las` holding the
/// stitched parts' points (their share of the budget is spent); `keep`, a
/// file left even if the merge fails (a part's file moved in).
pub fn merged(
    flight: &Flight,
    out_dir: &Path,
    options: &RunOptions<'_>,
    joined: Option<Box<LasWriter>>,
    keep: Option<PathBuf>,
) -> Result<Prepared, Error> {
    let rollback = Rollback::new(out_dir, keep);
    let share = if joined.is_some() { 0.0 } else { 1.0 };
    let estimate = check_budget(flight, out_dir, options, share)?;
    let opening = joined.map_or(Opening::Fresh, Opening::Joined);
    let sinks = sinks::open(flight, out_dir, opening)?;
    write_survey(flight.survey(), out_dir)?;
    Ok(Prepared {
        out_dir: out_dir.to_path_buf(),
        sinks,
        report: new_report(flight),
        before: Before::default(),
        trajectories: true,
        estimate,
        rollback: Some(rollback),
    })
}

/// The report's sink for `flight`: over the area its lines cover, pixels
/// for its planned density.
pub(super) fn new_report(flight: &Flight) -> ReportSink {
    ReportSink::new(flight.covered_area(), flight.plan().point_density_per_m2)
}

/// What the run will cost; refused, unless `options.no_space_check`, when
/// the `share` of its output still to be written would not fit the free
/// space of `out_dir`'s file system or its memory the machine's.
fn check_budget(
    flight: &Flight,
    out_dir: &Path,
    options: &RunOptions<'_>,
    share: f64,
) -> Result<Budget, Error> {
    let estimate = flight.estimate(options.threads);
    if !options.no_space_check {
        let shortfalls = estimate.shortfalls(
            out_dir,
            crate::budget::free_bytes(out_dir),
            crate::budget::available_memory(),
            share,
        );
        if !shortfalls.is_empty() {
            return Err(Error::Budget(BudgetError {
                dir: out_dir.to_path_buf(),
                shortfalls,
            }));
        }
    }
    Ok(estimate)
}

/// Writes the survey as run into `out_dir/survey.toml`, with the seed
/// fixed and file paths made absolute, so that `lidarsim run
/// DIR/survey.toml` repeats it and `lidarsim waveform` can simulate any
/// pulse again; scene entries given as data are written beside it, as
/// files it names. Returns the survey's text.
pub fn write_survey(survey: &Survey, out_dir: &Path) -> Result<String, Error> {
    for data in data_files(survey) {
        let path = out_dir.join(&data.path);
        data.write(out_dir).at(&path)?;
    }
    let path = out_dir.join(SURVEY);
    let text = survey_text(survey).map_err(|e| {
        crate::output::WriteError::new(&path, crate::output::WriteCause::Unsupported(e.to_string()))
    })?;
    write_atomic(&path, text.as_bytes())?;
    Ok(text)
}

/// The text [`write_survey`] writes for `survey`.
pub fn survey_text(survey: &Survey) -> Result<String, toml::ser::Error> {
    toml::to_string(&replayable_with_data(survey))
}
