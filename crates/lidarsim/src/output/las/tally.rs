//! A finished LAS file read back: the counts and bounds its header holds,
//! once its layout is checked against the settings that would continue it
//! (a resumed run's file) or append it (a part's file in a merge).

use std::io::Read;
use std::path::Path;

use super::{HEADER_SIZE, LasSettings, RawHeader};
use crate::output::{AtFile, WriteError};

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
    done: &'static str,
) -> Result<Tally, WriteError> {
    let bad = |reason: String| WriteError::mismatch(named, done, reason);
    let mut bytes = [0u8; HEADER_SIZE as usize];
    std::fs::File::open(file)
        .and_then(|mut f| f.read_exact(&mut bytes))
        .at(file)?;
    if settings.compressed {
        return Err(bad(
            "LAZ files cannot be continued; run the survey again".into()
        ));
    }
    let format = settings.point_format();
    let h = RawHeader::parse(&bytes)
        .ok()
        .filter(|h| h.version == (1, 4) && h.point_format == format)
        .ok_or_else(|| bad(format!("not a LAS 1.4 file of point format {format}")))?;
    let vlrs = settings.vlrs().map_err(|e| bad(e.to_string()))?;
    let offset_to_points = u64::from(HEADER_SIZE) + vlrs.len() as u64;
    if h.record_len != settings.record_len()
        || u64::from(h.offset_to_points) != offset_to_points
        || h.scale != [settings.scale_m; 3]
        || h.offset != settings.offset_m
    {
        return Err(bad(
            "its record layout, scale or offset differ from the survey's".into(),
        ));
    }
    let mut t = Tally {
        count: h.point_count,
        by_return: h.by_return,
        min: [i32::MAX; 3],
        max: [i32::MIN; 3],
        creation_day_year: h.creation_day_year,
        offset_to_points,
    };
    if t.count > 0 {
        for a in 0..3 {
            // Header bounds are integers × scale + offset: exact inverse.
            let quantize = |v| settings.quantize(v, a).map_err(|e| bad(e.to_string()));
            t.max[a] = quantize(h.max[a])?;
            t.min[a] = quantize(h.min[a])?;
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
