//! `[scanner]`'s deflector keys: which kind, and the keys of that kind.

use super::{Bounds, Checker};
use crate::message::num;
use crate::sensor::deflector::risley::Prism;
use crate::sensor::deflector::{Deflector, Fibre, Mirror, MirrorProfile, Palmer, Polygon, Risley};
use crate::survey::KeyPath;
use crate::survey::raw::RawScanner;

/// The kinds, as the survey spells them.
const KINDS: [&str; 5] = ["oscillating", "polygon", "palmer", "risley", "fibre"];

/// Checks the deflector keys of `[scanner]` (`sp`) for pulses at `prf_hz`.
pub(crate) fn deflector(c: &mut Checker, s: &RawScanner, sp: &KeyPath, prf_hz: f64) -> Deflector {
    let kind = kind(c, s, sp);
    check_owned_keys(c, s, sp, kind);
    if kind == "risley" {
        check_keys_risley_ignores(c, s, sp);
        return Deflector::Risley(risley(c, s, sp, prf_hz));
    }
    let freq_key = sp.key("scan_frequency_hz");
    let scan_frequency_hz = c.positive(freq_key.clone(), s.scan_frequency_hz, 50.0, " Hz");
    // A polygon's facet may look up to ±180° (a mirror turning a full
    // circle, as on UAV scanners that see sideways and up); the other
    // deflectors look down.
    let widest = if kind == "polygon" { 180.0 } else { 89.0 };
    let scan_angle_deg = scan_angle(c, sp.key("scan_angle_deg"), s.scan_angle_deg, widest);
    let sweep = Sweep {
        freq_key,
        prf_hz,
        scan_frequency_hz,
        scan_angle_deg,
    };
    match kind {
        "polygon" => Deflector::Polygon(polygon(c, s, sp, &sweep)),
        "palmer" => Deflector::Palmer(palmer(c, s, sp, &sweep)),
        "fibre" => Deflector::Fibre(fibre(c, s, sp, &sweep)),
        _ => Deflector::Oscillating(mirror(c, s, sp, &sweep)),
    }
}

/// The deflector's kind, as `KINDS` spells it (the default when unknown,
/// with a problem).
fn kind<'a>(c: &mut Checker, s: &'a RawScanner, sp: &KeyPath) -> &'a str {
    match s.deflector.as_deref() {
        None => "oscillating",
        Some(k) if KINDS.contains(&k) => k,
        Some("conic") => "palmer",
        Some("fiber") => "fibre",
        Some(other) => {
            c.err(
                sp.key("deflector"),
                format!(
                    "unknown deflector '{other}'; expected one of {}",
                    KINDS.map(|k| format!("\"{k}\"")).join(", ")
                ),
            );
            "oscillating"
        }
    }
}

/// Keys that belong to one kind only must not be given for another.
fn check_owned_keys(c: &mut Checker, s: &RawScanner, sp: &KeyPath, kind: &str) {
    let owned = [
        ("mirror", s.mirror.is_some(), "oscillating"),
        ("facets", s.facets.is_some(), "polygon"),
        (
            "scan_angle_along_deg",
            s.scan_angle_along_deg.is_some(),
            "palmer",
        ),
        (
            "prism_deviation_deg",
            s.prism_deviation_deg.is_some(),
            "risley",
        ),
        (
            "rotor_frequency_hz",
            s.rotor_frequency_hz.is_some(),
            "risley",
        ),
        ("fibres", s.fibres.is_some(), "fibre"),
    ];
    for (key, given, owner) in owned {
        if given && owner != kind {
            c.err(
                sp.key(key),
                format!(
                    "applies only to deflector = \"{owner}\"; this scanner's deflector is \
                     \"{kind}\""
                ),
            );
        }
    }
}

/// Keys every kind but the Risley prisms uses must not be given for them.
fn check_keys_risley_ignores(c: &mut Checker, s: &RawScanner, sp: &KeyPath) {
    let unused = [
        (
            "scan_angle_deg",
            s.scan_angle_deg.is_some(),
            "the prisms set the field of view",
        ),
        (
            "scan_frequency_hz",
            s.scan_frequency_hz.is_some(),
            "the rotors set the pattern",
        ),
    ];
    for (key, given, why) in unused {
        if given {
            c.err(
                sp.key(key),
                format!("does not apply to deflector = \"risley\": {why}"),
            );
        }
    }
}

/// What every kind but the Risley prisms shares: a scan rate and angle.
struct Sweep {
    /// `scan_frequency_hz`'s key.
    freq_key: KeyPath,
    prf_hz: f64,
    scan_frequency_hz: f64,
    scan_angle_deg: f64,
}

impl Sweep {
    /// Half the field of view, radians.
    fn half_angle_rad(&self) -> f64 {
        self.scan_angle_deg.to_radians()
    }

    /// Fewest pulse slots per scan line (or per turn), `divisor`: below
    /// this the pattern is not drawn at all.
    fn limit(&self, c: &mut Checker, divisor: f64, label: &str, what: &str) {
        let most = self.prf_hz / divisor;
        if self.scan_frequency_hz > most {
            c.err(
                self.freq_key.clone(),
                format!(
                    "must be at most prf_hz / {label} = {} Hz, got {}: {what}",
                    num(most),
                    num(self.scan_frequency_hz)
                ),
            );
        }
    }
}

/// A rotating polygon: its facets, and a field of view within each
/// facet's sweep.
fn polygon(c: &mut Checker, s: &RawScanner, sp: &KeyPath, sweep: &Sweep) -> Polygon {
    let scan_angle_deg = sweep.scan_angle_deg;
    let facets = c.count(sp.key("facets"), s.facets, 4, 2, 64) as u32;
    if scan_angle_deg == 0.0 {
        c.err(
            sp.key("scan_angle_deg"),
            "must be above 0 for a polygon: pulses leave only while a facet looks \
             within ±scan_angle_deg, and a polygon with no field of view fires none",
        );
    }
    let sweep_half_deg = 360.0 / f64::from(facets);
    if scan_angle_deg > sweep_half_deg {
        c.err(
            sp.key("scan_angle_deg"),
            format!(
                "must be at most 360° / facets = {}° for {facets} facets (each facet \
                 sweeps the beam through ±{}°), got {}",
                num(sweep_half_deg),
                num(sweep_half_deg),
                num(scan_angle_deg)
            ),
        );
    }
    sweep.limit(
        c,
        4.0,
        "4",
        "scan_frequency_hz is the polygon's scan lines per second, and a line needs \
         at least four pulse slots",
    );
    Polygon {
        facets,
        line_rate_hz: sweep.scan_frequency_hz,
        scan_half_angle_rad: sweep.half_angle_rad(),
    }
}

/// A Palmer (conical) scanner: its ellipse's half-angles.
fn palmer(c: &mut Checker, s: &RawScanner, sp: &KeyPath, sweep: &Sweep) -> Palmer {
    let along = match s.scan_angle_along_deg {
        None => sweep.scan_angle_deg,
        given => scan_angle(c, sp.key("scan_angle_along_deg"), given, 89.0),
    };
    sweep.limit(
        c,
        8.0,
        "8",
        "scan_frequency_hz is the Palmer scanner's turns per second, and a turn \
         needs at least eight pulses to draw its ellipse",
    );
    Palmer {
        rotation_hz: sweep.scan_frequency_hz,
        across_half_angle_rad: sweep.half_angle_rad(),
        along_half_angle_rad: along.to_radians(),
    }
}

/// A fibre array: its fibres, each fired once per sweep.
fn fibre(c: &mut Checker, s: &RawScanner, sp: &KeyPath, sweep: &Sweep) -> Fibre {
    let fibres = c.count(sp.key("fibres"), s.fibres, 128, 2, 4096) as u32;
    sweep.limit(
        c,
        f64::from(fibres),
        "fibres",
        "scan_frequency_hz is the fibre fan's sweeps per second, and each sweep \
         fires every fibre once",
    );
    Fibre {
        fibres,
        scan_half_angle_rad: sweep.half_angle_rad(),
        sweep_rate_hz: sweep.scan_frequency_hz,
    }
}

/// An oscillating mirror: its profile.
fn mirror(c: &mut Checker, s: &RawScanner, sp: &KeyPath, sweep: &Sweep) -> Mirror {
    let profile = match s.mirror.as_deref() {
        None | Some("triangle") => MirrorProfile::Triangle,
        Some("sine") | Some("sinusoidal") => MirrorProfile::Sine,
        Some(other) => {
            c.err(
                sp.key("mirror"),
                format!("unknown mirror '{other}'; expected \"triangle\" or \"sine\""),
            );
            MirrorProfile::Triangle
        }
    };
    sweep.limit(
        c,
        4.0,
        "4",
        "the mirror would sweep its scan line with fewer than two pulses",
    );
    Mirror {
        profile,
        scan_frequency_hz: sweep.scan_frequency_hz,
        scan_half_angle_rad: sweep.half_angle_rad(),
    }
}

/// A scan half-angle, degrees: from 0 to `widest` (default 20).
fn scan_angle(c: &mut Checker, key: KeyPath, value: Option<f64>, widest: f64) -> f64 {
    let given = match value {
        Some(a) if a >= 90.0 && widest < 90.0 => {
            c.err(
                key.clone(),
                format!(
                    "must be between 0 and 89°, got {a}: at 90° or more from nadir the beam \
                     points at or above the horizon and meets no ground"
                ),
            );
            None
        }
        other => other,
    };
    c.number(key, given, 20.0, Bounds::between(0.0, widest, "°"))
}

/// The Risley prisms: two or three, deviations adding up to less than 89°.
fn risley(c: &mut Checker, s: &RawScanner, sp: &KeyPath, prf_hz: f64) -> Risley {
    let dev_key = sp.key("prism_deviation_deg");
    let rot_key = sp.key("rotor_frequency_hz");
    let (Some(devs), Some(rots)) = (&s.prism_deviation_deg, &s.rotor_frequency_hz) else {
        let missing = if s.prism_deviation_deg.is_none() {
            dev_key
        } else {
            rot_key
        };
        c.err(
            missing,
            "a Risley scanner needs prism_deviation_deg and rotor_frequency_hz, one value per \
             prism (e.g. [17.6, 17.6] and [-77.7, 121.6])",
        );
        return Risley { prisms: Vec::new() };
    };
    if !(2..=3).contains(&devs.len()) || devs.len() != rots.len() {
        c.err(
            rot_key,
            format!(
                "give two or three prisms, the same number in prism_deviation_deg and \
                 rotor_frequency_hz; got {} and {}",
                devs.len(),
                rots.len()
            ),
        );
        return Risley { prisms: Vec::new() };
    }
    let mut prisms = Vec::new();
    for (i, (&d, &f)) in devs.iter().zip(rots).enumerate() {
        let d = c.number(
            dev_key.index(i),
            Some(d),
            10.0,
            Bounds::above(0.0, "°").at_most(45.0),
        );
        if !f.is_finite() || f == 0.0 || f.abs() > prf_hz / 8.0 {
            c.err(
                rot_key.index(i),
                format!(
                    "must be a non-zero rate of at most prf_hz / 8 = {} Hz in size, got {}",
                    num(prf_hz / 8.0),
                    num(f)
                ),
            );
        }
        prisms.push(Prism {
            deviation_rad: d.to_radians(),
            frequency_hz: f,
        });
    }
    let r = Risley { prisms };
    if r.half_field_of_view_rad().to_degrees() >= 89.0 {
        c.err(
            dev_key,
            format!(
                "the deviations add up to {}°: the beam would reach the horizon",
                num(r.half_field_of_view_rad().to_degrees())
            ),
        );
    }
    r
}
