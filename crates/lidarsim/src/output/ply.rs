//! PLY point output, `binary_little_endian 1.0` (the PLY format of Turk,
//! 1994, as CloudCompare, MeshLab, Open3D and plyfile read it): one
//! `vertex` element per point with double-precision coordinates (projected
//! coordinates need more than a float's 7 digits) and the point's
//! attributes.
//!
//! The vertex count is known only at the end, so the header is written with
//! the count line padded by a comment line of fixed total length and
//! rewritten in place when the file is finished.

use std::io::{self, Seek, SeekFrom, Write};
use std::path::Path;

use super::{AtFile, AtomicFile, PointRecord, PointSink, WriteCause, WriteError};

/// The vertex properties in record order: (PLY type, name).
pub const PLY_PROPERTIES: [(&str, &str); 16] = [
    ("double", "x"),
    ("double", "y"),
    ("double", "z"),
    ("double", "gps_time"),
    ("ushort", "intensity"),
    ("uchar", "return_number"),
    ("uchar", "number_of_returns"),
    ("uchar", "classification"),
    ("uchar", "component"),
    ("ushort", "point_source_id"),
    ("float", "scan_angle"),
    ("float", "amplitude"),
    ("float", "echo_width"),
    ("float", "range"),
    ("float", "incidence_angle"),
    ("uint", "object_id"),
];

/// Bytes of one vertex record.
pub const PLY_RECORD_LEN: usize = 8 * 4 + 2 + 4 + 2 + 4 * 5 + 4;

/// Width reserved for the vertex count and its padding comment, bytes.
const COUNT_FIELD: usize = 20;

/// Writes `points.ply`.
#[derive(Debug)]
pub struct PlyWriter {
    file: AtomicFile,
    origin_m: [f64; 3],
    count: u64,
    buf: Vec<u8>,
}

impl PlyWriter {
    /// Creates `path` (as `path.partial` until finished); `origin_m` is
    /// added to every position.
    pub fn create(path: &Path, origin_m: [f64; 3]) -> Result<Self, WriteError> {
        let mut file = AtomicFile::create(path)?;
        file.writer().write_all(&header(0)).at(path)?;
        Ok(Self {
            file,
            origin_m,
            count: 0,
            buf: Vec::with_capacity(1 << 16),
        })
    }
}

impl PlyWriter {
    /// Length of a PLY file of `points` vertices.
    pub fn file_len(points: u64) -> u64 {
        header(0).len() as u64 + points * PLY_RECORD_LEN as u64
    }

    /// Continues `path`, which an interrupted run finished early when it
    /// held `len` bytes: its header must be this writer's header for the
    /// vertices those bytes hold, and vertices are appended after them.
    pub fn resume(path: &Path, len: u64, origin_m: [f64; 3]) -> Result<Self, WriteError> {
        let bad = |reason: String| {
            WriteError::new(
                path,
                WriteCause::Mismatch {
                    action: "continue",
                    reason,
                },
            )
        };
        let header_len = header(0).len() as u64;
        let record = PLY_RECORD_LEN as u64;
        if len < header_len || !(len - header_len).is_multiple_of(record) {
            return Err(bad(format!(
                "{len} bytes are not a header and whole {record}-byte vertices"
            )));
        }
        let count = (len - header_len) / record;
        let mut file = AtomicFile::reopen(path, len)?;
        let mut head = vec![0u8; header_len as usize];
        {
            let w = file.writer().get_mut();
            let mut read = || -> io::Result<()> {
                w.seek(SeekFrom::Start(0))?;
                io::Read::read_exact(w.file_mut(), &mut head)?;
                w.seek(SeekFrom::End(0))?;
                Ok(())
            };
            read().at(path)?;
        }
        if head != header(count) {
            return Err(bad(format!(
                "its header does not describe {count} vertices of this writer"
            )));
        }
        Ok(Self {
            file,
            origin_m,
            count,
            buf: Vec::with_capacity(1 << 16),
        })
    }

    /// Writes the header for the vertices written so far.
    fn write_header(&mut self) -> Result<(), WriteError> {
        let h = header(self.count);
        let w = self.file.writer();
        let mut write = || -> io::Result<()> {
            w.flush()?;
            w.seek(SeekFrom::Start(0))?;
            w.write_all(&h)?;
            w.seek(SeekFrom::End(0))?;
            Ok(())
        };
        write().at(self.file.path())
    }
}

/// The header for `count` vertices; always the same length.
fn header(count: u64) -> Vec<u8> {
    let digits = count.to_string();
    // The padding comment absorbs what the count does not use, so the
    // header length does not depend on the count.
    let pad = " ".repeat(COUNT_FIELD - digits.len());
    let mut h = String::from("ply\nformat binary_little_endian 1.0\n");
    h.push_str("comment lidarsim point cloud: one vertex per echo\n");
    h.push_str(&format!("comment padding{pad}\n"));
    h.push_str(&format!("element vertex {digits}\n"));
    for (ty, name) in PLY_PROPERTIES {
        h.push_str(&format!("property {ty} {name}\n"));
    }
    h.push_str("end_header\n");
    h.into_bytes()
}

impl PointSink for PlyWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        self.buf.clear();
        let o = self.origin_m;
        for p in points {
            for v in [
                p.position_m.x + o[0],
                p.position_m.y + o[1],
                p.position_m.z + o[2],
                p.gps_time_s,
            ] {
                self.buf.extend_from_slice(&v.to_le_bytes());
            }
            self.buf.extend_from_slice(&p.intensity.to_le_bytes());
            self.buf.extend_from_slice(&[
                p.return_number,
                p.number_of_returns,
                p.classification,
                p.component.code(),
            ]);
            self.buf.extend_from_slice(&p.point_source_id.to_le_bytes());
            for v in [
                p.scan_angle_deg,
                p.amplitude,
                p.echo_width_ns,
                p.range_m,
                p.incidence_angle_deg.unwrap_or(f64::NAN),
            ] {
                self.buf.extend_from_slice(&(v as f32).to_le_bytes());
            }
            self.buf.extend_from_slice(&p.object_code().to_le_bytes());
            self.count += 1;
        }
        let path = self.file.path().to_path_buf();
        self.file.writer().write_all(&self.buf).at(&path)
    }

    fn finish(mut self: Box<Self>) -> Result<(), WriteError> {
        self.write_header()?;
        self.file.commit()
    }

    fn suspend(mut self: Box<Self>) -> Result<(), WriteError> {
        self.write_header()?;
        self.file.suspend()
    }

    fn discard(self: Box<Self>) {}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_length_does_not_depend_on_the_count() {
        assert_eq!(header(0).len(), header(u64::MAX).len());
        let text = String::from_utf8(header(12345)).unwrap();
        assert!(text.contains("\nelement vertex 12345\n"));
        assert!(text.ends_with("end_header\n"));
        // Record length from the PLY type sizes.
        let size = |t: &str| match t {
            "double" => 8,
            "float" | "uint" => 4,
            "ushort" => 2,
            "uchar" => 1,
            _ => unreachable!(),
        };
        let total: usize = PLY_PROPERTIES.iter().map(|(t, _)| size(t)).sum();
        assert_eq!(total, PLY_RECORD_LEN);
    }
}
