//! Runs split into parts: part `K` of `N` simulates its stretch of the
//! survey's pulses ([`crate::sim::parts`]) into a directory of its own —
//! the survey as run, its points and a record of what it did
//! (`part.json`) — for [`super::merge`] to join.
//!
//! A survey whose only point output is one plain LAS file ([`stitched`])
//! has each part write its points as that LAS file (`points.las`, encoded
//! with the unsplit run's settings) and what its report gathered
//! (`report.state`): the merge copies the records as they are and joins
//! the reports, so its cost is that of copying bytes. Any other survey's
//! parts keep their points whole, every field ([`crate::output::part`]),
//! and the merge hands them to the writers again.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::names::{MARKER, REPORT_STATE, SURVEY};
pub use super::names::{PART_LAS, PART_POINTS, PART_RECORD};
use super::prepare::{new_report, write_survey};
use super::resume::fnv1a_hex;
use super::{RunOptions, outdir};
use crate::error::{Error, PathError};
use crate::flight::Flight;
use crate::output::checksum::file_crc32;
use crate::output::part::PartWriter;
use crate::output::{AtFile, FileSink, LasWriter, PointSink, WriteError, write_atomic};
use crate::report::ReportSink;
use crate::sim::parts::{MAX_PARTS, PulseRange, split};
use crate::sim::{RunControl, RunCounts, RunOutcome, Simulator, Timer};
use crate::survey::Survey;

/// What a part did (`part.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartRecord {
    /// Version of the simulator that ran it.
    pub lidarsim_version: String,
    /// True once every pulse of the part is in its point file.
    pub complete: bool,
    /// `K`, from 1.
    pub part: usize,
    /// `N`.
    pub parts: usize,
    /// Seed of the random streams.
    pub seed: u64,
    /// FNV-1a of the part's `survey.toml`.
    pub survey_fnv1a: String,
    /// The pulses it simulated.
    pub ranges: Vec<PulseRange>,
    /// Pulses emitted.
    pub pulses: u64,
    /// Pulse slots simulated.
    pub pulse_slots: u64,
    /// Points written.
    pub points: u64,
    /// Pulses with at least one echo.
    pub pulses_with_echo: u64,
    /// Points by return number (first, second, …).
    pub points_by_return: Vec<u64>,
    /// The point file: [`PART_POINTS`], or [`PART_LAS`] when the survey's
    /// parts are [`stitched`].
    pub points_file: String,
    /// Bytes of the point file.
    pub points_bytes: u64,
    /// Bytes of the report's state (`report.state`) of a stitched part; 0
    /// for none.
    pub report_bytes: u64,
    /// CRC-32 of the point file ([`crate::output::checksum`]); the merge
    /// joins a file only when it still has it.
    #[serde(default)]
    pub points_crc32: Option<String>,
    /// CRC-32 of the report's state, when there is one.
    #[serde(default)]
    pub report_crc32: Option<String>,
    /// Threads it ran on.
    pub threads: usize,
    /// Wall-clock time of its simulation, s.
    pub wall_time_s: f64,
    /// Every file the part wrote into its directory, this record and the
    /// output marker included, by name (`scene/…` for scene data): what
    /// a merge that takes the parts removes, and all it removes.
    #[serde(default)]
    pub files: Vec<String>,
}

/// Refuses part `k` of `n` unless `1 ≤ k ≤ n ≤ MAX_PARTS`, saying why.
pub fn check_part_number(k: usize, n: usize) -> Result<(), String> {
    if n == 0 || n > MAX_PARTS {
        return Err(format!(
            "part {k}/{n}: N must be from 1 to {MAX_PARTS}, the most parts a survey is split into"
        ));
    }
    if !(1..=n).contains(&k) {
        return Err(format!("part {k}/{n}: K must be from 1 to N"));
    }
    Ok(())
}

/// Whether `name` (relative to a part's directory) is a file a part run
/// writes: its record, points, report state, survey, the output marker or
/// a scene data file under [`outdir::DATA_DIR`].
pub fn is_part_file(name: &str) -> bool {
    match name.split_once('/') {
        Some((dir, file)) => dir == super::names::DATA_DIR && super::names::is_data_file(file),
        None => [
            PART_RECORD,
            PART_POINTS,
            PART_LAS,
            REPORT_STATE,
            SURVEY,
            MARKER,
        ]
        .contains(&name),
    }
}

impl PartRecord {
    /// The files the part wrote ([`PartRecord::files`]); a record of an
    /// earlier version, which lists none, wrote its record, points, report
    /// state, survey and the marker.
    pub fn written(&self) -> Vec<String> {
        if !self.files.is_empty() {
            return self.files.clone();
        }
        let mut files = vec![
            PART_RECORD.to_string(),
            self.points_file.clone(),
            SURVEY.to_string(),
            MARKER.to_string(),
        ];
        if self.report_bytes > 0 {
            files.push(REPORT_STATE.to_string());
        }
        files
    }

    /// The counts it recorded.
    pub(super) fn counts(&self) -> RunCounts {
        let mut c = RunCounts {
            pulses: self.pulses,
            pulse_slots: self.pulse_slots,
            points: self.points,
            pulses_with_echo: self.pulses_with_echo,
            ..RunCounts::default()
        };
        for (a, b) in c.points_by_return.iter_mut().zip(&self.points_by_return) {
            *a = *b;
        }
        c
    }
}

/// A part refused, at `path`, for `reason`.
pub(super) fn refused(path: &Path, reason: impl Into<String>) -> Error {
    Error::Part(PathError::new(path, reason))
}

/// Whether the parts of `survey` write their points as the LAS file of the
/// unsplit run, for a merge that copies them: true when that file, plain
/// and without waveforms, is the survey's only point output.
pub fn stitched(survey: &Survey) -> bool {
    let f = &survey.output.formats;
    f.las
        && !f.las_waveform
        && !f.laz
        && !f.ply
        && !f.xyz
        && survey.output.layout == crate::survey::Layout::Single
}

/// The pulses of part `k` of `n` of `flight`.
pub fn part_ranges(flight: &Flight, k: usize, n: usize) -> Vec<PulseRange> {
    split(flight.line_pulses(), n).swap_remove(k - 1)
}

/// Simulates part `k` of `n` (`1 ≤ k ≤ n`) of `flight` into `out_dir`:
/// `survey.toml` (with the files of scene entries given as data), the
/// points (`points.part`, or `points.las` and `report.state` when
/// [`stitched`]) and `part.json`. A part stopped early (`options.stop`)
/// leaves no point file and a record with `"complete": false`; the run
/// options' resume and pulse budget do not apply to parts. A part that
/// fails leaves nothing of its own behind.
pub fn run_part(
    flight: &Flight,
    (k, n): (usize, usize),
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<PartRecord, Error> {
    check_part_number(k, n).map_err(|why| refused(out_dir, why))?;
    let survey = flight.survey();
    outdir::check_inputs(out_dir, &crate::files::input_files(survey))?;
    outdir::prepare_fresh(out_dir, options.overwrite)?;
    let written = outdir::Rollback::new(out_dir, None);
    let text = write_survey(survey, out_dir)?;
    let ranges = part_ranges(flight, k, n);
    let stitch = stitched(survey);
    let points_file = if stitch { PART_LAS } else { PART_POINTS };
    let points_path = out_dir.join(points_file);
    let sink: Box<FileSink> = if stitch {
        Box::new(LasWriter::create(&points_path, flight.las_settings())?)
    } else {
        Box::new(PartWriter::create(&points_path)?)
    };
    let mut report = stitch.then(|| new_report(flight));
    let timer = Timer::start();
    let outcome = simulate(flight, &ranges, sink, report.as_mut(), options)?;
    let wall_time_s = timer.seconds();
    let kept = match &outcome {
        Simulated::Complete(_) => keep(out_dir, points_file, report.as_ref())?,
        Simulated::Stopped(_) => Kept::default(),
    };
    let c = outcome.counts();
    let last = c
        .points_by_return
        .iter()
        .rposition(|&n| n > 0)
        .map_or(0, |i| i + 1);
    let record = PartRecord {
        lidarsim_version: env!("CARGO_PKG_VERSION").to_string(),
        complete: matches!(outcome, Simulated::Complete(_)),
        part: k,
        parts: n,
        seed: survey.seed,
        survey_fnv1a: fnv1a_hex(text.as_bytes()),
        ranges,
        pulses: c.pulses,
        pulse_slots: c.pulse_slots,
        points: c.points,
        pulses_with_echo: c.pulses_with_echo,
        points_by_return: c.points_by_return[..last].to_vec(),
        points_file: points_file.to_string(),
        files: part_files(survey, points_file, &kept),
        points_bytes: kept.points_bytes,
        report_bytes: kept.report_bytes,
        points_crc32: kept.points_crc32,
        report_crc32: kept.report_crc32,
        threads: options.threads,
        wall_time_s,
    };
    let path = out_dir.join(PART_RECORD);
    let json = serde_json::to_vec_pretty(&record)
        .map_err(std::io::Error::from)
        .at(&path)?;
    write_atomic(&path, &json)?;
    written.done();
    Ok(record)
}

/// How a part's simulation ended.
enum Simulated {
    /// Every pulse of the part is in its point file, finished.
    Complete(RunOutcome),
    /// Stopped early: its point file is gone.
    Stopped(RunOutcome),
}

impl Simulated {
    fn counts(&self) -> RunCounts {
        match self {
            Simulated::Complete(o) | Simulated::Stopped(o) => o.counts.clone(),
        }
    }
}

/// Simulates the part's `ranges` of `flight` into `sink` (and `report`);
/// finishes the sink when every pulse is in, drops it (and its partial
/// file) when stopped early.
fn simulate(
    flight: &Flight,
    ranges: &[PulseRange],
    mut sink: Box<FileSink>,
    report: Option<&mut ReportSink>,
    options: &RunOptions<'_>,
) -> Result<Simulated, Error> {
    let survey = flight.survey();
    let sim =
        Simulator::new(survey, flight.world()).with_waveforms(survey.output.formats.las_waveform);
    let control = RunControl {
        stop: options.stop,
        only: Some(ranges),
        ..RunControl::default()
    };
    let result = {
        let mut sinks: Vec<&mut (dyn PointSink<Error = WriteError> + 'static)> =
            vec![sink.as_mut()];
        if let Some(r) = report {
            sinks.push(r);
        }
        sim.run_from(options.threads, &mut sinks, options.progress, &control)
    };
    match result {
        Err(e) => {
            sink.discard();
            Err(e.into())
        }
        Ok(o) if o.stopped_at.is_none() => {
            sink.finish()?;
            Ok(Simulated::Complete(o))
        }
        Ok(o) => {
            drop(sink);
            Ok(Simulated::Stopped(o))
        }
    }
}

/// What a complete part keeps of its points and report, as its record
/// describes them.
#[derive(Debug, Default)]
struct Kept {
    points_bytes: u64,
    points_crc32: Option<String>,
    report_bytes: u64,
    report_crc32: Option<String>,
}

/// Measures the complete part's point file and writes its report's state.
fn keep(out_dir: &Path, points_file: &str, report: Option<&ReportSink>) -> Result<Kept, Error> {
    let points_path = out_dir.join(points_file);
    let mut kept = Kept {
        points_bytes: std::fs::metadata(&points_path).at(&points_path)?.len(),
        points_crc32: Some(file_crc32(&points_path).at(&points_path)?),
        ..Kept::default()
    };
    if let Some(r) = report {
        let state = r.save();
        write_atomic(&out_dir.join(REPORT_STATE), &state)?;
        kept.report_bytes = state.len() as u64;
        let mut hasher = crc32fast::Hasher::new();
        hasher.update(&state);
        kept.report_crc32 = Some(format!("{:08x}", hasher.finalize()));
    }
    Ok(kept)
}

/// Every file the part wrote, by name.
fn part_files(survey: &Survey, points_file: &str, kept: &Kept) -> Vec<String> {
    let mut files: Vec<String> = crate::files::data_files(survey)
        .into_iter()
        .map(|d| d.path)
        .collect();
    files.extend([SURVEY, MARKER, PART_RECORD].map(String::from));
    if kept.points_crc32.is_some() {
        files.push(points_file.to_string());
        if kept.report_bytes > 0 {
            files.push(REPORT_STATE.to_string());
        }
    }
    files
}
