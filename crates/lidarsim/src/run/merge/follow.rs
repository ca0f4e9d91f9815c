//! A merge that follows its parts while they run ([`merge_following`]):
//! given the directories every part will write, it looks at them in turn
//! and adds each part as soon as its record says it finished, so that a
//! split run's points are mostly joined by the time its last part ends —
//! for a job array whose merge starts with its parts rather than after
//! them.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use super::admit::finished;
use super::{Merge, Parts};
use crate::error::Error;
use crate::run::part::refused;
use crate::run::{RunOptions, Summary};

/// How a [`merge_following`] waits for its parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Follow {
    /// The time between two looks at the parts not finished yet.
    pub poll: Duration,
    /// Given up after this long without a part finishing (`None`: waits
    /// for as long as it takes, until stopped).
    pub give_up_after: Option<Duration>,
}

impl Default for Follow {
    /// A look every 2 s, never giving up.
    fn default() -> Self {
        Self {
            poll: Duration::from_secs(2),
            give_up_after: None,
        }
    }
}

/// Merges the parts that will be written into `part_dirs` (directories
/// that need not exist yet) into `out_dir`, as [`super::merge`] merges
/// them, adding each one ([`Merge::add`]) once its record says it
/// finished: a part not finished yet is looked at again after
/// `follow.poll`. A part that finished but does not belong to the run is
/// refused at once. `parts_added(added, given)` is called after each part
/// is added. The output is claimed before the first look; a merge that
/// gives up (`follow.give_up_after`) or is stopped (`options.stop`)
/// names the parts it was waiting for and leaves no merged file, and
/// every part as it was: taken parts are removed once the merge is
/// complete, but the first part's LAS file is copied, not moved.
pub fn merge_following(
    part_dirs: &[PathBuf],
    out_dir: &Path,
    options: &RunOptions<'_>,
    taken: Parts,
    follow: &Follow,
    parts_added: &dyn Fn(usize, usize),
) -> Result<Summary, Error> {
    crate::run::outdir::check_parts(out_dir, part_dirs)?;
    let mut merge = Merge::begin(out_dir, options.overwrite, taken)?;
    // A following merge is the one most likely to end early (a part that
    // failed): it leaves the parts whole, to be merged again.
    merge.copy_first_part();
    let mut waiting: Vec<&PathBuf> = part_dirs.iter().collect();
    let mut news = Instant::now();
    let mut added = 0;
    while !waiting.is_empty() {
        let before = waiting.len();
        let mut still = Vec::with_capacity(before);
        for dir in waiting {
            if finished(dir) {
                merge.add(dir)?;
                added += 1;
                parts_added(added, part_dirs.len());
            } else {
                still.push(dir);
            }
        }
        waiting = still;
        if waiting.is_empty() {
            break;
        }
        if waiting.len() < before {
            news = Instant::now();
        }
        let stopped = options.stop.is_some_and(|s| s.load(Ordering::Relaxed));
        let gave_up = follow
            .give_up_after
            .filter(|&limit| news.elapsed() >= limit);
        if stopped || gave_up.is_some() {
            return Err(not_finished(out_dir, &waiting, gave_up));
        }
        std::thread::sleep(follow.poll);
    }
    merge.finish(options, None)
}

/// The error of a merge that stopped waiting for the parts in `waiting`:
/// given up after the time `gave_up` names, or else stopped.
fn not_finished(out_dir: &Path, waiting: &[&PathBuf], gave_up: Option<Duration>) -> Error {
    let which: Vec<String> = waiting.iter().map(|d| d.display().to_string()).collect();
    let why = match gave_up {
        Some(limit) => format!(
            "gave up after {:.1} s without a part finishing",
            limit.as_secs_f64()
        ),
        None => "stopped".to_string(),
    };
    refused(
        out_dir,
        format!(
            "merge {why}: {} of the parts did not finish: {}",
            which.len(),
            which.join(", ")
        ),
    )
}
