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
//! A merge refuses parts that do not make one run: a directory that is not
//! a part, a part that did not finish, a point file cut short or changed,
//! a part of another survey, seed, number of parts or lidarsim version, a
//! part given twice and a part missing.

use std::io;
use std::path::{Path, PathBuf};

use super::part::{PART_LAS, PART_POINTS, PART_RECORD, PartRecord, error, part_ranges, stitched};
use super::resume::fnv1a_hex;
use super::{RunError, RunOptions, Source, Summary, execute, outdir};
use crate::output::part::PartReader;
use crate::output::{LasJoin, LasWriter, PointRecord, PointSink, WaveformBlock, file_error};
use crate::report::ReportSink;
use crate::sim::{RunCounts, RunOutcome};
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

/// A part directory's record, checked against its own files (its survey
/// text by hash, its point and report files by length).
fn read_part(dir: &Path) -> Result<PartRecord, RunError> {
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
    Ok(record)
}

/// What a merge does with its parts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Parts {
    /// Leaves them as they are: the merge can be made again.
    #[default]
    Keep,
    /// Takes them: the first stitched part's LAS file is moved into the
    /// output rather than copied (on one file system), and every part's
    /// directory is removed once the merge is complete. A merge that fails
    /// after the move leaves that file as the output's `points.las.partial`.
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
            claimed: outdir::claim(out_dir, overwrite)?,
            gathered: Gathered::default(),
            join: LasJoin::new(&out_dir.join(PART_LAS)),
            failed: false,
        })
    }

    /// Adds the part in `dir`, refused as [`merge`] refuses it, and joins
    /// the stitched parts' LAS files that can be joined in order. A part
    /// refused leaves the merge as it was; a part whose file cannot be
    /// joined fails the merge.
    pub fn add(&mut self, dir: &Path) -> Result<(), RunError> {
        self.check_usable()?;
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
            let take = self.taken == Parts::Take;
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
            Some(_) => Ok(None),
            None => World::build(&survey)
                .map(Some)
                .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string())),
        };
        let (world, joined) = if with_report {
            let joining = || {
                let take = taken == Parts::Take;
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
        let Some(world) = given.or(world.as_ref()) else {
            unreachable!("a merge builds the world it is not given")
        };
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
        let summary = execute(
            &survey,
            world,
            &out_dir,
            options,
            Source::Parts {
                parts: &inputs,
                joined,
            },
        )?;
        if taken == Parts::Take {
            for (dir, _) in &parts {
                std::fs::remove_dir_all(dir).map_err(|e| RunError {
                    path: dir.clone(),
                    source: io::Error::new(e.kind(), format!("merged, but not removed: {e}")),
                })?;
            }
        }
        Ok(summary)
    }
}

/// The refusal of a merge given no part.
fn no_part(out_dir: &Path) -> RunError {
    error(
        out_dir,
        io::ErrorKind::InvalidInput,
        "no part to merge".into(),
    )
}

/// The parts of a merge so far, each checked against the first.
#[derive(Debug, Default)]
struct Gathered {
    first: Option<First>,
    parts: Vec<(PathBuf, PartRecord)>,
}

/// What the first part added to a merge says of them all.
#[derive(Debug)]
struct First {
    dir: PathBuf,
    record: PartRecord,
    /// Its survey (read to know how its parts are joined).
    survey: Survey,
    points_file: &'static str,
    with_report: bool,
}

impl First {
    /// The first part, in `dir` with its `record`, and its survey.
    fn read(dir: &Path, record: &PartRecord) -> Result<Self, RunError> {
        let survey_path = dir.join("survey.toml");
        let survey = Survey::load(&survey_path)
            .map_err(|e| error(&survey_path, io::ErrorKind::InvalidData, e.to_string()))?;
        let with_report = stitched(&survey);
        Ok(First {
            dir: dir.to_path_buf(),
            record: record.clone(),
            survey,
            points_file: if with_report { PART_LAS } else { PART_POINTS },
            with_report,
        })
    }

    /// Refuses the part in `dir` with `record` if it is not of the first
    /// part's run, or one of `parts` already.
    fn check(
        &self,
        parts: &[(PathBuf, PartRecord)],
        dir: &Path,
        record: &PartRecord,
    ) -> Result<(), RunError> {
        let r0 = &self.record;
        let foreign = |what: String| {
            error(
                dir,
                io::ErrorKind::InvalidData,
                format!(
                    "part {}/{} is not of the run of {}: {what}",
                    record.part,
                    record.parts,
                    self.dir.display()
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
        if record.points_file != self.points_file || (record.report_bytes > 0) != self.with_report {
            return Err(error(
                dir,
                io::ErrorKind::InvalidData,
                format!(
                    "part {}/{} holds {}, but the parts of its survey hold {}{}",
                    record.part,
                    record.parts,
                    record.points_file,
                    self.points_file,
                    if self.with_report {
                        " and report.state"
                    } else {
                        ""
                    }
                ),
            ));
        }
        Ok(())
    }
}

impl Gathered {
    /// Adds the part in `dir` once its record and files agree with each
    /// other and with the parts before it; a part refused leaves them as
    /// they were.
    fn admit(&mut self, dir: &Path) -> Result<(), RunError> {
        let record = read_part(dir)?;
        match &self.first {
            Some(first) => first.check(&self.parts, dir, &record)?,
            None => {
                let first = First::read(dir, &record)?;
                first.check(&self.parts, dir, &record)?;
                self.first = Some(first);
            }
        }
        self.parts.push((dir.to_path_buf(), record));
        Ok(())
    }

    /// Part `k`, if it is added.
    fn part(&self, k: usize) -> Option<(&Path, &PartRecord)> {
        self.parts
            .iter()
            .find(|(_, r)| r.part == k)
            .map(|(d, r)| (d.as_path(), r))
    }

    /// The first part and every part, unless [`Gathered::missing`]
    /// refuses them.
    fn complete(self, out_dir: &Path) -> Result<(First, Vec<(PathBuf, PartRecord)>), RunError> {
        self.missing(out_dir)?;
        match self.first {
            Some(first) => Ok((first, self.parts)),
            None => Err(no_part(out_dir)),
        }
    }

    /// Refuses a merge of no part or with a part missing.
    fn missing(&self, out_dir: &Path) -> Result<(), RunError> {
        let Some(first) = &self.first else {
            return Err(no_part(out_dir));
        };
        let n = first.record.parts;
        let missing: Vec<String> = (1..=n)
            .filter(|&k| self.part(k).is_none())
            .map(|k| format!("{k}/{n}"))
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        let which = match missing.as_slice() {
            [one] => format!("part {one} is"),
            many => format!("parts {} are", many.join(", ")),
        };
        Err(error(
            out_dir,
            io::ErrorKind::NotFound,
            format!("{which} missing: a merge needs all {n} parts"),
        ))
    }
}

/// Joins the points of `parts`, in order, in `sinks` and `report`: the
/// reports of stitched parts, whose points a writer has adopted already
/// ([`merge`]), are joined ([`stitch`]); other parts' points are handed
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
