//! The parts of a split run as the source of a merge's points
//! ([`PartsFeed`], a [`Source`]): a stitched part's report state joined to
//! the run's report (its points adopted by the LAS writer already), any
//! other part's points read back and handed to the writers and the report
//! again.

use std::path::Path;

use super::PartInput;
use crate::error::Error;
use crate::output::part::PartReader;
use crate::output::{AtFile, PointRecord, WaveformBlock};
use crate::report::ReportSink;
use crate::run::drive::{Fed, RunSink, Source};
use crate::sim::{RunCounts, RunOutcome};

/// The parts, in order, as a source of the run's points. The counts fed
/// are those the parts recorded; the simulation time, theirs summed.
pub(super) struct PartsFeed<'a> {
    /// The parts.
    pub(super) parts: &'a [PartInput],
}

impl Source for PartsFeed<'_> {
    fn feed<'s>(
        self,
        mut sinks: Vec<RunSink<'s>>,
        report: &'s mut ReportSink,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Fed, Error> {
        let parts = self.parts;
        let counts = if !parts.is_empty() && parts.iter().all(|p| p.report.is_some()) {
            stitch(parts, report, progress)?
        } else {
            sinks.push(report);
            replay(parts, &mut sinks, progress)?
        };
        Ok(Fed {
            outcome: RunOutcome {
                counts,
                stopped_at: None,
            },
            wall_time_s: parts.iter().map(|p| p.wall_time_s).sum(),
        })
    }
}

/// Joins what each stitched part's report gathered to `report`; progress
/// in pulse slots after each part.
fn stitch(
    parts: &[PartInput],
    report: &mut ReportSink,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunCounts, Error> {
    let mut counts = RunCounts::default();
    for part in parts {
        if let Some(path) = &part.report {
            let state = std::fs::read(path).at(path)?;
            let mut later = report.empty_like();
            later
                .restore(&state)
                .and_then(|()| report.absorb(&later))
                .map_err(|e| super::refused(path, e.to_string()))?;
        }
        counts.add(&part.counts);
        progress(counts.pulse_slots);
    }
    Ok(counts)
}

/// A part's point file that holds another number of points than its
/// record.
pub(super) fn miscounted(path: &Path, held: u64, recorded: u64) -> Error {
    super::refused(
        path,
        format!("holds {held} points, but its part recorded {recorded}"),
    )
}

/// Hands the points of `parts`, in order, to `sinks`; progress in pulse
/// slots after each part. The points read are checked against the
/// parts' records.
fn replay(
    parts: &[PartInput],
    sinks: &mut [RunSink<'_>],
    progress: &(dyn Fn(u64) + Sync),
) -> Result<RunCounts, Error> {
    let mut counts = RunCounts::default();
    let (mut points, mut waves): (Vec<PointRecord>, WaveformBlock) = Default::default();
    for part in parts {
        let mut reader = PartReader::open(&part.points)?;
        let mut read = 0u64;
        while reader.next_block(&mut points, &mut waves)? {
            for sink in sinks.iter_mut() {
                sink.write_block(&points, &waves)?;
            }
            read += points.len() as u64;
        }
        if read != part.counts.points {
            return Err(miscounted(&part.points, read, part.counts.points));
        }
        counts.add(&part.counts);
        progress(counts.pulse_slots);
    }
    Ok(counts)
}
