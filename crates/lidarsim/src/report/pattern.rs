//! The scan pattern: where the pulses of the first scan lines meet level
//! ground, seen from above and coloured by time — computed from the survey
//! alone (deflector, channels, PRF and the first line's speed and height),
//! so that each kind of scanner shows its own picture: zig-zag lines, one-way
//! parallel lines, overlapping ellipses, a rosette, a fixed fan.

use crate::geometry::DVec3;
use crate::render::{Image, ramp};
use crate::sensor::channel::FiringOrder;
use crate::survey::Survey;

/// Side of the picture, px.
const SIZE: usize = 560;
/// Margin for the labels, px.
const MARGIN: usize = 40;
/// Most dots drawn.
const MAX_DOTS: usize = 20_000;

/// The pattern's ground points: (right of the track, along it, time), m
/// and s, over about six scan lines (50 ms of a Risley rosette, at most
/// 0.25 s), flying at `speed_mps` `height_m` above level ground.
pub fn pattern_points(survey: &Survey, height_m: f64, speed_mps: f64) -> Vec<(f64, f64, f64)> {
    let s = &survey.scanner;
    let lines = s.deflector.lines_per_s();
    let span_s = if lines > 0.0 { 6.0 / lines } else { 0.05 }.min(0.25);
    let pulses = (span_s * s.prf_hz).ceil() as u64;
    let stride = pulses.div_ceil(MAX_DOTS as u64).max(1);
    let mounts: Vec<_> = s.channels.iter().map(|c| c.mount()).collect();
    let firing = FiringOrder::new(&s.channels);
    let mut out = Vec::new();
    for k in (0..pulses).step_by(stride as usize) {
        let t = k as f64 / s.prf_hz;
        if !s.deflector.emits_at(t) {
            continue;
        }
        let d: DVec3 = mounts[firing.channel_of(k)] * s.deflector.direction_at(t);
        // Beams more than 80° from nadir meet level ground far away, or
        // never.
        if d.z < 0.17 {
            continue;
        }
        // Scanner x points left of the track, y along it, z down.
        out.push((
            -d.x / d.z * height_m,
            d.y / d.z * height_m + speed_mps * t,
            t,
        ));
    }
    out
}

/// The picture of [`pattern_points`], at one scale in both directions.
pub fn scan_pattern_plot(survey: &Survey, height_m: f64, speed_mps: f64) -> Image {
    let pts = pattern_points(survey, height_m, speed_mps);
    let mut img = Image::new(SIZE, SIZE, [255, 255, 255]);
    let ink = [20, 20, 20];
    if pts.is_empty() {
        img.text(MARGIN, SIZE / 2, "NO PULSE MEETS THE GROUND", ink);
        return img;
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y, _) in &pts {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let t_max = pts.last().map_or(1.0, |p| p.2).max(1e-9);
    let inner = (SIZE - 2 * MARGIN) as f64;
    let scale = inner / (x1 - x0).max(y1 - y0).max(1e-6);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    for &(x, y, t) in &pts {
        let px = (SIZE as f64 / 2.0 + (x - cx) * scale).round() as usize;
        let py = (SIZE as f64 / 2.0 - (y - cy) * scale).round() as usize;
        img.fill(px.min(SIZE - 2), py.min(SIZE - 2), 2, 2, ramp(t / t_max));
    }
    img.text(
        MARGIN,
        12,
        &format!(
            "{:.0} M ACROSS, {:.1} M ALONG, FIRST {:.0} MS",
            x1 - x0,
            y1 - y0,
            t_max * 1e3
        ),
        ink,
    );
    img.text(MARGIN, SIZE - 20, "FLIGHT DIRECTION UP, COLOUR: TIME", ink);
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    fn survey(scanner: &str) -> Survey {
        Survey::from_toml(
            &format!(
                "[scanner]\n{scanner}\n[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 100, 100]\n\
                 speed_mps = 50\n"
            ),
            None,
        )
        .unwrap()
    }

    /// The pattern's across-track extent is the swath `2H·tan θ`; a
    /// polygon's points all run left to right within a line.
    #[test]
    fn the_pattern_spans_the_swath() {
        let s = survey(
            "deflector = \"polygon\"\nfacets = 8\nscan_angle_deg = 30\nscan_frequency_hz = 100",
        );
        let pts = pattern_points(&s, 100.0, 50.0);
        let max = pts.iter().map(|p| p.0.abs()).fold(0.0, f64::max);
        let swath_half = 100.0 * 30f64.to_radians().tan();
        assert!(max <= swath_half + 1e-9 && max > 0.97 * swath_half, "{max}");
        let img = scan_pattern_plot(&s, 100.0, 50.0);
        assert_eq!((img.width, img.height), (SIZE, SIZE));
        // A Palmer scanner: every point on the circle about the moving
        // nadir point.
        let s = survey("deflector = \"palmer\"\nscan_angle_deg = 20\nscan_frequency_hz = 50");
        let r = 100.0 * 20f64.to_radians().tan();
        for (x, y, t) in pattern_points(&s, 100.0, 50.0) {
            assert!(((x).hypot(y - 50.0 * t) - r).abs() < 1e-9);
        }
    }
}
