//! Plots of the flight from the survey alone: the attitude against time
//! and the observed minus true trajectory.

use crate::render::{Figure, Series, time_panels};
use crate::sensor::platform::FlightLine;
use crate::survey::Survey;

/// Samples of the flight plots (about one per pixel column).
const FLIGHT_SAMPLES: usize = 900;

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
pub fn attitude_plot(lines: &[FlightLine]) -> Figure {
    let samples = flight_samples(lines);
    let names = ["roll ω, °", "pitch φ, °", "yaw κ − line heading, °"];
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
    time_panels(&series)
}

/// The observed trajectory (what the GNSS/IMU measured, without its
/// per-pulse white noise) minus the true one against the time since the
/// survey's start: position x, y, z (m) in one picture and roll, pitch,
/// yaw (degrees) in the other.
pub fn trajectory_error_plots(survey: &Survey, lines: &[FlightLine]) -> (Figure, Figure) {
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
        time_panels(&[series(0, "x, m"), series(1, "y, m"), series(2, "z, m")]),
        time_panels(&[
            series(3, "roll ω, °"),
            series(4, "pitch φ, °"),
            series(5, "yaw κ, °"),
        ]),
    )
}
