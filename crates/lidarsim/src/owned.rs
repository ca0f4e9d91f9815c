//! A directory a command writes a few files of its own into (`lidarsim
//! twin`, `lidarsim compare`): new, empty, or one the command wrote before
//! (it holds the command's marker file); any other is refused unless the
//! caller overwrites, which replaces only the command's own files and
//! keeps everything else. A run's directory has its own, richer rules
//! (`run::outdir`).

use std::path::Path;

use crate::output::{AtFile, WriteCause, WriteError};

/// Files a command writes into a directory, and the marker that says it
/// wrote there.
#[derive(Clone, Copy, Debug)]
pub struct OwnFiles {
    /// The command, for messages (`"twin"`).
    pub command: &'static str,
    /// The files it writes, by final name.
    pub files: &'static [&'static str],
    /// The marker file's name.
    pub marker: &'static str,
}

impl OwnFiles {
    /// Whether `name` is one of the files, also under its `.partial` name,
    /// or the marker.
    pub fn owns(&self, name: &str) -> bool {
        let base = name.strip_suffix(".partial").unwrap_or(name);
        name == self.marker || self.files.contains(&base)
    }

    /// Makes `dir` ready: created if missing; refused if it holds anything
    /// but these files unless it holds the marker or `overwrite`; the files
    /// of an earlier write removed (a symbolic link itself, never what it
    /// points to). Errors are the directory's or the file's, with a message
    /// that says what to do.
    pub fn claim(&self, dir: &Path, overwrite: bool) -> Result<(), WriteError> {
        let refused = |why: String| WriteError::new(dir, WriteCause::Refused(why));
        if dir.exists() && !dir.is_dir() {
            return Err(refused(
                "is not a directory: choose a directory for the output".into(),
            ));
        }
        std::fs::create_dir_all(dir).at(dir)?;
        let (mut own, mut foreign) = (Vec::new(), Vec::new());
        for entry in std::fs::read_dir(dir).at(dir)? {
            let entry = entry.at(dir)?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if self.owns(&name) {
                own.push(entry.path());
            } else {
                foreign.push(name);
            }
        }
        if !foreign.is_empty() && !dir.join(self.marker).exists() && !overwrite {
            foreign.sort();
            let shown = foreign
                .iter()
                .take(5)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ");
            return Err(refused(format!(
                "the directory is not empty and no {} wrote it (it holds {shown}{}): choose a \
                 new or empty directory, or pass --overwrite to replace only its own files ({}) \
                 and keep the rest",
                self.command,
                if foreign.len() > 5 { " and more" } else { "" },
                self.files.join(", ")
            )));
        }
        for path in own {
            if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir()) {
                return Err(WriteError::new(
                    &path,
                    WriteCause::Refused(
                        "is a directory where a file is written: move it away".into(),
                    ),
                ));
            }
            std::fs::remove_file(&path).at(&path)?;
        }
        Ok(())
    }

    /// Writes the marker (last, once the files are whole).
    pub fn mark(&self, dir: &Path) -> Result<(), WriteError> {
        let path = dir.join(self.marker);
        crate::output::write_atomic(
            &path,
            format!(
                "lidarsim {} wrote this directory; it replaces only its own files here.\n",
                self.command
            )
            .as_bytes(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OWN: OwnFiles = OwnFiles {
        command: "test",
        files: &["a.json"],
        marker: ".lidarsim-test",
    };

    #[test]
    fn a_foreign_directory_is_refused_unless_overwritten_and_keeps_its_files() {
        let d = std::env::temp_dir().join(format!("lidarsim-owned-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        std::fs::write(d.join("a.json"), "old").unwrap();
        let e = OWN.claim(&d, false).unwrap_err();
        assert!(e.to_string().contains("notes.txt") && e.to_string().contains("--overwrite"));
        assert_eq!(std::fs::read(d.join("a.json")).unwrap(), b"old");
        OWN.claim(&d, true).unwrap();
        assert!(!d.join("a.json").exists());
        assert_eq!(std::fs::read(d.join("notes.txt")).unwrap(), b"mine");
        OWN.mark(&d).unwrap();
        // Marked: claimed again without asking, the foreign file kept.
        std::fs::write(d.join("a.json"), "new").unwrap();
        OWN.claim(&d, false).unwrap();
        assert!(!d.join("a.json").exists() && d.join("notes.txt").exists());
        std::fs::remove_dir_all(&d).ok();
    }
}
