//! Checksums of whole files: what a part run records of the files it
//! wrote, so that a merge joins those bytes and no others (a part's file
//! swapped with another's, or written over in place, keeps its length but
//! not its checksum). CRC-32 (IEEE 802.3, as zlib computes it) catches
//! every burst of up to 32 changed bits and all but 2⁻³² of other changes;
//! it guards against accidents, not against forgery.

use std::io::{self, Read};
use std::path::Path;

/// The CRC-32 of the file at `path`, as eight lowercase hexadecimal
/// digits.
pub fn file_crc32(path: &Path) -> io::Result<String> {
    let mut file = std::fs::File::open(path)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match file.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => hasher.update(&buf[..n]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(format!("{:08x}", hasher.finalize()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The check value of CRC-32/ISO-HDLC: "123456789" → cbf43926
    /// (Williams, "A painless guide to CRC error detection algorithms").
    #[test]
    fn the_standard_check_value() {
        let path = std::env::temp_dir().join(format!("lidarsim-crc-{}", std::process::id()));
        std::fs::write(&path, b"123456789").unwrap();
        assert_eq!(file_crc32(&path).unwrap(), "cbf43926");
        std::fs::remove_file(&path).ok();
    }
}
