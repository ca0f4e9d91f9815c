//! What the report gathers while the points stream past: per map pixel the
//! highest point and a count, the returns per pulse, the points of the
//! cross-section band, two sample pulses and the error statistics, on a
//! grid bounded in pixels whatever the area or the length of the flight.

use std::io;

use super::ErrorStats;
use crate::geometry::Aabb;
use crate::output::{PointRecord, PointSink};
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
    /// it is never the single-return pulse): (line index, pulse index,
    /// returns).
    pub richest_pulse: Option<(u32, u64, u8)>,
    /// A pulse with a single return.
    pub single_pulse: Option<(u32, u64)>,
    /// Georeferencing errors of all points.
    pub errors: ErrorStats,
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

impl PointSink for ReportSink {
    fn write(&mut self, points: &[PointRecord]) -> io::Result<()> {
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
                if p.number_of_returns > 1
                    && self.richest_pulse.is_none_or(|r| p.number_of_returns > r.2)
                {
                    self.richest_pulse = Some((line, p.pulse_index, p.number_of_returns));
                }
                if p.number_of_returns == 1 && self.single_pulse.is_none() {
                    self.single_pulse = Some((line, p.pulse_index));
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

    fn finish(self: Box<Self>) -> io::Result<()> {
        Ok(())
    }

    fn discard(self: Box<Self>) {}
}

#[cfg(test)]
mod tests {
    use crate::geometry::DVec3;
    use crate::output::{PointRecord, PointSink};
    use crate::report::ReportSink;
    use crate::report::testing::{area, rec};

    #[test]
    fn the_two_sample_pulses_are_different_pulses() {
        let mut sink = ReportSink::new(area(10.0, 10.0), 4.0);
        // Only single-return pulses: one sample, no "richest" pulse.
        let single: Vec<PointRecord> = (0..5)
            .map(|k| rec((1.0, 1.0, 0.0), DVec3::ZERO, (1, 1), (0, k)))
            .collect();
        sink.write(&single).unwrap();
        assert_eq!(sink.single_pulse, Some((0, 0)));
        assert_eq!(sink.richest_pulse, None);
        // A pulse with three returns on the second line.
        let three: Vec<PointRecord> = (1..=3)
            .map(|n| rec((2.0, 2.0, 3.0 - f64::from(n)), DVec3::ZERO, (n, 3), (1, 7)))
            .collect();
        sink.write(&three).unwrap();
        assert_eq!(sink.richest_pulse, Some((1, 7, 3)));
        assert_eq!(sink.single_pulse, Some((0, 0)));
    }
}
