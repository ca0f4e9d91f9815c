//! What a survey is expected to give, computed without simulating.
//!
//! Textbook ALS planning formulas (e.g. Baltsavias 1999, "Airborne laser
//! scanning: basic relations and formulas", ISPRS J. 54): over level ground
//! at height `H` below the sensor, the swath is `W = 2·H·tan θ` for scan
//! half-angle θ, the mean point density of one line is `PRF / (v·W)`, the
//! distance between scan lines along track is `v / (2·f_scan)` for an
//! oscillating mirror (two scan lines per mirror cycle), and the footprint
//! diameter at nadir is `H·γ` for full divergence γ.

use serde::Serialize;

use crate::accel::RayCaster;
use crate::geometry::{DVec3, Ray};
use crate::scene::SurfaceClass;
use crate::survey::Survey;

/// Expected figures of one flight line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinePlan {
    /// Line number (0-based).
    pub line: u32,
    /// Pulses emitted.
    pub pulses: u64,
    /// Duration, s.
    pub duration_s: f64,
    /// Height of the sensor above the ground under the middle of the line, m.
    pub height_above_ground_m: f64,
    /// Swath width `2·H·tan θ`, m.
    pub swath_width_m: f64,
    /// Mean point density `PRF / (v·W)`, points per m² (one return per pulse).
    pub point_density_per_m2: f64,
    /// Footprint diameter at nadir `H·γ`, m.
    pub footprint_diameter_m: f64,
    /// Distance between scan lines along track at nadir, m.
    pub scan_line_spacing_m: f64,
    /// Distance between neighbouring footprints across track at nadir, m.
    pub across_track_spacing_m: f64,
}

/// Expected figures of a survey.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Plan {
    /// Per flight line.
    pub lines: Vec<LinePlan>,
    /// Total pulses.
    pub pulses: u64,
    /// Pulse-weighted mean swath width, m.
    pub swath_width_m: f64,
    /// Pulse-weighted mean point density of a single line, per m².
    pub point_density_per_m2: f64,
    /// Pulse-weighted mean nadir footprint diameter, m.
    pub footprint_diameter_m: f64,
    /// Expected size of `points.las` if every pulse gives one point, bytes.
    pub expected_las_bytes: u64,
    /// Flight time including turns, s.
    pub flight_time_s: f64,
}

/// Size of `points.las` with one point per pulse: the header, the VLRs
/// (Extra Bytes: 54 + 192 per field; waveform packet descriptors: 255 ×
/// (54 + 26); WKT: 54 + its length + 1) and the point records (30 bytes for
/// format 6 or 59 for format 9, 20 of echo attributes, 12 of error vector).
fn expected_las_bytes(survey: &Survey, pulses: u64) -> u64 {
    let o = &survey.output;
    let errors = !survey.navigation.is_zero();
    let fields = 5 * u64::from(o.extra_bytes) + 3 * u64::from(errors);
    let mut header = 375;
    if fields > 0 {
        header += 54 + 192 * fields;
    }
    if o.formats.las_waveform {
        header += 255 * (54 + 26);
    }
    if let Some(wkt) = &o.crs_wkt {
        header += 54 + wkt.len() as u64 + 1;
    }
    let record = if o.formats.las_waveform { 59 } else { 30 }
        + 20 * u64::from(o.extra_bytes)
        + 12 * u64::from(errors);
    header + record * pulses
}

/// Height of the ground below `p` (ground, road or water surfaces; any
/// surface if none of those lies below; `z = 0` if nothing does).
pub fn ground_below(caster: &dyn RayCaster, p: DVec3) -> f64 {
    let ray = Ray {
        origin: p,
        dir: -DVec3::Z,
    };
    let ground = |prim: &crate::scene::Primitive| {
        matches!(
            prim.class,
            SurfaceClass::Ground | SurfaceClass::Road | SurfaceClass::Water
        )
    };
    caster
        .closest_hit_where(&ray, 0.0, f64::INFINITY, &ground)
        .or_else(|| caster.closest_hit(&ray, 0.0, f64::INFINITY))
        .map_or(0.0, |h| p.z - h.t)
}

/// Computes the plan of `survey` over the scene of `caster`.
pub fn plan(survey: &Survey, caster: &dyn RayCaster) -> Plan {
    let s = &survey.scanner;
    let mut lines = Vec::new();
    for line in &survey.lines {
        let mid = (line.start_m + line.end_m) * 0.5;
        let h = (mid.z - ground_below(caster, mid)).max(0.0);
        let w = 2.0 * h * s.mirror.scan_half_angle_rad.tan();
        let pulses = survey.pulses_of(line);
        // Angular step between pulses at nadir for a triangle mirror is
        // 4 θ f / PRF; for a sine mirror it is 2π θ f / PRF.
        let omega = match s.mirror.profile {
            crate::scanner::MirrorProfile::Triangle => 4.0,
            crate::scanner::MirrorProfile::Sine => std::f64::consts::TAU,
        } * s.mirror.scan_half_angle_rad
            * s.mirror.scan_frequency_hz;
        lines.push(LinePlan {
            line: line.index,
            pulses,
            duration_s: line.duration_s(),
            height_above_ground_m: h,
            swath_width_m: w,
            point_density_per_m2: if w > 0.0 {
                s.prf_hz / (line.speed_mps * w)
            } else {
                0.0
            },
            footprint_diameter_m: h * s.divergence_rad,
            scan_line_spacing_m: line.speed_mps / (2.0 * s.mirror.scan_frequency_hz),
            across_track_spacing_m: h * omega / s.prf_hz,
        });
    }
    let pulses: u64 = lines.iter().map(|l| l.pulses).sum();
    let weighted = |f: fn(&LinePlan) -> f64| {
        if pulses == 0 {
            0.0
        } else {
            lines.iter().map(|l| f(l) * l.pulses as f64).sum::<f64>() / pulses as f64
        }
    };
    let flight_time_s = survey
        .lines
        .last()
        .map_or(0.0, |l| l.start_time_s + l.duration_s());
    Plan {
        swath_width_m: weighted(|l| l.swath_width_m),
        point_density_per_m2: weighted(|l| l.point_density_per_m2),
        footprint_diameter_m: weighted(|l| l.footprint_diameter_m),
        expected_las_bytes: expected_las_bytes(survey, pulses),
        flight_time_s,
        pulses,
        lines,
    }
}
