//! How a scan was flown, read from its points: the strips ([`strips`]),
//! each strip's track, speed and flying height ([`track`]), pulse rate
//! and mirror ([`mirror`]) and pulse density, combined into one scanner
//! and one flight line per strip ([`combine`]) that reproduce the scan's
//! density and pattern. Without GPS times or scan angles nothing of that
//! can be read: lines planned from the options the user gives instead.

pub mod combine;
pub mod mirror;
pub mod strips;
pub mod track;

use serde::Serialize;

use super::TwinError;
use crate::scan::ScanCloud;
use crate::scan::density::{Density, density};

/// What the user gives about the acquisition: each replaces what would
/// be read from the scan.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AcquisitionSettings {
    /// Flying height above the ground, m.
    pub altitude_m: Option<f64>,
    /// Ground speed, m/s.
    pub speed_mps: Option<f64>,
    /// Pulse rate, Hz.
    pub prf_hz: Option<f64>,
    /// Mirror cycles (or scan lines, for a polygon) per second.
    pub scan_frequency_hz: Option<f64>,
    /// Largest scan angle, degrees.
    pub scan_angle_deg: Option<f64>,
    /// Compass heading of planned lines, degrees (when the strips cannot
    /// be read).
    pub heading_deg: Option<f64>,
    /// Distance between planned lines, m.
    pub line_spacing_m: Option<f64>,
}

/// First returns a strip needs to be read.
pub const MIN_STRIP_POINTS: usize = 200;

/// One strip as read.
#[derive(Clone, Debug, Serialize)]
pub struct StripReport {
    /// Strip number, from 1, by time.
    pub strip: usize,
    /// Its point source ID.
    pub source_id: u16,
    /// Its first returns.
    pub first_returns: usize,
    /// From its first to its last return, s.
    pub duration_s: f64,
    /// Its scan angles, smallest and largest, degrees.
    pub scan_angle_deg: [f64; 2],
    /// First returns per m² where it covers the scan.
    pub pulse_density_per_m2: f64,
    /// The fitted track, when it could be.
    pub track: Option<TrackReport>,
    /// Why not.
    pub track_problem: Option<String>,
    /// Pulse period from the time steps, s.
    pub pulse_period_s: Option<f64>,
    /// The mirror, when it could be read.
    pub mirror: Option<MirrorReport>,
    /// Why not.
    pub mirror_problem: Option<String>,
}

/// A strip's track, for the report.
#[derive(Clone, Debug, Serialize)]
pub struct TrackReport {
    /// Compass heading, degrees.
    pub heading_deg: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// Flying height above the ground, m.
    pub height_m: f64,
    /// Its standard error, m.
    pub height_se_m: f64,
    /// Skew of the scan lines from square to the track, degrees.
    pub scan_line_skew_deg: f64,
    /// Residual of the scan-angle plane, degrees.
    pub residual_deg: f64,
    /// Whether positive angles are right of the flight direction.
    pub positive_angles_right: bool,
}

/// A strip's mirror, for the report.
#[derive(Clone, Debug, Serialize)]
pub struct MirrorReport {
    /// Both ways (oscillating) or one (polygon).
    pub both_ways: bool,
    /// Cycles or lines per second.
    pub frequency_hz: f64,
    /// Angular speed of the beam, degrees per second.
    pub angular_speed_deg_s: f64,
    /// Sweeps read.
    pub sweeps: usize,
    /// Relative spread of the periods.
    pub period_spread: f64,
}

/// A strip with everything read from it.
#[derive(Clone, Debug)]
pub struct ReadStrip {
    /// Its points.
    pub strip: strips::Strip,
    /// Its track.
    pub track: Option<track::Track>,
    /// Its mirror.
    pub mirror: Option<mirror::Mirror>,
    /// Its pulse period, s.
    pub pulse_period_s: Option<f64>,
    /// Its first-return density.
    pub density: Density,
    /// Mean sec²θ of its points (the ground spacing of a beam turning
    /// evenly in angle grows as sec²θ).
    pub mean_sec2: f64,
    /// The report of it.
    pub report: StripReport,
}

/// Reads every strip of `cloud` (heights above ground `h`): its track,
/// mirror, pulse period and density. Strips of fewer than
/// [`MIN_STRIP_POINTS`] first returns are left out.
pub fn read_strips(cloud: &ScanCloud, h: &[f64]) -> Vec<ReadStrip> {
    let first: Vec<usize> = (0..cloud.len()).filter(|&k| cloud.is_first(k)).collect();
    let strips = strips::split_strips(&first, &cloud.gps_time, &cloud.point_source_id);
    strips
        .into_iter()
        .filter(|s| s.points.len() >= MIN_STRIP_POINTS)
        .enumerate()
        .filter_map(|(i, s)| read_strip(cloud, h, s, i + 1))
        .collect()
}

/// One strip read.
fn read_strip(cloud: &ScanCloud, h: &[f64], strip: strips::Strip, n: usize) -> Option<ReadStrip> {
    let pts = &strip.points;
    let t: Vec<f64> = pts.iter().map(|&k| cloud.gps_time[k]).collect();
    let a: Vec<f64> = pts
        .iter()
        .map(|&k| f64::from(cloud.scan_angle_deg[k]))
        .collect();
    let mut mask = vec![false; cloud.len()];
    pts.iter().for_each(|&k| mask[k] = true);
    let density = density((&cloud.x, &cloud.y), |k| mask[k])?;
    let track = track::fit_track(cloud, h, pts);
    let period = mirror::pulse_period_s(&t);
    let mirror = period.map(|p| mirror::read_mirror(&t, &a, cloud.facts.scan_angle_step_deg, p));
    let mean_sec2 = a.iter().map(|d| d.to_radians().cos().powi(-2)).sum::<f64>() / a.len() as f64;
    let (lo, hi) = a
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &v| {
            (l.min(v), u.max(v))
        });
    let report = StripReport {
        strip: n,
        source_id: strip.source_id,
        first_returns: pts.len(),
        duration_s: t[t.len() - 1] - t[0],
        scan_angle_deg: [lo, hi],
        pulse_density_per_m2: density.per_m2,
        track: track.as_ref().ok().map(|tr| TrackReport {
            heading_deg: tr.heading_deg(),
            speed_mps: tr.speed_mps,
            height_m: tr.height_m,
            height_se_m: tr.height_se_m,
            scan_line_skew_deg: tr.skew_deg,
            residual_deg: tr.residual_deg,
            positive_angles_right: tr.positive_right,
        }),
        track_problem: track.as_ref().err().map(|p| match p {
            track::TrackProblem::NarrowAngles(span) => format!(
                "its scan angles span {} degrees: too few to read the flying height from",
                crate::message::num(*span)
            ),
            track::TrackProblem::Degenerate => "its points lie on a line".to_string(),
        }),
        pulse_period_s: period,
        mirror: mirror
            .as_ref()
            .and_then(|m| m.as_ref().ok())
            .map(|m| MirrorReport {
                both_ways: m.both_ways,
                frequency_hz: m.frequency_hz,
                angular_speed_deg_s: m.angular_speed_deg_s,
                sweeps: m.sweeps,
                period_spread: m.period_spread,
            }),
        mirror_problem: match &mirror {
            None => Some("too few distinct GPS times".into()),
            Some(Err(mirror::MirrorProblem::TooFewSweeps(n))) => Some(format!(
                "{n} sweeps of the beam cross it, {} needed to read the mirror",
                mirror::MIN_SWEEPS
            )),
            Some(Ok(_)) => None,
        },
    };
    Some(ReadStrip {
        strip,
        track: track.ok(),
        mirror: mirror.and_then(Result::ok),
        pulse_period_s: period,
        density,
        mean_sec2,
        report,
    })
}

/// Whether `cloud` has what strips are read from: GPS times and scan
/// angles. Otherwise the error says what is missing and which options
/// give planned lines instead (when they are not given).
pub fn check_timing(cloud: &ScanCloud, settings: &AcquisitionSettings) -> Result<bool, TwinError> {
    let missing = match (cloud.has_gps_times(), cloud.has_scan_angles()) {
        (true, true) => return Ok(true),
        (false, false) => "neither GPS times nor scan angles",
        (false, true) => "no GPS times",
        (true, false) => "no scan angles (all are 0)",
    };
    let planned = settings.heading_deg.is_some()
        && settings.altitude_m.is_some()
        && settings.scan_angle_deg.is_some();
    if planned {
        return Ok(false);
    }
    Err(TwinError::NoTiming {
        file: cloud.name.clone(),
        missing: missing.to_string(),
        point_format: cloud.facts.point_format,
    })
}
