//! The third stage of a run: a complete run's point files finished under
//! their final names, its report and `summary.json` written; a stopped
//! run's files kept under their `.partial` names with the report's state
//! and the record a resumed run checks ([`super::resume`]).

use std::path::Path;

use super::RunOptions;
use super::drive::Driven;
use super::names::{REPORT, REPORT_STATE, SUMMARY, SURVEY, TRAJECTORY_FILES};
use super::prepare::Prepared;
use super::{replay, resume};
use crate::error::Error;
use crate::files::{data_files, layout_dir, point_files};
use crate::flight::Flight;
use crate::output::{AtFile, WriteCause, WriteError, write_atomic};
use crate::report::ReportSink;
use crate::sim::{PulsePosition, Simulator};
use crate::summary::{Measured, NextPulse, Summary};

/// Finishes the run `prepared` was driven into: complete, or stopped at
/// `driven.stopped_at`. Returns its summary, as written.
pub fn finish(
    flight: &Flight,
    mut prepared: Prepared,
    driven: Driven,
    options: &RunOptions<'_>,
) -> Result<Summary, Error> {
    let measured = Measured {
        counts: driven.counts,
        threads: options.threads,
        wall_time_s: driven.wall_time_s,
        estimate: prepared.estimate.clone(),
    };
    let rollback = prepared.rollback.take();
    let summary = match driven.stopped_at {
        Some(next) => suspend(flight, prepared, next, &measured)?,
        None => complete(flight, prepared, &measured)?,
    };
    // Complete, or stopped with what it needs to go on: the files stay.
    if let Some(r) = rollback {
        r.done();
    }
    Ok(summary)
}

/// A stopped run: every point file finished for the pulses before `next`
/// but under its `.partial` name, the report's state saved, and a summary
/// that says where to go on and records the files as they are.
fn suspend(
    flight: &Flight,
    prepared: Prepared,
    next: PulsePosition,
    measured: &Measured,
) -> Result<Summary, Error> {
    let out_dir = &prepared.out_dir;
    for s in prepared.sinks {
        s.suspend()?;
    }
    let state = prepared.report.save();
    write_atomic(&out_dir.join(REPORT_STATE), &state)?;
    let next = NextPulse::of(next);
    let survey = flight.survey();
    let names = point_files(survey);
    let record = resume::record(out_dir, &names, survey.seed, next, &measured.counts, &state)?;
    let mut summary = Summary::of(flight, measured, files_written(flight, false));
    summary.complete = false;
    summary.next_pulse = Some(next);
    summary.resume = Some(record);
    write_summary(out_dir, &summary)?;
    Ok(summary)
}

/// A complete run: the point files under their final names, the report,
/// the summary; a resumed run's saved report state removed.
fn complete(flight: &Flight, prepared: Prepared, measured: &Measured) -> Result<Summary, Error> {
    let out_dir = &prepared.out_dir;
    for s in prepared.sinks {
        s.finish()?;
    }
    let summary = Summary::of(flight, measured, files_written(flight, true));
    write_report(flight, out_dir, &summary, &prepared.report)?;
    write_summary(out_dir, &summary)?;
    let state = out_dir.join(REPORT_STATE);
    match std::fs::remove_file(&state) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(WriteError::io(&state, e).into());
        }
        _ => {}
    }
    Ok(summary)
}

/// The files a run of `flight` wrote, relative to its directory, as the
/// summary lists them: the point files (under their `.partial` names
/// unless `complete`), the strips or tiles directory, the scene data, the
/// survey, the trajectories, then the report (or its saved state) and the
/// summary.
fn files_written(flight: &Flight, complete: bool) -> Vec<String> {
    let survey = flight.survey();
    let partial = if complete { "" } else { ".partial" };
    let mut files: Vec<String> = point_files(survey)
        .iter()
        .map(|n| format!("{n}{partial}"))
        .collect();
    files.extend(layout_dir(survey).map(|dir| format!("{dir}/")));
    files.extend(data_files(survey).into_iter().map(|d| d.path));
    files.push(SURVEY.to_string());
    files.extend(TRAJECTORY_FILES.iter().map(|(name, _)| name.to_string()));
    files.push(if complete { REPORT } else { REPORT_STATE }.to_string());
    files.push(SUMMARY.to_string());
    files
}

/// Writes `report.html`, with the waveforms of a pulse with the most
/// echoes and of a single-echo pulse, simulated again.
fn write_report(
    flight: &Flight,
    out_dir: &Path,
    summary: &Summary,
    report: &ReportSink,
) -> Result<(), Error> {
    let sim = Simulator::new(flight.survey(), flight.world());
    let picks = [
        report
            .richest_pulse
            .map(|p| (p, format!("{} echoes", p.returns))),
        report
            .single_pulse
            .map(|p| (p, "a single echo".to_string())),
    ];
    let mut waveforms = Vec::new();
    for (p, what) in picks.into_iter().flatten() {
        if let Some(line) = flight.lines().get(p.line as usize) {
            let (plot, _) = replay::pulse(&sim, line, p.pulse);
            waveforms.push((
                format!("Line {} pulse {}: {what}", p.line + 1, p.pulse),
                plot,
            ));
        }
    }
    let path = out_dir.join(REPORT);
    let page = crate::report::html(flight.survey(), flight.lines(), summary, report, &waveforms)
        .map_err(|e| WriteError::new(&path, WriteCause::Unsupported(e.to_string())))?;
    Ok(write_atomic(&path, page.as_bytes())?)
}

/// Writes `summary.json`.
fn write_summary(out_dir: &Path, summary: &Summary) -> Result<(), Error> {
    let path = out_dir.join(SUMMARY);
    let json = serde_json::to_vec_pretty(summary)
        .map_err(std::io::Error::from)
        .at(&path)?;
    Ok(write_atomic(&path, &json)?)
}
