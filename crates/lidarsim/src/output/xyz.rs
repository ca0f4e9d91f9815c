//! Plain-text point output: one point per line, space separated, with a
//! header line naming the columns.

use std::io::{self, Write};
use std::path::Path;

use super::{AtomicFile, PointRecord, PointSink};

/// The column names of the header line, in order.
pub const XYZ_COLUMNS: &str = "x y z intensity return_number number_of_returns classification \
                               gps_time scan_angle_deg point_source_id amplitude echo_width_ns \
                               range_m component";

/// Writes `points.xyz`.
#[derive(Debug)]
pub struct XyzWriter {
    file: AtomicFile,
    origin_m: [f64; 3],
    line: String,
}

impl XyzWriter {
    /// Creates `path` (as `path.partial` until finished) and writes the
    /// header line; `origin_m` is added to every position.
    pub fn create(path: &Path, origin_m: [f64; 3]) -> io::Result<Self> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file.writer(), "{XYZ_COLUMNS}").map_err(|e| file.error(e))?;
        Ok(Self {
            file,
            origin_m,
            line: String::with_capacity(256),
        })
    }

    /// Continues `path`, finished early by an interrupted run when it held
    /// `len` bytes: points are appended after them.
    pub fn resume(path: &Path, len: u64, origin_m: [f64; 3]) -> io::Result<Self> {
        Ok(Self {
            file: AtomicFile::reopen(path, len)?,
            origin_m,
            line: String::with_capacity(256),
        })
    }
}

impl PointSink for XyzWriter {
    fn write(&mut self, points: &[PointRecord]) -> io::Result<()> {
        use std::fmt::Write as _;
        let o = self.origin_m;
        for p in points {
            self.line.clear();
            // Formatting into a String cannot fail.
            let _ = writeln!(
                self.line,
                "{:.3} {:.3} {:.3} {} {} {} {} {:.9} {:.3} {} {:.6} {:.3} {:.4} {}",
                p.position_m.x + o[0],
                p.position_m.y + o[1],
                p.position_m.z + o[2],
                p.intensity,
                p.return_number,
                p.number_of_returns,
                p.classification,
                p.gps_time_s,
                p.scan_angle_deg,
                p.point_source_id,
                p.amplitude,
                p.echo_width_ns,
                p.range_m,
                p.component
            );
            if let Err(e) = self.file.writer().write_all(self.line.as_bytes()) {
                return Err(self.file.error(e));
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> io::Result<()> {
        self.file.commit()
    }

    fn discard(self: Box<Self>) {}
}
