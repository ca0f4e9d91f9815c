//! `report.state`: everything a [`ReportSink`] has gathered, saved when a
//! run stops early and restored when it resumes.

use super::ReportSink;
use super::sink::MAX_PROFILE_POINTS;
use super::sink::SamplePulse;
use crate::render::RenderPoint;

/// First bytes of a saved [`ReportSink`] state (format version 3: the
/// pixels in runs, those that hold no point left out).
const STATE_MAGIC: &[u8; 8] = b"LSREPRT3";

/// First bytes of a state in format version 2 (every pixel written), which
/// [`ReportSink::restore`] still reads: an interrupted run saved by an
/// earlier build resumes.
const STATE_MAGIC_V2: &[u8; 8] = b"LSREPRT2";

/// Bytes of one pixel's record: its top's height, intensity and class, and
/// its point count.
const PIXEL_BYTES: usize = 11;

impl ReportSink {
    /// Writes everything the sink has gathered, so that an interrupted run
    /// can continue it with [`ReportSink::restore`] (little-endian binary:
    /// the grid, the pixels that hold points in runs, the histogram, the
    /// cross-section points, the two sample pulses and the error
    /// statistics).
    pub fn save(&self) -> Vec<u8> {
        let n = self.count.len();
        let touched = (0..n).filter(|&k| !self.untouched(k)).count();
        let mut b = Vec::with_capacity(touched * (PIXEL_BYTES + 8) + self.profile.len() * 32 + 256);
        b.extend_from_slice(STATE_MAGIC);
        for v in [self.width as u64, self.height as u64] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.x0, self.y0, self.resolution_m, self.profile_y] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        // The pixels in row order as runs: the number of untouched pixels
        // (as a new sink holds them), the number of touched ones that
        // follow, and their records. A part of a survey covers a strip of
        // the area; the rest of its grid is left out.
        let mut k = 0;
        while k < n {
            let first = (k..n).find(|&j| !self.untouched(j)).unwrap_or(n);
            let end = (first..n).find(|&j| self.untouched(j)).unwrap_or(n);
            b.extend_from_slice(&run_len(first - k).to_le_bytes());
            b.extend_from_slice(&run_len(end - first).to_le_bytes());
            for j in first..end {
                b.extend_from_slice(&self.top_z[j].to_le_bytes());
                b.extend_from_slice(&self.top_intensity[j].to_le_bytes());
                b.push(self.top_class[j]);
                b.extend_from_slice(&self.count[j].to_le_bytes());
            }
            k = end;
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
            Some(r) => (1u8, (r.line, r.pulse, r.returns)),
            None => (0, (0, 0, 0)),
        };
        b.push(flag);
        b.extend_from_slice(&line.to_le_bytes());
        b.extend_from_slice(&pulse.to_le_bytes());
        b.push(n);
        let (flag, (line, pulse)) = match self.single_pulse {
            Some(r) => (1u8, (r.line, r.pulse)),
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
        b
    }

    /// Continues from a state written by [`ReportSink::save`]; `self` must be
    /// a new sink over the same area (the grid is compared).
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), StateError> {
        let mut r = StateReader { bytes, at: 0 };
        let runs = match r.take(8)? {
            m if m == STATE_MAGIC => true,
            m if m == STATE_MAGIC_V2 => false,
            _ => return Err(StateError::NotAState),
        };
        let (w, h) = (r.u64()?, r.u64()?);
        let grid = [r.f64()?, r.f64()?, r.f64()?, r.f64()?];
        if (w, h) != (self.width as u64, self.height as u64)
            || grid != [self.x0, self.y0, self.resolution_m, self.profile_y]
        {
            return Err(StateError::OtherArea);
        }
        let n = self.count.len();
        let mut k = 0;
        while k < n {
            // Version 2 is one run of every pixel.
            let (untouched, touched) = if runs {
                (r.u32()? as usize, r.u32()? as usize)
            } else {
                (0, n)
            };
            let first = k + untouched;
            let end = first
                .checked_add(touched)
                .filter(|&e| e <= n && (untouched, touched) != (0, 0))
                .ok_or(StateError::Runs)?;
            for j in k..first {
                self.clear_pixel(j);
            }
            for j in first..end {
                self.top_z[j] = f32::from_bits(r.u32()?);
                self.top_intensity[j] = r.u16()?;
                self.top_class[j] = r.u8()?;
                self.count[j] = r.u32()?;
            }
            k = end;
        }
        for n in &mut self.returns_per_pulse {
            *n = r.u64()?;
        }
        let n = r.u64()?;
        if n > MAX_PROFILE_POINTS as u64 {
            return Err(StateError::Profile);
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
        self.richest_pulse = (flag == 1).then_some(SamplePulse {
            line,
            pulse,
            returns: n,
        });
        let (flag, line, pulse) = (r.u8()?, r.u32()?, r.u64()?);
        self.single_pulse = (flag == 1).then_some(SamplePulse {
            line,
            pulse,
            returns: 1,
        });
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
            return Err(StateError::Trailing);
        }
        Ok(())
    }
}

impl ReportSink {
    /// Whether pixel `k` is as a new sink holds it (no point seen).
    fn untouched(&self, k: usize) -> bool {
        self.count[k] == 0
            && self.top_z[k] == f32::NEG_INFINITY
            && self.top_intensity[k] == 0
            && self.top_class[k] == 0
    }

    /// Sets pixel `k` as a new sink holds it.
    fn clear_pixel(&mut self, k: usize) {
        self.top_z[k] = f32::NEG_INFINITY;
        self.top_intensity[k] = 0;
        self.top_class[k] = 0;
        self.count[k] = 0;
    }
}

/// A run's length as the state writes it. A grid's pixels are counted in
/// `u32` (a report's grid is at most a few million pixels).
fn run_len(n: usize) -> u32 {
    u32::try_from(n).expect("a report grid has fewer than 2^32 pixels")
}

/// Why a saved state cannot be restored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum StateError {
    /// Its first bytes are not a state's.
    #[error("bad report state: not a report state")]
    NotAState,
    /// Its grid is not the sink's.
    #[error("bad report state: it was made for another area")]
    OtherArea,
    /// Its pixel runs do not add up to the grid.
    #[error("bad report state: its pixel runs do not cover the grid")]
    Runs,
    /// It holds more cross-section points than a sink keeps.
    #[error("bad report state: too many cross-section points")]
    Profile,
    /// Bytes follow its end.
    #[error("bad report state: trailing bytes")]
    Trailing,
    /// It ends early.
    #[error("bad report state: truncated")]
    Truncated,
}

/// Little-endian reader over a saved state.
struct StateReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl StateReader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], StateError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or(StateError::Truncated)?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N], StateError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, StateError> {
        Ok(self.array::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, StateError> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    fn u32(&mut self) -> Result<u32, StateError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> Result<u64, StateError> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn f64(&mut self) -> Result<f64, StateError> {
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
        let state = before.save();
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

    /// The state of `sink`.
    fn state(sink: &ReportSink) -> Vec<u8> {
        sink.save()
    }

    #[test]
    fn a_state_leaves_out_the_pixels_that_hold_no_point() {
        // Two points, in two pixels apart from each other and from the
        // grid's first and last pixels, outside the cross-section band
        // (y = 25 ± 1 m).
        let new = ReportSink::new(area(50.0, 50.0), 4.0);
        let n = new.count.len();
        assert!(n > 2_000, "{n} pixels");
        let mut two = ReportSink::new(area(50.0, 50.0), 4.0);
        two.write(&[
            rec((10.0, 10.0, 1.0), DVec3::ZERO, (1, 1), (0, 0)),
            rec((40.0, 40.0, 1.0), DVec3::ZERO, (1, 1), (0, 1)),
        ])
        .unwrap();
        assert!(two.profile.is_empty());
        // A new sink: one run of all pixels, none written. Each touched
        // pixel that is not at an end adds a run (two u32) and its record
        // (f32 height, u16 intensity, u8 class, u32 count); the grid's own
        // fields are the same size.
        let empty = state(&new);
        assert_eq!(state(&two).len(), empty.len() + 2 * (8 + 11));
        assert!(empty.len() < 1_000, "{} bytes", empty.len());
        let mut back = ReportSink::new(area(50.0, 50.0), 4.0);
        back.restore(&state(&two)).unwrap();
        assert!(back == two);
        // A state whose runs overrun the grid is refused.
        let mut bad = empty.clone();
        let runs = 8 + 16 + 32;
        bad[runs..runs + 4].copy_from_slice(&(n as u32 + 1).to_le_bytes());
        let err = ReportSink::new(area(50.0, 50.0), 4.0)
            .restore(&bad)
            .unwrap_err();
        assert!(err.to_string().contains("runs"), "{err}");
    }

    #[test]
    fn a_state_in_the_earlier_layout_of_every_pixel_is_restored() {
        // Version 2: the magic `LSREPRT2`, then the grid's fields, then
        // every pixel's record in row order, then the rest as in version
        // 3. Written here from the sink's fields.
        let mut sink = ReportSink::new(area(50.0, 50.0), 4.0);
        let pts: Vec<PointRecord> = (0..300u64)
            .map(|k| {
                let f = k as f64;
                rec(
                    ((f * 0.37) % 50.0, (f * 0.61) % 50.0, f % 7.0),
                    DVec3::new(0.01, 0.0, 0.0),
                    (1, 1),
                    (0, k),
                )
            })
            .collect();
        sink.write(&pts).unwrap();
        let v3 = state(&sink);
        let header = 8 + 16 + 32;
        let mut v2 = b"LSREPRT2".to_vec();
        v2.extend_from_slice(&v3[8..header]);
        for k in 0..sink.count.len() {
            v2.extend_from_slice(&sink.top_z[k].to_le_bytes());
            v2.extend_from_slice(&sink.top_intensity[k].to_le_bytes());
            v2.push(sink.top_class[k]);
            v2.extend_from_slice(&sink.count[k].to_le_bytes());
        }
        // The rest (the returns-per-pulse histogram, the cross-section
        // points, the sample pulses, the error statistics) is the end of
        // the version-3 state after its pixel runs.
        let rest = header + runs_len(&v3, sink.count.len());
        v2.extend_from_slice(&v3[rest..]);
        let mut back = ReportSink::new(area(50.0, 50.0), 4.0);
        back.restore(&v2).unwrap();
        assert!(back == sink);
        assert!(v2.len() > v3.len());
    }

    /// The length of a version-3 state's pixel runs, from the first to the
    /// end of the last.
    fn runs_len(v3: &[u8], n: usize) -> usize {
        let u32_at = |at: usize| u32::from_le_bytes(v3[at..at + 4].try_into().unwrap()) as usize;
        let (mut at, mut k) = (8 + 16 + 32, 0);
        while k < n {
            let (untouched, touched) = (u32_at(at), u32_at(at + 4));
            at += 8 + 11 * touched;
            k += untouched + touched;
        }
        at - (8 + 16 + 32)
    }
}
