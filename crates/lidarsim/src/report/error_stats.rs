//! The georeferencing errors of the points (computed minus true position),
//! summed as they pass: RMS per axis and horizontally, largest and mean.

use crate::geometry::DVec3;

/// Georeferencing errors of points (computed minus true position,
/// [`PointRecord::error_m`](crate::output::PointRecord::error_m)), summed
/// as the points pass.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// Points counted.
    pub count: u64,
    /// Sum of the error vectors (x, y, z), m.
    pub sum_m: [f64; 3],
    /// Sum of the squared errors per axis, m².
    pub sum_sq_m2: [f64; 3],
    /// Largest horizontal error, m.
    pub max_horizontal_m: f64,
    /// Largest vertical error (absolute value), m.
    pub max_vertical_m: f64,
}

impl ErrorStats {
    /// Counts one point's error vector.
    pub fn add(&mut self, e: DVec3) {
        let v = [e.x, e.y, e.z];
        self.count += 1;
        for (k, x) in v.into_iter().enumerate() {
            self.sum_m[k] += x;
            self.sum_sq_m2[k] += x * x;
        }
        self.max_horizontal_m = self.max_horizontal_m.max(e.x.hypot(e.y));
        self.max_vertical_m = self.max_vertical_m.max(e.z.abs());
    }

    /// Counts the points `later` counted, as if they had followed.
    pub fn absorb(&mut self, later: &ErrorStats) {
        self.count += later.count;
        for k in 0..3 {
            self.sum_m[k] += later.sum_m[k];
            self.sum_sq_m2[k] += later.sum_sq_m2[k];
        }
        self.max_horizontal_m = self.max_horizontal_m.max(later.max_horizontal_m);
        self.max_vertical_m = self.max_vertical_m.max(later.max_vertical_m);
    }

    /// Mean error vector (x, y, z), m.
    pub fn mean_m(&self) -> [f64; 3] {
        let n = self.count.max(1) as f64;
        self.sum_m.map(|s| s / n)
    }

    /// Root mean square error per axis (x, y, z), m.
    pub fn rms_m(&self) -> [f64; 3] {
        let n = self.count.max(1) as f64;
        self.sum_sq_m2.map(|s| (s / n).sqrt())
    }

    /// Root mean square of the horizontal error, m.
    pub fn rms_horizontal_m(&self) -> f64 {
        ((self.sum_sq_m2[0] + self.sum_sq_m2[1]) / self.count.max(1) as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::DVec3;
    use crate::output::{PointRecord, PointSink};
    use crate::report::ReportSink;
    use crate::report::testing::{area, rec};

    #[test]
    fn error_statistics_are_the_rms_largest_and_mean_errors() {
        let mut sink = ReportSink::new(area(10.0, 10.0), 4.0);
        let errors = [
            DVec3::new(0.3, 0.4, 0.0),
            DVec3::new(-0.3, -0.4, 0.2),
            DVec3::new(0.0, 0.0, -0.6),
        ];
        let pts: Vec<PointRecord> = errors
            .iter()
            .enumerate()
            .map(|(k, e)| rec((1.0, 1.0, 0.0), *e, (1, 1), (0, k as u64)))
            .collect();
        sink.write(&pts).unwrap();
        let e = sink.errors;
        assert_eq!(e.count, 3);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        // RMS per axis: √((0.09 + 0.09) / 3), √((0.16 + 0.16) / 3),
        // √((0.04 + 0.36) / 3); horizontal: √((0.25 + 0.25) / 3).
        let [rx, ry, rz] = e.rms_m();
        assert!(close(rx, 0.06f64.sqrt()) && close(ry, (0.32f64 / 3.0).sqrt()));
        assert!(close(rz, (0.4f64 / 3.0).sqrt()));
        assert!(close(e.rms_horizontal_m(), (0.5f64 / 3.0).sqrt()));
        assert!(close(e.max_horizontal_m, 0.5) && close(e.max_vertical_m, 0.6));
        let [mx, my, mz] = e.mean_m();
        assert!(close(mx, 0.0) && close(my, 0.0) && close(mz, -0.4 / 3.0));
    }
}
