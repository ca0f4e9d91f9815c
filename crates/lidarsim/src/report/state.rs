//! `report.state`: everything a [`ReportSink`] has gathered, saved when a
//! run stops early and restored when it resumes.

use std::io;

use super::ReportSink;
use super::sink::MAX_PROFILE_POINTS;
use crate::render::RenderPoint;

/// First bytes of a saved [`ReportSink`] state (format version 2: with the
/// error statistics).
const STATE_MAGIC: &[u8; 8] = b"LSREPRT2";

impl ReportSink {
    /// Writes everything the sink has gathered, so that an interrupted run
    /// can continue it with [`ReportSink::restore`] (little-endian binary:
    /// the grid, the per-pixel arrays, the histogram, the cross-section
    /// points, the two sample pulses and the error statistics).
    pub fn save(&self, w: &mut dyn io::Write) -> io::Result<()> {
        let mut b = Vec::with_capacity(self.count.len() * 11 + self.profile.len() * 32 + 256);
        b.extend_from_slice(STATE_MAGIC);
        for v in [self.width as u64, self.height as u64] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.x0, self.y0, self.resolution_m, self.profile_y] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for k in 0..self.count.len() {
            b.extend_from_slice(&self.top_z[k].to_le_bytes());
            b.extend_from_slice(&self.top_intensity[k].to_le_bytes());
            b.push(self.top_class[k]);
            b.extend_from_slice(&self.count[k].to_le_bytes());
        }
        for n in self.returns_per_pulse {
            b.extend_from_slice(&n.to_le_bytes());
        }
        b.extend_from_slice(&(self.profile.len() as u64).to_le_bytes());
        for p in &self.profile {
            for v in [p.x, p.y, p.z] {
                b.extend_from_slice(&v.to_le_bytes());
            }
            b.extend_from_slice(&p.intensity.to_le_bytes());
            b.extend_from_slice(&[p.classification, p.return_number, p.number_of_returns]);
            b.extend_from_slice(&p.source.to_le_bytes());
        }
        let (flag, (line, pulse, n)) = match self.richest_pulse {
            Some(r) => (1u8, r),
            None => (0, (0, 0, 0)),
        };
        b.push(flag);
        b.extend_from_slice(&line.to_le_bytes());
        b.extend_from_slice(&pulse.to_le_bytes());
        b.push(n);
        let (flag, (line, pulse)) = match self.single_pulse {
            Some(r) => (1u8, r),
            None => (0, (0, 0)),
        };
        b.push(flag);
        b.extend_from_slice(&line.to_le_bytes());
        b.extend_from_slice(&pulse.to_le_bytes());
        let e = &self.errors;
        b.extend_from_slice(&e.count.to_le_bytes());
        for v in e.sum_m.iter().chain(&e.sum_sq_m2) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [e.max_horizontal_m, e.max_vertical_m] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&b)
    }

    /// Continues from a state written by [`ReportSink::save`]; `self` must be
    /// a new sink over the same area (the grid is compared).
    pub fn restore(&mut self, bytes: &[u8]) -> io::Result<()> {
        let mut r = StateReader { bytes, at: 0 };
        if r.take(8)? != STATE_MAGIC {
            return Err(state_error("not a report state"));
        }
        let (w, h) = (r.u64()?, r.u64()?);
        let grid = [r.f64()?, r.f64()?, r.f64()?, r.f64()?];
        if (w, h) != (self.width as u64, self.height as u64)
            || grid != [self.x0, self.y0, self.resolution_m, self.profile_y]
        {
            return Err(state_error("it was made for another area"));
        }
        for k in 0..self.count.len() {
            self.top_z[k] = f32::from_bits(r.u32()?);
            self.top_intensity[k] = r.u16()?;
            self.top_class[k] = r.u8()?;
            self.count[k] = r.u32()?;
        }
        for n in &mut self.returns_per_pulse {
            *n = r.u64()?;
        }
        let n = r.u64()?;
        if n > MAX_PROFILE_POINTS as u64 {
            return Err(state_error("too many cross-section points"));
        }
        self.profile.clear();
        for _ in 0..n {
            self.profile.push(RenderPoint {
                x: r.f64()?,
                y: r.f64()?,
                z: r.f64()?,
                intensity: r.u16()?,
                classification: r.u8()?,
                return_number: r.u8()?,
                number_of_returns: r.u8()?,
                source: r.u16()?,
                gps_time_s: 0.0,
            });
        }
        let (flag, line, pulse, n) = (r.u8()?, r.u32()?, r.u64()?, r.u8()?);
        self.richest_pulse = (flag == 1).then_some((line, pulse, n));
        let (flag, line, pulse) = (r.u8()?, r.u32()?, r.u64()?);
        self.single_pulse = (flag == 1).then_some((line, pulse));
        self.errors.count = r.u64()?;
        for v in self.errors.sum_m.iter_mut() {
            *v = r.f64()?;
        }
        for v in self.errors.sum_sq_m2.iter_mut() {
            *v = r.f64()?;
        }
        self.errors.max_horizontal_m = r.f64()?;
        self.errors.max_vertical_m = r.f64()?;
        if r.at != bytes.len() {
            return Err(state_error("trailing bytes"));
        }
        Ok(())
    }
}

fn state_error(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("bad report state: {what}"),
    )
}

/// Little-endian reader over a saved state.
struct StateReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl StateReader<'_> {
    fn take(&mut self, n: usize) -> io::Result<&[u8]> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| state_error("truncated"))?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn array<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    fn u8(&mut self) -> io::Result<u8> {
        Ok(self.array::<1>()?[0])
    }
    fn u16(&mut self) -> io::Result<u16> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    fn u32(&mut self) -> io::Result<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> io::Result<u64> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn f64(&mut self) -> io::Result<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::DVec3;
    use crate::output::{PointRecord, PointSink};
    use crate::report::ReportSink;
    use crate::report::testing::{area, rec};

    #[test]
    fn a_restored_sink_continues_to_the_uninterrupted_one() {
        // Points with errors, several returns, some in the cross-section
        // band (y = 25 ± 1 m), in two halves.
        let pts: Vec<PointRecord> = (0..400u64)
            .map(|k| {
                let f = k as f64;
                let returns = 1 + (k % 3) as u8;
                rec(
                    ((f * 0.37) % 50.0, (f * 0.61) % 50.0, f % 7.0),
                    DVec3::new(0.01 * (f % 5.0), -0.02 * (f % 3.0), 0.003 * f),
                    (1 + (k % returns as u64) as u8, returns),
                    ((k / 200) as u16, k / 3),
                )
            })
            .collect();
        let (first, second) = pts.split_at(173);
        let mut whole = ReportSink::new(area(50.0, 50.0), 4.0);
        whole.write(first).unwrap();
        whole.write(second).unwrap();
        let mut before = ReportSink::new(area(50.0, 50.0), 4.0);
        before.write(first).unwrap();
        let mut state = Vec::new();
        before.save(&mut state).unwrap();
        let mut resumed = ReportSink::new(area(50.0, 50.0), 4.0);
        resumed.restore(&state).unwrap();
        assert!(resumed == before);
        resumed.write(second).unwrap();
        assert!(resumed == whole);
        assert!(whole.errors.count == 400 && !whole.profile.is_empty());
        // A state cut short is refused.
        let mut other = ReportSink::new(area(50.0, 50.0), 4.0);
        assert!(other.restore(&state[..state.len() - 1]).is_err());
    }
}
