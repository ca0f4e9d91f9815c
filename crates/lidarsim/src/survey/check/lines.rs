//! Where the flight lines come from: `[[flight_line]]` entries, a
//! `[plan]` or `[platform] trajectory_file` (exactly one).

use std::path::Path;

use super::{Bounds, Checker, outline};
use crate::geometry::DVec3;
use crate::message::num;
use crate::sensor::platform::Interpolation;
use crate::survey::spec::{LineSpec, PlanSpec};
use crate::survey::{KeyPath, MAX_LINE_HOURS, MAX_PLAN_LINES, RawSurvey, raw};

/// Checks the sources of the flight lines; settings a trajectory file
/// overrides become `warnings`.
pub(crate) fn lines(
    c: &mut Checker,
    raw: &RawSurvey,
    scan_half_angle_rad: f64,
    base: &Path,
    warnings: &mut Vec<String>,
) -> LineSpec {
    let root = KeyPath::root();
    let p = &raw.platform;
    let pp = root.key("platform");
    let mut straight: Vec<(DVec3, DVec3, f64)> = Vec::new();
    for (i, l) in raw.flight_lines.iter().enumerate() {
        let lp = root.key("flight_line").index(i);
        let start = c.point(lp.key("start_m"), &l.start_m);
        let end = c.point(lp.key("end_m"), &l.end_m);
        let speed = c.positive(lp.key("speed_mps"), l.speed_mps, 60.0, " m/s");
        if l.speed_mps.is_none() {
            c.err(lp.key("speed_mps"), "is required: ground speed in m/s");
        }
        let altitude = l.altitude_m.map(|a| {
            c.number(
                lp.key("altitude_m"),
                Some(a),
                0.0,
                Bounds::between(-1e4, 1e5, " m"),
            )
        });
        let (Some(mut start), Some(mut end)) = (start, end) else {
            continue;
        };
        if let Some(a) = altitude {
            start.z = a;
            end.z = a;
        }
        if (end - start).length() < 1e-6 {
            c.err(
                lp.key("end_m"),
                "must differ from start_m: the line has no length",
            );
            continue;
        }
        let hours = (end - start).length() / speed / 3600.0;
        if hours > MAX_LINE_HOURS {
            c.err(
                lp.key("end_m"),
                format!(
                    "the line would take {} h at {} m/s; a flight line may take at most \
                     {MAX_LINE_HOURS} h",
                    crate::message::fixed(hours, 1),
                    crate::message::num(speed)
                ),
            );
            continue;
        }
        straight.push((start, end, speed));
    }
    // Flight lines: [[flight_line]], a [plan] or a trajectory file.
    let sources = usize::from(!raw.flight_lines.is_empty())
        + usize::from(raw.plan.is_some())
        + usize::from(p.trajectory_file.is_some());
    if sources == 0 {
        c.err(
            root.key("flight_line"),
            "the survey needs flight lines: [[flight_line]] entries, a [plan] or \
             platform.trajectory_file",
        );
    } else if sources > 1 {
        // Point at the second way given.
        let key = if raw.plan.is_some() && !raw.flight_lines.is_empty() {
            root.key("plan")
        } else {
            pp.key("trajectory_file")
        };
        c.err(
            key,
            "give flight lines one way only: [[flight_line]], [plan] or \
             platform.trajectory_file",
        );
    }
    let interpolation = match p.interpolation.as_deref() {
        None | Some("linear") => Interpolation::Linear,
        Some("spline") => Interpolation::Spline,
        Some(other) => {
            c.err(
                pp.key("interpolation"),
                format!("unknown interpolation '{other}'; expected \"linear\" or \"spline\""),
            );
            Interpolation::Linear
        }
    };
    if p.trajectory_file.is_some() {
        for (set, key) in [
            (p.sway.is_some(), "sway"),
            (p.drift_m.is_some(), "drift_m"),
            (p.turn_time_s.is_some(), "turn_time_s"),
        ] {
            if set {
                warnings.push(format!(
                    "key `platform.{key}`: ignored with a trajectory file, which gives the \
                     attitude, the path and the times itself"
                ));
            }
        }
    }
    let plan = raw
        .plan
        .as_ref()
        .and_then(|plan| check_plan(c, plan, scan_half_angle_rad));
    LineSpec {
        straight,
        plan,
        trajectory: p
            .trajectory_file
            .as_ref()
            .map(|file| (base.join(file), interpolation)),
    }
}

/// Checks `[plan]` (its lines are generated over the ground by the world).
fn check_plan(c: &mut Checker, plan: &raw::RawPlan, scan_half_angle_rad: f64) -> Option<PlanSpec> {
    let pp = KeyPath::root().key("plan");
    let area = outline(c, &pp, &plan.rectangle_m, &plan.area_m);
    if plan.altitude_m.is_none() {
        c.err(
            pp.key("altitude_m"),
            "is required: flying height above the ground in metres",
        );
    }
    let altitude = c.positive(pp.key("altitude_m"), plan.altitude_m, 500.0, " m");
    let heading = c.number(
        pp.key("heading_deg"),
        plan.heading_deg,
        0.0,
        Bounds::between(-360.0, 360.0, "°"),
    );
    let speed = c.positive(pp.key("speed_mps"), plan.speed_mps, 60.0, " m/s");
    let run_in = c.number(
        pp.key("run_in_m"),
        plan.run_in_m,
        0.0,
        Bounds::between(0.0, 1e5, " m"),
    );
    let swath = 2.0 * altitude * scan_half_angle_rad.tan();
    let spacing = match (plan.line_spacing_m, plan.side_overlap) {
        (Some(s), None) => c.positive(pp.key("line_spacing_m"), Some(s), 100.0, " m"),
        (None, Some(o)) => {
            let o = c.number(
                pp.key("side_overlap"),
                Some(o),
                0.2,
                Bounds::between(0.0, 0.95, ""),
            );
            swath * (1.0 - o)
        }
        (None, None) => swath * 0.8,
        (Some(_), Some(_)) => {
            c.err(
                pp.key("side_overlap"),
                "give line_spacing_m or side_overlap, not both",
            );
            swath
        }
    };
    let area = area?;
    if spacing <= 0.0 {
        c.err(
            pp.key("side_overlap"),
            "the scan angle gives no swath to space lines by",
        );
        return None;
    }
    let lines = crate::sensor::platform::plan_line_count(&area, -heading.to_radians(), spacing);
    if lines > MAX_PLAN_LINES as f64 {
        let key = if plan.line_spacing_m.is_some() {
            pp.key("line_spacing_m")
        } else {
            pp.key("side_overlap")
        };
        c.err(
            key,
            format!(
                "lines {} m apart would make {} flight lines over the area; a plan may make at \
                 most {MAX_PLAN_LINES}",
                num(spacing),
                num(lines)
            ),
        );
        return None;
    }
    Some(PlanSpec {
        area,
        yaw_rad: -heading.to_radians(),
        spacing_m: spacing,
        run_in_m: run_in,
        altitude_m: altitude,
        speed_mps: speed,
    })
}
