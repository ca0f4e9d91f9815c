//! The report's pictures of the points, drawn from what the sink gathered:
//! top views by height, intensity and class, the point density and the
//! cross-section.

use super::ReportSink;
use crate::render::{
    ColorBy, Image, Palette, class_color, framed, hole_source, no_data, profile_exaggerated,
};

/// Side of the cells of the density map, m.
const DENSITY_CELL_M: f64 = 5.0;
/// Height of the cross-section's plot, px.
const PROFILE_HEIGHT_PX: usize = 300;

impl ReportSink {
    /// A map of the pixels holding points, coloured by `color`: one-pixel
    /// holes inside the data take the colour of their highest neighbour
    /// ([`hole_source`]), other empty pixels are hatched as "no data".
    fn map(&self, color: impl Fn(usize) -> [u8; 3]) -> Image {
        let (w, h) = (self.width, self.height);
        let mut img = Image::new(w, h, [0; 3]);
        let filled = |k: usize| self.filled(k);
        let z = |k: usize| f64::from(self.top_z[k]);
        for k in 0..w * h {
            let source = if filled(k) {
                Some(k)
            } else {
                hole_source(w, h, k, filled, z)
            };
            let (x, y) = (k % w, k / w);
            img.set(x, y, source.map_or_else(|| no_data(x, y), &color));
        }
        img
    }

    /// The colour bar of a top view by height: over the robust range of the
    /// pixels' highest points ([`crate::render::ROBUST_QUANTILES`]).
    pub fn height_palette(&self) -> Palette {
        Palette::robust(
            ColorBy::Height,
            (0..self.top_z.len())
                .filter(|&k| self.filled(k))
                .map(|k| f64::from(self.top_z[k])),
        )
        .with_no_data()
    }

    /// The colour bar of a top view by intensity: over the robust range of
    /// the intensities of the pixels' highest points.
    pub fn intensity_palette(&self) -> Palette {
        Palette::robust(
            ColorBy::Intensity,
            (0..self.top_z.len())
                .filter(|&k| self.filled(k))
                .map(|k| f64::from(self.top_intensity[k])),
        )
        .with_no_data()
    }

    /// Top view by height.
    pub fn height_map(&self) -> Image {
        let p = self.height_palette();
        let map = self.map(|k| p.bar_color(f64::from(self.top_z[k])));
        framed(&map, &p, self.resolution_m)
    }

    /// Top view by intensity.
    pub fn intensity_map(&self) -> Image {
        let p = self.intensity_palette();
        let map = self.map(|k| p.bar_color(f64::from(self.top_intensity[k])));
        framed(&map, &p, self.resolution_m)
    }

    /// Top view by class.
    pub fn class_map(&self) -> Image {
        let mut classes: Vec<u8> = (0..self.top_z.len())
            .filter(|&k| self.filled(k))
            .map(|k| self.top_class[k])
            .collect();
        classes.sort_unstable();
        classes.dedup();
        let p = Palette::classes(&classes).with_no_data();
        let map = self.map(|k| class_color(self.top_class[k]).0);
        framed(&map, &p, self.resolution_m)
    }

    /// Point density (points per m², all returns) in cells of about 5 m,
    /// on a colour bar from 0 to twice `planned` (or the 98th percentile of
    /// the cells if higher), and the median over cells with points.
    pub fn density_map(&self, planned: f64) -> (Image, f64) {
        let b = ((DENSITY_CELL_M / self.resolution_m).round() as usize).max(1);
        let (cw, ch) = (self.width.div_ceil(b), self.height.div_ceil(b));
        let mut cells = vec![0u64; cw * ch];
        for (k, &c) in self.count.iter().enumerate() {
            cells[(k / self.width / b) * cw + (k % self.width) / b] += u64::from(c);
        }
        let area = (b as f64 * self.resolution_m).powi(2);
        // The median over cells with points: cells cut by the edge of the
        // area or of the swath would drag a mean down.
        let mut filled: Vec<f64> = cells
            .iter()
            .filter(|&&c| c > 0)
            .map(|&c| c as f64 / area)
            .collect();
        filled.sort_by(f64::total_cmp);
        let median = filled.get(filled.len() / 2).copied().unwrap_or(0.0);
        // Up to twice the plan, or further where overlaps and canopy echoes
        // go beyond that (98th percentile).
        let p98 = filled
            .get((filled.len().saturating_sub(1) as f64 * 0.98) as usize)
            .copied()
            .unwrap_or(0.0);
        let top = (2.0 * planned).max(p98).max(1e-9);
        let p = Palette::bar(ColorBy::Intensity, (0.0, top))
            .titled("POINTS/M²")
            .with_no_data();
        let mut map = Image::new(self.width, self.height, [0; 3]);
        for k in 0..self.width * self.height {
            let c = cells[(k / self.width / b) * cw + (k % self.width) / b];
            let (x, y) = (k % self.width, k / self.width);
            let color = if c > 0 {
                p.bar_color(c as f64 / area)
            } else {
                no_data(x, y)
            };
            map.set(x, y, color);
        }
        (framed(&map, &p, self.resolution_m), median)
    }

    /// Cross-section along x through the middle of the area, 2 m wide, by
    /// class, its heights stretched to fill the picture.
    pub fn profile_image(&self) -> Image {
        let x1 = self.x0 + self.width as f64 * self.resolution_m;
        profile_exaggerated(
            &self.profile,
            (self.x0, self.profile_y),
            (x1, self.profile_y),
            2.0,
            ColorBy::Class,
            ((x1 - self.x0) / 1200.0).max(0.1),
            PROFILE_HEIGHT_PX,
        )
    }

    /// The heights the cross-section spans (its points' lowest and
    /// highest), m.
    pub fn profile_heights(&self) -> Option<(f64, f64)> {
        let x1 = self.x0 + self.width as f64 * self.resolution_m;
        self.profile
            .iter()
            .filter(|p| p.x >= self.x0 && p.x <= x1)
            .map(|p| p.z)
            .fold(None, |r, z| {
                Some(r.map_or((z, z), |(a, b): (f64, f64)| (a.min(z), b.max(z))))
            })
    }
}

#[cfg(test)]
mod tests {
    use crate::geometry::{Aabb, DVec3};
    use crate::output::{PointRecord, PointSink};
    use crate::render::class_color;
    use crate::report::ReportSink;
    use crate::report::testing::{area, rec};

    #[test]
    fn density_map_measures_a_uniform_cloud() {
        // 8 points per m² on a regular grid over 100 m × 60 m.
        let area = Aabb {
            min: DVec3::new(0.0, 0.0, 0.0),
            max: DVec3::new(100.0, 60.0, 0.0),
        };
        let mut sink = ReportSink::new(area, 8.0);
        let step = (1.0f64 / 8.0).sqrt();
        let n = (100.0 / step) as usize;
        let m = (60.0 / step) as usize;
        let mut pts = Vec::new();
        for i in 0..n {
            for j in 0..m {
                pts.push(PointRecord {
                    position_m: DVec3::new((i as f64 + 0.5) * step, (j as f64 + 0.5) * step, 1.0),
                    gps_time_s: 0.0,
                    intensity: 100,
                    amplitude: 0.0,
                    echo_width_ns: 4.0,
                    range_m: 100.0,
                    beam_dir: -DVec3::Z,
                    error_m: DVec3::ZERO,
                    return_number: 1,
                    number_of_returns: 1,
                    scan_direction_positive: true,
                    edge_of_flight_line: false,
                    scan_angle_deg: 0.0,
                    classification: 2,
                    point_source_id: 1,
                    pulse_index: 0,
                    object_id: None,
                    component: Default::default(),
                    channel: 0,
                    incidence_angle_deg: Some(0.0),
                    echo_time_ps: 0.0,
                });
            }
        }
        sink.write(&pts).unwrap();
        let (_, mean) = sink.density_map(8.0);
        // The median cell holds the planned density (edge cells are cut).
        assert!((mean - 8.0).abs() < 0.02 * 8.0, "{mean}");
        assert_eq!(sink.returns_per_pulse[1], pts.len() as u64);
        assert_eq!(sink.single_pulse.map(|s| (s.line, s.pulse)), Some((0, 0)));
    }

    #[test]
    fn one_pixel_gaps_inside_the_swath_are_filled_in_the_maps() {
        // 4 points/m² planned: 1 m pixels. Rows of points every 0.1 m along
        // x, 1.5 m apart, over 40 m × 30 m of a 40 m × 40 m area: every third
        // pixel row is empty.
        let mut sink = ReportSink::new(area(40.0, 40.0), 4.0);
        assert_eq!(sink.resolution_m(), 1.0);
        let pts: Vec<PointRecord> = (0..=20)
            .flat_map(|k| {
                (0..=400).map(move |i| {
                    rec(
                        (i as f64 * 0.1, k as f64 * 1.5, 0.0),
                        DVec3::ZERO,
                        (1, 1),
                        (0, 0),
                    )
                })
            })
            .collect();
        sink.write(&pts).unwrap();
        let img = sink.class_map();
        let ground = class_color(2).0;
        // 41 × 41 pixels of 1 m; row 0 at the north edge holds y 40–41 m.
        // The data cover y 0–30 m, rows 10 to 40, and all columns.
        assert_eq!((sink.width, sink.height), (41, 41));
        for y in 10..=40 {
            for x in 0..=40 {
                assert_eq!(img.get(x, y), ground, "({x}, {y})");
            }
        }
        // North of the data: no data.
        for x in 0..=40 {
            assert!(crate::render::NO_DATA.contains(&img.get(x, 9)), "({x}, 9)");
        }
    }
}
