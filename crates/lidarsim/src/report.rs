//! `report.html`: one self-contained page per run — survey parameters, the
//! figures of `summary.json`, top views by height, intensity and class, a
//! cross-section, returns per pulse, the point density against the plan,
//! and sample waveforms — with every picture embedded, so it opens in any
//! browser without a network.
//!
//! The pictures are accumulated while the points stream past
//! ([`ReportSink`] is a [`PointSink`]): per pixel the highest point and a
//! count, on at most 500 000 pixels (coarser for large areas), so memory is
//! bounded whatever the area or the length of the flight.

use std::fmt::Write as _;
use std::io;

use crate::geometry::Aabb;
use crate::output::{PointRecord, PointSink};
use crate::render::{ColorBy, Image, Palette, RenderPoint, WaveformPlot, class_color, framed};
use crate::run::Summary;
use crate::survey::Survey;

/// Largest number of pixels of the report's maps.
const MAX_PIXELS: usize = 500_000;
/// Side of the cells of the density map, m.
const DENSITY_CELL_M: f64 = 5.0;
/// Largest number of points kept for the cross-section.
const MAX_PROFILE_POINTS: usize = 200_000;
/// Height of the cross-section's plot, px.
const PROFILE_HEIGHT_PX: usize = 300;

/// Collects what the report shows while points are written.
#[derive(Debug)]
pub struct ReportSink {
    x0: f64,
    y0: f64,
    resolution_m: f64,
    width: usize,
    height: usize,
    top_z: Vec<f32>,
    top_intensity: Vec<u16>,
    top_class: Vec<u8>,
    count: Vec<u32>,
    /// Pulses by number of returns (index = returns, 1–15).
    pub returns_per_pulse: [u64; 16],
    /// Cross-section band: along x at `profile_y`, 2 m wide.
    profile_y: f64,
    profile: Vec<RenderPoint>,
    /// A pulse with the most returns seen: (line index, pulse index, returns).
    pub richest_pulse: Option<(u32, u64, u8)>,
    /// A pulse with a single return.
    pub single_pulse: Option<(u32, u64)>,
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

    /// A map from the per-pixel data; empty pixels stay grey.
    fn map(&self, color: impl Fn(usize) -> Option<[u8; 3]>) -> Image {
        let mut img = Image::new(self.width, self.height, crate::render::EMPTY);
        for k in 0..self.width * self.height {
            if let Some(c) = color(k) {
                img.set(k % self.width, k / self.width, c);
            }
        }
        img
    }

    /// Top view by height.
    pub fn height_map(&self) -> Image {
        let filled = |k: usize| self.top_z[k] > f32::NEG_INFINITY;
        let range = crate::render::robust_range(
            (0..self.top_z.len())
                .filter(|&k| filled(k))
                .map(|k| f64::from(self.top_z[k]))
                .collect(),
        );
        let p = Palette::bar(ColorBy::Height, range);
        let map = self.map(|k| filled(k).then(|| p.bar_color(f64::from(self.top_z[k]))));
        framed(&map, &p, self.resolution_m)
    }

    /// Top view by intensity.
    pub fn intensity_map(&self) -> Image {
        let filled = |k: usize| self.top_z[k] > f32::NEG_INFINITY;
        let range = crate::render::robust_range(
            (0..self.top_z.len())
                .filter(|&k| filled(k))
                .map(|k| f64::from(self.top_intensity[k]))
                .collect(),
        );
        let p = Palette::bar(ColorBy::Intensity, range);
        let map = self.map(|k| filled(k).then(|| p.bar_color(f64::from(self.top_intensity[k]))));
        framed(&map, &p, self.resolution_m)
    }

    /// Top view by class.
    pub fn class_map(&self) -> Image {
        let mut classes: Vec<u8> = (0..self.top_z.len())
            .filter(|&k| self.top_z[k] > f32::NEG_INFINITY)
            .map(|k| self.top_class[k])
            .collect();
        classes.sort_unstable();
        classes.dedup();
        let p = Palette::classes(&classes);
        let map = self
            .map(|k| (self.top_z[k] > f32::NEG_INFINITY).then(|| class_color(self.top_class[k]).0));
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
        let p = Palette::bar(ColorBy::Intensity, (0.0, top)).titled("POINTS/M²");
        let map = self.map(|k| {
            let c = cells[(k / self.width / b) * cw + (k % self.width) / b];
            (c > 0).then(|| p.bar_color(c as f64 / area))
        });
        (framed(&map, &p, self.resolution_m), median)
    }

    /// Cross-section along x through the middle of the area, 2 m wide, by
    /// class, its heights stretched to fill the picture.
    pub fn profile_image(&self) -> Image {
        let x1 = self.x0 + self.width as f64 * self.resolution_m;
        crate::render::profile_exaggerated(
            &self.profile,
            (self.x0, self.profile_y),
            (x1, self.profile_y),
            2.0,
            ColorBy::Class,
            ((x1 - self.x0) / 1200.0).max(0.1),
            PROFILE_HEIGHT_PX,
        )
    }
}

/// First bytes of a saved [`ReportSink`] state (format version 1).
const STATE_MAGIC: &[u8; 8] = b"LSREPRT1";

impl ReportSink {
    /// Writes everything the sink has gathered, so that an interrupted run
    /// can continue it with [`ReportSink::restore`] (little-endian binary:
    /// the grid, the per-pixel arrays, the histogram, the cross-section
    /// points and the two sample pulses).
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
            });
        }
        let (flag, line, pulse, n) = (r.u8()?, r.u32()?, r.u64()?, r.u8()?);
        self.richest_pulse = (flag == 1).then_some((line, pulse, n));
        let (flag, line, pulse) = (r.u8()?, r.u32()?, r.u64()?);
        self.single_pulse = (flag == 1).then_some((line, pulse));
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
            if p.return_number == 1 {
                self.returns_per_pulse[usize::from(p.number_of_returns.min(15))] += 1;
                let line = u32::from(p.point_source_id).saturating_sub(1);
                if self.richest_pulse.is_none_or(|r| p.number_of_returns > r.2) {
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

/// Standard base64 (RFC 4648) of `bytes`.
pub fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= c.len() {
                out.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn img_tag(img: &Image, alt: &str) -> io::Result<String> {
    Ok(format!(
        "<img alt=\"{alt}\" src=\"data:image/png;base64,{}\">",
        base64(&img.to_png()?)
    ))
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The whole page.
pub fn html(
    survey: &Survey,
    summary: &Summary,
    sink: &ReportSink,
    waveforms: &[(String, WaveformPlot)],
) -> io::Result<String> {
    let mut h = String::new();
    let s = &survey.scanner;
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>lidarsim report</title>\
         <style>body{{font-family:sans-serif;margin:2em;max-width:1400px}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 8px;text-align:left}}\
         img{{max-width:100%;border:1px solid #ddd}}.bar{{background:#3b528b;height:14px}}</style>\
         </head><body><h1>lidarsim report</h1>"
    );
    let _ = write!(
        h,
        "<h2>Survey</h2><table>\
         <tr><th>source</th><td>{}</td></tr>\
         <tr><th>seed</th><td>{}</td></tr>\
         <tr><th>PRF</th><td>{} Hz</td></tr>\
         <tr><th>mirror</th><td>{:?}, {} Hz, ±{:.2}°</td></tr>\
         <tr><th>beam</th><td>{:.3} mrad, {} sub-rays</td></tr>\
         <tr><th>pulse</th><td>{:?}</td></tr>\
         <tr><th>flight lines</th><td>{}</td></tr>\
         <tr><th>scene primitives</th><td>{}</td></tr></table>",
        esc(&survey
            .source
            .as_ref()
            .map_or_else(|| "built-in demo".to_string(), |p| p.display().to_string())),
        summary.seed,
        s.prf_hz,
        s.mirror.profile,
        s.mirror.scan_frequency_hz,
        s.mirror.scan_half_angle_rad.to_degrees(),
        s.divergence_rad * 1e3,
        s.subrays,
        survey.receiver.pulse,
        survey.lines.len(),
        summary.scene_primitives
    );
    let _ = write!(h, "<h2>Summary</h2><table>");
    let rows = [
        ("pulses", summary.pulses.to_string()),
        ("points", summary.points.to_string()),
        ("pulses with an echo", summary.pulses_with_echo.to_string()),
        (
            "points by return",
            format!("{:?}", summary.points_by_return),
        ),
        ("expected swath", format!("{:.1} m", summary.swath_width_m)),
        (
            "expected density (one line)",
            format!("{:.2} /m²", summary.point_density_per_m2),
        ),
        (
            "footprint at nadir",
            format!("{:.3} m", summary.footprint_diameter_m),
        ),
        (
            "wall time",
            format!(
                "{:.2} s on {} thread(s)",
                summary.wall_time_s, summary.threads
            ),
        ),
        (
            "pulses per second",
            format!("{:.0}", summary.pulses_per_second),
        ),
        ("GPS time", summary.gps_time.to_string()),
    ];
    for (k, v) in rows {
        let _ = write!(h, "<tr><th>{k}</th><td>{}</td></tr>", esc(&v));
    }
    let _ = write!(h, "</table>");
    for w in &summary.warnings {
        let _ = write!(h, "<p><b>warning:</b> {}</p>", esc(w));
    }
    let _ = write!(
        h,
        "<h2>Top views</h2><p>Highest point per {:.2} m pixel.</p>{}{}{}",
        sink.resolution_m(),
        img_tag(&sink.height_map(), "top view by height")?,
        img_tag(&sink.intensity_map(), "top view by intensity")?,
        img_tag(&sink.class_map(), "top view by class")?
    );
    let _ = write!(
        h,
        "<h2>Cross-section</h2><p>West to east through the middle, 2 m wide, by class.</p>{}",
        img_tag(&sink.profile_image(), "cross-section")?
    );
    let total: u64 = sink.returns_per_pulse.iter().sum();
    let _ = write!(
        h,
        "<h2>Returns per pulse</h2><table><tr><th>returns</th><th>pulses</th><th></th></tr>"
    );
    for (n, &c) in sink.returns_per_pulse.iter().enumerate().skip(1) {
        if c == 0 {
            continue;
        }
        let pct = 100.0 * c as f64 / total.max(1) as f64;
        let _ = write!(
            h,
            "<tr><td>{n}</td><td>{c} ({pct:.1} %)</td><td><div class=\"bar\" style=\"width:{:.0}px\"></div></td></tr>",
            4.0 * pct
        );
    }
    let _ = write!(h, "</table>");
    let (density, mean) = sink.density_map(summary.point_density_per_m2);
    let _ = write!(
        h,
        "<h2>Point density</h2><p>All returns per m², colour bar from 0 to at least twice the planned \
         single-line density of {:.2} /m² (overlapping lines add up). Median over cells of about \
         5 m with points: {:.2} /m².</p>{}",
        summary.point_density_per_m2,
        mean,
        img_tag(&density, "point density")?
    );
    if !waveforms.is_empty() {
        let _ = write!(h, "<h2>Sample waveforms</h2>");
        for (title, plot) in waveforms {
            let _ = write!(
                h,
                "<h3>{}</h3>{}",
                esc(title),
                img_tag(&plot.render(), title)?
            );
        }
    }
    let _ = writeln!(h, "</body></html>");
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::DVec3;

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
                    object_id: 0,
                    component: 0,
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
        assert_eq!(sink.single_pulse, Some((0, 0)));
    }

    #[test]
    fn base64_matches_rfc_4648_examples() {
        // RFC 4648, section 10.
        for (raw, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(raw.as_bytes()), enc);
        }
    }
}
