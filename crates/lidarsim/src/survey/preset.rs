//! Instrument presets: `[scanner] preset = "riegl_vq_780i"` fills every
//! `[scanner]` key the survey does not give with the instrument's datasheet
//! value, and names the instrument's limits so that a survey asking for
//! more (a PRF it does not offer, a scan rate beyond its range, a wider
//! field of view) is warned.
//!
//! Values come from the manufacturers' datasheets where those state them
//! and otherwise from the instrument definitions of the reference simulator
//! HELIOS++ (`scanners_als.xml`), as each preset's `source` says. The beam
//! divergence here is the full angle at 1/e² of the peak irradiance.
//!
//! Two-channel instruments (RIEGL VQ-1560i) have their channels
//! (`[[scanner.channels]]`); the Livox Avia's six emitters are modelled as
//! one beam at their total pulse rate; elliptical beams have both
//! divergences; each preset's `note` says what it leaves out.

use crate::message::num;
use crate::survey::raw::RawScanner;

/// An instrument.
#[derive(Clone, Debug, PartialEq)]
pub struct Preset {
    /// Survey id (`riegl_vq_780i`).
    pub id: &'static str,
    /// Maker and model.
    pub name: &'static str,
    /// Where the values come from.
    pub source: &'static str,
    /// What the preset does not model, if anything.
    pub note: &'static str,
    /// `[scanner]` keys it sets, as TOML.
    pub keys: &'static str,
    /// Pulse rates offered, Hz: a list, or `[min, max]` when `prf_range`.
    pub prf_hz: &'static [f64],
    /// Whether `prf_hz` is a range rather than a list.
    pub prf_range: bool,
    /// Scan rates (lines/s, turns/s or sweeps/s as the deflector counts
    /// them), Hz: `[min, max]`; empty for a Risley scanner (fixed rotors).
    pub scan_frequency_hz: &'static [f64],
    /// Largest scan half-angle, degrees.
    pub max_scan_angle_deg: f64,
}

/// Every preset.
pub const PRESETS: &[Preset] = &[
    Preset {
        id: "leica_als50_ii",
        name: "Leica ALS50-II",
        source: "NERC-ARF sensor notes (Leica ALS50-II): 75° FOV, 0.22 mrad, 1064 nm, 4 returns, \
                 returns at least 2.7 m apart, a 4 or 9 ns pulse, up to 150 kHz; HELIOS++ \
                 scanners_als.xml: 0–90 Hz scan",
        note: "which of its 4 and 9 ns pulses goes with which pulse rate (4 ns is taken)",
        keys: r#"deflector = "oscillating"
mirror = "triangle"
prf_hz = 150000
scan_frequency_hz = 40
scan_angle_deg = 20
divergence_mrad = 0.22
wavelength_nm = 1064
pulse_fwhm_ns = 4
max_returns = 4
echo_detection = "discrete"
min_return_separation_m = 2.7"#,
        prf_hz: &[20_000.0, 150_000.0],
        prf_range: true,
        scan_frequency_hz: &[0.0, 90.0],
        max_scan_angle_deg: 37.5,
    },
    Preset {
        id: "optech_galaxy",
        name: "Teledyne Optech Galaxy",
        source: "HELIOS++ scanners_als.xml (optech_galaxy): 35–550 kHz, 0–120 Hz, ±30°, \
                 1064 nm, 8 ns, 8 returns; divergence 0.25 mrad (Optech datasheet)",
        note: "its least separation of returns is not published: a discrete receiver's default \
               (2.7 m); the datasheet's 0.25 mrad divergence is taken as the 1/e² angle (HELIOS++ uses \
               0.354 mrad, √2 × 0.25)",
        keys: r#"deflector = "oscillating"
mirror = "triangle"
prf_hz = 550000
scan_frequency_hz = 60
scan_angle_deg = 25
divergence_mrad = 0.25
wavelength_nm = 1064
pulse_fwhm_ns = 8
max_returns = 8
echo_detection = "discrete""#,
        prf_hz: &[35_000.0, 550_000.0],
        prf_range: true,
        scan_frequency_hz: &[0.0, 120.0],
        max_scan_angle_deg: 30.0,
    },
    Preset {
        id: "riegl_lms_q780",
        name: "RIEGL LMS-Q780",
        source: "RIEGL LMS-Q780 datasheet and bathymetry slides: polygon, 60° FOV of a 90° \
                 facet sweep, up to 400 kHz (266 k measurements/s), 10–200 lines/s, \
                 0.25 mrad, 20 mm; HELIOS++ scanners_als.xml: 100/200/300/400 kHz",
        note: "",
        keys: r#"deflector = "polygon"
facets = 8
prf_hz = 400000
scan_frequency_hz = 100
scan_angle_deg = 30
divergence_mrad = 0.25
wavelength_nm = 1064
pulse_fwhm_ns = 4
max_returns = 15
echo_detection = "waveform""#,
        prf_hz: &[100_000.0, 200_000.0, 300_000.0, 400_000.0],
        prf_range: false,
        scan_frequency_hz: &[10.0, 200.0],
        max_scan_angle_deg: 30.0,
    },
    Preset {
        id: "riegl_vq_780i",
        name: "RIEGL VQ-780i",
        source: "HELIOS++ scanners_als.xml (riegl_vq-780i): polygon ±45° sweep, ±30° effective, \
                 150–1000 kHz, 20–300 lines/s, 0.25 mrad, 4 ns, 5 returns at 1 MHz",
        note: "",
        keys: r#"deflector = "polygon"
facets = 8
prf_hz = 1000000
scan_frequency_hz = 225
scan_angle_deg = 30
divergence_mrad = 0.25
wavelength_nm = 1064
pulse_fwhm_ns = 4
max_returns = 5
echo_detection = "waveform""#,
        prf_hz: &[
            150_000.0,
            250_000.0,
            350_000.0,
            500_000.0,
            700_000.0,
            1_000_000.0,
        ],
        prf_range: false,
        scan_frequency_hz: &[20.0, 300.0],
        max_scan_angle_deg: 30.0,
    },
    Preset {
        id: "riegl_vq_1560i",
        name: "RIEGL VQ-1560i",
        source: "RIEGL VQ-1560i datasheet: two channels, up to 2 MHz (1.33 M measurements/s on \
                 the ground), 60° FOV; HELIOS++ scanners_als.xml: ±14° fore/aft channel tilt, \
                 40–600 lines/s",
        note: "both channels share one polygon and fire in turn (1 MHz each at 2 MHz); the 8° \
               yaw of an early HELIOS++ definition is left out (not in the datasheet)",
        keys: r#"deflector = "polygon"
facets = 8
prf_hz = 2000000
scan_frequency_hz = 400
scan_angle_deg = 30
divergence_mrad = 0.25
wavelength_nm = 1064
pulse_fwhm_ns = 4
max_returns = 5
echo_detection = "waveform"

[[channels]]
along_tilt_deg = 14

[[channels]]
along_tilt_deg = -14"#,
        prf_hz: &[
            150_000.0,
            250_000.0,
            350_000.0,
            500_000.0,
            700_000.0,
            1_000_000.0,
            2_000_000.0,
        ],
        prf_range: false,
        scan_frequency_hz: &[40.0, 600.0],
        max_scan_angle_deg: 30.0,
    },
    Preset {
        id: "riegl_vux_1uav",
        name: "RIEGL VUX-1UAV",
        source: "HELIOS++ scanners_als.xml (riegl_vux-1uav): rotating mirror, 330° of each \
                 360° turn, 50–550 kHz, 10–200 lines/s, 0.5 mrad, 4 returns at 550 kHz",
        note: "",
        keys: r#"deflector = "polygon"
facets = 2
prf_hz = 550000
scan_frequency_hz = 100
scan_angle_deg = 165
divergence_mrad = 0.5
wavelength_nm = 1064
pulse_fwhm_ns = 4
max_returns = 4
echo_detection = "waveform""#,
        prf_hz: &[
            50_000.0, 100_000.0, 200_000.0, 300_000.0, 380_000.0, 550_000.0,
        ],
        prf_range: false,
        scan_frequency_hz: &[10.0, 200.0],
        max_scan_angle_deg: 165.0,
    },
    Preset {
        id: "riegl_vq_880_g",
        name: "RIEGL VQ-880-G (green channel)",
        source: "HELIOS++ scanners_als.xml (riegl_vq-880g): Palmer scanner, ±20° cone, \
                 200–700 kHz, 30–80 turns/s, 532 nm, 0.7 mrad (0.7/1.0/1.5 selectable), \
                 9 returns",
        note: "the green (bathymetric) channel; water is not modelled",
        keys: r#"deflector = "palmer"
prf_hz = 550000
scan_frequency_hz = 80
scan_angle_deg = 20
divergence_mrad = 0.7
wavelength_nm = 532
pulse_fwhm_ns = 2
max_returns = 9
echo_detection = "waveform""#,
        prf_hz: &[200_000.0, 400_000.0, 550_000.0, 700_000.0],
        prf_range: false,
        scan_frequency_hz: &[30.0, 80.0],
        max_scan_angle_deg: 20.0,
    },
    Preset {
        id: "livox_mid_70",
        name: "Livox Mid-70",
        source: "Livox Mid-70 user manual: 70.4° circular FOV, 100 k points/s, 905 nm, \
                 0.28° × 0.03° beam; rotors −4664 and +7294 rpm (Brazeal et al., Sensors \
                 21:4722, 2021; HELIOS++ scanners_als.xml)",
        note: "prism deviations are the first-order ones (17.6° each) that give the 70.4° FOV; \
               the beam's 0.03° × 0.28° (FWHM) as 0.89 × 8.3 mrad at 1/e², the wide axis \
               along the track (the mounting decides it)",
        keys: r#"deflector = "risley"
prism_deviation_deg = [17.6, 17.6]
rotor_frequency_hz = [-77.733333, 121.566667]
prf_hz = 100000
divergence_mrad = 0.89
divergence_along_mrad = 8.3
wavelength_nm = 905
pulse_fwhm_ns = 4
max_returns = 2
echo_detection = "discrete""#,
        prf_hz: &[100_000.0],
        prf_range: false,
        scan_frequency_hz: &[],
        max_scan_angle_deg: 35.2,
    },
    Preset {
        id: "livox_avia",
        name: "Livox Avia",
        source: "HELIOS++ scanners_als.xml (DJI Zenmuse L1 = Livox Avia): three prisms at \
                 −131.55, 40.80 and 213.16 Hz, 6 emitters × 40 kHz = 240 k points/s, 905 nm, \
                 3 returns; 70.4° × 77.2° FOV (Livox Avia user manual)",
        note: "one beam at the six emitters' total rate; the 70.4° × 77.2° field of view as a \
               circle of ±38.6° (prism deviations: the exact single-prism ones scaled to it); \
               the beam's 0.03° × 0.28° (FWHM) as 0.89 × 8.3 mrad at 1/e², the wide axis \
               along the track",
        keys: r#"deflector = "risley"
prism_deviation_deg = [19.06, 18.01, 1.53]
rotor_frequency_hz = [-131.5463, 40.8032, 213.1611]
prf_hz = 240000
divergence_mrad = 0.89
divergence_along_mrad = 8.3
wavelength_nm = 905
pulse_fwhm_ns = 4
max_returns = 3
echo_detection = "discrete""#,
        prf_hz: &[240_000.0],
        prf_range: false,
        scan_frequency_hz: &[],
        max_scan_angle_deg: 38.6,
    },
];

/// The preset with this id.
pub fn find(id: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.id == id)
}

/// Keys that belong to one deflector kind: a survey that names another
/// deflector than the preset's takes none of these from the preset.
const DEFLECTOR_KEYS: [&str; 8] = [
    "mirror",
    "facets",
    "scan_angle_along_deg",
    "prism_deviation_deg",
    "rotor_frequency_hz",
    "fibres",
    "scan_angle_deg",
    "scan_frequency_hz",
];

/// A preset as a survey used it.
#[derive(Clone, Debug, PartialEq)]
pub struct PresetUse {
    /// The instrument.
    pub preset: &'static Preset,
    /// The `[scanner]` keys it set (`key = value`), those the survey did
    /// not give.
    pub set: Vec<String>,
}

/// `raw` with the keys it does not give taken from `preset`, and those
/// keys as `key = value` lines.
pub fn apply(preset: &Preset, raw: &RawScanner) -> (RawScanner, Vec<String>) {
    let own_deflector_keys = toml::from_str::<toml::Table>(preset.keys)
        .expect("preset keys are valid TOML")
        .get("deflector")
        .cloned();
    fill(raw, preset.keys, |table, k| {
        // A survey that names another kind of deflector than the
        // instrument's takes none of the instrument's deflector keys.
        let own_deflector = table
            .get("deflector")
            .is_some_and(|own| Some(own) != own_deflector_keys.as_ref());
        // A survey that sets the divergence has a round beam unless it
        // sets the divergence along the track too.
        let own_beam = k == "divergence_along_mrad" && table.contains_key("divergence_mrad");
        own_beam || (own_deflector && DEFLECTOR_KEYS.contains(&k))
    })
}

/// `raw` (a table of the survey) with each of `keys` (TOML) that it does
/// not give and `skip(raw's table, key)` does not refuse, and the keys
/// taken as `key = value` lines: how a preset fills a table.
pub(crate) fn fill<T: serde::Serialize + serde::de::DeserializeOwned>(
    raw: &T,
    keys: &str,
    skip: impl Fn(&toml::Table, &str) -> bool,
) -> (T, Vec<String>) {
    let mut table = match toml::Value::try_from(raw) {
        Ok(toml::Value::Table(t)) => t,
        _ => Default::default(),
    };
    let keys: toml::Table = toml::from_str(keys).expect("preset keys are valid TOML");
    let mut set = Vec::new();
    for (k, v) in keys {
        if table.contains_key(&k) || skip(&table, &k) {
            continue;
        }
        set.push(format!("{k} = {v}"));
        table.insert(k, v);
    }
    let merged = toml::Value::Table(table)
        .try_into()
        .expect("preset keys belong to the table");
    (merged, set)
}

/// The deflector kind the preset sets.
pub fn kind(preset: &Preset) -> String {
    let keys: toml::Table = toml::from_str(preset.keys).expect("preset keys are valid TOML");
    keys.get("deflector")
        .and_then(|k| k.as_str())
        .unwrap_or("oscillating")
        .to_string()
}

/// Warnings for settings beyond the instrument's datasheet limits: the
/// PRF, and — when the survey keeps the instrument's kind of deflector —
/// its scan rate and field of view.
pub fn limits(
    preset: &Preset,
    prf_hz: f64,
    deflector: &crate::sensor::deflector::Deflector,
) -> Vec<String> {
    use crate::sensor::deflector::Deflector;
    let mut out = Vec::new();
    let list = |v: &[f64]| v.iter().map(|x| num(*x)).collect::<Vec<_>>().join(", ");
    let prf_ok = if preset.prf_range {
        (preset.prf_hz[0]..=preset.prf_hz[1]).contains(&prf_hz)
    } else {
        preset.prf_hz.iter().any(|&p| (p - prf_hz).abs() < 0.5)
    };
    if !prf_ok {
        let offered = if preset.prf_range {
            format!("{} to {} Hz", num(preset.prf_hz[0]), num(preset.prf_hz[1]))
        } else {
            format!("{} Hz", list(preset.prf_hz))
        };
        out.push(format!(
            "key `scanner.prf_hz`: the {} offers {offered} (datasheet), not {} Hz",
            preset.name,
            num(prf_hz)
        ));
    }
    if deflector.kind() != kind(preset) {
        return out;
    }
    let scan_frequency_hz = match deflector {
        Deflector::Oscillating(m) => Some(m.scan_frequency_hz),
        Deflector::Polygon(p) => Some(p.line_rate_hz),
        Deflector::Palmer(p) => Some(p.rotation_hz),
        Deflector::Fibre(f) => Some(f.sweep_rate_hz),
        Deflector::Risley(_) => None,
    };
    if let (Some(f), [lo, hi]) = (scan_frequency_hz, preset.scan_frequency_hz)
        && (f < *lo || f > *hi)
    {
        out.push(format!(
            "key `scanner.scan_frequency_hz`: the {} scans at {} to {} Hz (datasheet), not {} Hz",
            preset.name,
            num(*lo),
            num(*hi),
            num(f)
        ));
    }
    let half_angle_deg = deflector.max_off_nadir_rad().to_degrees();
    if half_angle_deg > preset.max_scan_angle_deg + 1e-6 {
        let key = match deflector {
            Deflector::Risley(_) => "prism_deviation_deg",
            Deflector::Palmer(p) if p.along_half_angle_rad > p.across_half_angle_rad => {
                "scan_angle_along_deg"
            }
            _ => "scan_angle_deg",
        };
        out.push(format!(
            "key `scanner.{key}`: the {} sees at most ±{}° (datasheet), not ±{:.2}°",
            preset.name,
            num(preset.max_scan_angle_deg),
            half_angle_deg
        ));
    }
    out
}
