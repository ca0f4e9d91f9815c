//! LAS 1.4 writer, point data record format 6.
//!
//! Byte layout from the ASPRS LAS Specification 1.4 R15 (9 July 2019):
//! public header block (Table 3, 375 bytes), point data record format 6
//! (Table 8, 30 bytes). All values little-endian.

use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

use super::{AtomicFile, PointRecord, PointSink, file_error};

/// Size of a point data record of format 6, bytes.
pub const POINT_FORMAT_6_LEN: u16 = 30;
const HEADER_SIZE: u16 = 375;

/// Fixed parts of the header chosen before the first point.
#[derive(Clone, Debug, PartialEq)]
pub struct LasSettings {
    /// Coordinate resolution, m (same on all axes).
    pub scale_m: f64,
    /// Offset subtracted before scaling, m.
    pub offset_m: [f64; 3],
    /// True when GPS time is Adjusted Standard GPS Time (global encoding
    /// bit 0); false when it is seconds of a GPS week, which is what
    /// readers assume for our seconds-since-flight-start.
    pub adjusted_standard_gps_time: bool,
    /// File source ID (0 when the file holds several flight lines).
    pub file_source_id: u16,
    /// File creation day of year and year.
    pub creation_day_year: (u16, u16),
    /// Generating software, up to 32 bytes.
    pub generating_software: String,
    /// Append the georeferencing error vector (`error_x`, `error_y`,
    /// `error_z`, 32-bit floats, m) to every point as LAS 1.4 extra bytes,
    /// described by an Extra Bytes VLR.
    pub error_extra_bytes: bool,
}

/// Names and descriptions of the error extra bytes.
const ERROR_FIELDS: [(&str, &str); 3] = [
    ("error_x", "computed minus true x (m)"),
    ("error_y", "computed minus true y (m)"),
    ("error_z", "computed minus true z (m)"),
];

/// Size of a VLR header, bytes (LAS 1.4 R15, Table 13).
const VLR_HEADER_LEN: usize = 54;
/// Size of one Extra Bytes descriptor, bytes (LAS 1.4 R15, Table 24).
const EXTRA_BYTES_DESCRIPTOR_LEN: usize = 192;

/// Streams points into a LAS 1.4 file; the header (counts, bounds) is
/// written again when the file is finished.
#[derive(Debug)]
pub struct LasWriter {
    file: AtomicFile,
    settings: LasSettings,
    count: u64,
    by_return: [u64; 15],
    min: [i32; 3],
    max: [i32; 3],
    buf: Vec<u8>,
}

impl LasWriter {
    /// Creates `path` (as `path.partial` until finished).
    pub fn create(path: &Path, settings: LasSettings) -> io::Result<Self> {
        let mut w = Self {
            file: AtomicFile::create(path)?,
            settings,
            count: 0,
            by_return: [0; 15],
            min: [i32::MAX; 3],
            max: [i32::MIN; 3],
            buf: Vec::with_capacity(1 << 16),
        };
        let header = w.header();
        let vlrs = w.vlrs();
        let named = |e| file_error(path, e);
        w.file.writer().write_all(&header).map_err(named)?;
        w.file.writer().write_all(&vlrs).map_err(named)?;
        Ok(w)
    }

    /// Continues `path`, a file this writer finished when a run was
    /// interrupted: the point counts, counts by return, bounds and creation
    /// date are taken from its header, which must match `settings`
    /// (scale, offset, record layout), and points are appended after the
    /// `len` bytes the file had then.
    pub fn resume(path: &Path, mut settings: LasSettings, len: u64) -> io::Result<Self> {
        let bad = |what: String| {
            file_error(
                path,
                io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!("cannot continue this file: {what}"),
                ),
            )
        };
        let mut h = [0u8; HEADER_SIZE as usize];
        // The file as the interrupted run finished it, or as a failed
        // resume left it.
        let partial = AtomicFile::partial_of(path);
        let current = if path.exists() || !partial.exists() {
            path
        } else {
            &partial
        };
        std::fs::File::open(current)
            .and_then(|mut f| io::Read::read_exact(&mut f, &mut h))
            .map_err(|e| file_error(path, e))?;
        let u16_at = |o: usize| u16::from_le_bytes([h[o], h[o + 1]]);
        let u32_at = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
        let u64_at = |o: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&h[o..o + 8]);
            u64::from_le_bytes(b)
        };
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        if &h[0..4] != b"LASF" || h[24..26] != [1, 4] || h[104] != 6 {
            return Err(bad("not a LAS 1.4 file of point format 6".into()));
        }
        settings.creation_day_year = (u16_at(90), u16_at(92));
        let mut w = Self {
            file: AtomicFile::unopened(path),
            settings,
            count: u64_at(247),
            by_return: [0; 15],
            min: [i32::MAX; 3],
            max: [i32::MIN; 3],
            buf: Vec::with_capacity(1 << 16),
        };
        for (i, n) in w.by_return.iter_mut().enumerate() {
            *n = u64_at(255 + 8 * i);
        }
        let s = &w.settings;
        let offset_to_points = u64::from(HEADER_SIZE) + w.vlrs().len() as u64;
        if u16_at(105) != w.record_len()
            || u64::from(u32_at(96)) != offset_to_points
            || (0..3)
                .any(|a| f64_at(131 + 8 * a) != s.scale_m || f64_at(155 + 8 * a) != s.offset_m[a])
        {
            return Err(bad(
                "its record layout, scale or offset differ from the survey's".into(),
            ));
        }
        let expected = w
            .count
            .checked_mul(u64::from(w.record_len()))
            .and_then(|b| b.checked_add(offset_to_points));
        if expected != Some(len) {
            return Err(bad(format!(
                "its header counts {} points but {len} bytes were recorded",
                w.count
            )));
        }
        if w.count > 0 {
            for a in 0..3 {
                // Header bounds are integers × scale + offset: exact inverse.
                let (max, min) = (f64_at(179 + 16 * a), f64_at(187 + 16 * a));
                w.max[a] = w.quantize(max, a).map_err(|e| bad(e.to_string()))?;
                w.min[a] = w.quantize(min, a).map_err(|e| bad(e.to_string()))?;
            }
        }
        // Only now, with everything checked, is the file touched.
        w.file = AtomicFile::reopen(path, len)?;
        Ok(w)
    }

    fn quantize(&self, v: f64, axis: usize) -> io::Result<i32> {
        let q = ((v - self.settings.offset_m[axis]) / self.settings.scale_m).round();
        if q.is_finite() && q >= i32::MIN as f64 && q <= i32::MAX as f64 {
            Ok(q as i32)
        } else {
            Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "coordinate {v} m cannot be stored with offset {} m and scale {} m",
                    self.settings.offset_m[axis], self.settings.scale_m
                ),
            ))
        }
    }

    /// Bytes of one point record.
    fn record_len(&self) -> u16 {
        POINT_FORMAT_6_LEN
            + if self.settings.error_extra_bytes {
                12
            } else {
                0
            }
    }

    /// The VLRs between the header and the points.
    fn vlrs(&self) -> Vec<u8> {
        let mut v = Vec::new();
        if self.settings.error_extra_bytes {
            // VLR header (Table 13): reserved, user ID, record ID, length
            // after header, description.
            v.extend_from_slice(&0u16.to_le_bytes());
            v.extend_from_slice(&fixed_str::<16>("LASF_Spec"));
            v.extend_from_slice(&4u16.to_le_bytes());
            let len = (ERROR_FIELDS.len() * EXTRA_BYTES_DESCRIPTOR_LEN) as u16;
            v.extend_from_slice(&len.to_le_bytes());
            v.extend_from_slice(&fixed_str::<32>("georeferencing errors"));
            for (name, description) in ERROR_FIELDS {
                // Extra Bytes descriptor (Table 24): reserved, data type 9
                // (float), options 0 (no no-data/min/max/scale/offset), name,
                // unused, no_data, min, max, scale, offset, description.
                v.extend_from_slice(&[0, 0, 9, 0]);
                v.extend_from_slice(&fixed_str::<32>(name));
                v.extend_from_slice(&[0u8; 4]);
                v.extend_from_slice(&[0u8; 24 * 5]);
                v.extend_from_slice(&fixed_str::<32>(description));
            }
            debug_assert_eq!(
                v.len(),
                VLR_HEADER_LEN + ERROR_FIELDS.len() * EXTRA_BYTES_DESCRIPTOR_LEN
            );
        }
        v
    }

    /// The 375-byte public header block (LAS 1.4 R15, Table 3).
    fn header(&self) -> Vec<u8> {
        let s = &self.settings;
        let mut h = Vec::with_capacity(HEADER_SIZE as usize);
        h.extend_from_slice(b"LASF");
        h.extend_from_slice(&s.file_source_id.to_le_bytes());
        // Global encoding: bit 0 GPS time type; bit 4 WKT, which the
        // specification requires for point formats 6–10.
        let encoding: u16 = u16::from(s.adjusted_standard_gps_time) | (1 << 4);
        h.extend_from_slice(&encoding.to_le_bytes());
        h.extend_from_slice(&[0u8; 16]); // project ID (GUID)
        h.extend_from_slice(&[1, 4]); // version 1.4
        h.extend_from_slice(&fixed_str::<32>("lidarsim simulation"));
        h.extend_from_slice(&fixed_str::<32>(&s.generating_software));
        h.extend_from_slice(&s.creation_day_year.0.to_le_bytes());
        h.extend_from_slice(&s.creation_day_year.1.to_le_bytes());
        h.extend_from_slice(&HEADER_SIZE.to_le_bytes());
        let vlrs = self.vlrs().len() as u32;
        h.extend_from_slice(&(u32::from(HEADER_SIZE) + vlrs).to_le_bytes()); // offset to points
        h.extend_from_slice(&u32::from(vlrs > 0).to_le_bytes()); // number of VLRs
        h.push(6); // point data record format
        h.extend_from_slice(&self.record_len().to_le_bytes());
        // Legacy point counts: zero for point formats 6–10.
        h.extend_from_slice(&0u32.to_le_bytes());
        h.extend_from_slice(&[0u8; 20]);
        for _ in 0..3 {
            h.extend_from_slice(&s.scale_m.to_le_bytes());
        }
        for o in s.offset_m {
            h.extend_from_slice(&o.to_le_bytes());
        }
        let (min, max) = if self.count == 0 {
            ([0.0; 3], [0.0; 3])
        } else {
            (
                [0, 1, 2].map(|a| self.min[a] as f64 * s.scale_m + s.offset_m[a]),
                [0, 1, 2].map(|a| self.max[a] as f64 * s.scale_m + s.offset_m[a]),
            )
        };
        for a in 0..3 {
            h.extend_from_slice(&max[a].to_le_bytes());
            h.extend_from_slice(&min[a].to_le_bytes());
        }
        h.extend_from_slice(&0u64.to_le_bytes()); // start of waveform data packet record
        h.extend_from_slice(&0u64.to_le_bytes()); // start of first EVLR
        h.extend_from_slice(&0u32.to_le_bytes()); // number of EVLRs
        h.extend_from_slice(&self.count.to_le_bytes());
        for n in self.by_return {
            h.extend_from_slice(&n.to_le_bytes());
        }
        debug_assert_eq!(h.len(), HEADER_SIZE as usize);
        h
    }
}

fn fixed_str<const N: usize>(s: &str) -> [u8; N] {
    let mut out = [0u8; N];
    let b = s.as_bytes();
    let n = b.len().min(N);
    out[..n].copy_from_slice(&b[..n]);
    out
}

impl PointSink for LasWriter {
    fn write(&mut self, points: &[PointRecord]) -> io::Result<()> {
        self.buf.clear();
        for p in points {
            let xyz = [
                self.quantize(p.position_m.x, 0)?,
                self.quantize(p.position_m.y, 1)?,
                self.quantize(p.position_m.z, 2)?,
            ];
            for (a, q) in xyz.iter().enumerate() {
                self.min[a] = self.min[a].min(*q);
                self.max[a] = self.max[a].max(*q);
                self.buf.extend_from_slice(&q.to_le_bytes());
            }
            self.buf.extend_from_slice(&p.intensity.to_le_bytes());
            let rn = p.return_number.clamp(1, 15);
            let nr = p.number_of_returns.clamp(1, 15);
            self.buf.push(rn | (nr << 4));
            // Classification flags 0, scanner channel 0, then the scan
            // direction flag (bit 6) and edge of flight line (bit 7).
            self.buf.push(
                (u8::from(p.scan_direction_positive) << 6) | (u8::from(p.edge_of_flight_line) << 7),
            );
            self.buf.push(p.classification);
            self.buf.push(p.component); // user data: what returned the echo
            // Scan angle in 0.006° increments, −30 000 … +30 000.
            let sa = (p.scan_angle_deg / 0.006)
                .round()
                .clamp(-30_000.0, 30_000.0) as i16;
            self.buf.extend_from_slice(&sa.to_le_bytes());
            self.buf.extend_from_slice(&p.point_source_id.to_le_bytes());
            self.buf.extend_from_slice(&p.gps_time_s.to_le_bytes());
            if self.settings.error_extra_bytes {
                for e in [p.error_m.x, p.error_m.y, p.error_m.z] {
                    self.buf.extend_from_slice(&(e as f32).to_le_bytes());
                }
            }
            self.count += 1;
            self.by_return[usize::from(rn) - 1] += 1;
        }
        let r = self.file.writer().write_all(&self.buf);
        r.map_err(|e| self.file.error(e))
    }

    fn finish(mut self: Box<Self>) -> io::Result<()> {
        let header = self.header();
        let w = self.file.writer();
        let r = w
            .flush()
            .and_then(|()| w.seek(SeekFrom::Start(0)))
            .and_then(|_| w.write_all(&header));
        if let Err(e) = r {
            return Err(self.file.error(e));
        }
        self.file.commit()
    }

    fn discard(self: Box<Self>) {}
}
