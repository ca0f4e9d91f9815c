//! Runs split into parts and their merge: part `K` of `N` simulates its
//! stretch of the survey's pulses ([`crate::sim::parts`]) into a directory
//! of its own — the survey as run, its points and a record of what it did
//! (`part.json`) — and [`merge`] joins the parts' points, in order, in the
//! writers an unsplit run uses, so that the merged directory holds the
//! files of the unsplit run byte for byte (the timings of `summary.json`
//! apart).
//!
//! A survey whose only point output is one plain LAS file ([`stitched`])
//! has each part write its points as that LAS file (`points.las`, encoded
//! with the unsplit run's settings) and what its report gathered
//! (`report.state`): the merge copies the records as they are and joins
//! the reports, so its cost is that of copying bytes. Any other survey's
//! parts keep their points whole, every field ([`crate::output::part`]),
//! and the merge hands them to the writers again.
//!
//! A merge refuses parts that do not make one run: a directory that is not
//! a part, a part that did not finish, a point file cut short or changed,
//! a part of another survey, seed, number of parts or lidarsim version, a
//! part given twice and a part missing.

use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::resume::fnv1a_hex;
use super::{RunError, RunOptions, Source, Summary, execute, outdir, write_survey};
use crate::output::part::{PartReader, PartWriter};
use crate::output::{LasWriter, PointRecord, PointSink, WaveformBlock, file_error, write_atomic};
use crate::report::ReportSink;
use crate::sim::parts::{PulseRange, split};
use crate::sim::{RunControl, RunCounts, RunOutcome, Simulator, Timer};
use crate::survey::Survey;
use crate::world::World;

/// A part's point file, every field of every point (when not
/// [`stitched`]).
pub const PART_POINTS: &str = "points.part";
/// A stitched part's point file: its records as the unsplit run's LAS
/// file holds them.
pub const PART_LAS: &str = "points.las";
/// A part's record.
pub const PART_RECORD: &str = "part.json";

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
    /// Threads it ran on.
    pub threads: usize,
    /// Wall-clock time of its simulation, s.
    pub wall_time_s: f64,
}

impl PartRecord {
    fn counts(&self) -> RunCounts {
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

/// A part given to a merge: its point file, with the counts and the time
/// its record holds.
#[derive(Clone, Debug)]
pub struct PartInput {
    /// The part's point file.
    pub points: PathBuf,
    /// What its report gathered, when the part is stitched.
    pub report: Option<PathBuf>,
    /// What the part recorded.
    pub counts: RunCounts,
    /// Its simulation time, s.
    pub wall_time_s: f64,
}

fn error(path: &Path, kind: io::ErrorKind, message: String) -> RunError {
    RunError {
        path: path.to_path_buf(),
        source: io::Error::new(kind, message),
    }
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

/// The pulses of part `k` of `n` of `survey` over `world`'s lines.
pub fn part_ranges(survey: &Survey, world: &World, k: usize, n: usize) -> Vec<PulseRange> {
    let pulses: Vec<u64> = world.lines.iter().map(|l| survey.pulses_of(l)).collect();
    split(&pulses, n).swap_remove(k - 1)
}

/// Simulates part `k` of `n` (`1 ≤ k ≤ n`) of `survey` into `out_dir`:
/// `survey.toml` (with the files of scene entries given as data), the
/// points (`points.part`, or `points.las` and `report.state` when
/// [`stitched`]) and `part.json`. A part stopped early (`options.stop`)
/// leaves no point file and a record with `"complete": false`; the run
/// options' resume and pulse budget do not apply to parts.
pub fn run_part(
    survey: &Survey,
    world: &World,
    (k, n): (usize, usize),
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<PartRecord, RunError> {
    if !(1..=n).contains(&k) {
        return Err(error(
            out_dir,
            io::ErrorKind::InvalidInput,
            format!("part {k}/{n}: K must be from 1 to N"),
        ));
    }
    outdir::check_inputs(out_dir, &crate::files::input_files(survey))?;
    outdir::prepare_fresh(out_dir, options.overwrite)?;
    let text = write_survey(survey, out_dir)?;
    let ranges = part_ranges(survey, world, k, n);
    let sim = Simulator::new(survey, world).with_waveforms(survey.output.formats.las_waveform);
    let stitch = stitched(survey);
    let points_file = if stitch { PART_LAS } else { PART_POINTS };
    let points_path = out_dir.join(points_file);
    let named = |path: &Path| {
        let path = path.to_path_buf();
        move |source| RunError { path, source }
    };
    let mut sink: Box<dyn PointSink> = if stitch {
        let settings = crate::files::las_settings(survey, world);
        Box::new(LasWriter::create(&points_path, settings).map_err(named(&points_path))?)
    } else {
        Box::new(PartWriter::create(&points_path).map_err(named(&points_path))?)
    };
    let mut report = stitch.then(|| {
        let plan = crate::plan::plan(survey, world);
        ReportSink::new(super::covered_area(world, &plan), plan.point_density_per_m2)
    });
    let control = RunControl {
        stop: options.stop,
        only: Some(&ranges),
        ..RunControl::default()
    };
    let timer = Timer::start();
    let outcome = {
        let mut sinks: Vec<&mut (dyn PointSink + 'static)> = vec![sink.as_mut()];
        if let Some(r) = report.as_mut() {
            sinks.push(r);
        }
        sim.run_from(options.threads, &mut sinks, options.progress, &control)
    };
    let wall_time_s = timer.seconds();
    let (outcome, complete) = match outcome {
        Ok(o) => {
            let complete = o.stopped_at.is_none();
            (o, complete)
        }
        Err(e) => {
            sink.discard();
            return Err(super::run_error(out_dir, e));
        }
    };
    let (mut points_bytes, mut report_bytes) = (0, 0);
    if complete {
        sink.finish().map_err(|e| super::run_error(out_dir, e))?;
        points_bytes = std::fs::metadata(&points_path)
            .map_err(named(&points_path))?
            .len();
        if let Some(r) = &report {
            let path = out_dir.join(super::REPORT_STATE);
            let mut state = Vec::new();
            r.save(&mut state).map_err(named(&path))?;
            write_atomic(&path, &state).map_err(named(&path))?;
            report_bytes = state.len() as u64;
        }
    } else {
        drop(sink);
    }
    let c = outcome.counts;
    let last = c
        .points_by_return
        .iter()
        .rposition(|&n| n > 0)
        .map_or(0, |i| i + 1);
    let record = PartRecord {
        lidarsim_version: env!("CARGO_PKG_VERSION").to_string(),
        complete,
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
        points_bytes,
        report_bytes,
        threads: options.threads,
        wall_time_s,
    };
    let path = out_dir.join(PART_RECORD);
    let json = serde_json::to_vec_pretty(&record).map_err(|e| named(&path)(e.into()))?;
    write_atomic(&path, &json).map_err(named(&path))?;
    Ok(record)
}

/// A part directory's record and survey text, checked against its own
/// files.
fn read_part(dir: &Path) -> Result<(PartRecord, String), RunError> {
    let path = dir.join(PART_RECORD);
    let bytes = std::fs::read(&path).map_err(|e| {
        error(
            dir,
            e.kind(),
            format!(
                "not the directory of a part (no readable {PART_RECORD}: {e}); write parts with \
                 `lidarsim run SURVEY --part K/N -o DIR`"
            ),
        )
    })?;
    let record: PartRecord = serde_json::from_slice(&bytes).map_err(|e| {
        error(
            &path,
            io::ErrorKind::InvalidData,
            format!("is not a part's record: {e}"),
        )
    })?;
    if !record.complete {
        return Err(error(
            dir,
            io::ErrorKind::InvalidData,
            format!(
                "part {}/{} did not finish (its record says \"complete\": false): run it again",
                record.part, record.parts
            ),
        ));
    }
    let survey_path = dir.join("survey.toml");
    let text = std::fs::read_to_string(&survey_path).map_err(|e| {
        error(
            &survey_path,
            e.kind(),
            format!("cannot read the part's survey: {e}"),
        )
    })?;
    if fnv1a_hex(text.as_bytes()) != record.survey_fnv1a {
        return Err(error(
            &survey_path,
            io::ErrorKind::InvalidData,
            "was changed after the part ran (its hash is not the one the part recorded)".into(),
        ));
    }
    if ![PART_POINTS, PART_LAS].contains(&record.points_file.as_str()) {
        return Err(error(
            &path,
            io::ErrorKind::InvalidData,
            format!(
                "names its points {:?}, which is neither {PART_POINTS} nor {PART_LAS}",
                record.points_file
            ),
        ));
    }
    let mut files = vec![(record.points_file.as_str(), record.points_bytes)];
    if record.report_bytes > 0 {
        files.push((super::REPORT_STATE, record.report_bytes));
    }
    for (name, bytes) in files {
        let file = dir.join(name);
        let len = std::fs::metadata(&file)
            .map_err(|e| {
                error(
                    &file,
                    e.kind(),
                    format!("cannot read the part's {name}: {e}"),
                )
            })?
            .len();
        if len != bytes {
            return Err(error(
                &file,
                io::ErrorKind::InvalidData,
                format!(
                    "holds {len} bytes, but part {}/{} wrote {bytes}: it was cut short or changed",
                    record.part, record.parts
                ),
            ));
        }
    }
    Ok((record, text))
}

/// Merges the parts in `part_dirs` (in any order) into `out_dir`: the files
/// an unsplit run of their survey writes, byte for byte (the timings of
/// `summary.json` apart: its `wall_time_s` is the parts' simulation time,
/// summed). The survey is the parts' `survey.toml`; its world is built
/// again for the report and the summary.
pub fn merge(
    part_dirs: &[PathBuf],
    out_dir: &Path,
    options: &RunOptions<'_>,
) -> Result<Summary, RunError> {
    let Some(first_dir) = part_dirs.first() else {
        return Err(error(
            out_dir,
            io::ErrorKind::InvalidInput,
            "no part to merge".into(),
        ));
    };
    let mut parts: Vec<(PathBuf, PartRecord)> = Vec::new();
    let mut first: Option<(PartRecord, String)> = None;
    for dir in part_dirs {
        let (record, text) = read_part(dir)?;
        if let Some((r0, _)) = &first {
            let foreign = |what: String| {
                error(
                    dir,
                    io::ErrorKind::InvalidData,
                    format!(
                        "part {}/{} is not of the run of {}: {what}",
                        record.part,
                        record.parts,
                        first_dir.display()
                    ),
                )
            };
            if record.survey_fnv1a != r0.survey_fnv1a {
                return Err(foreign("its survey.toml differs".into()));
            }
            if record.seed != r0.seed {
                return Err(foreign(format!("seed {} against {}", record.seed, r0.seed)));
            }
            if record.parts != r0.parts {
                return Err(foreign(format!(
                    "one of {} parts, not {}",
                    record.parts, r0.parts
                )));
            }
            if record.lidarsim_version != r0.lidarsim_version {
                return Err(foreign(format!(
                    "lidarsim {} against {}",
                    record.lidarsim_version, r0.lidarsim_version
                )));
            }
        } else {
            first = Some((record.clone(), text));
        }
        if let Some((other, _)) = parts.iter().find(|(_, r)| r.part == record.part) {
            return Err(error(
                dir,
                io::ErrorKind::InvalidData,
                format!(
                    "part {}/{} is given twice: {} and {}",
                    record.part,
                    record.parts,
                    other.display(),
                    dir.display()
                ),
            ));
        }
        parts.push((dir.clone(), record));
    }
    let (r0, _) = first.expect("one part at least");
    let n = r0.parts;
    let missing: Vec<String> = (1..=n)
        .filter(|k| !parts.iter().any(|(_, r)| r.part == *k))
        .map(|k| format!("{k}/{n}"))
        .collect();
    if !missing.is_empty() {
        let which = match missing.as_slice() {
            [one] => format!("part {one} is"),
            many => format!("parts {} are", many.join(", ")),
        };
        return Err(error(
            out_dir,
            io::ErrorKind::NotFound,
            format!("{which} missing: a merge needs all {n} parts"),
        ));
    }
    parts.sort_by_key(|(_, r)| r.part);

    // The survey the parts ran, and its world.
    let survey_path = parts[0].0.join("survey.toml");
    let survey = Survey::load(&survey_path)
        .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string()))?;
    let world = World::build(&survey)
        .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string()))?;
    for (dir, r) in &parts {
        if r.ranges != part_ranges(&survey, &world, r.part, n) {
            return Err(error(
                dir,
                io::ErrorKind::InvalidData,
                format!(
                    "part {}/{n} simulated other pulses than its survey splits into part {}",
                    r.part, r.part
                ),
            ));
        }
    }
    let (points_file, with_report) = if stitched(&survey) {
        (PART_LAS, true)
    } else {
        (PART_POINTS, false)
    };
    for (dir, r) in &parts {
        if r.points_file != points_file || (r.report_bytes > 0) != with_report {
            return Err(error(
                dir,
                io::ErrorKind::InvalidData,
                format!(
                    "part {}/{n} holds {}, but the parts of its survey hold {points_file}{}",
                    r.part,
                    r.points_file,
                    if with_report { " and report.state" } else { "" }
                ),
            ));
        }
    }
    let inputs: Vec<PartInput> = parts
        .iter()
        .map(|(dir, r)| PartInput {
            points: dir.join(&r.points_file),
            report: with_report.then(|| dir.join(super::REPORT_STATE)),
            counts: r.counts(),
            wall_time_s: r.wall_time_s,
        })
        .collect();
    execute(&survey, &world, out_dir, options, Source::Parts(&inputs))
}

/// Joins the points of `parts`, in order, in `sinks` and `report`:
/// stitched parts' files are appended as they are ([`stitch`]), other
/// parts' points are handed to the writers ([`replay`]).
pub(crate) fn gather<'a>(
    parts: &[PartInput],
    mut sinks: Vec<&'a mut (dyn PointSink + 'static)>,
    report: &'a mut ReportSink,
    progress: &(dyn Fn(u64) + Sync),
) -> io::Result<RunOutcome> {
    if !parts.is_empty() && parts.iter().all(|p| p.report.is_some()) {
        stitch(parts, &mut sinks, report, progress)
    } else {
        sinks.push(report);
        replay(parts, &mut sinks, progress)
    }
}

/// Appends each stitched part's point file to `sinks` as it is and joins
/// what its report gathered to `report`; progress in pulse slots after
/// each part. The counts are the parts' records, checked against the
/// points appended.
fn stitch(
    parts: &[PartInput],
    sinks: &mut [&mut (dyn PointSink + 'static)],
    report: &mut ReportSink,
    progress: &(dyn Fn(u64) + Sync),
) -> io::Result<RunOutcome> {
    let mut counts = RunCounts::default();
    for part in parts {
        for sink in sinks.iter_mut() {
            let n = sink.append_file(&part.points)?;
            if n != part.counts.points {
                return Err(miscounted(&part.points, n, part.counts.points));
            }
        }
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
fn miscounted(path: &Path, held: u64, recorded: u64) -> io::Error {
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
