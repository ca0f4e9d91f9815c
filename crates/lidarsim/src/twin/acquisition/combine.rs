//! The strips' readings combined into one scanner and the lines that fly
//! it: the flying height, speed and track of each strip, the mirror's
//! frequency and amplitude (medians over the strips that show them), and
//! the pulse rate that reproduces the scan's density.
//!
//! A beam turning evenly through the angle S per sweep cycle — 2θₘ both
//! ways for a triangle mirror, 720°/N per line for a polygon of N facets
//! — from height H lays `PRF / (S · v · H · sec²θ)` pulses per m² at the
//! scan angle θ (S in radians). Each strip's density, speed, height and
//! angles thus name the PRF that made it; the survey takes their median
//! (a scanner has one PRF) and flies each line at the speed that gives its
//! strip's density with it.

use serde::Serialize;

use super::{AcquisitionSettings, ReadStrip, StripReport};
use crate::message::num;
use crate::twin::TwinError;

/// A value the twin uses, and where it came from.
#[derive(Clone, Debug, Serialize)]
pub struct Estimate {
    /// The value.
    pub value: f64,
    /// `"read"` (from the scan), `"given"` (an option), `"derived"`
    /// (from other values) or `"assumed"` (a default).
    pub source: &'static str,
    /// The smallest and largest of the strips' values, when several
    /// strips were read.
    pub range: Option<[f64; 2]>,
}

impl Estimate {
    fn of(given: Option<f64>, read: &[f64], fallback: (f64, &'static str)) -> Self {
        if let Some(v) = given {
            return Self {
                value: v,
                source: "given",
                range: None,
            };
        }
        if read.is_empty() {
            return Self {
                value: fallback.0,
                source: fallback.1,
                range: None,
            };
        }
        let mut v = read.to_vec();
        v.sort_by(f64::total_cmp);
        Self {
            value: median_sorted(&v),
            source: "read",
            range: (v.len() > 1).then(|| [v[0], v[v.len() - 1]]),
        }
    }
}

/// The median of sorted values (the mean of the middle two of an even
/// number).
pub fn median_sorted(v: &[f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The twin's kind of deflector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Deflector {
    /// A triangle-profile oscillating mirror.
    Oscillating,
    /// A rotating polygon of this many facets.
    Polygon {
        /// Facets.
        facets: u32,
    },
}

/// The scanner of the twin.
#[derive(Clone, Debug, Serialize)]
pub struct TwinScanner {
    /// Pulse rate, Hz.
    pub prf_hz: Estimate,
    /// Mirror cycles or scan lines per second.
    pub scan_frequency_hz: Estimate,
    /// Largest scan angle, degrees.
    pub scan_angle_deg: Estimate,
    /// The deflector.
    pub deflector: Deflector,
    /// Most returns per pulse.
    pub max_returns: u8,
}

/// A flight line of the twin, in the scan's coordinates.
#[derive(Clone, Debug, Serialize)]
pub struct TwinLine {
    /// Start, m.
    pub start_m: [f64; 3],
    /// End, m.
    pub end_m: [f64; 3],
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// The strip it re-flies (from 1).
    pub strip: usize,
}

/// Parallel lines planned over the scan's area (when its strips cannot
/// be read).
#[derive(Clone, Debug, Serialize)]
pub struct TwinPlan {
    /// Compass heading, degrees.
    pub heading_deg: f64,
    /// Distance between lines, m.
    pub line_spacing_m: f64,
    /// Flying height above the ground at the area's centre, m.
    pub altitude_m: f64,
    /// Ground speed, m/s.
    pub speed_mps: f64,
}

/// How the twin flies.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Flight {
    /// One line per strip of the scan.
    Lines(Vec<TwinLine>),
    /// Lines planned from the options.
    Plan(TwinPlan),
}

/// The acquisition as the twin flies it, and how it was read.
#[derive(Clone, Debug, Serialize)]
pub struct Acquisition {
    /// The scanner.
    pub scanner: TwinScanner,
    /// The lines.
    pub flight: Flight,
    /// First returns per m² over the whole scan.
    pub pulse_density_per_m2: f64,
    /// Flying height above the ground, m.
    pub flying_height_m: Estimate,
    /// Ground speed as read, m/s.
    pub speed_mps: Estimate,
    /// The pulse rate the time steps show, Hz.
    pub timing_prf_hz: Option<f64>,
    /// The strips as read.
    pub strips: Vec<StripReport>,
    /// Distances between neighbouring parallel strips and their overlap.
    pub line_spacing: Vec<Spacing>,
    /// What was assumed or looks odd, in words.
    pub notes: Vec<String>,
}

/// The spacing of a strip to its nearest parallel neighbour.
#[derive(Clone, Debug, Serialize)]
pub struct Spacing {
    /// The strips (from 1).
    pub strips: [usize; 2],
    /// Distance between their tracks, m.
    pub distance_m: f64,
    /// Share of a swath the two share (negative: a gap between them).
    pub side_overlap: f64,
}

/// What the combination needs besides the strips.
pub struct Scene<'a> {
    /// The scan's file (for messages).
    pub file: &'a str,
    /// The scan's horizontal bounds, m.
    pub bounds: [f64; 4],
    /// The ground's height at the area's centre, m.
    pub ground_z_m: f64,
    /// First returns per m² over the whole scan.
    pub density_per_m2: f64,
    /// The largest number of returns a pulse has in the scan (0: unset).
    pub max_returns_seen: u8,
    /// The largest scan angle of any point, degrees (absolute).
    pub max_angle_deg: f64,
}

/// The twin's acquisition from its read strips.
pub fn combine(
    strips: &[ReadStrip],
    settings: &AcquisitionSettings,
    scene: &Scene<'_>,
) -> Result<Acquisition, TwinError> {
    let mut notes = Vec::new();
    let heights: Vec<f64> = strips
        .iter()
        .filter_map(|s| s.track.as_ref().map(|t| t.height_m))
        .collect();
    if heights.is_empty() && settings.altitude_m.is_none() {
        return Err(TwinError::NoHeight {
            file: scene.file.to_string(),
            why: strips
                .iter()
                .filter_map(|s| {
                    s.report
                        .track_problem
                        .as_ref()
                        .map(|p| format!("strip {}: {p}", s.report.strip))
                })
                .collect::<Vec<_>>()
                .join("; "),
        });
    }
    let flying_height_m = Estimate::of(settings.altitude_m, &heights, (0.0, "assumed"));
    check_airborne(scene, flying_height_m.value)?;
    let speeds: Vec<f64> = strips
        .iter()
        .filter_map(|s| s.track.as_ref().map(|t| t.speed_mps))
        .collect();
    let speed_mps = Estimate::of(settings.speed_mps, &speeds, (60.0, "assumed"));
    let (deflector, scan_frequency_hz, sweep_speed) = mirror_of(strips, settings, scene)?;
    let scan_angle_deg = amplitude(
        deflector,
        &scan_frequency_hz,
        sweep_speed,
        settings,
        scene,
        &mut notes,
    );
    let sweep_rad = match deflector {
        Deflector::Oscillating => 2.0 * scan_angle_deg.value.to_radians(),
        Deflector::Polygon { facets } => (720.0 / f64::from(facets)).to_radians(),
    };
    let implied: Vec<f64> = strips
        .iter()
        .filter(|s| s.density.interior)
        .filter_map(|s| {
            let t = s.track.as_ref()?;
            let h = settings.altitude_m.unwrap_or(t.height_m);
            let v = settings.speed_mps.unwrap_or(t.speed_mps);
            Some(s.density.per_m2 * sweep_rad * v * h * s.mean_sec2)
        })
        .collect();
    let prf_hz = Estimate::of(settings.prf_hz, &implied, (0.0, "assumed"));
    let timing_prf_hz = timing_prf(strips);
    notes.extend(timing_note(&prf_hz, timing_prf_hz));
    let max_returns = match scene.max_returns_seen {
        0 | 1 => {
            notes.push("no pulse has more than one return: max_returns assumed 5".into());
            5
        }
        n => n.min(15),
    };
    let scanner = TwinScanner {
        prf_hz,
        scan_frequency_hz,
        scan_angle_deg,
        deflector,
        max_returns,
    };
    notes.extend(sign_note(strips));
    let flight = lines(strips, &scanner, sweep_rad, settings, scene, &mut notes);
    let line_spacing = spacings(strips, &scanner);
    Ok(Acquisition {
        scanner,
        flight: Flight::Lines(flight),
        pulse_density_per_m2: scene.density_per_m2,
        flying_height_m,
        speed_mps,
        timing_prf_hz,
        strips: strips.iter().map(|s| s.report.clone()).collect(),
        line_spacing,
        notes,
    })
}

/// Refuses a scan that no aircraft flew: angles far beyond any airborne
/// line scanner's, or a flying height of a few metres.
fn check_airborne(scene: &Scene<'_>, height_m: f64) -> Result<(), TwinError> {
    let why = if scene.max_angle_deg > 75.0 {
        format!(
            "its scan angles reach {} degrees",
            num(scene.max_angle_deg.round())
        )
    } else if height_m < 20.0 {
        format!(
            "its scan angles change across the ground as from {} m above it",
            num(height_m.round())
        )
    } else {
        return Ok(());
    };
    Err(TwinError::NotAirborne {
        file: scene.file.to_string(),
        why,
    })
}

/// The deflector, its frequency and the beam's angular speed (deg/s, 0
/// when none was read).
fn mirror_of(
    strips: &[ReadStrip],
    settings: &AcquisitionSettings,
    scene: &Scene<'_>,
) -> Result<(Deflector, Estimate, f64), TwinError> {
    let read: Vec<&super::mirror::Mirror> =
        strips.iter().filter_map(|s| s.mirror.as_ref()).collect();
    if read.is_empty() && settings.scan_frequency_hz.is_none() {
        return Err(TwinError::NoMirror {
            file: scene.file.to_string(),
            why: strips
                .iter()
                .filter_map(|s| {
                    s.report
                        .mirror_problem
                        .as_ref()
                        .map(|p| format!("strip {}: {p}", s.report.strip))
                })
                .collect::<Vec<_>>()
                .join("; "),
        });
    }
    let both = read.iter().filter(|m| m.both_ways).count();
    let frequencies: Vec<f64> = read.iter().map(|m| m.frequency_hz).collect();
    let mut speeds: Vec<f64> = read.iter().map(|m| m.angular_speed_deg_s).collect();
    speeds.sort_by(f64::total_cmp);
    let speed = median_sorted(&speeds);
    let frequency = Estimate::of(settings.scan_frequency_hz, &frequencies, (50.0, "assumed"));
    let deflector = if read.is_empty() || both * 2 >= read.len() {
        Deflector::Oscillating
    } else {
        // A polygon turns the beam through 720°/N per line.
        let facets = (720.0 * frequency.value / speed.max(1e-9))
            .round()
            .clamp(2.0, 64.0);
        Deflector::Polygon {
            facets: facets as u32,
        }
    };
    Ok((deflector, frequency, speed))
}

/// The largest scan angle: given; else, for a triangle mirror, the
/// amplitude its angular speed shows (ω = 4·θₘ·f), at least the largest
/// angle seen; for a polygon, the largest angle seen (its field of view
/// may be wider: the scan shows only what fell on it).
fn amplitude(
    deflector: Deflector,
    frequency: &Estimate,
    speed_deg_s: f64,
    settings: &AcquisitionSettings,
    scene: &Scene<'_>,
    notes: &mut Vec<String>,
) -> Estimate {
    if let Some(v) = settings.scan_angle_deg {
        return Estimate::of(Some(v), &[], (v, "given"));
    }
    let seen = scene.max_angle_deg.ceil().max(1.0);
    let from_speed = match deflector {
        Deflector::Oscillating if speed_deg_s > 0.0 => speed_deg_s / (4.0 * frequency.value),
        _ => 0.0,
    };
    if from_speed > seen {
        Estimate {
            value: (from_speed * 10.0).round() / 10.0,
            source: "read",
            range: Some([seen, from_speed]),
        }
    } else {
        if from_speed > 0.0 && from_speed < 0.8 * seen {
            notes.push(format!(
                "the beam turns at {} degrees/s, a triangle mirror of ±{} degrees at {} Hz, \
                 but angles of {} degrees are seen (a sine mirror, or roll?): ±{} degrees taken",
                num(speed_deg_s.round()),
                num((from_speed * 10.0).round() / 10.0),
                num((frequency.value * 10.0).round() / 10.0),
                num(seen),
                num(seen)
            ));
        }
        Estimate {
            value: seen,
            source: "read",
            range: None,
        }
    }
}

/// A note when the density's PRF and the timing's differ by more than
/// 10 %.
fn timing_note(prf: &Estimate, timing: Option<f64>) -> Option<String> {
    let timing = timing?;
    let kept = prf.value / timing;
    (!(0.9..=1.1).contains(&kept)).then(|| {
        format!(
            "the time steps between pulses show {} Hz, the density needs {} Hz: the file holds \
             {} % of the pulses the timing implies (thinned, or pulses without echo)",
            num(timing.round()),
            num(prf.value.round()),
            num((kept * 100.0).round())
        )
    })
}

/// A note when every strip has its positive scan angles on the left.
fn sign_note(strips: &[ReadStrip]) -> Option<String> {
    let right: Vec<bool> = strips
        .iter()
        .filter_map(|s| s.track.as_ref().map(|t| t.positive_right))
        .collect();
    (!right.is_empty() && right.iter().all(|r| !r)).then(|| {
        "positive scan angles lie left of the flight direction in this file (the LAS \
         specification has them right): the twin's points follow the specification"
            .to_string()
    })
}

/// The pulse rate the time steps show: the median over the strips.
fn timing_prf(strips: &[ReadStrip]) -> Option<f64> {
    let mut rates: Vec<f64> = strips
        .iter()
        .filter_map(|s| s.pulse_period_s.map(|p| 1.0 / p))
        .collect();
    rates.sort_by(f64::total_cmp);
    (!rates.is_empty()).then(|| median_sorted(&rates))
}

/// One line per strip with a track, along it over the whole scan and a
/// margin, at its flying height over the ground, at the speed that gives
/// its density with the survey's PRF.
fn lines(
    strips: &[ReadStrip],
    scanner: &TwinScanner,
    sweep_rad: f64,
    settings: &AcquisitionSettings,
    scene: &Scene<'_>,
    notes: &mut Vec<String>,
) -> Vec<TwinLine> {
    let b = scene.bounds;
    let corners = [[b[0], b[1]], [b[2], b[1]], [b[2], b[3]], [b[0], b[3]]];
    let mut out = Vec::new();
    for s in strips {
        let Some(t) = &s.track else {
            notes.push(format!(
                "strip {} has no track ({}): it is not flown",
                s.report.strip,
                s.report.track_problem.as_deref().unwrap_or("")
            ));
            continue;
        };
        let h = settings.altitude_m.unwrap_or(t.height_m);
        let o = t.origin_m;
        let along = |p: [f64; 2]| (p[0] - o[0]) * t.along[0] + (p[1] - o[1]) * t.along[1];
        let (lo, hi) = corners
            .iter()
            .map(|&c| along(c))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), v| {
                (l.min(v), u.max(v))
            });
        let margin = 0.1 * (hi - lo) + 20.0;
        let z = scene.ground_z_m + h;
        let at = |s: f64| [o[0] + s * t.along[0], o[1] + s * t.along[1], z];
        let read = settings.speed_mps.unwrap_or(t.speed_mps);
        let speed = if settings.speed_mps.is_none() && s.density.interior {
            scanner.prf_hz.value / (s.density.per_m2 * sweep_rad * h * s.mean_sec2)
        } else {
            read
        };
        if !s.density.interior {
            notes.push(format!(
                "strip {} covers too little of the scan to measure its density: flown at the \
                 speed read",
                s.report.strip
            ));
        } else if (speed / read - 1.0).abs() > 0.1 {
            notes.push(format!(
                "strip {} flown at {} m/s rather than the {} m/s read, to give its density of {} \
                 per m² at {} Hz",
                s.report.strip,
                num((speed * 10.0).round() / 10.0),
                num((read * 10.0).round() / 10.0),
                num((s.density.per_m2 * 100.0).round() / 100.0),
                num(scanner.prf_hz.value.round())
            ));
        }
        out.push(TwinLine {
            start_m: at(lo - margin),
            end_m: at(hi + margin),
            speed_mps: speed,
            strip: s.report.strip,
        });
    }
    out
}

/// For each strip, the nearest strip flown parallel to it (either way,
/// within 15°): the distance between their tracks and the share of a
/// swath they share.
fn spacings(strips: &[ReadStrip], scanner: &TwinScanner) -> Vec<Spacing> {
    let tracks: Vec<(usize, &super::track::Track)> = strips
        .iter()
        .filter_map(|s| s.track.as_ref().map(|t| (s.report.strip, t)))
        .collect();
    let mut out = Vec::new();
    for (i, (a, ta)) in tracks.iter().enumerate() {
        let nearest = tracks
            .iter()
            .enumerate()
            .filter(|(j, (_, tb))| {
                *j != i
                    && (ta.along[0] * tb.along[0] + ta.along[1] * tb.along[1]).abs()
                        > 15f64.to_radians().cos()
            })
            .map(|(_, (b, tb))| {
                let d = [
                    tb.origin_m[0] - ta.origin_m[0],
                    tb.origin_m[1] - ta.origin_m[1],
                ];
                (*b, (d[0] * ta.along[1] - d[1] * ta.along[0]).abs(), tb)
            })
            .min_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((b, distance_m, tb)) = nearest
            && *a < b
        {
            let tan = scanner.scan_angle_deg.value.to_radians().tan();
            let swath = (ta.height_m + tb.height_m) * tan;
            out.push(Spacing {
                strips: [*a, b],
                distance_m,
                side_overlap: 1.0 - distance_m / swath,
            });
        }
    }
    out
}

/// Lines planned over the scan from the options, for a scan whose strips
/// cannot be read (no GPS times or no scan angles): the heading, flying
/// height and scan angle given (`check_timing` made sure), the spacing
/// of 30 % side overlap unless given, and the PRF that gives the scan's
/// density: every pulse lands on the ground between two lines, so the
/// mean density is `PRF / (v · spacing)`.
pub fn planned(settings: &AcquisitionSettings, scene: &Scene<'_>) -> Acquisition {
    let given = |v: Option<f64>| Estimate::of(v, &[], (0.0, "given"));
    let altitude = settings.altitude_m.unwrap_or(500.0);
    let angle = settings.scan_angle_deg.unwrap_or(20.0);
    let swath = 2.0 * altitude * angle.to_radians().tan();
    let spacing = settings.line_spacing_m.unwrap_or(0.7 * swath);
    let speed = Estimate::of(settings.speed_mps, &[], (60.0, "assumed"));
    let prf = settings
        .prf_hz
        .unwrap_or(scene.density_per_m2 * speed.value * spacing);
    let mut notes = vec![format!(
        "the strips cannot be read from the scan: lines planned {} m apart at heading {} degrees",
        num((spacing * 10.0).round() / 10.0),
        num(settings.heading_deg.unwrap_or(0.0))
    )];
    if scene.max_returns_seen <= 1 {
        notes.push("no pulse has more than one return: max_returns assumed 5".into());
    }
    Acquisition {
        scanner: TwinScanner {
            prf_hz: Estimate {
                value: prf,
                source: if settings.prf_hz.is_some() {
                    "given"
                } else {
                    "derived"
                },
                range: None,
            },
            scan_frequency_hz: Estimate::of(settings.scan_frequency_hz, &[], (50.0, "assumed")),
            scan_angle_deg: given(Some(angle)),
            deflector: Deflector::Oscillating,
            max_returns: if scene.max_returns_seen <= 1 {
                5
            } else {
                scene.max_returns_seen.min(15)
            },
        },
        flight: Flight::Plan(TwinPlan {
            heading_deg: settings.heading_deg.unwrap_or(0.0),
            line_spacing_m: spacing,
            altitude_m: altitude,
            speed_mps: speed.value,
        }),
        pulse_density_per_m2: scene.density_per_m2,
        flying_height_m: given(Some(altitude)),
        speed_mps: speed,
        timing_prf_hz: None,
        strips: Vec::new(),
        line_spacing: Vec::new(),
        notes,
    }
}
