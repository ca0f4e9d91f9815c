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

use admit::{First, Gathered};
pub(crate) use feed::gather;
use feed::miscounted;
pub use follow::{Follow, merge_following};

use super::part::{PART_LAS, error, part_ranges};
use super::resume::fnv1a_hex;
use super::{RunError, RunOptions, Source, Summary, execute, outdir};
use crate::output::{LasJoin, LasWriter};
use crate::sim::RunCounts;
use crate::survey::Survey;
use crate::world::World;

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
) -> Result<Summary, RunError> {
    merge_over(part_dirs, out_dir, options, taken, None)
}

/// [`merge`], over the world `built` holds when it is the world of the
/// parts' survey: when the survey it was built from is written as the
/// parts wrote theirs (the same `survey.toml` text, by its hash in their
/// records). The merge then neither reads the scene's files nor indexes
/// it again; a world of another survey is not used (the merge builds its
/// own, as [`merge`] does). A caller that kept the world the parts ran
/// on, or built it while they ran, saves the merge that time.
pub fn merge_over(
    part_dirs: &[PathBuf],
    out_dir: &Path,
    options: &RunOptions<'_>,
    taken: Parts,
    built: Option<(&Survey, &World)>,
) -> Result<Summary, RunError> {
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
    pub fn begin(out_dir: &Path, overwrite: bool, taken: Parts) -> Result<Self, RunError> {
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
    pub fn add(&mut self, dir: &Path) -> Result<(), RunError> {
        self.check_usable()?;
        outdir::check_parts(&self.out_dir, &[dir.to_path_buf()])?;
        let first_part = self.gathered.first.is_none();
        self.gathered.admit(dir)?;
        let taken_in = self.take_in(first_part);
        self.failed = taken_in.is_err();
        taken_in
    }

    /// What [`Merge::add`] does once the part is admitted.
    fn take_in(&mut self, first_part: bool) -> Result<(), RunError> {
        let Some(first) = &self.gathered.first else {
            return Ok(());
        };
        if first_part {
            outdir::check_inputs(&self.out_dir, &crate::files::input_files(&first.survey))?;
        }
        if first.with_report {
            let take = self.move_first;
            while let Some((dir, r)) = self.gathered.part(self.join.parts() + 1) {
                self.join
                    .append(&dir.join(&r.points_file), take)
                    .map_err(|e| super::run_error(&self.out_dir, e))?;
            }
        }
        Ok(())
    }

    /// Refuses a merge that failed.
    fn check_usable(&self) -> Result<(), RunError> {
        if self.failed {
            return Err(error(
                &self.out_dir,
                io::ErrorKind::Other,
                "a part given to this merge could not be taken in: merge the parts again".into(),
            ));
        }
        Ok(())
    }

    /// Finishes the merge once every part is added: the files [`merge`]
    /// writes, over the world of `built` as [`merge_over`] uses it.
    pub fn finish(
        self,
        options: &RunOptions<'_>,
        built: Option<(&Survey, &World)>,
    ) -> Result<Summary, RunError> {
        self.check_usable()?;
        let Merge {
            out_dir,
            taken,
            move_first,
            claimed,
            gathered,
            mut join,
            ..
        } = self;
        let (
            First {
                record: r0,
                with_report,
                ..
            },
            mut parts,
        ) = gathered.complete(&out_dir)?;
        let n = r0.parts;
        parts.sort_by_key(|(_, r)| r.part);
        // The survey the parts ran, as the first part wrote it.
        let survey_path = parts[0].0.join("survey.toml");
        let survey = Survey::load(&survey_path)
            .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string()))?;
        let inputs: Vec<PartInput> = parts
            .iter()
            .map(|(dir, r)| PartInput {
                points: dir.join(&r.points_file),
                report: with_report.then(|| dir.join(super::REPORT_STATE)),
                counts: r.counts(),
                wall_time_s: r.wall_time_s,
            })
            .collect();

        // Its world; the stitched parts not joined yet are joined
        // meanwhile.
        let las_path = out_dir.join(PART_LAS);
        let given = built
            .filter(|(s, _)| {
                super::survey_text(s).is_ok_and(|t| fnv1a_hex(t.as_bytes()) == r0.survey_fnv1a)
            })
            .map(|(_, w)| w);
        let build = || match given {
            Some(world) => Ok(Held::Given(world)),
            None => World::build(&survey)
                .map(|w| Held::Built(Box::new(w)))
                .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string())),
        };
        let (world, joined) = if with_report {
            let joining = || {
                let take = move_first;
                let mut slots: u64 = inputs[..join.parts()]
                    .iter()
                    .map(|p| p.counts.pulse_slots)
                    .sum();
                if slots > 0 {
                    (options.progress)(slots);
                }
                for part in &inputs[join.parts()..] {
                    join.append(&part.points, take)
                        .map_err(|e| super::run_error(&out_dir, e))?;
                    slots += part.counts.pulse_slots;
                    (options.progress)(slots);
                }
                join.finish().map_err(|e| super::run_error(&out_dir, e))
            };
            let (world, joined) = std::thread::scope(|s| {
                let world = s.spawn(build);
                let joined = joining();
                (
                    world.join().expect("building a world does not panic"),
                    joined,
                )
            });
            (world?, Some(joined?))
        } else {
            (build()?, None)
        };
        // The file being joined is the one an earlier run's files may not
        // take with them.
        let joining = joined
            .is_some()
            .then(|| crate::output::AtomicFile::partial_of(&las_path));
        claimed.clear(joining.as_deref())?;
        let world = world.get();
        for (dir, r) in &parts {
            if r.ranges != part_ranges(&survey, world, r.part, n) {
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
        let joined = match joined {
            None => None,
            Some(joined) => {
                let settings = crate::files::las_settings(&survey, world);
                let (writer, held) = LasWriter::adopt(joined, settings)
                    .map_err(|e| super::run_error(&out_dir, e))?;
                for (part, n) in inputs.iter().zip(held) {
                    if n != part.counts.points {
                        return Err(super::run_error(
                            &out_dir,
                            miscounted(&part.points, n, part.counts.points),
                        ));
                    }
                }
                Some(Box::new(writer))
            }
        };
        // Taken parts whose LAS files are joined and checked are not read
        // again: those files go while the rest is written (unlinking the
        // 31 files of the terrain split took 0.4 s), their directories at
        // the end.
        let early = taken == Parts::Take && joined.is_some();
        let (summary, removed) = std::thread::scope(|s| {
            let removing = early.then(|| s.spawn(|| remove_joined(&inputs)));
            let summary = execute(
                &survey,
                world,
                &out_dir,
                options,
                Source::Parts {
                    parts: &inputs,
                    joined,
                    keep: (move_first && with_report)
                        .then(|| crate::output::AtomicFile::partial_of(&las_path)),
                },
            );
            let removed =
                removing.map_or(Ok(()), |r| r.join().expect("removing files does not panic"));
            (summary, removed)
        });
        let summary = summary?;
        removed?;
        if taken == Parts::Take {
            for (dir, record) in &parts {
                let kept = remove_part(dir, record)?;
                if let (false, Some(warn)) = (kept.is_empty(), options.on_warning) {
                    warn(&format!(
                        "{}: kept the part's directory, without the files the part wrote: it \
                         holds files lidarsim did not write ({})",
                        dir.display(),
                        kept.join(", ")
                    ));
                }
            }
        }
        Ok(summary)
    }
}

/// Removes what the part in `dir` wrote (its record's [`files`], checked
/// at admission to be names a part writes), then the directory if that
/// leaves it empty; returns the names of what else it holds, which stay.
///
/// [`files`]: super::part::PartRecord::files
fn remove_part(dir: &Path, record: &super::part::PartRecord) -> Result<Vec<String>, RunError> {
    for name in record.written() {
        let path = dir.join(&name);
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(not_removed(&path, e)),
            _ => {}
        }
    }
    let data = dir.join(outdir::DATA_DIR);
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
fn remove_joined(parts: &[PartInput]) -> Result<(), RunError> {
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
fn not_removed(path: &Path, e: io::Error) -> RunError {
    RunError {
        path: path.to_path_buf(),
        source: io::Error::new(e.kind(), format!("merged, but not removed: {e}")),
    }
}

/// The world a merge runs over: the caller's, or one it built.
enum Held<'w> {
    /// The world of the parts' survey that the caller holds.
    Given(&'w World),
    /// The world the merge built.
    Built(Box<World>),
}

impl Held<'_> {
    /// The world.
    fn get(&self) -> &World {
        match self {
            Held::Given(world) => world,
            Held::Built(world) => world,
        }
    }
}
