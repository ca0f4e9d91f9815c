//! The flight lines of a survey: its `[[flight_line]]` entries as given,
//! a `[plan]`'s lines at their altitude over the ground of the index, or
//! the lines of a trajectory file; each timed, with its sway, drift and
//! navigation errors.

use std::sync::Arc;

use crate::accel::{Bvh, ground_below};
use crate::geometry::{Aabb, DVec3};
use crate::message::num;
use crate::sensor::navigation::LineErrors;
use crate::sensor::platform::{Drift, FlightLine, Sway, plan_lines};
use crate::survey::{KeyPath, MAX_LINE_HOURS, Survey};

/// The flight lines of `survey` in flight order, adding problems (a
/// generated line too long, a trajectory file that cannot be read) to
/// `problems`.
pub(super) fn flight_lines(
    survey: &Survey,
    index: &Bvh,
    problems: &mut Vec<(KeyPath, String)>,
) -> Vec<FlightLine> {
    let root = KeyPath::root();
    let spec = &survey.line_spec;
    let seed = survey.seed;
    let mut straight = spec.straight.clone();
    if let Some(plan) = &spec.plan {
        // Flying height above the ground at the area's centre.
        let n = plan.area.len() as f64;
        let (cx, cy) = (
            plan.area.iter().map(|p| p[0]).sum::<f64>() / n,
            plan.area.iter().map(|p| p[1]).sum::<f64>() / n,
        );
        let ground = ground_below(index, DVec3::new(cx, cy, 1e6));
        straight.extend(
            plan_lines(
                &plan.area,
                plan.yaw_rad,
                plan.spacing_m,
                plan.run_in_m,
                ground + plan.altitude_m,
            )
            .into_iter()
            .map(|(s, e)| (s, e, plan.speed_mps)),
        );
    }
    let tracks = match &spec.trajectory {
        None => Vec::new(),
        Some((path, interpolation)) => {
            match crate::io::trajectory::read_trajectory(path, *interpolation) {
                Ok(t) => t,
                Err(e) => {
                    problems.push((root.key("platform").key("trajectory_file"), e));
                    Vec::new()
                }
            }
        }
    };
    let mut lines = Vec::new();
    let mut t = 0.0;
    for (start, end, speed) in straight {
        let hours = (end - start).length() / speed / 3600.0;
        if hours.is_nan() || hours > MAX_LINE_HOURS {
            // Only generated lines get here: [[flight_line]] entries were
            // checked with the survey.
            problems.push((
                root.key("plan"),
                format!(
                    "a generated line would take {hours:.3e} h; a flight line may take at most \
                     {MAX_LINE_HOURS} h"
                ),
            ));
            break;
        }
        let index = lines.len() as u32;
        let line = FlightLine {
            index,
            start_m: start,
            end_m: end,
            speed_mps: speed,
            start_time_s: t,
            sway: survey.sway.as_ref().map(|cfg| Sway::new(cfg, seed, index)),
            nav_errors: LineErrors::default(),
            drift: survey
                .drift
                .map(|d| Drift::new(d.amplitude_m, d.period_s, seed, index)),
            track: None,
        };
        t += line.duration_s() + survey.turn_time_s;
        let nav_errors = LineErrors::new(&survey.navigation, seed, index, line.duration_s());
        lines.push(FlightLine { nav_errors, ..line });
    }
    for (start_time_s, track) in tracks {
        let index = lines.len() as u32;
        let (start_m, end_m) = track.ends();
        let duration = track.duration_s();
        let hours = duration / 3600.0;
        if hours.is_nan() || hours > MAX_LINE_HOURS || !start_time_s.is_finite() {
            problems.push((
                root.key("platform").key("trajectory_file"),
                format!(
                    "line {} of the trajectory lasts {:.3e} h; a flight line may take at most \
                     {MAX_LINE_HOURS} h",
                    index + 1,
                    duration / 3600.0
                ),
            ));
            break;
        }
        lines.push(FlightLine {
            index,
            start_m,
            end_m,
            speed_mps: track.length_m().max(1e-9) / duration,
            start_time_s,
            sway: None,
            nav_errors: LineErrors::new(&survey.navigation, seed, index, duration),
            drift: None,
            track: Some(Arc::new(track)),
        });
    }
    lines
}

/// Refuses a LAS scale too fine for the survey: LAS stores coordinates as
/// 32-bit integers of the scale, and every point must fit, receiver noise
/// anywhere within range of the lines included.
pub(super) fn check_las_scale(
    survey: &Survey,
    bounds: Aabb,
    lines: &[FlightLine],
    problems: &mut Vec<(KeyPath, String)>,
) {
    let formats = &survey.output.formats;
    if !(formats.las || formats.laz) {
        return;
    }
    let las_scale_m = survey.output.las_scale_m;
    let mut reach = if bounds.is_empty() {
        Aabb::EMPTY
    } else {
        bounds
    };
    for l in lines {
        for p in [l.start_m, l.end_m] {
            let r = DVec3::splat(survey.scanner.max_range_m);
            reach = reach.union_point(p - r).union_point(p + r);
        }
    }
    if reach.is_empty() {
        return;
    }
    let span = reach.extent().max_element();
    let finest = span / f64::from(i32::MAX);
    if las_scale_m < finest {
        problems.push((
            KeyPath::root().key("output").key("las_scale_m"),
            format!(
                "LAS stores coordinates as 32-bit integers of las_scale_m: points of this \
                 survey may lie {} m apart (the scene, and everything within \
                 scanner.max_range_m of the flight lines), which needs las_scale_m of at \
                 least {} m, got {}",
                num(span),
                num(finest),
                num(las_scale_m)
            ),
        ));
    }
}

/// Most tile files a run writes: more would be a layout chosen by mistake
/// (a `tile_m` of 1 m over a survey of hundreds of metres), each file a
/// LAS header and an `fsync`.
pub const MAX_TILES: u64 = 10_000;

/// Refuses `[output] layout = "tiles"` with a `tile_m` that would cut the
/// area the lines can reach (the scene's extent within each line's swath)
/// into more than [`MAX_TILES`] tiles, before anything runs.
pub(super) fn check_tiles(
    survey: &Survey,
    bounds: Aabb,
    lines: &[FlightLine],
    problems: &mut Vec<(KeyPath, String)>,
) {
    let crate::survey::Layout::Tiles(tile_m) = survey.output.layout else {
        return;
    };
    let area = reachable_area(survey, bounds, lines);
    if area.is_empty() {
        return;
    }
    let e = area.extent();
    let tiles = tiles_over(area, tile_m);
    if tiles > MAX_TILES as f64 {
        // The smallest round tile size that keeps to a tenth of the limit.
        let fitting = (e.x * e.y / (MAX_TILES as f64 / 10.0)).sqrt();
        let suggested = [1.0, 2.0, 5.0]
            .iter()
            .flat_map(|m| (0..12).map(move |p| m * 10f64.powi(p)))
            .find(|&t| t >= fitting)
            .unwrap_or(1e6);
        problems.push((
            KeyPath::root().key("output").key("tile_m"),
            format!(
                "tiles of {} m would cut the area the flight lines reach ({} m × {} m) into up \
                 to {} files, more than the {MAX_TILES} a run writes: choose a larger tile_m \
                 (for example {} m)",
                num(tile_m),
                num(e.x.round()),
                num(e.y.round()),
                num(tiles),
                num(suggested)
            ),
        ));
    }
}

/// Tiles of `tile_m` that `area` may touch, at most.
pub fn tiles_over(area: Aabb, tile_m: f64) -> f64 {
    if area.is_empty() {
        return 0.0;
    }
    let e = area.extent();
    let along = |len: f64| (len / tile_m).floor() + 2.0;
    along(e.x) * along(e.y)
}

/// The part of the scene's extent `bounds` (in plan) within reach of the
/// lines' pulses: each line's path, sampled, widened by the swath the
/// deflector's widest angle gives over the height above the scene's bottom.
pub fn reachable_area(survey: &Survey, bounds: Aabb, lines: &[FlightLine]) -> Aabb {
    if bounds.is_empty() {
        return Aabb::EMPTY;
    }
    let s = &survey.scanner;
    let angle = (s.deflector.max_off_nadir_rad() + 0.5 * s.divergence_rad).min(1.5);
    let mut area = Aabb::EMPTY;
    for line in lines {
        for k in 0..=64 {
            let p = line
                .pose_at(line.duration_s() * f64::from(k) / 64.0)
                .position_m;
            let h = (p.z - bounds.min.z).clamp(0.0, s.max_range_m);
            let reach = DVec3::new(1.0, 1.0, 0.0) * (h * angle.tan() + 1.0);
            area = area.union_point(p - reach).union_point(p + reach);
        }
    }
    let (lo, hi) = (area.min.max(bounds.min), area.max.min(bounds.max));
    if lo.x <= hi.x && lo.y <= hi.y {
        Aabb {
            min: DVec3::new(lo.x, lo.y, bounds.min.z),
            max: DVec3::new(hi.x, hi.y, bounds.max.z),
        }
    } else {
        Aabb::EMPTY
    }
}

/// Refuses a flight whose GPS times are too large for `f64` to tell its
/// pulses apart: at the last pulse the spacing of representable times must
/// be at most a quarter of the pulse period (about 60 ns at the adjusted
/// standard GPS times of today, 4·10⁸ s, fine for 2 MHz). The problem
/// names the key that made the times large.
pub(super) fn check_times(
    survey: &Survey,
    lines: &[FlightLine],
    problems: &mut Vec<(KeyPath, String)>,
) {
    let Some(last) = lines.last() else {
        return;
    };
    let start = survey.output.gps_start_time_s.unwrap_or(0.0);
    let end = start + last.start_time_s + last.duration_s();
    let period = 1.0 / survey.scanner.prf_hz;
    // The spacing of f64 values near `end`.
    let ulp = if end.is_finite() {
        f64::from_bits(end.abs().to_bits() + 1) - end.abs()
    } else {
        f64::INFINITY
    };
    if ulp <= period / 4.0 {
        return;
    }
    let root = KeyPath::root();
    let turns = survey.turn_time_s * lines.len().saturating_sub(1) as f64;
    let key = if lines.iter().any(|l| l.track.is_some()) && last.start_time_s > turns {
        root.key("platform").key("trajectory_file")
    } else if turns >= start {
        root.key("platform").key("turn_time_s")
    } else {
        root.key("output").key("gps_start_time_s")
    };
    problems.push((
        key,
        format!(
            "the flight's last pulse would have GPS time {} s, where 64-bit times are {} s \
             apart, more than a quarter of the {} s between pulses: its pulses could not be \
             told apart by time; keep the flight's times below {} s",
            num(end),
            num(ulp),
            num(period),
            num(period / 4.0 * 2f64.powi(52))
        ),
    ));
}
