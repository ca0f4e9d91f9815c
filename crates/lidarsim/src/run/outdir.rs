//! The output directory of a run: the rules that keep a run from
//! destroying what it did not write.
//!
//! A run writes into a new or empty directory, or into one an earlier run
//! wrote (it holds [`MARKER`]); then only the files a run writes
//! ([`RUN_FILES`], also under their `.partial` names) are removed first, so
//! that no file of the earlier run sits beside this run's summary. A
//! directory holding anything else is refused unless the caller overwrites
//! explicitly, and even then only the run's own names are removed. No run
//! ever writes over one of its own input files.

use std::io;
use std::path::{Path, PathBuf};

use super::names::{
    DATA_DIR, LAYOUT_DIRS, MARKER, RUN_FILES, is_data_file, is_layout_file, is_run_file,
};
use crate::error::{Error, PathError};
use crate::output::{AtFile, WriteError};

/// The entries of `dir/sub` if it is a directory holding only entries a
/// run writes there (`None` otherwise).
fn own_dir_entries(dir: &Path, sub: &str, ours: fn(&str) -> bool) -> Option<Vec<PathBuf>> {
    let path = dir.join(sub);
    let meta = std::fs::symlink_metadata(&path).ok()?;
    if !meta.is_dir() {
        return None;
    }
    let mut entries = Vec::new();
    for entry in std::fs::read_dir(&path).ok()? {
        let entry = entry.ok()?;
        if entry.file_type().ok()?.is_symlink() || !ours(&entry.file_name().to_string_lossy()) {
            return None;
        }
        entries.push(entry.path());
    }
    Some(entries)
}

/// The run's own subdirectories of `dir` with their entries.
fn own_dirs(dir: &Path) -> Vec<(&'static str, Vec<PathBuf>)> {
    let mut out = Vec::new();
    if let Some(e) = own_dir_entries(dir, DATA_DIR, is_data_file) {
        out.push((DATA_DIR, e));
    }
    for sub in LAYOUT_DIRS {
        if let Some(e) = own_dir_entries(dir, sub, is_layout_file) {
            out.push((sub, e));
        }
    }
    out
}

/// The output directory refused, for `reason`.
fn refused(dir: &Path, reason: String) -> Error {
    Error::Directory(PathError::new(dir, reason))
}

/// `path` made absolute, with symbolic links and `..` resolved as far as it
/// exists (the rest, not yet created, appended as written): two names of
/// one directory resolve to the same path, whether or not it exists yet.
pub fn resolved(path: &Path) -> PathBuf {
    use std::path::Component;
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = absolute.as_path();
    let mut rest = Vec::new();
    let mut base = loop {
        if let Ok(found) = std::fs::canonicalize(existing) {
            break found;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            // `..` or the root itself: nothing to resolve.
            _ => break existing.to_path_buf(),
        }
    };
    for name in rest.iter().rev() {
        match Path::new(name).components().next() {
            Some(Component::ParentDir) => {
                base.pop();
            }
            Some(Component::CurDir) | None => {}
            _ => base.push(name),
        }
    }
    base
}

/// Refuses an output directory in which a run would write over, or
/// remove, one of its `inputs` (the survey file, meshes, rasters, clouds,
/// trajectory file): an input named as a file a run writes directly in
/// it, or one inside the subdirectories a run clears there
/// ([`DATA_DIR`], [`LAYOUT_DIRS`]).
pub fn check_inputs(dir: &Path, inputs: &[PathBuf]) -> Result<(), Error> {
    let dir = resolved(dir);
    let cleared: Vec<PathBuf> = std::iter::once(DATA_DIR)
        .chain(LAYOUT_DIRS)
        .map(|sub| dir.join(sub))
        .collect();
    for input in inputs {
        let full = resolved(input);
        let Some(name) = full.file_name().map(|n| n.to_string_lossy().into_owned()) else {
            continue;
        };
        let written = full.parent() == Some(dir.as_path()) && is_run_file(&name);
        if written || cleared.iter().any(|sub| full.starts_with(sub)) {
            return Err(Error::Input(PathError::new(
                input,
                format!(
                    "the run would write over or remove this input file (a run writes {} \
                     in its output directory {}): choose another output directory",
                    if written {
                        name
                    } else {
                        full.display().to_string()
                    },
                    dir.display()
                ),
            )));
        }
    }
    Ok(())
}

/// Refuses an output directory that is, lies inside or holds one of the
/// directories a merge reads (`part_dirs`): the merge would clear what it
/// reads, and taking the parts would remove its own output. Checked before
/// anything is written.
pub fn check_parts(dir: &Path, part_dirs: &[PathBuf]) -> Result<(), Error> {
    let out = resolved(dir);
    for part in part_dirs {
        let p = resolved(part);
        let why = if out == p {
            "is the directory of a part it merges"
        } else if out.starts_with(&p) {
            "lies inside the directory of a part it merges"
        } else if p.starts_with(&out) {
            "holds the directory of a part it merges"
        } else {
            continue;
        };
        return Err(Error::Part(PathError::new(
            dir,
            format!(
                "the merge's output directory {why} ({}): a merge never writes where its \
                 parts are; choose an output directory outside every part",
                part.display()
            ),
        )));
    }
    Ok(())
}

/// Makes `dir` ready for a fresh run: created if missing; an empty
/// directory or one an earlier run wrote (it holds [`MARKER`]) has the
/// files a run writes removed; any other non-empty directory is refused
/// unless `overwrite`, which removes only the files a run writes and
/// leaves the rest. The marker is written last.
pub fn prepare_fresh(dir: &Path, overwrite: bool) -> Result<(), Error> {
    Ok(claim(dir, overwrite)?.clear(None)?)
}

/// An output directory a run may write into, with the files an earlier run
/// left there ([`claim`]), not yet removed.
#[derive(Debug)]
pub struct Claimed {
    dir: PathBuf,
    /// Files a run writes.
    files: Vec<PathBuf>,
    /// The run's own subdirectories with their entries.
    own: Vec<(&'static str, Vec<PathBuf>)>,
}

/// The first half of [`prepare_fresh`]: creates `dir` if missing and
/// refuses it as [`prepare_fresh`] does, but removes nothing yet, so that a
/// run can still fail (its survey's world, say) without losing the earlier
/// run's files.
pub fn claim(dir: &Path, overwrite: bool) -> Result<Claimed, Error> {
    if dir.exists() && !dir.is_dir() {
        return Err(refused(
            dir,
            "is not a directory: choose a directory for the output".into(),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::Directory(PathError::io(dir, "cannot create the output directory", e))
    })?;
    let Listing {
        claimed: ours,
        mut others,
    } = list(dir)?;
    let marked = dir.join(MARKER).exists();
    if !others.is_empty() && !marked && !overwrite {
        others.sort();
        let shown: Vec<&str> = others.iter().take(5).map(String::as_str).collect();
        let more = if others.len() > 5 {
            format!(" and {} more", others.len() - 5)
        } else {
            String::new()
        };
        return Err(refused(
            dir,
            format!(
                "the output directory is not empty and no lidarsim run wrote it (it holds {}{more}): \
                 choose a new or empty directory, or pass --overwrite (overwrite=True in Python) \
                 to replace only the files a run writes ({}) and keep the rest",
                shown.join(", "),
                RUN_FILES.join(", ")
            ),
        ));
    }
    for path in &ours.files {
        let meta = std::fs::symlink_metadata(path).at(path)?;
        if meta.is_dir() {
            return Err(refused(
                path,
                "is a directory where the run writes a file: move it away".into(),
            ));
        }
    }
    Ok(ours)
}

/// What a directory holds: the files and subdirectories a run writes, and
/// the names of everything else.
struct Listing {
    claimed: Claimed,
    others: Vec<String>,
}

/// Lists `dir` into what a run wrote there and what it did not.
fn list(dir: &Path) -> Result<Listing, WriteError> {
    let mut files = Vec::new();
    let mut others = Vec::new();
    let own = own_dirs(dir);
    for entry in std::fs::read_dir(dir).at(dir)? {
        let entry = entry.at(dir)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if is_run_file(&name) {
            if name != MARKER {
                files.push(entry.path());
            }
        } else if !own.iter().any(|(sub, _)| *sub == name) {
            others.push(name);
        }
    }
    Ok(Listing {
        claimed: Claimed {
            dir: dir.to_path_buf(),
            files,
            own,
        },
        others,
    })
}

/// Removes what a fresh run or merge wrote into `dir` before it failed —
/// every file a run writes, finished or `.partial`, and the run's own
/// subdirectories — but `keep` (a part's file moved in, the only copy of
/// its points), so that no output of a failed run looks complete. The run
/// cleared `dir` of such files when it began, so each of them is its own;
/// anything else in `dir` is left, and so is the marker.
pub fn roll_back(dir: &Path, keep: Option<&Path>) -> Result<(), WriteError> {
    list(dir)?.claimed.remove(keep)
}

/// The output directory of a fresh run or merge while it is written: if
/// the run fails (this is dropped before [`Rollback::done`]), what it
/// wrote is removed ([`roll_back`]), but `keep`.
#[derive(Debug)]
pub struct Rollback {
    dir: PathBuf,
    keep: Option<PathBuf>,
    armed: bool,
}

impl Rollback {
    /// Armed for `dir`, cleared by this run already; `keep` is left even
    /// when the run fails.
    pub fn new(dir: &Path, keep: Option<PathBuf>) -> Self {
        Self {
            dir: dir.to_path_buf(),
            keep,
            armed: true,
        }
    }

    /// The run is complete, or stopped with what it needs to go on: its
    /// files stay.
    pub fn done(mut self) {
        self.armed = false;
    }
}

impl Drop for Rollback {
    fn drop(&mut self) {
        if self.armed {
            // The run's own error is the one reported; a file that cannot
            // be removed keeps its `.partial` name or stands beside no
            // summary.
            let _ = roll_back(&self.dir, self.keep.as_deref());
        }
    }
}

impl Claimed {
    /// The second half of [`prepare_fresh`]: removes the earlier run's
    /// files (but `keep`, a file this run has begun meanwhile) and writes
    /// the marker.
    pub fn clear(self, keep: Option<&Path>) -> Result<(), WriteError> {
        let dir = self.dir.clone();
        self.remove(keep)?;
        crate::output::write_atomic(
            &dir.join(MARKER),
            b"lidarsim writes its runs into this directory; a new run replaces only its own files.\n",
        )
    }

    /// Removes the files and subdirectories listed, but `keep`.
    fn remove(self, keep: Option<&Path>) -> Result<(), WriteError> {
        for path in self.files {
            if keep == Some(path.as_path()) {
                continue;
            }
            // A symbolic link is removed itself, never what it points to.
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != io::ErrorKind::NotFound => {
                    return Err(WriteError::io(&path, e));
                }
                _ => {}
            }
        }
        // The scene data, strips and tiles an earlier run wrote, and their
        // directories.
        for (sub, entries) in self.own {
            for path in entries {
                let removed = if path.is_dir() {
                    std::fs::remove_dir_all(&path)
                } else {
                    std::fs::remove_file(&path)
                };
                removed.at(&path)?;
            }
            let path = self.dir.join(sub);
            std::fs::remove_dir(&path).at(&path)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::names::{DATA_DIR, MARKER};

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lidarsim-outdir-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn run_files_are_recognised_with_their_partial_names() {
        assert!(is_run_file("points.las"));
        assert!(is_run_file("points.las.partial"));
        assert!(is_run_file(MARKER));
        assert!(!is_run_file("points.las.bak"));
        assert!(!is_run_file("notes.txt"));
    }

    /// The scene files a run wrote are cleared with their directory; a
    /// `scene` directory holding anything else is someone else's.
    #[test]
    fn a_runs_scene_directory_is_cleared_and_a_foreign_one_kept() {
        assert!(is_data_file("mesh-0.obj") && is_data_file("point_cloud-12.xyz"));
        assert!(is_data_file("terrain-3.tif"));
        assert!(!is_data_file("mesh-.obj") && !is_data_file("mesh-0.tif"));
        assert!(!is_data_file("mesh-a.obj") && !is_data_file("notes.txt"));
        let d = temp("scene");
        std::fs::create_dir_all(d.join(DATA_DIR)).unwrap();
        std::fs::write(d.join(DATA_DIR).join("mesh-0.obj"), "v").unwrap();
        std::fs::write(d.join("points.las"), "old").unwrap();
        prepare_fresh(&d, false).unwrap();
        assert!(!d.join(DATA_DIR).exists() && !d.join("points.las").exists());
        std::fs::create_dir_all(d.join(DATA_DIR)).unwrap();
        std::fs::write(d.join(DATA_DIR).join("mesh-0.obj"), "v").unwrap();
        std::fs::write(d.join(DATA_DIR).join("mine.obj"), "v").unwrap();
        std::fs::remove_file(d.join(MARKER)).unwrap();
        let e = prepare_fresh(&d, false).unwrap_err();
        assert!(e.to_string().contains(DATA_DIR), "{e}");
        prepare_fresh(&d, true).unwrap();
        assert!(d.join(DATA_DIR).join("mine.obj").exists());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn a_foreign_directory_is_refused_unless_overwritten_and_keeps_its_files() {
        let d = temp("foreign");
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        std::fs::write(d.join("points.las"), "old").unwrap();
        let e = prepare_fresh(&d, false).unwrap_err();
        assert!(e.to_string().contains("notes.txt"), "{e}");
        assert!(e.to_string().contains("--overwrite"), "{e}");
        assert_eq!(std::fs::read(d.join("points.las")).unwrap(), b"old");
        prepare_fresh(&d, true).unwrap();
        assert!(!d.join("points.las").exists());
        assert_eq!(std::fs::read(d.join("notes.txt")).unwrap(), b"mine");
        assert!(d.join(MARKER).exists());
        // Now marked: a second run clears its own files without asking.
        std::fs::write(d.join("points.xyz"), "old").unwrap();
        prepare_fresh(&d, false).unwrap();
        assert!(!d.join("points.xyz").exists());
        std::fs::remove_dir_all(&d).ok();
    }

    #[cfg(unix)]
    #[test]
    fn a_planted_link_is_removed_not_followed() {
        let d = temp("link");
        let out = d.join("out");
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join(MARKER), "").unwrap();
        let victim = d.join("victim.txt");
        std::fs::write(&victim, "precious").unwrap();
        std::os::unix::fs::symlink(&victim, out.join("points.las.partial")).unwrap();
        prepare_fresh(&out, false).unwrap();
        assert!(!out.join("points.las.partial").exists());
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn an_input_among_the_run_files_is_refused() {
        let d = temp("inputs");
        let survey = d.join("survey.toml");
        std::fs::write(&survey, "# mine").unwrap();
        let e = check_inputs(&d, std::slice::from_ref(&survey)).unwrap_err();
        assert!(
            e.to_string().contains("write over or remove this input"),
            "{e}"
        );
        let other = d.join("my-survey.toml");
        std::fs::write(&other, "# mine").unwrap();
        check_inputs(&d, std::slice::from_ref(&other)).unwrap();
        // One the run would clear with its scene directory, named through
        // `..`: refused too.
        std::fs::create_dir_all(d.join(DATA_DIR)).unwrap();
        let mesh = d.join(DATA_DIR).join("mesh-0.obj");
        std::fs::write(&mesh, "v 0 0 0").unwrap();
        let roundabout = d
            .join(DATA_DIR)
            .join("..")
            .join(DATA_DIR)
            .join("mesh-0.obj");
        let e = check_inputs(&d, &[roundabout]).unwrap_err();
        assert!(e.to_string().contains("mesh-0.obj"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }

    /// The output of a merge may not be a part's directory, lie inside
    /// one or hold one, however the paths are written (a trailing `/.`,
    /// `..`, a link) and whether or not the output exists yet.
    #[test]
    fn a_merge_output_that_is_inside_or_holds_a_part_is_refused() {
        let d = temp("parts");
        let part = d.join("p1");
        std::fs::create_dir_all(&part).unwrap();
        let refused = |out: &Path| check_parts(out, std::slice::from_ref(&part)).unwrap_err();
        assert!(
            refused(&part.join("."))
                .to_string()
                .contains("is the directory")
        );
        let inside = part.join("merged").join("..").join("deeper");
        assert!(refused(&inside).to_string().contains("lies inside"));
        assert!(refused(&d).to_string().contains("holds"));
        #[cfg(unix)]
        {
            let link = d.join("link");
            std::os::unix::fs::symlink(&part, &link).unwrap();
            assert!(
                refused(&link.join("out"))
                    .to_string()
                    .contains("lies inside")
            );
        }
        check_parts(&d.join("p10"), std::slice::from_ref(&part)).unwrap();
        check_parts(&d.join("out"), std::slice::from_ref(&part)).unwrap();
        std::fs::remove_dir_all(&d).ok();
    }

    /// A failed run removes the run's files it wrote, finished or not,
    /// and leaves everything else — and the file it was told to keep.
    #[test]
    fn a_roll_back_removes_only_what_a_run_writes() {
        let d = temp("rollback");
        prepare_fresh(&d, false).unwrap();
        for f in [
            "survey.toml",
            "trajectory.csv",
            "points.las.partial",
            "notes.txt",
        ] {
            std::fs::write(d.join(f), f).unwrap();
        }
        std::fs::create_dir_all(d.join("strips")).unwrap();
        std::fs::write(d.join("strips").join("line-0001.las"), "l").unwrap();
        let kept = d.join("points.las.partial");
        drop(Rollback::new(&d, Some(kept.clone())));
        let mut left: Vec<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [MARKER, "notes.txt", "points.las.partial"]);
        // Done: nothing is removed.
        std::fs::write(d.join("summary.json"), "{}").unwrap();
        Rollback::new(&d, None).done();
        assert!(d.join("summary.json").exists());
        std::fs::remove_dir_all(&d).ok();
    }
}
