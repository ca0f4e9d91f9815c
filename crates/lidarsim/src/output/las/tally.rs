//! A finished LAS file read back: the counts and bounds its header holds,
//! once its layout is checked against the settings that would continue it
//! (a resumed run's file) or append it (a part's file in a merge).

use std::io::{self, Read};
use std::path::Path;

use super::{HEADER_SIZE, LasSettings};
use crate::output::file_error;

/// What the header of a finished file counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Tally {
    /// Point records.
    pub count: u64,
    /// Points by return number.
    pub by_return: [u64; 15],
    /// Smallest quantized coordinates (meaningless without points).
    pub min: [i32; 3],
    /// Largest quantized coordinates.
    pub max: [i32; 3],
    /// File creation day of year and year.
    pub creation_day_year: (u16, u16),
    /// Offset to the first point record, bytes.
    pub offset_to_points: u64,
}

/// Reads the public header of `file` (known to users as `named`), a LAS
/// 1.4 file this writer finished, and checks that `settings` write the same
/// records: point format, record length, VLRs, scale and offset. An error
/// names `named` and says what could not be `done` ("continue", "append").
pub(super) fn read(
    file: &Path,
    named: &Path,
    settings: &LasSettings,
    done: &str,
) -> io::Result<Tally> {
    let bad = |what: String| {
        file_error(
            named,
            io::Error::new(
                io::ErrorKind::InvalidData,
                format!("cannot {done} this file: {what}"),
            ),
        )
    };
    let mut h = [0u8; HEADER_SIZE as usize];
    std::fs::File::open(file)
        .and_then(|mut f| f.read_exact(&mut h))
        .map_err(|e| file_error(file, e))?;
    let u16_at = |o: usize| u16::from_le_bytes([h[o], h[o + 1]]);
    let u32_at = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let u64_at = |o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&h[o..o + 8]);
        u64::from_le_bytes(b)
    };
    let f64_at = |o: usize| f64::from_bits(u64_at(o));
    if settings.compressed {
        return Err(bad(
            "LAZ files cannot be continued; run the survey again".into()
        ));
    }
    let format = settings.point_format();
    if &h[0..4] != b"LASF" || h[24..26] != [1, 4] || h[104] != format {
        return Err(bad(format!("not a LAS 1.4 file of point format {format}")));
    }
    let offset_to_points = u64::from(HEADER_SIZE) + settings.vlrs()?.len() as u64;
    if u16_at(105) != settings.record_len()
        || u64::from(u32_at(96)) != offset_to_points
        || (0..3).any(|a| {
            f64_at(131 + 8 * a) != settings.scale_m || f64_at(155 + 8 * a) != settings.offset_m[a]
        })
    {
        return Err(bad(
            "its record layout, scale or offset differ from the survey's".into(),
        ));
    }
    let mut t = Tally {
        count: u64_at(247),
        by_return: [0; 15],
        min: [i32::MAX; 3],
        max: [i32::MIN; 3],
        creation_day_year: (u16_at(90), u16_at(92)),
        offset_to_points,
    };
    for (i, n) in t.by_return.iter_mut().enumerate() {
        *n = u64_at(255 + 8 * i);
    }
    if t.count > 0 {
        for a in 0..3 {
            // Header bounds are integers × scale + offset: exact inverse.
            let (max, min) = (f64_at(179 + 16 * a), f64_at(187 + 16 * a));
            t.max[a] = settings.quantize(max, a).map_err(|e| bad(e.to_string()))?;
            t.min[a] = settings.quantize(min, a).map_err(|e| bad(e.to_string()))?;
        }
    }
    Ok(t)
}

impl Tally {
    /// Bytes the file holds: the header, the VLRs and the records.
    pub fn file_len(&self, settings: &LasSettings) -> Option<u64> {
        self.count
            .checked_mul(u64::from(settings.record_len()))
            .and_then(|b| b.checked_add(self.offset_to_points))
    }
}
