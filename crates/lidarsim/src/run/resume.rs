//! What an interrupted run records so that `lidarsim run --resume` can
//! continue it, and the checks that refuse a resume whose record or files
//! changed since.
//!
//! An interrupted run finishes every point file for the pulses simulated
//! so far but leaves it under its `.partial` name; its `summary.json` says
//! `"complete": false`, where to go on (`next_pulse`) and, in `resume`, the
//! length of each file with a hash of its last mebibyte, hashes of
//! `survey.toml` and of the report's state, and a hash over all of that
//! and the counts (`state_fnv1a`). A summary edited by hand, a survey
//! edited before resuming, or a file cut short, replaced or appended to is
//! refused instead of giving a run that duplicates or skips pulses.

use std::collections::BTreeMap;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

use serde::Deserialize;

use super::names::{REPORT_STATE, SUMMARY, SURVEY};
use crate::error::{Error, PathError};
use crate::flight::Flight;
use crate::output::{AtFile, AtomicFile, WriteError};
use crate::sim::{PulsePosition, RunCounts};
pub use crate::summary::{FileState, NextPulse, ResumeState};

/// What a resumed run reads back from the `summary.json` of the
/// interrupted one.
#[derive(Debug, Deserialize)]
pub struct Interrupted {
    complete: bool,
    #[serde(default = "resumable_by_default")]
    resumable: bool,
    seed: u64,
    next_pulse: Option<NextPulse>,
    resume: Option<ResumeState>,
    pulses: u64,
    /// Pulse slots simulated (absent from records of runs whose every slot
    /// was a pulse).
    #[serde(default)]
    pulse_slots: Option<u64>,
    points: u64,
    pulses_with_echo: u64,
    points_by_return: Vec<u64>,
    /// Wall-clock seconds of the sessions so far.
    pub wall_time_s: f64,
}

fn resumable_by_default() -> bool {
    true
}

impl Interrupted {
    /// Where to go on.
    pub fn start(&self) -> PulsePosition {
        let n = self.next_pulse.unwrap_or_default();
        PulsePosition {
            line: n.line.saturating_sub(1) as usize,
            pulse: n.pulse,
        }
    }

    /// The counts of the pulses simulated so far.
    pub fn counts(&self) -> RunCounts {
        let mut c = RunCounts {
            pulses: self.pulses,
            pulse_slots: self.pulse_slots.unwrap_or(self.pulses),
            points: self.points,
            pulses_with_echo: self.pulses_with_echo,
            ..RunCounts::default()
        };
        for (a, b) in c.points_by_return.iter_mut().zip(&self.points_by_return) {
            *a = *b;
        }
        c
    }

    /// The recorded length of point file `name`.
    pub fn file_len(&self, name: &str) -> Option<u64> {
        Some(self.resume.as_ref()?.files.get(name)?.bytes)
    }
}

/// FNV-1a, 64 bits, as 16 hexadecimal digits.
pub fn fnv1a_hex(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// Bytes hashed at the end of each point file.
const TAIL_BYTES: u64 = 1 << 20;

/// The hash of the `bytes.min(TAIL_BYTES)` bytes before offset `bytes` of
/// `path`.
fn tail_hash(path: &Path, bytes: u64) -> io::Result<String> {
    let mut f = std::fs::File::open(path)?;
    let from = bytes.saturating_sub(TAIL_BYTES);
    f.seek(SeekFrom::Start(from))?;
    let mut buf = vec![0u8; (bytes - from) as usize];
    f.read_exact(&mut buf)?;
    Ok(fnv1a_hex(&buf))
}

/// The state hash over the record's parts.
fn state_hash(
    seed: u64,
    next: NextPulse,
    counts: &RunCounts,
    files: &BTreeMap<String, FileState>,
    survey: &str,
    report: &str,
) -> String {
    let mut text = format!(
        "{seed}|{}|{}|{}|{}|{}|{}|{:?}|{survey}|{report}",
        next.line,
        next.pulse,
        counts.pulses,
        counts.pulse_slots,
        counts.points,
        counts.pulses_with_echo,
        counts.points_by_return
    );
    for (name, f) in files {
        text.push_str(&format!("|{name}:{}:{}", f.bytes, f.tail_fnv1a));
    }
    fnv1a_hex(text.as_bytes())
}

/// Records the state of the run interrupted before `next`, whose point
/// files `names` were suspended in `dir` (as `NAME.partial`).
pub fn record(
    dir: &Path,
    names: &[&str],
    seed: u64,
    next: NextPulse,
    counts: &RunCounts,
    report_state: &[u8],
) -> Result<ResumeState, WriteError> {
    let mut files = BTreeMap::new();
    for name in names {
        let path = AtomicFile::partial_of(&dir.join(name));
        let bytes = std::fs::metadata(&path).at(&path)?.len();
        let tail_fnv1a = tail_hash(&path, bytes).at(&path)?;
        files.insert(name.to_string(), FileState { bytes, tail_fnv1a });
    }
    let survey_path = dir.join(SURVEY);
    let survey_fnv1a = fnv1a_hex(&std::fs::read(&survey_path).at(&survey_path)?);
    let report_state_fnv1a = fnv1a_hex(report_state);
    let state_fnv1a = state_hash(
        seed,
        next,
        counts,
        &files,
        &survey_fnv1a,
        &report_state_fnv1a,
    );
    Ok(ResumeState {
        files,
        survey_fnv1a,
        report_state_fnv1a,
        state_fnv1a,
    })
}

/// Reads the `summary.json` of the run interrupted in `dir` and checks it
/// against `flight` (of the run's own `survey.toml`), the saved report
/// state (returned with it) and the point files `names` the survey writes.
/// Every refusal names the file and says why.
pub fn read(dir: &Path, flight: &Flight, names: &[&str]) -> Result<(Interrupted, Vec<u8>), Error> {
    let survey = flight.survey();
    let path = dir.join(SUMMARY);
    let refuse = |path: &Path, msg: String| Error::Resume(PathError::new(path, msg));
    let text = std::fs::read(&path).map_err(|e| {
        let reason = format!("{e}: no interrupted run to resume in this directory");
        Error::Resume(PathError {
            path: path.clone(),
            reason,
            cause: Some(e),
        })
    })?;
    let prev: Interrupted = serde_json::from_slice(&text)
        .map_err(|e| refuse(&path, format!("not a summary of lidarsim: {e}")))?;
    if prev.complete {
        return Err(refuse(
            &path,
            "the run is complete: there is nothing to resume".into(),
        ));
    }
    if !prev.resumable {
        return Err(refuse(
            &path,
            "this run wrote LAZ, which cannot be continued: its files hold the pulses \
             simulated before it stopped; run the survey again for all of them"
                .into(),
        ));
    }
    if prev.seed != survey.seed {
        return Err(refuse(
            &path,
            format!(
                "the run used seed {} but the survey has seed {}: resume with the run's own \
                 survey.toml",
                prev.seed, survey.seed
            ),
        ));
    }
    let (Some(next), Some(state)) = (prev.next_pulse, &prev.resume) else {
        return Err(refuse(
            &path,
            "no next pulse or resume record: it is not the summary of an interrupted run".into(),
        ));
    };
    let changed = |what: &str| {
        refuse(
            &path,
            format!(
                "{what}: the record of the interrupted run does not match this directory, so \
                 resuming could duplicate or skip pulses; run the survey again"
            ),
        )
    };
    // The position and the pulse count must agree.
    let line_pulses = flight.line_pulses();
    let line_ok = next.line >= 1 && (next.line as usize) <= line_pulses.len();
    let before: u64 = line_pulses
        .iter()
        .take(next.line.saturating_sub(1) as usize)
        .sum();
    let in_line = line_ok && next.pulse < line_pulses[next.line as usize - 1];
    let counts = prev.counts();
    if !in_line || before + next.pulse != counts.pulse_slots {
        return Err(changed(&format!(
            "next pulse {} of line {} does not follow the {} pulses simulated",
            next.pulse, next.line, counts.pulse_slots
        )));
    }
    let want = state_hash(
        prev.seed,
        next,
        &counts,
        &state.files,
        &state.survey_fnv1a,
        &state.report_state_fnv1a,
    );
    if want != state.state_fnv1a {
        return Err(changed("summary.json was edited"));
    }
    let survey_toml = dir.join(SURVEY);
    let text = std::fs::read(&survey_toml)
        .map_err(|e| Error::Resume(PathError::io(&survey_toml, "cannot read it", e)))?;
    if fnv1a_hex(&text) != state.survey_fnv1a {
        return Err(refuse(
            &survey_toml,
            "changed since the run was interrupted: a resumed run must simulate the same \
             survey; run the changed survey afresh instead"
                .into(),
        ));
    }
    let state_path = dir.join(REPORT_STATE);
    let report_state = std::fs::read(&state_path)
        .map_err(|e| Error::Resume(PathError::io(&state_path, "cannot read it", e)))?;
    if fnv1a_hex(&report_state) != state.report_state_fnv1a {
        return Err(changed(&format!("{REPORT_STATE} changed")));
    }
    let mut recorded: Vec<&str> = state.files.keys().map(String::as_str).collect();
    let mut wanted = names.to_vec();
    recorded.sort_unstable();
    wanted.sort_unstable();
    if recorded != wanted {
        return Err(changed(&format!(
            "the run wrote {} but the survey writes {}",
            recorded.join(", "),
            wanted.join(", ")
        )));
    }
    for (name, f) in &state.files {
        let partial = AtomicFile::partial_of(&dir.join(name));
        let have = std::fs::symlink_metadata(&partial)
            .ok()
            .filter(|m| m.file_type().is_file())
            .map(|m| m.len());
        let ok = match have {
            Some(len) if len >= f.bytes => {
                tail_hash(&partial, f.bytes).is_ok_and(|h| h == f.tail_fnv1a)
            }
            _ => false,
        };
        if !ok {
            return Err(refuse(
                &partial,
                format!(
                    "missing, shorter than or different from the {} bytes the interrupted run \
                     wrote: the run cannot be resumed; run the survey again",
                    f.bytes
                ),
            ));
        }
    }
    Ok((prev, report_state))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_published_test_vectors() {
        // Test vectors of the FNV reference (Fowler, Noll, Vo): the empty
        // string, "a" and "foobar".
        assert_eq!(fnv1a_hex(b""), "cbf29ce484222325");
        assert_eq!(fnv1a_hex(b"a"), "af63dc4c8601ec8c");
        assert_eq!(fnv1a_hex(b"foobar"), "85944171f73967e8");
    }

    #[test]
    fn the_state_hash_changes_with_every_part() {
        let counts = RunCounts {
            pulses: 4096,
            pulse_slots: 4096,
            points: 4000,
            ..RunCounts::default()
        };
        let mut files = BTreeMap::new();
        files.insert(
            "points.las".to_string(),
            FileState {
                bytes: 100,
                tail_fnv1a: "00".into(),
            },
        );
        let next = NextPulse {
            line: 1,
            pulse: 4096,
        };
        let base = state_hash(1, next, &counts, &files, "a", "b");
        assert_ne!(base, state_hash(2, next, &counts, &files, "a", "b"));
        let later = NextPulse {
            line: 1,
            pulse: 6144,
        };
        assert_ne!(base, state_hash(1, later, &counts, &files, "a", "b"));
        let mut more = counts.clone();
        more.points += 1;
        assert_ne!(base, state_hash(1, next, &more, &files, "a", "b"));
        assert_ne!(base, state_hash(1, next, &counts, &files, "c", "b"));
        let mut longer = files.clone();
        longer.get_mut("points.las").unwrap().bytes = 101;
        assert_ne!(base, state_hash(1, next, &counts, &longer, "a", "b"));
    }
}
