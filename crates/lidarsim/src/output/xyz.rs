//! Plain-text point output: one point per line, space separated, with a
//! header line naming the columns.

use std::io::Write;
use std::path::Path;

use super::text::{push_fixed, push_u64};
use super::{AtomicFile, PointRecord, PointSink, WriteError};

/// The column names of the header line, in order.
pub const XYZ_COLUMNS: &str = "x y z intensity return_number number_of_returns classification \
                               gps_time scan_angle_deg point_source_id amplitude echo_width_ns \
                               range_m component";

/// Writes `points.xyz`.
#[derive(Debug)]
pub struct XyzWriter {
    file: AtomicFile,
    origin_m: [f64; 3],
    /// The lines of the block being written.
    block: Vec<u8>,
}

impl XyzWriter {
    /// Creates `path` (as `path.partial` until finished) and writes the
    /// header line; `origin_m` is added to every position.
    pub fn create(path: &Path, origin_m: [f64; 3]) -> Result<Self, WriteError> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file.writer(), "{XYZ_COLUMNS}").map_err(|e| file.error(e))?;
        Ok(Self {
            file,
            origin_m,
            block: Vec::with_capacity(1 << 16),
        })
    }

    /// Continues `path`, finished early by an interrupted run when it held
    /// `len` bytes: points are appended after them.
    pub fn resume(path: &Path, len: u64, origin_m: [f64; 3]) -> Result<Self, WriteError> {
        Ok(Self {
            file: AtomicFile::reopen(path, len)?,
            origin_m,
            block: Vec::with_capacity(1 << 16),
        })
    }
}

impl PointSink for XyzWriter {
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        let o = self.origin_m;
        // The columns after the first, each after a space.
        let fixed = |b: &mut Vec<u8>, v: f64, decimals: u32| {
            b.push(b' ');
            push_fixed(b, v, decimals);
        };
        let integer = |b: &mut Vec<u8>, v: u64| {
            b.push(b' ');
            push_u64(b, v);
        };
        self.block.clear();
        for p in points {
            let b = &mut self.block;
            // In `XYZ_COLUMNS` order.
            push_fixed(b, p.position_m.x + o[0], 3);
            fixed(b, p.position_m.y + o[1], 3);
            fixed(b, p.position_m.z + o[2], 3);
            integer(b, u64::from(p.intensity));
            integer(b, u64::from(p.return_number));
            integer(b, u64::from(p.number_of_returns));
            integer(b, u64::from(p.classification));
            fixed(b, p.gps_time_s, 9);
            fixed(b, p.scan_angle_deg, 3);
            integer(b, u64::from(p.point_source_id));
            fixed(b, p.amplitude, 6);
            fixed(b, p.echo_width_ns, 3);
            fixed(b, p.range_m, 4);
            integer(b, u64::from(p.component.code()));
            b.push(b'\n');
        }
        if let Err(e) = self.file.writer().write_all(&self.block) {
            return Err(self.file.error(e));
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), WriteError> {
        self.file.commit()
    }

    fn suspend(self: Box<Self>) -> Result<(), WriteError> {
        self.file.suspend()
    }

    fn discard(self: Box<Self>) {}
}
