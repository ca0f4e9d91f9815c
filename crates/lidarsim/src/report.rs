//! `report.html`: one self-contained page per run — survey parameters, the
//! figures of `summary.json`, top views by height, intensity and class, a
//! cross-section, returns per pulse, the point density against the plan,
//! the flight (attitude against time, observed against true trajectory),
//! the points' georeferencing errors when the survey has navigation
//! errors, and sample waveforms — with every picture embedded, so it opens
//! in any browser without a network.
//!
//! The pictures are accumulated while the points stream past
//! ([`ReportSink`] is a [`PointSink`]): per pixel the highest point and a
//! count, on at most 500 000 pixels (coarser for large areas), so memory is
//! bounded whatever the area or the length of the flight. The flight plots
//! are computed from the survey alone.

use std::fmt::Write as _;
use std::io;

use crate::geometry::{Aabb, DVec3};
use crate::output::{PointRecord, PointSink};
use crate::render::{
    ColorBy, Image, Palette, RenderPoint, Series, WaveformPlot, class_color, fixed, framed,
    hole_source, no_data,
};
use crate::sensor::platform::FlightLine;
use crate::summary::Summary;
use crate::survey::Survey;

/// Largest number of pixels of the report's maps.
const MAX_PIXELS: usize = 500_000;
/// Side of the cells of the density map, m.
const DENSITY_CELL_M: f64 = 5.0;
/// Largest number of points kept for the cross-section.
const MAX_PROFILE_POINTS: usize = 200_000;
/// Height of the cross-section's plot, px.
const PROFILE_HEIGHT_PX: usize = 300;
/// Samples of the flight plots (about one per pixel column).
const FLIGHT_SAMPLES: usize = 900;

/// Georeferencing errors of points (computed minus true position,
/// [`PointRecord::error_m`]), summed as the points pass.
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

/// Collects what the report shows while points are written.
#[derive(Debug, PartialEq)]
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
    fn filled(&self, k: usize) -> bool {
        self.top_z[k] > f32::NEG_INFINITY
    }

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

/// The pulse shape in words: "Gaussian, 4.0 ns FWHM".
fn pulse_words(p: &crate::waveform::PulseShape) -> String {
    use crate::waveform::PulseShape;
    let name = match p {
        PulseShape::Gaussian { .. } => "Gaussian",
        PulseShape::RiseTail { .. } => "rise-tail (fast rise, long tail)",
    };
    format!("{name}, {} ns FWHM", fixed(p.fwhm_s() * 1e9, 1))
}

/// The mirror's motion in words.
fn mirror_words(m: &crate::sensor::scanner::MirrorProfile) -> &'static str {
    match m {
        crate::sensor::scanner::MirrorProfile::Triangle => "triangle (constant angular speed)",
        crate::sensor::scanner::MirrorProfile::Sine => "sine",
    }
}

/// "1st", "2nd", "3rd", "4th", …
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (1, x) if x != 11 => "st",
        (2, x) if x != 12 => "nd",
        (3, x) if x != 13 => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

/// For each flight line, about [`FLIGHT_SAMPLES`] over the whole survey:
/// the time since the survey's start and the time since the line's start,
/// s (both ends of the line included).
fn flight_samples(lines: &[FlightLine]) -> Vec<(&FlightLine, Vec<(f64, f64)>)> {
    let total: f64 = lines.iter().map(|l| l.duration_s()).sum();
    let dt = (total / FLIGHT_SAMPLES as f64).max(1e-6);
    lines
        .iter()
        .map(|l| {
            let d = l.duration_s();
            let n = ((d / dt).ceil() as usize).clamp(1, FLIGHT_SAMPLES);
            let ts = (0..=n)
                .map(|j| {
                    let t = d * j as f64 / n as f64;
                    (l.start_time_s + t, t)
                })
                .collect();
            (l, ts)
        })
        .collect()
}

/// Angles of a run made continuous (no jump of 360° where a heading
/// crosses ±180°), degrees.
fn unwrapped(run: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(run.len());
    for (t, v) in run {
        let v = match out.last() {
            Some(&(_, prev)) => v + 360.0 * ((prev - v) / 360.0).round(),
            None => v,
        };
        out.push((t, v));
    }
    out
}

const SERIES_COLORS: [[u8; 3]; 3] = [[31, 119, 180], [214, 39, 40], [44, 160, 44]];

/// Roll ω, pitch φ and yaw κ of the true trajectory against the time since
/// the survey's start (specification Fig. 10), one panel each; yaw less
/// the line's heading, so that lines flown in opposite directions show
/// their sway on one scale.
pub fn attitude_plot(lines: &[FlightLine]) -> Image {
    let samples = flight_samples(lines);
    let names = [
        "ROLL (OMEGA) DEG",
        "PITCH (PHI) DEG",
        "YAW (KAPPA) - LINE HEADING DEG",
    ];
    let series: Vec<Series> = (0..3)
        .map(|axis| Series {
            title: names[axis].to_string(),
            color: SERIES_COLORS[axis],
            runs: samples
                .iter()
                .map(|(l, ts)| {
                    unwrapped(
                        ts.iter()
                            .map(|&(abs, t)| {
                                let a = l.pose_at(t).attitude;
                                let yaw = (a.yaw_rad - l.heading_rad()).to_degrees();
                                let v = [a.roll_rad.to_degrees(), a.pitch_rad.to_degrees(), yaw];
                                // Yaw within ±180°, then made continuous.
                                let v = if axis == 2 {
                                    (v[2] + 180.0).rem_euclid(360.0) - 180.0
                                } else {
                                    v[axis]
                                };
                                (abs, v)
                            })
                            .collect(),
                    )
                })
                .collect(),
        })
        .collect();
    crate::render::time_panels(&series)
}

/// The observed trajectory (what the GNSS/IMU measured, without its
/// per-pulse white noise) minus the true one against the time since the
/// survey's start: position x, y, z (m) in one picture and roll, pitch,
/// yaw (degrees) in the other.
pub fn trajectory_error_plots(survey: &Survey, lines: &[FlightLine]) -> (Image, Image) {
    let samples = flight_samples(lines);
    let diffs: Vec<Vec<(f64, [f64; 6])>> = samples
        .iter()
        .map(|(l, ts)| {
            ts.iter()
                .map(|&(abs, t)| {
                    let truth = l.pose_at(t);
                    let seen = crate::sensor::navigation::observed_pose(
                        &truth,
                        &survey.navigation,
                        &l.nav_errors,
                        t,
                        None,
                    );
                    let d = seen.position_m - truth.position_m;
                    let (a, b) = (seen.attitude, truth.attitude);
                    (
                        abs,
                        [
                            d.x,
                            d.y,
                            d.z,
                            (a.roll_rad - b.roll_rad).to_degrees(),
                            (a.pitch_rad - b.pitch_rad).to_degrees(),
                            (a.yaw_rad - b.yaw_rad).to_degrees(),
                        ],
                    )
                })
                .collect()
        })
        .collect();
    let series = |k: usize, title: &str| Series {
        title: title.to_string(),
        color: SERIES_COLORS[k % 3],
        runs: diffs
            .iter()
            .map(|run| run.iter().map(|(t, v)| (*t, v[k])).collect())
            .collect(),
    };
    (
        crate::render::time_panels(&[series(0, "X M"), series(1, "Y M"), series(2, "Z M")]),
        crate::render::time_panels(&[
            series(3, "ROLL DEG"),
            series(4, "PITCH DEG"),
            series(5, "YAW DEG"),
        ]),
    )
}

/// The whole page.
pub fn html(
    survey: &Survey,
    lines: &[FlightLine],
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
         <tr><th>mirror</th><td>{}, {} Hz, ±{:.2}°</td></tr>\
         <tr><th>beam</th><td>{:.3} mrad, {} sub-rays</td></tr>\
         <tr><th>pulse</th><td>{}</td></tr>\
         <tr><th>flight lines</th><td>{}</td></tr>\
         <tr><th>scene primitives</th><td>{}</td></tr></table>",
        esc(&survey
            .source
            .as_ref()
            .map_or_else(|| "built-in demo".to_string(), |p| p.display().to_string())),
        summary.seed,
        s.prf_hz,
        mirror_words(&s.mirror.profile),
        s.mirror.scan_frequency_hz,
        s.mirror.scan_half_angle_rad.to_degrees(),
        s.divergence_rad * 1e3,
        s.subrays,
        pulse_words(&survey.receiver.pulse),
        lines.len(),
        summary.scene_primitives
    );
    let _ = write!(h, "<h2>Summary</h2><table>");
    let by_return = summary
        .points_by_return
        .iter()
        .enumerate()
        .map(|(i, n)| format!("{} return: {n}", ordinal(i + 1)))
        .collect::<Vec<_>>()
        .join(", ");
    let rows = [
        ("pulses", summary.pulses.to_string()),
        ("points", summary.points.to_string()),
        ("pulses with an echo", summary.pulses_with_echo.to_string()),
        ("points by return", by_return),
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
    let (heights, intensities) = (
        sink.height_palette().range(),
        sink.intensity_palette().range(),
    );
    let _ = write!(
        h,
        "<h2>Top views</h2><p>Highest point per {:.2} m pixel; hatched grey where no point fell \
         (one-pixel gaps between scan lines take a neighbour's colour). Height and intensity \
         colours run from the 0.1st to the 99.9th percentile of the pixels (heights {} m to {} \
         m, intensities {} to {}); the few pixels beyond take the end colours, as the arrows on \
         the colour bar show.</p>{}{}{}",
        sink.resolution_m(),
        fixed(heights.0, 2),
        fixed(heights.1, 2),
        fixed(intensities.0, 0),
        fixed(intensities.1, 0),
        img_tag(&sink.height_map(), "top view by height")?,
        img_tag(&sink.intensity_map(), "top view by intensity")?,
        img_tag(&sink.class_map(), "top view by class")?
    );
    let span = match sink.profile_heights() {
        Some((lo, hi)) => format!(
            " Its points lie from {} m to {} m; heights are stretched to fill the picture (the \
             exaggeration is written under it).",
            fixed(lo, 2),
            fixed(hi, 2)
        ),
        None => " No point lies in it.".to_string(),
    };
    let _ = write!(
        h,
        "<h2>Cross-section</h2><p>West to east through the middle, 2 m wide, by class.{span}</p>{}",
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
    flight_section(&mut h, survey, lines, sink)?;
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

/// The flight: attitude against time and, with navigation errors, the
/// observed minus true trajectory and the points' georeferencing errors.
fn flight_section(
    h: &mut String,
    survey: &Survey,
    lines: &[FlightLine],
    sink: &ReportSink,
) -> io::Result<()> {
    if lines.is_empty() {
        return Ok(());
    }
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let clock = if offset == 0.0 {
        "the GPS time of the points".to_string()
    } else {
        format!("their GPS time − {offset} s")
    };
    let _ = write!(
        h,
        "<h2>Flight</h2><p>Attitude of the aircraft as flown (roll ω, pitch φ, and yaw κ less \
         the line's heading, degrees) against the time since the survey's start ({clock}); \
         the turns between flight lines are left out.</p>{}",
        img_tag(&attitude_plot(lines), "attitude against time")?
    );
    if survey.navigation.is_zero() {
        let _ = write!(
            h,
            "<p>The survey has no navigation errors: the observed trajectory is the true one \
             and the points carry no georeferencing error.</p>"
        );
        return Ok(());
    }
    let (position, attitude) = trajectory_error_plots(survey, lines);
    let _ = write!(
        h,
        "<h3>Observed − true trajectory</h3><p>What the GNSS/IMU measured minus the path \
         flown: biases and correlated errors (the white noise of each pulse comes on top). \
         Position in m:</p>{}<p>Attitude in degrees:</p>{}",
        img_tag(&position, "observed minus true position")?,
        img_tag(&attitude, "observed minus true attitude")?
    );
    let e = &sink.errors;
    if e.count == 0 {
        return Ok(());
    }
    let m = |v: f64| format!("{} m", fixed(v, 3));
    let [rx, ry, rz] = e.rms_m();
    let [mx, my, mz] = e.mean_m();
    let rows = [
        ("points", e.count.to_string()),
        (
            "RMS error x, y, z",
            format!("{}, {}, {} m", fixed(rx, 3), fixed(ry, 3), fixed(rz, 3)),
        ),
        ("RMS horizontal error", m(e.rms_horizontal_m())),
        ("RMS vertical error", m(rz)),
        ("largest horizontal error", m(e.max_horizontal_m)),
        ("largest vertical error", m(e.max_vertical_m)),
        (
            "mean error vector (x, y, z)",
            format!("({}, {}, {}) m", fixed(mx, 3), fixed(my, 3), fixed(mz, 3)),
        ),
    ];
    let _ = write!(
        h,
        "<h3>Georeferencing errors of the points</h3><p>Computed minus true position of every \
         point (the error_x, error_y, error_z extra bytes of points.las), over all points.</p>\
         <table>"
    );
    for (k, v) in rows {
        let _ = write!(h, "<tr><th>{k}</th><td>{}</td></tr>", esc(&v));
    }
    let _ = write!(h, "</table>");
    Ok(())
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

    /// A point of pulse `pulse` of line `line` (0-based) at `(x, y, z)`,
    /// return `n` of `of`, with georeferencing error `error`.
    fn rec(
        (x, y, z): (f64, f64, f64),
        error: DVec3,
        (n, of): (u8, u8),
        (line, pulse): (u16, u64),
    ) -> PointRecord {
        PointRecord {
            position_m: DVec3::new(x, y, z),
            gps_time_s: 0.0,
            intensity: 100,
            amplitude: 0.0,
            echo_width_ns: 4.0,
            range_m: 100.0,
            beam_dir: -DVec3::Z,
            error_m: error,
            return_number: n,
            number_of_returns: of,
            scan_direction_positive: true,
            edge_of_flight_line: false,
            scan_angle_deg: 0.0,
            classification: 2,
            point_source_id: line + 1,
            pulse_index: pulse,
            object_id: 0,
            component: 0,
            incidence_angle_deg: Some(0.0),
            echo_time_ps: 0.0,
        }
    }

    fn area(w: f64, h: f64) -> Aabb {
        Aabb {
            min: DVec3::new(0.0, 0.0, 0.0),
            max: DVec3::new(w, h, 0.0),
        }
    }

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

    /// The page of a short survey with navigation errors and a height
    /// that dips just below zero: human words for the pulse and mirror, no
    /// "-0.0", the flight plots and the error statistics.
    #[test]
    fn the_page_shows_flight_and_errors_in_words() {
        let text = r#"seed = 5
preset = "uav"
[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15
subrays = 3
[[flight_line]]
start_m = [0.0, -15.0, 300.0]
end_m = [0.0, 15.0, 300.0]
speed_mps = 50.0
[[flight_line]]
start_m = [30.0, 15.0, 300.0]
end_m = [30.0, -15.0, 300.0]
speed_mps = 50.0
[output]
formats = ["xyz"]
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, -0.04], [300, -300, -0.04], [300, 300, -0.04], [-300, 300, -0.04]]
"#;
        let survey = Survey::from_toml(text, None).unwrap();
        let dir = std::env::temp_dir().join(format!("lidarsim-report-page-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let progress = |_| {};
        crate::run::run_to_dir(&survey, &dir, &crate::run::RunOptions::new(1, &progress)).unwrap();
        let page = std::fs::read_to_string(dir.join("report.html")).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        for words in [
            "Gaussian, 4.0 ns FWHM",
            "triangle (constant angular speed)",
            "1st return:",
            "alt=\"attitude against time\"",
            "alt=\"observed minus true position\"",
            "alt=\"observed minus true attitude\"",
            "Georeferencing errors of the points",
            "RMS horizontal error",
        ] {
            assert!(page.contains(words), "no '{words}'");
        }
        for bad in ["fwhm_s", "Triangle", "-0.0 ", "-0.00 ", "[", "{ "] {
            let text_only: String = page
                .split("<img")
                .map(|part| part.split_once('>').map_or(part, |(_, rest)| rest))
                .collect();
            assert!(!text_only.contains(bad), "'{bad}' in the page");
        }
        // The single-echo pulse is shown once.
        assert_eq!(page.matches("<h3>Line ").count(), 1, "one sample pulse");
    }
}
