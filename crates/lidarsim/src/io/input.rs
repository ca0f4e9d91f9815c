//! Opening the files a survey reads: regular files only, each within a
//! size bound, and a "did you mean" for a name that is one typo away from
//! a file that exists.
//!
//! A device such as `/dev/zero`, a FIFO or a directory named as a mesh,
//! raster, cloud, trajectory or survey would otherwise be read without end.

use std::io;

use crate::message::edit_distance;
use std::path::{Path, PathBuf};

/// Largest survey file read, bytes (its arrays are bounded too, before
/// it is parsed: `survey::size`).
pub const MAX_SURVEY_BYTES: u64 = 16 << 20;

/// Largest mesh, raster, point cloud or glTF buffer read, bytes.
pub const MAX_INPUT_BYTES: u64 = 16 << 30;

/// Largest trajectory file read, bytes.
pub const MAX_TRAJECTORY_BYTES: u64 = 4 << 30;

/// Checks that `path` names a regular file of at most `max_bytes`
/// (following links) and returns its length. The error says what is wrong
/// in words, without the path (the caller names the file), with a "did you
/// mean" when the file does not exist but a similar name does.
pub fn check_input(path: &Path, max_bytes: u64) -> io::Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| {
        match similar_name(path).filter(|_| e.kind() == io::ErrorKind::NotFound) {
            Some(near) => io::Error::new(
                e.kind(),
                format!("{e} (did you mean '{}'?)", near.display()),
            ),
            None => e,
        }
    })?;
    if !meta.is_file() {
        let what = if meta.is_dir() {
            "is a directory"
        } else {
            "is not a regular file (a device, pipe or socket)"
        };
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{what}: give the path of a file"),
        ));
    }
    if meta.len() > max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "is {} bytes, more than the {max_bytes} bytes accepted for such a file",
                meta.len()
            ),
        ));
    }
    Ok(meta.len())
}

/// Reads a whole input file after [`check_input`]; reads at most
/// `max_bytes` even if the file grows meanwhile.
pub fn read_input(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    use std::io::Read;
    let len = check_input(path, max_bytes)?;
    let file = std::fs::File::open(path)?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// A text input read whole after [`check_input`]: UTF-8, without the
/// byte-order mark an editor may put first (U+FEFF, which would otherwise
/// stick to the first word: a CSV's first column name, a survey's first
/// key). An error names the line of the first byte that is not UTF-8.
pub fn read_text(path: &Path, max_bytes: u64) -> io::Result<String> {
    let bytes = read_input(path, max_bytes)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "line {line}: not valid UTF-8 (byte {}): save the file as UTF-8 text",
                at + 1
            ),
        )
    })?;
    Ok(match text.strip_prefix(BOM) {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// The byte-order mark (U+FEFF) some editors put at the start of UTF-8
/// text.
pub const BOM: char = '\u{feff}';

/// `line` without a leading byte-order mark (for readers that take a
/// file's lines one at a time: its first line).
pub fn strip_bom(line: &str) -> &str {
    line.strip_prefix(BOM).unwrap_or(line)
}

/// A file beside `path` whose name is within two edits of its name (the
/// closest), if any.
fn similar_name(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?.to_str()?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::read_dir(&dir)
        .ok()?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .map(|n| (edit_distance(name, &n), n))
        .filter(|(d, _)| *d <= 2)
        .min()
        .map(|(_, n)| path.with_file_name(n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_directories_and_typos_are_named() {
        let dir = std::env::temp_dir().join(format!("lidarsim-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("house.obj"), "v 0 0 0\n").unwrap();
        let e = check_input(&dir.join("hosue.obj"), 100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("did you mean") && e.contains("house.obj"), "{e}");
        let e = check_input(&dir, 100).unwrap_err().to_string();
        assert!(e.contains("a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = check_input(Path::new("/dev/zero"), 100)
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
        let e = check_input(&dir.join("house.obj"), 3)
            .unwrap_err()
            .to_string();
        assert!(e.contains("more than the 3 bytes"), "{e}");
        assert_eq!(
            read_input(&dir.join("house.obj"), 100).unwrap(),
            b"v 0 0 0\n"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
