//! The scan pattern: where the pulses of the first scan lines meet level
//! ground, seen from above and coloured by time — computed from the survey
//! alone (deflector, channels, PRF and the first line's speed and height),
//! so that each kind of scanner shows its own picture: zig-zag lines, one-way
//! parallel lines, overlapping ellipses, a rosette, a fixed fan.

use crate::geometry::DVec3;
use crate::render::{Anchor, Figure, Image, LABEL_PX, TITLE_PX, fixed, ramp};
use crate::sensor::channel::FiringOrder;
use crate::survey::Survey;

/// Width and height of the dots' area, px.
const PLOT_W: usize = 760;
/// Height of the dots' area, px.
const PLOT_H: usize = 360;
/// Room left of the dots for the along-track axis, px.
const LEFT: usize = 70;
/// Room above the dots for the title, px.
const TOP: usize = 28;
/// Room under the dots for the across-track axis, px.
const BOTTOM: usize = 46;
/// Most dots drawn.
const MAX_DOTS: usize = 20_000;
/// Share of the plot's height the pattern fills at least: a pattern much
/// longer across than along (a 291 m swath over 3.6 m of flight) is
/// stretched along the track, and the picture says by how much.
const MIN_FILL: f64 = 0.6;

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

/// The picture of [`pattern_points`]: across the track left to right,
/// along it upwards, at one scale unless the pattern is too short along
/// the track to be seen (then stretched along it to fill at least 60 %
/// of the height, and the title says by how much).
pub fn scan_pattern_plot(survey: &Survey, height_m: f64, speed_mps: f64) -> Figure {
    let pts = pattern_points(survey, height_m, speed_mps);
    let ink = [20, 20, 20];
    let mut fig = Figure::new(LEFT + PLOT_W + 20, TOP + PLOT_H + BOTTOM, [255, 255, 255]);
    if pts.is_empty() {
        let y = (TOP + PLOT_H / 2) as f64;
        fig.text(
            LEFT as f64,
            y,
            "no pulse meets the ground",
            TITLE_PX,
            Anchor::Start,
            ink,
        );
        return fig;
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y, _) in &pts {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    let (ex, ey) = ((x1 - x0).max(1e-6), (y1 - y0).max(1e-6));
    let (w, h) = ((PLOT_W - 4) as f64, (PLOT_H - 4) as f64);
    let scale = (w / ex).min(h / ey);
    // Along the track: at least MIN_FILL of the height.
    let scale_y = scale.max((MIN_FILL * h / ey).min(h / ey));
    let stretch = scale_y / scale;
    let t_max = pts.last().map_or(1.0, |p| p.2).max(1e-9);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let col = |x: f64| PLOT_W as f64 / 2.0 + (x - cx) * scale;
    let row = |y: f64| PLOT_H as f64 / 2.0 - (y - cy) * scale_y;
    let mut dots = Image::new(PLOT_W, PLOT_H, [255, 255, 255]);
    for &(x, y, t) in &pts {
        let (px, py) = (
            col(x).round().max(0.0) as usize,
            row(y).round().max(0.0) as usize,
        );
        dots.fill(
            px.min(PLOT_W - 2),
            py.min(PLOT_H - 2),
            2,
            2,
            ramp(t / t_max),
        );
    }
    fig.raster(LEFT, TOP, dots);
    // Axes: metres across (from the track) and along (from the first pulse).
    let (left, bottom) = (LEFT as f64 - 1.0, (TOP + PLOT_H) as f64);
    fig.line(
        vec![
            (left, TOP as f64),
            (left, bottom),
            (left + PLOT_W as f64, bottom),
        ],
        ink,
    );
    let (ticks, d) = crate::render::nice_ticks(x0, x1, 8);
    for v in ticks {
        let x = LEFT as f64 + col(v);
        fig.line(vec![(x, bottom), (x, bottom + 4.0)], ink);
        fig.text(x, bottom + 6.0, &fixed(v, d), LABEL_PX, Anchor::Middle, ink);
    }
    let (ticks, d) = crate::render::nice_ticks(y0, y1, 5);
    for v in ticks {
        let y = TOP as f64 + row(v);
        fig.line(vec![(left - 4.0, y), (left, y)], ink);
        fig.text(
            left - 6.0,
            y - 0.6 * LABEL_PX,
            &fixed(v, d),
            LABEL_PX,
            Anchor::End,
            ink,
        );
    }
    let across = "across the track (right of it), m";
    fig.text(
        LEFT as f64 + PLOT_W as f64 / 2.0,
        bottom + 24.0,
        across,
        TITLE_PX,
        Anchor::Middle,
        ink,
    );
    fig.vertical_text(
        4.0,
        TOP as f64 + PLOT_H as f64 / 2.0,
        "along the track, m",
        TITLE_PX,
        ink,
    );
    let scale_note = if stretch > 1.01 {
        format!(
            "; along-track stretched ×{}",
            fixed(stretch, if stretch < 10.0 { 1 } else { 0 })
        )
    } else {
        "; one scale in both directions".to_string()
    };
    let title = format!(
        "{} m across, {} m along, first {} ms, colour: time{scale_note}",
        fixed(ex, 0),
        fixed(ey, 1),
        fixed(t_max * 1e3, 0)
    );
    fig.text(LEFT as f64, 6.0, &title, TITLE_PX, Anchor::Start, ink);
    fig
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
        let img = scan_pattern_plot(&s, 100.0, 50.0).to_image();
        assert_eq!(
            (img.width, img.height),
            (LEFT + PLOT_W + 20, TOP + PLOT_H + BOTTOM)
        );
        // A Palmer scanner: every point on the circle about the moving
        // nadir point.
        let s = survey("deflector = \"palmer\"\nscan_angle_deg = 20\nscan_frequency_hz = 50");
        let r = 100.0 * 20f64.to_radians().tan();
        for (x, y, t) in pattern_points(&s, 100.0, 50.0) {
            assert!(((x).hypot(y - 50.0 * t) - r).abs() < 1e-9);
        }
    }
}
