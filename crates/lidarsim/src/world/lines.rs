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
                .map(|(d, period)| Drift::new(d, period, seed, index)),
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
