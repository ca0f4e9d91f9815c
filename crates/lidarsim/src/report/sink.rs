//! What the report gathers while the points stream past: per map pixel the
//! highest point and a count, the returns per pulse, the points of the
//! cross-section band, two sample pulses and the error statistics, on a
//! grid bounded in pixels whatever the area or the length of the flight.

use super::ErrorStats;
use super::state::StateError;
use crate::geometry::Aabb;
use crate::output::{PointRecord, PointSink, WriteError};
use crate::render::RenderPoint;

/// Largest number of pixels of the report's maps.
const MAX_PIXELS: usize = 500_000;
/// Largest number of points kept for the cross-section.
pub(super) const MAX_PROFILE_POINTS: usize = 200_000;

/// Collects what the report shows while points are written.
#[derive(Debug, PartialEq)]
pub struct ReportSink {
    /// West edge of the grid, m.
    pub(super) x0: f64,
    /// South edge of the grid, m.
    pub(super) y0: f64,
    /// Pixel size, m.
    pub(super) resolution_m: f64,
    /// Columns of the grid.
    pub(super) width: usize,
    /// Rows of the grid (row 0 at the north edge).
    pub(super) height: usize,
    /// Height of each pixel's highest point (−∞ where none), m.
    pub(super) top_z: Vec<f32>,
    /// Intensity of each pixel's highest point.
    pub(super) top_intensity: Vec<u16>,
    /// Class of each pixel's highest point.
    pub(super) top_class: Vec<u8>,
    /// Points in each pixel.
    pub(super) count: Vec<u32>,
    /// Pulses by number of returns (index = returns, 1–15).
    pub returns_per_pulse: [u64; 16],
    /// Cross-section band: along x at `profile_y`, 2 m wide.
    pub(super) profile_y: f64,
    /// The points in that band (at most [`MAX_PROFILE_POINTS`]).
    pub(super) profile: Vec<RenderPoint>,
    /// A pulse with the most returns seen, if one had two or more (so that
    /// it is never the single-return pulse).
    pub richest_pulse: Option<SamplePulse>,
    /// A pulse with a single return.
    pub single_pulse: Option<SamplePulse>,
    /// Georeferencing errors of all points.
    pub errors: ErrorStats,
}

/// A pulse the report draws the waveform of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SamplePulse {
    /// Index of its flight line (0 = first).
    pub line: u32,
    /// Its index within the line.
    pub pulse: u64,
    /// Its number of returns.
    pub returns: u8,
}

impl ReportSink {
    /// A sink over `area` (x, y) with pixels fine enough for about four
    /// points each at `density_per_m2`.
    pub fn new(area: Aabb, density_per_m2: f64) -> Self {
        let (w_m, h_m) = (area.extent().x.max(1.0), area.extent().y.max(1.0));
        let mut res = (4.0 / density_per_m2.max(1e-6)).sqrt().max(0.05);
        while (w_m / res) * (h_m / res) > MAX_PIXELS as f64 {
            res *= 1.25;
        }
        let width = (w_m / res).ceil() as usize + 1;
        let height = (h_m / res).ceil() as usize + 1;
        let n = width * height;
        Self {
            x0: area.min.x,
            y0: area.min.y,
            resolution_m: res,
            width,
            height,
            top_z: vec![f32::NEG_INFINITY; n],
            top_intensity: vec![0; n],
            top_class: vec![0; n],
            count: vec![0; n],
            returns_per_pulse: [0; 16],
            profile_y: area.center().y,
            profile: Vec::new(),
            richest_pulse: None,
            single_pulse: None,
            errors: ErrorStats::default(),
        }
    }

    /// Pixel size of the maps, m.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    fn pixel(&self, x: f64, y: f64) -> Option<usize> {
        let i = ((x - self.x0) / self.resolution_m).floor();
        let j = ((y - self.y0) / self.resolution_m).floor();
        if i < 0.0 || j < 0.0 || i >= self.width as f64 || j >= self.height as f64 {
            return None;
        }
        // Row 0 at the north edge.
        Some((self.height - 1 - j as usize) * self.width + i as usize)
    }

    /// Whether pixel `k` holds a point.
    pub(super) fn filled(&self, k: usize) -> bool {
        self.top_z[k] > f32::NEG_INFINITY
    }
}

impl ReportSink {
    /// A sink over the same grid that has seen no point.
    pub fn empty_like(&self) -> Self {
        let n = self.count.len();
        Self {
            top_z: vec![f32::NEG_INFINITY; n],
            top_intensity: vec![0; n],
            top_class: vec![0; n],
            count: vec![0; n],
            returns_per_pulse: [0; 16],
            profile: Vec::new(),
            richest_pulse: None,
            single_pulse: None,
            errors: ErrorStats::default(),
            ..*self
        }
    }

    /// Takes in what `later` gathered from the points that follow this
    /// sink's (the next part of a split run): afterwards the sink holds
    /// what it would hold had it seen all the points itself — the same
    /// pixels, histogram, cross-section and sample pulses, and the error
    /// statistics up to the order of their sums. Refused when `later`
    /// covers another grid.
    pub fn absorb(&mut self, later: &ReportSink) -> Result<(), StateError> {
        if (later.width, later.height) != (self.width, self.height)
            || [later.x0, later.y0, later.resolution_m, later.profile_y]
                != [self.x0, self.y0, self.resolution_m, self.profile_y]
        {
            return Err(StateError::OtherArea);
        }
        for k in 0..self.count.len() {
            self.count[k] += later.count[k];
            // A later point replaces the highest only when strictly higher.
            if later.top_z[k] > self.top_z[k] {
                self.top_z[k] = later.top_z[k];
                self.top_intensity[k] = later.top_intensity[k];
                self.top_class[k] = later.top_class[k];
            }
        }
        for (a, b) in self
            .returns_per_pulse
            .iter_mut()
            .zip(later.returns_per_pulse)
        {
            *a += b;
        }
        let room = MAX_PROFILE_POINTS.saturating_sub(self.profile.len());
        self.profile
            .extend(later.profile.iter().take(room).cloned());
        if let Some(r) = later.richest_pulse
            && self.richest_pulse.is_none_or(|s| r.returns > s.returns)
        {
            self.richest_pulse = Some(r);
        }
        self.single_pulse = self.single_pulse.or(later.single_pulse);
        self.errors.absorb(&later.errors);
        Ok(())
    }
}

impl PointSink for ReportSink {
    /// The report gathers in memory, beside the sinks that write files.
    type Error = WriteError;

    fn write(&mut self, points: &[PointRecord]) -> Result<(), WriteError> {
        for p in points {
            let (x, y, z) = (p.position_m.x, p.position_m.y, p.position_m.z);
            if let Some(k) = self.pixel(x, y) {
                self.count[k] += 1;
                if (z as f32) > self.top_z[k] {
                    self.top_z[k] = z as f32;
                    self.top_intensity[k] = p.intensity;
                    self.top_class[k] = p.classification;
                }
            }
            self.errors.add(p.error_m);
            if p.return_number == 1 {
                self.returns_per_pulse[usize::from(p.number_of_returns.min(15))] += 1;
                let line = u32::from(p.point_source_id).saturating_sub(1);
                let sample = SamplePulse {
                    line,
                    pulse: p.pulse_index,
                    returns: p.number_of_returns,
                };
                if p.number_of_returns > 1
                    && self
                        .richest_pulse
                        .is_none_or(|r| p.number_of_returns > r.returns)
                {
                    self.richest_pulse = Some(sample);
                }
                if p.number_of_returns == 1 && self.single_pulse.is_none() {
                    self.single_pulse = Some(sample);
                }
            }
            if (y - self.profile_y).abs() <= 1.0 && self.profile.len() < MAX_PROFILE_POINTS {
                self.profile.push(RenderPoint {
                    x,
                    y,
                    z,
                    intensity: p.intensity,
                    classification: p.classification,
                    return_number: p.return_number,
                    number_of_returns: p.number_of_returns,
                    source: p.point_source_id,
                    gps_time_s: 0.0,
                });
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<(), WriteError> {
        Ok(())
    }

    fn discard(self: Box<Self>) {}
}

#[cfg(test)]
mod tests {
    use crate::geometry::DVec3;
    use crate::output::{PointRecord, PointSink};
    use crate::report::testing::{area, rec};
    use crate::report::{ReportSink, SamplePulse};

    #[test]
    fn the_two_sample_pulses_are_different_pulses() {
        let mut sink = ReportSink::new(area(10.0, 10.0), 4.0);
        // Only single-return pulses: one sample, no "richest" pulse.
        let single: Vec<PointRecord> = (0..5)
            .map(|k| rec((1.0, 1.0, 0.0), DVec3::ZERO, (1, 1), (0, k)))
            .collect();
        sink.write(&single).unwrap();
        assert_eq!(sink.single_pulse, Some(sample(0, 0, 1)));
        assert_eq!(sink.richest_pulse, None);
        // A pulse with three returns on the second line.
        let three: Vec<PointRecord> = (1..=3)
            .map(|n| rec((2.0, 2.0, 3.0 - f64::from(n)), DVec3::ZERO, (n, 3), (1, 7)))
            .collect();
        sink.write(&three).unwrap();
        assert_eq!(sink.richest_pulse, Some(sample(1, 7, 3)));
        assert_eq!(sink.single_pulse, Some(sample(0, 0, 1)));
    }

    fn sample(line: u32, pulse: u64, returns: u8) -> SamplePulse {
        SamplePulse {
            line,
            pulse,
            returns,
        }
    }

    /// Points with ties in height, several pulses of one to four returns,
    /// some in the cross-section band, and errors in quarter metres so
    /// that their sums are exact in any order.
    fn points(n: u64) -> Vec<PointRecord> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u64| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 33) % m
        };
        let mut out = Vec::new();
        for pulse in 0..n {
            let of = 1 + next(4) as u8;
            let (x, y) = (next(40) as f64 * 0.25, 4.0 + next(8) as f64 * 0.25);
            let line = (pulse / 50) as u16;
            for r in 1..=of {
                let z = next(6) as f64 * 0.5;
                let e = DVec3::new(next(5) as f64 * 0.25, 0.0, -(next(3) as f64) * 0.25);
                let mut p = rec((x, y, z), e, (r, of), (line, pulse));
                p.intensity = next(1000) as u16;
                p.classification = next(3) as u8;
                out.push(p);
            }
        }
        out
    }

    #[test]
    fn absorbing_the_next_points_sink_is_seeing_them_all() {
        let all = points(400);
        let mut whole = ReportSink::new(area(10.0, 10.0), 4.0);
        whole.write(&all).unwrap();
        for cuts in [vec![0, all.len()], vec![17, 300, 301], vec![1, 2, 900]] {
            let mut merged = ReportSink::new(area(10.0, 10.0), 4.0);
            let mut from = 0;
            for cut in cuts.into_iter().chain([all.len()]) {
                let mut part = merged.empty_like();
                part.write(&all[from..cut]).unwrap();
                merged.absorb(&part).unwrap();
                from = cut;
            }
            assert_eq!(merged, whole);
        }
        let other = ReportSink::new(area(12.0, 10.0), 4.0);
        assert!(whole.absorb(&other).is_err());
    }
}
