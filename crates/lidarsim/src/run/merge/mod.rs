//! The merge of a split run ([`super::part`]): the parts' directories,
//! given in any order, checked to make one run and joined, in order, in
//! the writers an unsplit run uses, so that the merged directory holds the
//! files of the unsplit run byte for byte (the timings of `summary.json`
//! apart).
//!
//! Stitched parts' LAS files ([`super::part::stitched`]) are joined as they
//! are while the survey's world is built on another thread, then adopted
//! by the LAS writer of the survey's settings, which checks them
//! ([`crate::output::LasWriter::adopt`]); their reports' states are
//! joined. Other parts' points are read back whole and handed to the
//! writers again.
//!
//! A merge refuses parts that do not make one run (`admit.rs`): a
//! directory that is not a part, a part that did not finish, a point file
//! cut short or changed, a part of another survey, seed, number of parts
//! or lidarsim version, a part given twice and a part missing. What the
//! run's writers and report are then handed is `feed.rs`'s.

use std::io;
use std::path::{Path, PathBuf};

mod admit;
mod feed;
mod follow;

use admit::Gathered;
use feed::{PartsFeed, miscounted};
pub use follow::{Follow, merge_following};

use super::names::{PART_LAS, REPORT_STATE, SURVEY};
use super::part::{PartRecord, part_ranges, refused};
use super::prepare::survey_text;
use super::resume::fnv1a_hex;
use super::{RunOptions, Summary, drive, finish, outdir, prepare};
use crate::error::Error;
use crate::flight::Flight;
use crate::output::{AtomicFile, JoinedLas, LasJoin, LasWriter};
use crate::sim::RunCounts;
use crate::survey::Survey;

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

/// What a merge does with its parts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Parts {
    /// Leaves them as they are: the merge can be made again.
    #[default]
    Keep,
    /// Takes them: the first stitched part's LAS file is moved into the
    /// output rather than copied (on one file system), the other stitched
    /// parts' LAS files are removed once the joined file is checked
    /// against them (while the rest of the output is written), and, once
    /// the merge is complete, the files each part wrote (its record lists
    /// them) and its directory if nothing else is left in it. A merge that
    /// fails after the move leaves that file as the output's
    /// `points.las.partial`, and its parts must be run again.
    Take,
}

/// Merges the parts in `part_dirs` (in any order) into `out_dir`: the files
/// an unsplit run of their survey writes, byte for byte (the timings of
/// `summary.json` apart: its `wall_time_s` is the parts' simulation time,
/// summed). The survey is the parts' `survey.toml`; its world is built
/// again for the report and the summary. The output directory is claimed
/// (refused as a run refuses it) once the parts' records are checked, and
/// cleared of an earlier run's files once the world is built: a merge that
/// cannot build it leaves them as they were.
pub fn merge(
    part_dirs: &[PathBuf],
    out_dir: &Path,
    options: &RunOptions<'_>,
    taken: Parts,
) -> Result<Summary, Error> {
    merge_over(part_dirs, out_dir, options, taken, None)
}

/// [`merge`], over the flight `built` when it is the flight of the
/// parts' survey: when its survey is written as the parts wrote theirs
/// (the same `survey.toml` text, by its hash in their records). The merge
/// then neither reads the scene's files nor indexes it again; a flight of
/// another survey is not used (the merge builds its own, as [`merge`]
/// does). A caller that kept the flight the parts ran, or built it while
/// they ran, saves the merge that time.
pub fn merge_over(
    part_dirs: &[PathBuf],
    out_dir: &Path,
    options: &RunOptions<'_>,
    taken: Parts,
    built: Option<&Flight>,
) -> Result<Summary, Error> {
    outdir::check_parts(out_dir, part_dirs)?;
    let mut gathered = Gathered::default();
    for dir in part_dirs {
        gathered.admit(dir)?;
    }
    gathered.missing(out_dir)?;
    if let Some(first) = &gathered.first {
        outdir::check_inputs(out_dir, &crate::files::input_files(&first.survey))?;
    }
    let mut merge = Merge::begin(out_dir, options.overwrite, taken)?;
    merge.gathered = gathered;
    merge.finish(options, built)
}

/// A merge made as its parts arrive: each part given to [`Merge::add`] is
/// checked against those before it at once, and a stitched part's LAS file
/// joined as soon as every part before it is, so that a split run's
/// parts are mostly joined by the time the last one ends;
/// [`Merge::finish`] joins the rest and writes what [`merge`] writes.
/// The output directory is claimed when the merge begins and cleared of
/// an earlier run's files when it finishes.
#[derive(Debug)]
pub struct Merge {
    out_dir: PathBuf,
    taken: Parts,
    /// Whether the first stitched part's LAS file is moved into the output
    /// (taken parts, unless [`Merge::copy_first_part`]).
    move_first: bool,
    claimed: outdir::Claimed,
    gathered: Gathered,
    join: LasJoin,
    /// Whether an added part could not be taken in (its join failed, or
    /// the output would overwrite the survey's inputs): the merge can then
    /// only be begun again.
    failed: bool,
}

impl Merge {
    /// Begins a merge into `out_dir`, claimed as a run claims its output
    /// (`overwrite`: [`RunOptions::overwrite`]).
    pub fn begin(out_dir: &Path, overwrite: bool, taken: Parts) -> Result<Self, Error> {
        Ok(Self {
            out_dir: out_dir.to_path_buf(),
            taken,
            move_first: taken == Parts::Take,
            claimed: outdir::claim(out_dir, overwrite)?,
            gathered: Gathered::default(),
            join: LasJoin::new(&out_dir.join(PART_LAS)),
            failed: false,
        })
    }

    /// Copies the first stitched part's LAS file even when the parts are
    /// taken, so that a merge that fails before it finishes leaves every
    /// part as it was (taken parts are still removed once it is
    /// complete). Call before the first part is added.
    pub fn copy_first_part(&mut self) {
        self.move_first = false;
    }

    /// Adds the part in `dir`, refused as [`merge`] refuses it, and joins
    /// the stitched parts' LAS files that can be joined in order. A part
    /// refused leaves the merge as it was; a part whose file cannot be
    /// joined fails the merge.
    pub fn add(&mut self, dir: &Path) -> Result<(), Error> {
        self.check_usable()?;
        outdir::check_parts(&self.out_dir, &[dir.to_path_buf()])?;
        let first_part = self.gathered.first.is_none();
        self.gathered.admit(dir)?;
        let taken_in = self.take_in(first_part);
        self.failed = taken_in.is_err();
        taken_in
    }

    /// What [`Merge::add`] does once the part is admitted.
    fn take_in(&mut self, first_part: bool) -> Result<(), Error> {
        let Some(first) = &self.gathered.first else {
            return Ok(());
        };
        if first_part {
            outdir::check_inputs(&self.out_dir, &crate::files::input_files(&first.survey))?;
        }
        if first.with_report {
            let take = self.move_first;
            while let Some((dir, r)) = self.gathered.part(self.join.parts() + 1) {
                self.join.append(&dir.join(&r.points_file), take)?;
            }
        }
        Ok(())
    }

    /// Refuses a merge that failed.
    fn check_usable(&self) -> Result<(), Error> {
        if self.failed {
            return Err(refused(
                &self.out_dir,
                "a part given to this merge could not be taken in: merge the parts again",
            ));
        }
        Ok(())
    }

    /// Finishes the merge once every part is added: the files [`merge`]
    /// writes, over the flight `built` as [`merge_over`] uses it.
    pub fn finish(
        self,
        options: &RunOptions<'_>,
        built: Option<&Flight>,
    ) -> Result<Summary, Error> {
        self.check_usable()?;
        let Merge {
            out_dir,
            taken,
            move_first,
            claimed,
            gathered,
            join,
            ..
        } = self;
        let (first, mut parts) = gathered.complete(&out_dir)?;
        parts.sort_by_key(|(_, r)| r.part);
        let with_report = first.with_report;
        let inputs = part_inputs(&parts, with_report);
        // The survey the parts ran, as the first part wrote it, and its
        // flight; the stitched parts not joined yet are joined meanwhile.
        let survey = Survey::load(&parts[0].0.join(SURVEY))?;
        let given = built.filter(|f| same_survey(f.survey(), &first.record));
        let build = move || -> Result<Held<'_>, Error> {
            Ok(match given {
                Some(flight) => Held::Given(flight),
                None => Held::Built(Box::new(Flight::build(survey)?)),
            })
        };
        let (held, joined) = if with_report {
            let (held, joined) = std::thread::scope(|s| {
                let held = s.spawn(build);
                let joined = join_rest(join, &inputs, move_first, options.progress);
                (
                    held.join().expect("building a flight does not panic"),
                    joined,
                )
            });
            (held?, Some(joined?))
        } else {
            (build()?, None)
        };
        let flight = held.get();
        // The file being joined is the one an earlier run's files may not
        // take with them.
        let las_partial = AtomicFile::partial_of(&out_dir.join(PART_LAS));
        claimed.clear(joined.is_some().then_some(las_partial.as_path()))?;
        check_ranges(flight, &parts)?;
        let joined = match joined {
            Some(joined) => Some(adopt(flight, joined, &inputs)?),
            None => None,
        };
        let run = PartsRun {
            inputs: &inputs,
            keep: (move_first && with_report).then_some(las_partial),
            // Taken parts whose LAS files are joined and checked are not
            // read again: those files go while the rest is written
            // (unlinking the 31 files of the terrain split took 0.4 s),
            // their directories at the end.
            remove_early: taken == Parts::Take && joined.is_some(),
        };
        let summary = run.run(flight, &out_dir, options, joined)?;
        if taken == Parts::Take {
            remove_parts(&parts, options)?;
        }
        Ok(summary)
    }
}

/// Whether `survey` is the one the parts ran: its `survey.toml` text
/// hashes as the first part's record says.
fn same_survey(survey: &Survey, first: &PartRecord) -> bool {
    survey_text(survey).is_ok_and(|t| fnv1a_hex(t.as_bytes()) == first.survey_fnv1a)
}

/// The parts, in order, as a merge joins them.
fn part_inputs(parts: &[(PathBuf, PartRecord)], with_report: bool) -> Vec<PartInput> {
    parts
        .iter()
        .map(|(dir, r)| PartInput {
            points: dir.join(&r.points_file),
            report: with_report.then(|| dir.join(REPORT_STATE)),
            counts: r.counts(),
            wall_time_s: r.wall_time_s,
        })
        .collect()
}

/// Joins the stitched parts' LAS files that `join` has not joined yet
/// (moving the first into place with `move_first`); `progress` in pulse
/// slots after each part.
fn join_rest(
    mut join: LasJoin,
    inputs: &[PartInput],
    move_first: bool,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<JoinedLas, Error> {
    let mut slots: u64 = inputs[..join.parts()]
        .iter()
        .map(|p| p.counts.pulse_slots)
        .sum();
    if slots > 0 {
        progress(slots);
    }
    for part in &inputs[join.parts()..] {
        join.append(&part.points, move_first)?;
        slots += part.counts.pulse_slots;
        progress(slots);
    }
    Ok(join.finish()?)
}

/// Refuses parts that simulated other pulses than `flight` splits into.
fn check_ranges(flight: &Flight, parts: &[(PathBuf, PartRecord)]) -> Result<(), Error> {
    for (dir, r) in parts {
        if r.ranges != part_ranges(flight, r.part, r.parts) {
            return Err(refused(
                dir,
                format!(
                    "part {}/{n} simulated other pulses than its survey splits into part {}",
                    r.part,
                    r.part,
                    n = r.parts
                ),
            ));
        }
    }
    Ok(())
}

/// The LAS writer of `flight`'s `points.las` holding the `joined` parts,
/// each checked to hold the points its record counts.
fn adopt(
    flight: &Flight,
    joined: JoinedLas,
    inputs: &[PartInput],
) -> Result<Box<LasWriter>, Error> {
    let (writer, held) = LasWriter::adopt(joined, flight.las_settings())?;
    for (part, n) in inputs.iter().zip(held) {
        if n != part.counts.points {
            return Err(miscounted(&part.points, n, part.counts.points));
        }
    }
    Ok(Box::new(writer))
}

/// The run a merge writes from its parts.
struct PartsRun<'a> {
    inputs: &'a [PartInput],
    /// A file the merge leaves even if it fails: the first part's LAS
    /// file, moved into the output to be joined to.
    keep: Option<PathBuf>,
    /// Remove the parts' joined files while the run is written.
    remove_early: bool,
}

impl PartsRun<'_> {
    /// Prepares, drives and finishes the run of `flight` into `out_dir`
    /// from the parts (`joined`: the writer holding the stitched parts'
    /// points).
    fn run(
        self,
        flight: &Flight,
        out_dir: &Path,
        options: &RunOptions<'_>,
        joined: Option<Box<LasWriter>>,
    ) -> Result<Summary, Error> {
        let inputs = self.inputs;
        std::thread::scope(|s| {
            let removing = self.remove_early.then(|| s.spawn(|| remove_joined(inputs)));
            let summary = (|| {
                let mut prepared = prepare::merged(flight, out_dir, options, joined, self.keep)?;
                let feed = PartsFeed { parts: inputs };
                let driven = drive::drive(flight, &mut prepared, feed, options)?;
                finish::finish(flight, prepared, driven, options)
            })();
            let removed =
                removing.map_or(Ok(()), |r| r.join().expect("removing files does not panic"));
            let summary = summary?;
            removed?;
            Ok(summary)
        })
    }
}

/// Removes what each taken part wrote ([`remove_part`]), warning of a
/// part's directory kept because it holds other files.
fn remove_parts(parts: &[(PathBuf, PartRecord)], options: &RunOptions<'_>) -> Result<(), Error> {
    for (dir, record) in parts {
        let kept = remove_part(dir, record)?;
        if let (false, Some(warn)) = (kept.is_empty(), options.on_warning) {
            warn(&format!(
                "{}: kept the part's directory, without the files the part wrote: it holds \
                 files lidarsim did not write ({})",
                dir.display(),
                kept.join(", ")
            ));
        }
    }
    Ok(())
}

/// Removes what the part in `dir` wrote (its record's [`files`], checked
/// at admission to be names a part writes), then the directory if that
/// leaves it empty; returns the names of what else it holds, which stay.
///
/// [`files`]: super::part::PartRecord::files
fn remove_part(dir: &Path, record: &PartRecord) -> Result<Vec<String>, Error> {
    for name in record.written() {
        let path = dir.join(&name);
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(not_removed(&path, e)),
            _ => {}
        }
    }
    let data = dir.join(super::names::DATA_DIR);
    if std::fs::read_dir(&data).is_ok_and(|mut d| d.next().is_none()) {
        std::fs::remove_dir(&data).map_err(|e| not_removed(&data, e))?;
    }
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| not_removed(dir, e))?
        .filter_map(|e| Some(e.ok()?.file_name().to_string_lossy().into_owned()))
        .collect();
    if left.is_empty() {
        std::fs::remove_dir(dir).map_err(|e| not_removed(dir, e))?;
    }
    left.sort();
    Ok(left)
}

/// Removes the point files of `parts`, joined already (a file moved into
/// the output is gone already).
fn remove_joined(parts: &[PartInput]) -> Result<(), Error> {
    for part in parts {
        match std::fs::remove_file(&part.points) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => {
                return Err(not_removed(&part.points, e));
            }
            _ => {}
        }
    }
    Ok(())
}

/// The error of a part's file or directory that was merged but could not
/// be removed.
fn not_removed(path: &Path, e: io::Error) -> Error {
    Error::Part(crate::error::PathError::io(
        path,
        "merged, but not removed",
        e,
    ))
}

/// The flight a merge runs over: the caller's, or one it built.
enum Held<'f> {
    /// The flight of the parts' survey that the caller holds.
    Given(&'f Flight),
    /// The flight the merge built.
    Built(Box<Flight>),
}

impl Held<'_> {
    /// The flight.
    fn get(&self) -> &Flight {
        match self {
            Held::Given(world) => world,
            Held::Built(world) => world,
        }
    }
}
