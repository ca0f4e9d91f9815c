//! The public header block of a LAS file, field by field as LAS 1.4 R15
//! Table 3 lays it out — the one description both the writer and every
//! reader of a header use, so that no other code knows an offset. Files of
//! LAS 1.0 to 1.3 have shorter headers (227 and 235 bytes); the fields
//! they lack read as zero.

use std::fmt;

/// Bytes of a LAS 1.4 public header block.
pub const HEADER_SIZE_14: u16 = 375;

/// Bytes of the header block of LAS 1.0–1.2 (fields up to the bounds).
const HEADER_SIZE_10: usize = 227;

/// The public header block (LAS 1.4 R15, Table 3).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawHeader {
    /// File source ID (the flight line of a strip, 0 for a mix).
    pub file_source_id: u16,
    /// Global encoding bits: 0 GPS time type, 2 waveform packets in an
    /// external file, 4 WKT.
    pub global_encoding: u16,
    /// Project ID (GUID), as stored.
    pub project_id: [u8; 16],
    /// Version major, minor.
    pub version: (u8, u8),
    /// System identifier, NUL-padded.
    pub system_identifier: [u8; 32],
    /// Generating software, NUL-padded.
    pub generating_software: [u8; 32],
    /// File creation day of year, year.
    pub creation_day_year: (u16, u16),
    /// Bytes of this header block.
    pub header_size: u16,
    /// Offset from the file's start to the first point record.
    pub offset_to_points: u32,
    /// Variable length records following the header.
    pub number_of_vlrs: u32,
    /// Point data record format, bit 7 (and 6) set for LASzip.
    pub point_format: u8,
    /// Bytes of a point record.
    pub record_len: u16,
    /// Legacy (32-bit) number of point records; 0 for formats 6–10.
    pub legacy_point_count: u32,
    /// Legacy number of points by return (1–5).
    pub legacy_by_return: [u32; 5],
    /// Scale factors x, y, z.
    pub scale: [f64; 3],
    /// Offsets x, y, z.
    pub offset: [f64; 3],
    /// Largest x, y, z.
    pub max: [f64; 3],
    /// Smallest x, y, z.
    pub min: [f64; 3],
    /// Start of the waveform data packet record (1.3+), 0 when external.
    pub start_of_waveform_data: u64,
    /// Start of the first extended VLR (1.4).
    pub start_of_first_evlr: u64,
    /// Extended VLRs (1.4).
    pub number_of_evlrs: u32,
    /// Number of point records (1.4).
    pub point_count: u64,
    /// Number of points by return 1–15 (1.4).
    pub by_return: [u64; 15],
}

/// Why bytes are not a LAS header this reader takes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HeaderError {
    /// The file is shorter than a header.
    Short(usize),
    /// No `LASF` signature.
    Signature,
    /// A version other than 1.0–1.4.
    Version(u8, u8),
    /// A header size smaller than its version's.
    Size {
        /// The version.
        version: (u8, u8),
        /// Bytes it declares.
        declared: u16,
        /// Bytes its version has.
        needed: usize,
    },
}

impl fmt::Display for HeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HeaderError::Short(n) => write!(
                f,
                "the file ends early: it is truncated or not a LAS file (it holds {n} bytes, \
                 fewer than a LAS header)"
            ),
            HeaderError::Signature => {
                f.write_str("the file signature is not 'LASF': it is not a LAS or LAZ file")
            }
            HeaderError::Version(major, minor) => write!(
                f,
                "its header says LAS {major}.{minor}; LAS 1.0 to 1.4 are read"
            ),
            HeaderError::Size {
                version: (major, minor),
                declared,
                needed,
            } => write!(
                f,
                "its header declares {declared} bytes, but a LAS {major}.{minor} header holds \
                 {needed}"
            ),
        }
    }
}

impl std::error::Error for HeaderError {}

/// Bytes of the header of LAS `1.minor`.
fn size_of_version(minor: u8) -> usize {
    match minor {
        0..=2 => HEADER_SIZE_10,
        3 => 235,
        _ => HEADER_SIZE_14 as usize,
    }
}

/// Little-endian fields read in order.
struct Fields<'a> {
    b: &'a [u8],
    at: usize,
}

impl Fields<'_> {
    /// The next `N` bytes, zero past the end of the header read.
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        if let Some(src) = self.b.get(self.at..self.at + N) {
            out.copy_from_slice(src);
        }
        self.at += N;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
}

impl RawHeader {
    /// Reads the header at the start of `bytes` (at least as many as its
    /// version's header holds).
    pub fn parse(bytes: &[u8]) -> Result<Self, HeaderError> {
        if bytes.len() >= 4 && &bytes[0..4] != b"LASF" {
            return Err(HeaderError::Signature);
        }
        if bytes.len() < HEADER_SIZE_10 {
            return Err(HeaderError::Short(bytes.len()));
        }
        let version = (bytes[24], bytes[25]);
        if version.0 != 1 || version.1 > 4 {
            return Err(HeaderError::Version(version.0, version.1));
        }
        let needed = size_of_version(version.1);
        if bytes.len() < needed {
            return Err(HeaderError::Short(bytes.len()));
        }
        let mut f = Fields {
            b: &bytes[..needed],
            at: 4,
        };
        let mut h = RawHeader {
            file_source_id: f.u16(),
            global_encoding: f.u16(),
            project_id: f.take(),
            version: (f.u8(), f.u8()),
            system_identifier: f.take(),
            generating_software: f.take(),
            creation_day_year: (f.u16(), f.u16()),
            header_size: f.u16(),
            offset_to_points: f.u32(),
            number_of_vlrs: f.u32(),
            point_format: f.u8(),
            record_len: f.u16(),
            legacy_point_count: f.u32(),
            ..RawHeader::default()
        };
        h.legacy_by_return = [(); 5].map(|()| f.u32());
        h.scale = [(); 3].map(|()| f.f64());
        h.offset = [(); 3].map(|()| f.f64());
        for a in 0..3 {
            h.max[a] = f.f64();
            h.min[a] = f.f64();
        }
        h.start_of_waveform_data = f.u64();
        h.start_of_first_evlr = f.u64();
        h.number_of_evlrs = f.u32();
        h.point_count = f.u64();
        h.by_return = [(); 15].map(|()| f.u64());
        if usize::from(h.header_size) < needed {
            return Err(HeaderError::Size {
                version,
                declared: h.header_size,
                needed,
            });
        }
        Ok(h)
    }

    /// The number of point records: the 64-bit count of LAS 1.4, else the
    /// legacy one.
    pub fn points(&self) -> u64 {
        if self.version.1 >= 4 && self.point_count > 0 {
            self.point_count
        } else {
            u64::from(self.legacy_point_count)
        }
    }

    /// Whether the points are LASzip-compressed (bit 7 of the format).
    pub fn compressed(&self) -> bool {
        self.point_format & 0x80 != 0
    }

    /// The 375 bytes of this header as LAS 1.4 lays them out.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut h = Vec::with_capacity(usize::from(HEADER_SIZE_14));
        h.extend_from_slice(b"LASF");
        h.extend_from_slice(&self.file_source_id.to_le_bytes());
        h.extend_from_slice(&self.global_encoding.to_le_bytes());
        h.extend_from_slice(&self.project_id);
        h.extend_from_slice(&[self.version.0, self.version.1]);
        h.extend_from_slice(&self.system_identifier);
        h.extend_from_slice(&self.generating_software);
        h.extend_from_slice(&self.creation_day_year.0.to_le_bytes());
        h.extend_from_slice(&self.creation_day_year.1.to_le_bytes());
        h.extend_from_slice(&self.header_size.to_le_bytes());
        h.extend_from_slice(&self.offset_to_points.to_le_bytes());
        h.extend_from_slice(&self.number_of_vlrs.to_le_bytes());
        h.push(self.point_format);
        h.extend_from_slice(&self.record_len.to_le_bytes());
        h.extend_from_slice(&self.legacy_point_count.to_le_bytes());
        for n in self.legacy_by_return {
            h.extend_from_slice(&n.to_le_bytes());
        }
        for v in self.scale.iter().chain(&self.offset) {
            h.extend_from_slice(&v.to_le_bytes());
        }
        for a in 0..3 {
            h.extend_from_slice(&self.max[a].to_le_bytes());
            h.extend_from_slice(&self.min[a].to_le_bytes());
        }
        h.extend_from_slice(&self.start_of_waveform_data.to_le_bytes());
        h.extend_from_slice(&self.start_of_first_evlr.to_le_bytes());
        h.extend_from_slice(&self.number_of_evlrs.to_le_bytes());
        h.extend_from_slice(&self.point_count.to_le_bytes());
        for n in self.by_return {
            h.extend_from_slice(&n.to_le_bytes());
        }
        debug_assert_eq!(h.len(), usize::from(HEADER_SIZE_14));
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Offsets of LAS 1.4 R15 Table 3, written down independently of the
    /// code above: each field written by `to_bytes` is where the table
    /// puts it.
    #[test]
    fn fields_sit_at_the_offsets_of_table_3() {
        let h = RawHeader {
            version: (1, 4),
            header_size: 375,
            offset_to_points: 0x0102_0304,
            point_format: 6,
            record_len: 30,
            scale: [0.01, 0.02, 0.03],
            min: [1.0, 2.0, 3.0],
            max: [4.0, 5.0, 6.0],
            start_of_first_evlr: 77,
            point_count: 123_456_789_012,
            by_return: [9; 15],
            ..RawHeader::default()
        };
        let b = h.to_bytes();
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        assert_eq!(&b[0..4], b"LASF");
        assert_eq!((b[24], b[25]), (1, 4));
        assert_eq!(u16::from_le_bytes([b[94], b[95]]), 375);
        assert_eq!(
            u32::from_le_bytes(b[96..100].try_into().unwrap()),
            0x0102_0304
        );
        assert_eq!((b[104], u16::from_le_bytes([b[105], b[106]])), (6, 30));
        assert_eq!(f64_at(139), 0.02);
        assert_eq!((f64_at(179), f64_at(187)), (4.0, 1.0)); // max x, min x
        assert_eq!((f64_at(211), f64_at(219)), (6.0, 3.0)); // max z, min z
        assert_eq!(u64_at(235), 77);
        assert_eq!(u64_at(247), 123_456_789_012);
        assert_eq!(u64_at(255 + 8 * 14), 9);
        assert_eq!(RawHeader::parse(&b).unwrap(), h);
    }

    #[test]
    fn a_short_header_of_an_old_version_reads_and_foreign_versions_are_named() {
        let mut b = RawHeader {
            version: (1, 2),
            header_size: 227,
            legacy_point_count: 42,
            ..RawHeader::default()
        }
        .to_bytes();
        b.truncate(227);
        let h = RawHeader::parse(&b).unwrap();
        assert_eq!((h.points(), h.start_of_first_evlr), (42, 0));
        b[24..26].copy_from_slice(&[9, 9]);
        let e = RawHeader::parse(&b).unwrap_err();
        assert_eq!(e, HeaderError::Version(9, 9));
        assert!(e.to_string().contains("LAS 9.9"), "{e}");
        assert_eq!(RawHeader::parse(&b[..100]), Err(HeaderError::Short(100)));
    }
}
