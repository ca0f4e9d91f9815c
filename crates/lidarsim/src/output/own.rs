//! Single files a command writes at a path the user names (`render -o`,
//! `waveform -o`, `demo --export-survey`, the bench's scenes): written
//! where nothing is, or over a file this program wrote there before — one
//! that carries lidarsim's mark — and never over anything else: not the
//! cloud being rendered, not a picture or a survey of the user's.

use std::io::{self, Read};
use std::path::Path;

use super::{AtFile, WriteCause, WriteError};

/// How a file shows that lidarsim wrote it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// A PNG picture with the text chunk `Software` = `lidarsim`
    /// ([`PNG_SOFTWARE`]).
    Png,
    /// A text file whose first line begins with this.
    FirstLine(&'static str),
}

/// The `Software` text of the PNG pictures lidarsim writes.
pub const PNG_SOFTWARE: &str = "lidarsim";

/// The bytes of a PNG `tEXt` chunk's key and text naming lidarsim.
const PNG_MARK: &[u8] = b"tEXtSoftware\0lidarsim";

/// How much of a file is read to find its mark.
const MARK_BYTES: u64 = 4096;

/// Refuses `path` as the place of a file of `mark` when something is
/// there that lidarsim did not write (without that mark, or not a regular
/// file); a missing file, or one with the mark, may be written. The error
/// does not name the path: the caller does.
pub fn check_replaceable(path: &Path, mark: Mark) -> Result<(), WriteError> {
    let meta = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(WriteError::io(path, e)),
        Ok(m) => m,
    };
    let refused = |what: &str| {
        Err(WriteError::new(
            path,
            WriteCause::Refused(format!(
                "a file is there and {what}: lidarsim writes only where nothing is or over a \
                 file it wrote itself; choose another name, or move that file away"
            )),
        ))
    };
    if !meta.is_file() {
        return refused("is not a regular file");
    }
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MARK_BYTES).read_to_end(&mut head))
        .at(path)?;
    let ours = match mark {
        Mark::Png => {
            head.starts_with(b"\x89PNG\r\n\x1a\n")
                && head.windows(PNG_MARK.len()).any(|w| w == PNG_MARK)
        }
        Mark::FirstLine(prefix) => head.starts_with(prefix.as_bytes()),
    };
    if ours {
        Ok(())
    } else {
        refused("was not written by lidarsim")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_what_lidarsim_wrote_is_replaced() {
        let d = std::env::temp_dir().join(format!("lidarsim-own-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("a.png");
        check_replaceable(&p, Mark::Png).unwrap();
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nsomeone else's picture").unwrap();
        let e = check_replaceable(&p, Mark::Png).unwrap_err();
        assert!(e.to_string().contains("not written by lidarsim"), "{e}");
        let mut ours = b"\x89PNG\r\n\x1a\n....".to_vec();
        ours.extend_from_slice(PNG_MARK);
        std::fs::write(&p, &ours).unwrap();
        check_replaceable(&p, Mark::Png).unwrap();
        let t = d.join("s.toml");
        std::fs::write(&t, "seed = 1\n").unwrap();
        assert!(check_replaceable(&t, Mark::FirstLine("# lidarsim")).is_err());
        std::fs::write(&t, "# lidarsim: the demo\nseed = 1\n").unwrap();
        check_replaceable(&t, Mark::FirstLine("# lidarsim")).unwrap();
        assert!(check_replaceable(&d, Mark::Png).is_err());
        std::fs::remove_dir_all(&d).ok();
    }
}
