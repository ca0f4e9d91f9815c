//! LAS 1.4 writer: point data record format 6, or 9 with full waveforms in
//! an external `.wdp` file; optionally LAZ-compressed.
//!
//! Byte layout from the ASPRS LAS Specification 1.4 R15 (9 July 2019):
//! public header block (Table 3, 375 bytes), VLR header (Table 13, 54
//! bytes), point data record formats 6 (Table 8, 30 bytes) and 9 (Table 11:
//! format 6 followed by the 29-byte wave packet), Extra Bytes VLR (Table 24,
//! 192-byte descriptors), Waveform Packet Descriptor VLRs (Table 17, 26
//! bytes), OGC coordinate system WKT VLR (section 2.5, record 2112). All
//! values little-endian. LAZ follows LASzip: the points are compressed by the
//! `laz` crate (layered chunked compression of point 14, wave packet 14 for
//! format 9, and the extra bytes), the "laszip encoded" VLR (record 22204)
//! describes the items, and bit 7 of the point data format byte marks the
//! file as compressed.

mod header;
mod join;
mod tally;
mod vlr;
mod wdp;

use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

use laz::{LasZipCompressor, LazItemRecordBuilder, LazVlr};

use super::{
    AtFile, AtomicFile, OutFile, PointRecord, PointSink, WaveformBlock, WriteCause, WriteError,
};
pub use header::{HEADER_SIZE_14, HeaderError, RawHeader};
pub use join::{JoinedLas, LasJoin};
use vlr::{ATTRIBUTE_FIELDS, ERROR_FIELDS, fixed_str};
pub use wdp::{
    Digitizer, WAVEFORM_BITS, WAVEFORM_DESCRIPTORS, WAVEFORM_SAMPLES_STEP, WDP_HEADER_LEN,
};
use wdp::{WavePacketLink, WdpFile, wdp_header, write_wave_packet};

/// Bytes of point records gathered before an uncompressed file is written
/// (as much as the file's buffer holds, so that they need not pass through
/// it).
const LAS_WRITE_BYTES: usize = 1 << 20;

/// Size of a point data record of format 6, bytes.
pub const POINT_FORMAT_6_LEN: u16 = 30;
/// Size of a point data record of format 9, bytes: format 6 plus the wave
/// packet (descriptor index u8, byte offset u64, packet size u32, return
/// point waveform location f32, X(t), Y(t), Z(t) f32).
pub const POINT_FORMAT_9_LEN: u16 = 59;
const HEADER_SIZE: u16 = HEADER_SIZE_14;

/// Fixed parts of the header chosen before the first point.
#[derive(Clone, Debug, PartialEq)]
pub struct LasSettings {
    /// Coordinate resolution, m (same on all axes).
    pub scale_m: f64,
    /// Offset subtracted before scaling, m (in output coordinates, i.e.
    /// after `origin_m` is added).
    pub offset_m: [f64; 3],
    /// Added to every world position before it is stored (`[output]
    /// offset_m`: local world frame → projected coordinates), m.
    pub origin_m: [f64; 3],
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
    /// Append the echo attributes (`amplitude`, `echo_width`, `range`,
    /// `incidence_angle`, `object_id`) to every point as LAS 1.4 extra
    /// bytes, described by an Extra Bytes VLR.
    pub attribute_extra_bytes: bool,
    /// Append the georeferencing error vector (`error_x`, `error_y`,
    /// `error_z`, 32-bit floats, m) as extra bytes after the attributes.
    pub error_extra_bytes: bool,
    /// OGC coordinate system WKT written as a VLR (user ID
    /// `LASF_Projection`, record 2112), if any.
    pub crs_wkt: Option<String>,
    /// Compress the points (LAZ).
    pub compressed: bool,
    /// Write point format 9 with the waveforms, digitised by this, in an
    /// external `.wdp` file beside the LAS file.
    pub waveform: Option<Digitizer>,
    /// With `waveform`: the `.wdp` file is written by another writer
    /// fed the same blocks (the LAS beside this LAZ file); this one only
    /// computes the same packet offsets for its points.
    pub waveform_file_shared: bool,
}

/// A point's return number and number of returns as LAS stores them
/// (each 1 to 15).
pub fn return_numbers(p: &PointRecord) -> (u8, u8) {
    (
        p.return_number.clamp(1, 15),
        p.number_of_returns.clamp(1, 15),
    )
}

/// A scan angle in the LAS 1.4 field's units of 0.006°, −30 000 to 30 000.
pub fn scan_angle_units(deg: f64) -> i16 {
    (deg / 0.006).round().clamp(-30_000.0, 30_000.0) as i16
}

impl LasSettings {
    /// The X, Y and Z integers stored for a point at `position_m` (world
    /// metres; `origin_m` is added first): `round((v − offset) / scale)`.
    /// Reading them back as `X · scale + offset` gives the file's
    /// coordinates.
    pub fn quantize_point(
        &self,
        position_m: crate::geometry::DVec3,
    ) -> Result<[i32; 3], WriteCause> {
        let o = self.origin_m;
        Ok([
            self.quantize(position_m.x + o[0], 0)?,
            self.quantize(position_m.y + o[1], 1)?,
            self.quantize(position_m.z + o[2], 2)?,
        ])
    }

    /// One output coordinate `v` (m, after `origin_m`) on `axis` as the
    /// stored integer; an error when it does not fit in an i32.
    pub fn quantize(&self, v: f64, axis: usize) -> Result<i32, WriteCause> {
        let q = ((v - self.offset_m[axis]) / self.scale_m).round();
        if q.is_finite() && q >= i32::MIN as f64 && q <= i32::MAX as f64 {
            Ok(q as i32)
        } else {
            Err(WriteCause::Coordinate {
                value: v,
                offset: self.offset_m[axis],
                scale: self.scale_m,
            })
        }
    }

    /// The point data record format: 6, or 9 with waveforms.
    pub fn point_format(&self) -> u8 {
        if self.waveform.is_some() { 9 } else { 6 }
    }

    /// Bytes of one point record.
    pub fn record_len(&self) -> u16 {
        let base = if self.point_format() == 9 {
            POINT_FORMAT_9_LEN
        } else {
            POINT_FORMAT_6_LEN
        };
        base + self.extra_bytes_len()
    }

    /// The LASzip description of the point record: point 14 (+ wave packet
    /// 14) + extra bytes, layered chunked compression.
    fn laz_vlr(&self) -> Result<LazVlr, WriteCause> {
        let items = LazItemRecordBuilder::default_for_point_format_id(
            self.point_format(),
            self.extra_bytes_len(),
        )
        .map_err(|e| WriteCause::Unsupported(e.to_string()))?;
        Ok(LazVlr::from_laz_items(items))
    }

    /// Length of an uncompressed LAS file of `points` points with these
    /// settings: header, VLRs and point records.
    pub fn file_len(&self, points: u64) -> u64 {
        let vlrs = self.vlrs().map_or(0, |v| v.len() as u64);
        u64::from(HEADER_SIZE) + vlrs + points * u64::from(self.record_len())
    }
}

/// Where the points' bytes go: straight to the file or through LASzip.
enum Body {
    Plain,
    Laz(Box<LasZipCompressor<'static, BufWriter<OutFile>>>),
}

/// Streams points into a LAS 1.4 (or LAZ) file; the header (counts,
/// bounds) is written again when the file is finished.
pub struct LasWriter {
    file: AtomicFile,
    settings: LasSettings,
    body: Body,
    wdp: Option<WdpFile>,
    count: u64,
    by_return: [u64; 15],
    min: [i32; 3],
    max: [i32; 3],
    buf: Vec<u8>,
}

impl std::fmt::Debug for LasWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LasWriter")
            .field("settings", &self.settings)
            .field("count", &self.count)
            .finish_non_exhaustive()
    }
}

impl LasWriter {
    /// Creates `path` (as `path.partial` until finished), and with
    /// waveforms the `.wdp` file of the same base name beside it (unless
    /// `waveform_file_shared`).
    pub fn create(path: &Path, settings: LasSettings) -> Result<Self, WriteError> {
        let file = AtomicFile::create(path)?;
        let wdp = match settings.waveform {
            None => None,
            Some(digitizer) => {
                let wdp_path = path.with_extension("wdp");
                let file = if settings.waveform_file_shared {
                    None
                } else {
                    let mut f = AtomicFile::create(&wdp_path)?;
                    f.writer().write_all(&wdp_header(0)).at(&wdp_path)?;
                    Some(f)
                };
                Some(WdpFile {
                    file,
                    path: wdp_path,
                    next_offset: WDP_HEADER_LEN,
                    digitizer,
                    buf: Vec::new(),
                })
            }
        };
        let mut w = Self {
            file,
            settings,
            body: Body::Plain,
            wdp,
            count: 0,
            by_return: [0; 15],
            min: [i32::MAX; 3],
            max: [i32::MIN; 3],
            buf: Vec::with_capacity(LAS_WRITE_BYTES + (1 << 16)),
        };
        let header = w.header();
        let refuse = |cause| WriteError::new(path, cause);
        let vlrs = w.settings.vlrs().map_err(refuse)?;
        w.file.writer().write_all(&header).at(path)?;
        w.file.writer().write_all(&vlrs).at(path)?;
        if w.settings.compressed {
            let writer = w.file.take_writer();
            let laz_vlr = w.settings.laz_vlr().map_err(refuse)?;
            let compressor = LasZipCompressor::new(writer, laz_vlr)
                .map_err(|e| WriteError::new(path, WriteCause::Unsupported(e.to_string())))?;
            w.body = Body::Laz(Box::new(compressor));
        }
        Ok(w)
    }

    /// Continues `path`, a file this writer finished when a run was
    /// interrupted: the point counts, counts by return, bounds and creation
    /// date are taken from its header, which must match `settings`
    /// (scale, offset, record layout), and points are appended after the
    /// `len` bytes the file had then. With waveforms, the `.wdp` file
    /// beside it is continued after its `wdp_len` bytes.
    pub fn resume(
        path: &Path,
        mut settings: LasSettings,
        len: u64,
        wdp_len: Option<u64>,
    ) -> Result<Self, WriteError> {
        // The file as the interrupted run finished it, or as a failed
        // resume left it.
        let partial = AtomicFile::partial_of(path);
        let t = tally::read(&partial, path, &settings, "continue")?;
        settings.creation_day_year = t.creation_day_year;
        let bad = |reason: String| {
            WriteError::new(
                path,
                WriteCause::Mismatch {
                    action: "continue",
                    reason,
                },
            )
        };
        if t.file_len(&settings) != Some(len) {
            return Err(bad(format!(
                "its header counts {} points but {len} bytes were recorded",
                t.count
            )));
        }
        let mut w = Self {
            file: AtomicFile::unopened(path),
            settings,
            body: Body::Plain,
            wdp: None,
            count: t.count,
            by_return: t.by_return,
            min: t.min,
            max: t.max,
            buf: Vec::with_capacity(LAS_WRITE_BYTES + (1 << 16)),
        };
        // Only now, with everything checked, are the files touched.
        if let Some(digitizer) = w.settings.waveform {
            let wdp_path = path.with_extension("wdp");
            let wdp_len = wdp_len
                .filter(|&n| n >= WDP_HEADER_LEN)
                .ok_or_else(|| bad("the length of its waveform file was not recorded".into()))?;
            w.wdp = Some(WdpFile {
                file: Some(AtomicFile::reopen(&wdp_path, wdp_len)?),
                path: wdp_path,
                next_offset: wdp_len,
                digitizer,
                buf: Vec::new(),
            });
        }
        w.file = AtomicFile::reopen(path, len)?;
        Ok(w)
    }

    /// Writes what is buffered, ends the compressed stream and writes the
    /// final headers of the LAS file and of its own waveform file; returns
    /// both files, to be committed or suspended.
    fn complete(mut self) -> Result<(AtomicFile, Option<AtomicFile>), WriteError> {
        if !self.buf.is_empty() {
            let rest = std::mem::take(&mut self.buf);
            self.file
                .write_unbuffered(&rest)
                .map_err(|e| self.file.error(e))?;
        }
        if let Body::Laz(mut c) = std::mem::replace(&mut self.body, Body::Plain) {
            c.done().map_err(|e| self.file.error(e))?;
            self.file.put_writer(c.into_inner());
        }
        let header = self.header();
        let w = self.file.writer();
        let r = w
            .flush()
            .and_then(|()| w.seek(SeekFrom::Start(0)))
            .and_then(|_| w.write_all(&header))
            .and_then(|()| w.seek(SeekFrom::End(0)).map(|_| ()));
        if let Err(e) = r {
            return Err(self.file.error(e));
        }
        let mut wdp_file = None;
        if let Some(wdp) = self.wdp.take()
            && let Some(mut file) = wdp.file
        {
            let len = wdp.next_offset - WDP_HEADER_LEN;
            let w = file.writer();
            w.flush()
                .and_then(|()| w.seek(SeekFrom::Start(0)))
                .and_then(|_| w.write_all(&wdp_header(len)))
                .and_then(|()| w.seek(SeekFrom::End(0)))
                .at(&wdp.path)?;
            wdp_file = Some(file);
        }
        Ok((self.file, wdp_file))
    }

    /// The 375-byte public header block (LAS 1.4 R15, Table 3) for the
    /// points written so far.
    fn header(&self) -> Vec<u8> {
        let s = &self.settings;
        let list = s.vlr_list().unwrap_or_default();
        let vlr_bytes: usize = list.iter().map(vlr::Vlr::len).sum();
        let (min, max) = if self.count == 0 {
            ([0.0; 3], [0.0; 3])
        } else {
            (
                [0, 1, 2].map(|a| self.min[a] as f64 * s.scale_m + s.offset_m[a]),
                [0, 1, 2].map(|a| self.max[a] as f64 * s.scale_m + s.offset_m[a]),
            )
        };
        RawHeader {
            file_source_id: s.file_source_id,
            // Bit 0 GPS time type; bit 2 waveform data packets in an
            // external file; bit 4 WKT, which the specification requires
            // for point formats 6–10.
            global_encoding: u16::from(s.adjusted_standard_gps_time)
                | (u16::from(s.waveform.is_some()) << 2)
                | (1 << 4),
            version: (1, 4),
            system_identifier: fixed_str::<32>("lidarsim simulation"),
            generating_software: fixed_str::<32>(&s.generating_software),
            creation_day_year: s.creation_day_year,
            header_size: HEADER_SIZE,
            offset_to_points: u32::from(HEADER_SIZE) + vlr_bytes as u32,
            number_of_vlrs: list.len() as u32,
            // Bit 7 of the format marks LASzip compression.
            point_format: s.point_format() | if s.compressed { 0x80 } else { 0 },
            record_len: s.record_len(),
            scale: [s.scale_m; 3],
            offset: s.offset_m,
            max,
            min,
            point_count: self.count,
            by_return: self.by_return,
            // Legacy counts are zero for point formats 6–10, the waveform
            // packets are in the external file and there are no EVLRs.
            ..RawHeader::default()
        }
        .to_bytes()
    }

    /// Encodes a block of points after the records gathered so far, and
    /// passes them on once they fill [`LAS_WRITE_BYTES`] (uncompressed) or
    /// at once (to the compressor). A block that fails leaves no record.
    fn encode(
        &mut self,
        points: &[PointRecord],
        waveforms: &WaveformBlock,
    ) -> Result<(), WriteError> {
        let start = self.buf.len();
        let before = (self.count, self.by_return, self.min, self.max);
        if let Err(e) = self.encode_records(points, waveforms) {
            self.buf.truncate(start);
            (self.count, self.by_return, self.min, self.max) = before;
            return Err(e);
        }
        let r = match &mut self.body {
            Body::Plain if self.buf.len() < LAS_WRITE_BYTES => return Ok(()),
            Body::Plain => self.file.write_unbuffered(&self.buf),
            Body::Laz(c) => c.compress_many(&self.buf),
        };
        self.buf.clear();
        r.map_err(|e| self.file.error(e))
    }

    /// Appends the records of `points` to the buffer (and writes their
    /// waveform packets).
    fn encode_records(
        &mut self,
        points: &[PointRecord],
        waveforms: &WaveformBlock,
    ) -> Result<(), WriteError> {
        let mut cursor = 0;
        // (pulse key, wave packet fields) of the packet last written.
        let mut current: Option<((u16, u64), WavePacketLink)> = None;
        // The buffer takes the points' records whole (an `extend` per field
        // costs a capacity check and a length update each).
        self.buf
            .reserve(points.len() * usize::from(self.settings.record_len()));
        for p in points {
            let xyz = self
                .settings
                .quantize_point(p.position_m)
                .map_err(|cause| WriteError::new(self.file.path(), cause))?;
            // The 30 bytes of point data record format 6 (LAS 1.4 R15,
            // Table 16).
            let mut rec = [0u8; POINT_FORMAT_6_LEN as usize];
            for (a, q) in xyz.iter().enumerate() {
                self.min[a] = self.min[a].min(*q);
                self.max[a] = self.max[a].max(*q);
                rec[4 * a..4 * a + 4].copy_from_slice(&q.to_le_bytes());
            }
            rec[12..14].copy_from_slice(&p.intensity.to_le_bytes());
            let (rn, nr) = return_numbers(p);
            rec[14] = rn | (nr << 4);
            // Classification flags 0, the scanner channel (bits 4–5), the
            // scan direction flag (bit 6) and edge of flight line (bit 7).
            rec[15] = ((p.channel & 3) << 4)
                | (u8::from(p.scan_direction_positive) << 6)
                | (u8::from(p.edge_of_flight_line) << 7);
            rec[16] = p.classification;
            rec[17] = p.component.code(); // user data: what returned the echo
            // Scan angle in 0.006° increments, −30 000 … +30 000.
            let sa = scan_angle_units(p.scan_angle_deg);
            rec[18..20].copy_from_slice(&sa.to_le_bytes());
            rec[20..22].copy_from_slice(&p.point_source_id.to_le_bytes());
            rec[22..30].copy_from_slice(&p.gps_time_s.to_le_bytes());
            self.buf.extend_from_slice(&rec);
            if let Some(wdp) = self.wdp.as_mut() {
                let key = (p.point_source_id, p.pulse_index);
                let link = match current {
                    Some((k, link)) if k == key => Some(link),
                    _ => {
                        // Packets are in pulse order like the points.
                        while cursor < waveforms.packets.len()
                            && (
                                waveforms.packets[cursor].point_source_id,
                                waveforms.packets[cursor].pulse_index,
                            ) != key
                        {
                            cursor += 1;
                        }
                        match waveforms.packets.get(cursor) {
                            Some(packet) => {
                                let link = wdp
                                    .write_packet(
                                        waveforms.samples_of(packet),
                                        packet.first_sample_ps,
                                    )
                                    .at(&wdp.path)?;
                                current = Some((key, link));
                                Some(link)
                            }
                            None => None,
                        }
                    }
                };
                write_wave_packet(&mut self.buf, p, link, wdp.digitizer.bin_ps);
            }
            if self.settings.attribute_extra_bytes {
                let mut extra = [0u8; 4 * ATTRIBUTE_FIELDS.len()];
                for (i, v) in [
                    p.amplitude,
                    p.echo_width_ns,
                    p.range_m,
                    p.incidence_angle_deg.unwrap_or(f64::NAN),
                ]
                .into_iter()
                .enumerate()
                {
                    extra[4 * i..4 * i + 4].copy_from_slice(&(v as f32).to_le_bytes());
                }
                extra[16..20].copy_from_slice(&p.object_code().to_le_bytes());
                self.buf.extend_from_slice(&extra);
            }
            if self.settings.error_extra_bytes {
                let mut extra = [0u8; 4 * ERROR_FIELDS.len()];
                for (i, e) in [p.error_m.x, p.error_m.y, p.error_m.z]
                    .into_iter()
                    .enumerate()
                {
                    extra[4 * i..4 * i + 4].copy_from_slice(&(e as f32).to_le_bytes());
                }
                self.buf.extend_from_slice(&extra);
            }
            self.count += 1;
            self.by_return[usize::from(rn) - 1] += 1;
        }
        Ok(())
    }
}

impl PointSink for LasWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        self.encode(points, &WaveformBlock::default())
    }

    fn write_block(
        &mut self,
        points: &[PointRecord],
        waveforms: &WaveformBlock,
    ) -> Result<(), WriteError> {
        self.encode(points, waveforms)
    }

    fn finish(self: Box<Self>) -> Result<(), WriteError> {
        let (file, wdp) = self.complete()?;
        if let Some(wdp) = wdp {
            wdp.commit()?;
        }
        file.commit()
    }

    fn suspend(self: Box<Self>) -> Result<(), WriteError> {
        let (file, wdp) = self.complete()?;
        if let Some(wdp) = wdp {
            wdp.suspend()?;
        }
        file.suspend()
    }

    fn discard(self: Box<Self>) {}
}

#[cfg(test)]
mod tests;
