//! The parts given to a merge admitted one at a time: each directory's
//! record read and checked against the part's own files, then against
//! the first part admitted (the same survey, seed, number of parts and
//! lidarsim version, and no part twice); at the end, no part missing.

use std::io;
use std::path::{Path, PathBuf};

use super::super::names::{PART_LAS, PART_POINTS, PART_RECORD, REPORT_STATE, SURVEY};
use super::super::part::{PartRecord, is_part_file, refused, stitched};
use super::super::resume::fnv1a_hex;
use crate::error::Error;
use crate::output::checksum::file_crc32;
use crate::survey::Survey;

/// The largest part record read, bytes: a record lists its pulse ranges
/// (a few per part) and files, a few kilobytes at most.
const MAX_RECORD_BYTES: u64 = 1 << 20;

/// The record of the part in `dir`, read as a survey's input files are
/// (a regular file of bounded size: a device or a FIFO named `part.json`
/// is refused, not read without end), or why not.
fn read_record(dir: &Path) -> Result<Vec<u8>, io::Error> {
    crate::io::input::read_input(&dir.join(PART_RECORD), MAX_RECORD_BYTES)
}

/// Whether the part in `dir` is done with: its record is there and says
/// it is complete, or is no part's record at all (for [`read_part`] to
/// refuse). A part writes its record last, whole: a directory without
/// one, or whose part was stopped early, may still be written.
pub(super) fn finished(dir: &Path) -> bool {
    match read_record(dir) {
        Ok(bytes) => {
            serde_json::from_slice::<PartRecord>(&bytes).map_or(true, |record| record.complete)
        }
        // Something that is not a file, or too large, is refused at once.
        Err(e) => e.kind() != io::ErrorKind::NotFound,
    }
}

/// Refuses a record whose counts could not come from a part run: more
/// parts than a survey is split into, a part number outside them, more
/// return numbers than LAS has, or a file a part never writes.
fn check_counts(path: &Path, r: &PartRecord) -> Result<(), Error> {
    let bad = |why: String| refused(path, why);
    super::super::part::check_part_number(r.part, r.parts)
        .map_err(|why| bad(format!("is not a part's record: {why}")))?;
    if r.points_by_return.len() > 15 || r.ranges.len() > 1 << 16 {
        return Err(bad(format!(
            "is not a part's record: it lists {} return numbers (LAS has 15) and {} pulse \
             ranges",
            r.points_by_return.len(),
            r.ranges.len()
        )));
    }
    if let Some(f) = r.files.iter().find(|f| !is_part_file(f)) {
        return Err(bad(format!(
            "lists {f:?} among the files its part wrote, but a part never writes such a file"
        )));
    }
    Ok(())
}

/// A part directory's record, checked against its own files (its survey
/// text by hash, its point and report files by length and checksum).
fn read_part(dir: &Path) -> Result<PartRecord, Error> {
    let path = dir.join(PART_RECORD);
    let bytes = read_record(dir).map_err(|e| {
        refused(
            &path,
            format!(
                "not the record of a part ({e}); write parts with \
                 `lidarsim run SURVEY --part K/N -o DIR`"
            ),
        )
    })?;
    let record: PartRecord = serde_json::from_slice(&bytes)
        .map_err(|e| refused(&path, format!("is not a part's record: {e}")))?;
    check_counts(&path, &record)?;
    if !record.complete {
        return Err(refused(
            dir,
            format!(
                "part {}/{} did not finish (its record says \"complete\": false): run it again",
                record.part, record.parts
            ),
        ));
    }
    let survey_path = dir.join(SURVEY);
    let text = crate::io::input::read_input(&survey_path, crate::io::input::MAX_SURVEY_BYTES)
        .map_err(|e| refused(&survey_path, format!("cannot read the part's survey: {e}")))?;
    if fnv1a_hex(&text) != record.survey_fnv1a {
        return Err(refused(
            &survey_path,
            "was changed after the part ran (its hash is not the one the part recorded)",
        ));
    }
    if ![PART_POINTS, PART_LAS].contains(&record.points_file.as_str()) {
        return Err(refused(
            &path,
            format!(
                "names its points {:?}, which is neither {PART_POINTS} nor {PART_LAS}",
                record.points_file
            ),
        ));
    }
    let mut files = vec![(
        record.points_file.as_str(),
        record.points_bytes,
        &record.points_crc32,
    )];
    if record.report_bytes > 0 {
        files.push((REPORT_STATE, record.report_bytes, &record.report_crc32));
    }
    for (name, bytes, crc) in files {
        check_file(&dir.join(name), &record, bytes, crc.as_deref())?;
    }
    Ok(record)
}

/// Refuses a part's file that is not the one its part wrote: of another
/// length than `bytes`, or with another checksum than `crc` (a record
/// without one is of a lidarsim that did not record it).
fn check_file(
    file: &Path,
    record: &PartRecord,
    bytes: u64,
    crc: Option<&str>,
) -> Result<(), Error> {
    let (k, n) = (record.part, record.parts);
    let name = file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let len = crate::io::input::check_input(file, u64::MAX)
        .map_err(|e| refused(file, format!("cannot read the part's {name}: {e}")))?;
    if len != bytes {
        return Err(refused(
            file,
            format!(
                "holds {len} bytes, but part {k}/{n} wrote {bytes}: it was cut short or changed"
            ),
        ));
    }
    let Some(crc) = crc else {
        return Err(refused(
            file,
            format!(
                "part {k}/{n} recorded no checksum of it (it was written by an earlier \
                 lidarsim): run the part again"
            ),
        ));
    };
    let found = file_crc32(file).map_err(|e| refused(file, e.to_string()))?;
    if found != crc {
        return Err(refused(
            file,
            format!(
                "is not the file part {k}/{n} wrote: its checksum is {found}, the part recorded \
                 {crc} (it was changed, or swapped with another part's)"
            ),
        ));
    }
    Ok(())
}

/// The refusal of a merge given no part.
fn no_part(out_dir: &Path) -> Error {
    refused(out_dir, "no part to merge")
}

/// The parts of a merge so far, each checked against the first.
#[derive(Debug, Default)]
pub(super) struct Gathered {
    /// The first part admitted.
    pub(super) first: Option<First>,
    /// Every part admitted, in the order of admission.
    pub(super) parts: Vec<(PathBuf, PartRecord)>,
}

/// What the first part added to a merge says of them all.
#[derive(Debug)]
pub(super) struct First {
    /// Its directory.
    dir: PathBuf,
    /// Its record.
    pub(super) record: PartRecord,
    /// Its survey (read to know how its parts are joined).
    pub(super) survey: Survey,
    /// The point file every part holds.
    points_file: &'static str,
    /// Whether the parts are stitched ([`stitched`]): their LAS files
    /// joined as they are, their reports' states kept.
    pub(super) with_report: bool,
}

impl First {
    /// The first part, in `dir` with its `record`, and its survey.
    fn read(dir: &Path, record: &PartRecord) -> Result<Self, Error> {
        let survey_path = dir.join(SURVEY);
        let survey = Survey::load(&survey_path)?;
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
    ) -> Result<(), Error> {
        let r0 = &self.record;
        let foreign = |what: String| {
            refused(
                dir,
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
            return Err(refused(
                dir,
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
            return Err(refused(
                dir,
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
    pub(super) fn admit(&mut self, dir: &Path) -> Result<(), Error> {
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
    pub(super) fn part(&self, k: usize) -> Option<(&Path, &PartRecord)> {
        self.parts
            .iter()
            .find(|(_, r)| r.part == k)
            .map(|(d, r)| (d.as_path(), r))
    }

    /// The first part and every part, unless [`Gathered::missing`]
    /// refuses them.
    pub(super) fn complete(
        self,
        out_dir: &Path,
    ) -> Result<(First, Vec<(PathBuf, PartRecord)>), Error> {
        self.missing(out_dir)?;
        match self.first {
            Some(first) => Ok((first, self.parts)),
            None => Err(no_part(out_dir)),
        }
    }

    /// Refuses a merge of no part or with a part missing.
    pub(super) fn missing(&self, out_dir: &Path) -> Result<(), Error> {
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
        Err(refused(
            out_dir,
            format!("{which} missing: a merge needs all {n} parts"),
        ))
    }
}
