//! The parts' points and reports handed to the writers and the report of
//! the run a merge writes: a stitched part's report state joined (its
//! points adopted by the LAS writer already), any other part's points read
//! back and written again.

use std::io;
use std::path::Path;

use super::PartInput;
use crate::output::part::PartReader;
use crate::output::{PointRecord, PointSink, WaveformBlock, file_error};
use crate::report::ReportSink;
use crate::sim::{RunCounts, RunOutcome};

/// Joins the points of `parts`, in order, in `sinks` and `report`: the
/// reports of stitched parts, whose points a writer has adopted already
/// ([`super::merge`]), are joined ([`stitch`]); other parts' points are handed
/// to the writers ([`replay`]).
pub(crate) fn gather<'a>(
    parts: &[PartInput],
    mut sinks: Vec<&'a mut (dyn PointSink + 'static)>,
    report: &'a mut ReportSink,
    progress: &(dyn Fn(u64) + Sync),
) -> io::Result<RunOutcome> {
    if !parts.is_empty() && parts.iter().all(|p| p.report.is_some()) {
        stitch(parts, report, progress)
    } else {
        sinks.push(report);
        replay(parts, &mut sinks, progress)
    }
}

/// Joins what each stitched part's report gathered to `report`; progress
/// in pulse slots after each part. The counts are the parts' records.
fn stitch(
    parts: &[PartInput],
    report: &mut ReportSink,
    progress: &(dyn Fn(u64) + Sync),
) -> io::Result<RunOutcome> {
    let mut counts = RunCounts::default();
    for part in parts {
        if let Some(path) = &part.report {
            let state = std::fs::read(path).map_err(|e| file_error(path, e))?;
            let mut later = report.empty_like();
            later
                .restore(&state)
                .and_then(|()| report.absorb(&later))
                .map_err(|e| file_error(path, e))?;
        }
        counts.add(&part.counts);
        progress(counts.pulse_slots);
    }
    Ok(RunOutcome {
        counts,
        stopped_at: None,
    })
}

/// A part's point file that holds another number of points than its
/// record.
pub(super) fn miscounted(path: &Path, held: u64, recorded: u64) -> io::Error {
    file_error(
        path,
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("holds {held} points, but its part recorded {recorded}"),
        ),
    )
}

/// Hands the points of `parts`, in order, to `sinks`; progress in pulse
/// slots after each block. The counts are the parts' records, checked
/// against the points read.
fn replay(
    parts: &[PartInput],
    sinks: &mut [&mut (dyn PointSink + 'static)],
    progress: &(dyn Fn(u64) + Sync),
) -> io::Result<RunOutcome> {
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
    Ok(RunOutcome {
        counts,
        stopped_at: None,
    })
}
