//! Survey configuration: parse, validate, build the scene.
//!
//! Two layers (raw values as in the file, then a checked form): [`RawSurvey`] mirrors
//! the TOML file; [`Survey`] is the checked form the simulator trusts, with
//! units converted (degrees → radians, ns → s) and the [`Scene`] built.
//! Every problem is reported as a [`Diagnostic`] naming the file, line,
//! column and key; all problems found in one pass are reported together.

mod locate;
pub mod raw;

pub use locate::{KeyPath, Locator, Seg};
pub use raw::RawSurvey;

use std::collections::HashMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::canopy::{CanopyConfig, ReturnModel};
use crate::detection::{DetectorConfig, ReturnSelection};
use crate::geometry::DVec3;
use crate::io::obj::load_obj;
use crate::message::edit_distance;
pub use crate::message::num;
use crate::scene::forest::{ForestSpec, generate};
use crate::scene::{
    Material, MeshPlacement, Polygon, Primitive, Scene, Shape, Species, SurfaceClass, TreeSpec,
};
use crate::sensor::navigation::{ErrorModel, LineErrors, NavigationErrors};
use crate::sensor::platform::{Drift, FlightLine, Interpolation, Sway, SwayConfig, plan_lines};
use crate::sensor::scanner::{Mirror, MirrorProfile};
use crate::waveform::{PulseShape, ReceiverConfig, range_to_bin};

/// Highest pulse repetition frequency accepted, Hz.
pub const MAX_PRF_HZ: f64 = 1e7;

/// Longest flight line accepted, hours (no airborne line lasts a day; the
/// limit keeps pulse counts and per-line error series finite).
pub const MAX_LINE_HOURS: f64 = 24.0;

pub use crate::geometry::MAX_COORDINATE_M;

/// Shortest emitted pulse accepted (FWHM), ns.
pub const MIN_PULSE_FWHM_NS: f64 = 0.01;

/// Most samples of the emitted pulse's shape at the receiver's bin: each
/// sub-ray return is convolved with them.
pub const MAX_PULSE_SAMPLES: usize = 4096;

/// Most samples of a pulse's record from `min_range_m` to `max_range_m`
/// (with f64 samples, 32 MiB per buffer and thread).
pub const MAX_WINDOW_SAMPLES: usize = 1 << 22;

/// Longest range accepted (`max_range_m`, `reference_range_m`), m.
pub const MAX_RANGE_M: f64 = 100_000.0;

/// Most attitude sway frequencies (each costs every pulse a sine).
pub const MAX_SWAY_FREQUENCIES: usize = 32;

/// Most vertices of a `[[polygon]]` and of an outline (`area_m`): larger
/// shapes belong in a mesh file.
pub const MAX_POLYGON_VERTICES: usize = 4096;

/// Most flight lines a `[plan]` may generate.
pub const MAX_PLAN_LINES: usize = 10_000;

/// Largest species weight of a `[[forest]]` mix (weights are relative).
pub const MAX_SPECIES_WEIGHT: f64 = 1e6;

/// Most trees in a survey (`[[tree]]` entries and generated stands): each
/// costs about 1 kB of scene and index.
pub const MAX_TREES: f64 = 5e6;

/// Largest GNSS position error of any kind (bias, noise, random walk), m.
pub const MAX_GNSS_ERROR_M: f64 = 1000.0;

/// Largest attitude or boresight error of any kind, degrees.
pub const MAX_ATTITUDE_ERROR_DEG: f64 = 10.0;

/// Seed used when the survey names none.
pub const DEFAULT_SEED: u64 = 1;

/// One problem in a survey file.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// The survey file (or `<demo>` for the built-in survey).
    pub file: String,
    /// 1-based line (0 when unknown).
    pub line: usize,
    /// 1-based column (0 when unknown).
    pub column: usize,
    /// The key the problem is about (`scanner.prf_hz`).
    pub key: String,
    /// What is wrong, and what would be right.
    pub message: String,
    /// The offending line of the file.
    pub source_line: Option<String>,
    /// Characters to underline from `column` on (at least 1).
    pub width: usize,
    /// A hint, when one is obvious ("did you mean `prf_hz`?").
    pub help: Option<String>,
}

impl Diagnostic {
    /// A problem with the whole file (unreadable, not UTF-8), at `line` if
    /// known (0 otherwise).
    pub fn file_level(file: &str, line: usize, message: String) -> Self {
        Self {
            file: file.to_string(),
            line,
            column: 0,
            key: String::new(),
            message,
            source_line: None,
            width: 1,
            help: None,
        }
    }
}

/// Rendered like the diagnostics of rustc and miette, without colours:
///
/// ```text
/// key `flight_line[0].speed_mps`: must be greater than 0 m/s, got -3
///   --> survey.toml:11:13
///    |
/// 11 | speed_mps = -3
///    |             ^^
///    = help: …
/// ```
impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}", self.message)?;
        } else {
            write!(f, "key `{}`: {}", self.key, self.message)?;
        }
        let gutter = " ".repeat(self.line.max(1).to_string().len());
        write!(f, "\n{gutter}--> {}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}", self.line)?;
            if self.column > 0 {
                write!(f, ":{}", self.column)?;
            }
        }
        if let Some(src) = &self.source_line {
            // A long line is shown as a window around the column, so that
            // a 20 MB value is not echoed whole.
            let src: Vec<char> = src.trim_end().chars().collect();
            let col = self.column.max(1) - 1;
            let from = col.saturating_sub(SHOWN_BEFORE);
            let to = (col + SHOWN_AFTER).min(src.len());
            let lead = if from > 0 { "…" } else { "" };
            let tail = if to < src.len() { "…" } else { "" };
            let text: String = src[from.min(to)..to].iter().collect();
            write!(f, "\n{gutter} |\n{} | {lead}{text}{tail}", self.line)?;
            if self.column > 0 {
                let shown = to - from.min(to);
                let at = col - from + lead.chars().count();
                let width = self.width.min(shown.saturating_sub(col - from)).max(1);
                write!(f, "\n{gutter} | {}{}", " ".repeat(at), "^".repeat(width))?;
            }
        }
        if let Some(help) = &self.help {
            write!(f, "\n{gutter} = help: {help}")?;
        }
        Ok(())
    }
}

/// Characters of a source line shown before the column of a problem.
const SHOWN_BEFORE: usize = 60;
/// Characters of a source line shown from the column of a problem on.
const SHOWN_AFTER: usize = 100;

/// A survey that could not be loaded: one or more diagnostics.
#[derive(Clone, Debug, PartialEq)]
pub struct SurveyError {
    /// All problems found.
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for SurveyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for SurveyError {}

/// Scanner settings after validation.
#[derive(Clone, Debug, PartialEq)]
pub struct ScannerSettings {
    /// Pulse repetition frequency, Hz.
    pub prf_hz: f64,
    /// The oscillating mirror.
    pub mirror: Mirror,
    /// Full beam divergence, rad.
    pub divergence_rad: f64,
    /// Sub-rays per pulse.
    pub subrays: usize,
    /// Closest range the receiver records, m.
    pub min_range_m: f64,
    /// Farthest range the receiver records, m.
    pub max_range_m: f64,
    /// Laser wavelength, nm (recorded in the summary).
    pub wavelength_nm: f64,
}

/// Which files to write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Formats {
    /// `points.las` (`"las"`, point format 6, or `"las-waveform"`).
    pub las: bool,
    /// `points.las` as point format 9 with the waveforms in `points.wdp`
    /// (`"las-waveform"`; implies `las`).
    pub las_waveform: bool,
    /// `points.laz` (`"laz"`).
    pub laz: bool,
    /// `points.ply` (`"ply"`).
    pub ply: bool,
    /// `points.xyz` (`"xyz"`).
    pub xyz: bool,
}

/// Output settings after validation.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSettings {
    /// Point formats.
    pub formats: Formats,
    /// Interval between rows of `trajectory.csv`, s.
    pub trajectory_interval_s: f64,
    /// When set, GPS times are Adjusted Standard GPS Time and the flight
    /// starts at this value (s); otherwise they are seconds since the start
    /// of the flight.
    pub gps_start_time_s: Option<f64>,
    /// LAS coordinate resolution, m.
    pub las_scale_m: f64,
    /// Echo attributes as LAS extra bytes (`extra_bytes`, default on).
    pub extra_bytes: bool,
    /// OGC WKT of the coordinate reference system (`crs` or `crs_wkt`).
    pub crs_wkt: Option<String>,
    /// EPSG code when the CRS was given as `crs = "EPSG:code"`.
    pub crs_epsg: Option<u32>,
    /// Added to world coordinates in every output (points and
    /// trajectories), m: `offset_m = [E, N, H]`.
    pub offset_m: DVec3,
}

/// A validated survey with its scene.
#[derive(Clone, Debug)]
pub struct Survey {
    /// Seed of all random streams.
    pub seed: u64,
    /// Laser, mirror and beam.
    pub scanner: ScannerSettings,
    /// Receiver (sampling, pulse, noise).
    pub receiver: ReceiverConfig,
    /// Echo detection.
    pub detector: DetectorConfig,
    /// Speckle looks when speckle is on.
    pub speckle_looks: Option<f64>,
    /// LAS intensity per unit of echo energy amplitude.
    pub intensity_gain: f64,
    /// Attitude sway settings when sway is on.
    pub sway: Option<SwayConfig>,
    /// Time between the end of one line and the start of the next, s.
    pub turn_time_s: f64,
    /// Flight lines in flight order (sway seeded per line).
    pub lines: Vec<FlightLine>,
    /// How sub-rays march through tree crowns.
    pub canopy: CanopyConfig,
    /// GNSS/IMU, boresight, lever-arm, ranging and encoder errors.
    pub navigation: NavigationErrors,
    /// Trees placed by `[[forest]]` entries, per entry.
    pub forest_trees: Vec<usize>,
    /// Things that are allowed but probably not what was meant, each
    /// naming its key (printed by the command line, kept in the summary).
    pub warnings: Vec<String>,
    /// What to write.
    pub output: OutputSettings,
    /// The surfaces.
    pub scene: Scene,
    /// The raw form it was built from (for the summary and `--export`).
    pub raw: RawSurvey,
    /// The file it was read from, if any.
    pub source: Option<PathBuf>,
}

/// Splits a serde message into what the user reads and a hint: an unknown
/// field gets "did you mean" when one of the expected names is within two
/// edits of the one given (otherwise the list of valid names); Rust type
/// names become TOML words.
fn explain(message: &str) -> (String, Option<String>) {
    let message = message.trim();
    if let Some(rest) = message.strip_prefix("unknown field `")
        && let Some((given, expected)) = rest.split_once('`')
    {
        let names: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
        let best = names
            .iter()
            .map(|name| (edit_distance(given, name), *name))
            .min();
        let help = match best {
            Some((d, name)) if d <= 2 => format!("did you mean `{name}`?"),
            _ if names.is_empty() => "this table takes no keys".to_string(),
            _ => format!("valid keys here: {}", names.join(", ")),
        };
        return (format!("unknown field `{given}`"), Some(help));
    }
    let mut m = message.to_string();
    for (rust, toml) in [
        ("expected f64", "expected a number"),
        ("expected u64", "expected a non-negative integer"),
        ("expected i64", "expected an integer"),
        ("expected a sequence", "expected an array"),
        ("expected a boolean", "expected true or false"),
    ] {
        m = m.replace(rust, toml);
    }
    if let Some(at) = m.find("expected struct Raw") {
        m.replace_range(at.., "expected a table");
    }
    if let Some(rest) = m.strip_prefix("invalid type: integer `")
        && let Some((n, _)) = rest.split_once("` as i128")
    {
        m = format!(
            "integer {n} is too large: TOML integers are 64-bit (up to 9223372036854775807)"
        );
    }
    if m.contains("did not match any variant of untagged enum NumberOrList") {
        m = "expected a number or an array of numbers".to_string();
    }
    (m, None)
}

/// The error of `diagnostics` sorted by line (those without a line last).
fn diagnostics_in_file_order(mut diagnostics: Vec<Diagnostic>) -> SurveyError {
    diagnostics.sort_by_key(|d| if d.line == 0 { usize::MAX } else { d.line });
    SurveyError { diagnostics }
}

/// Most problems of structure (unknown keys, wrong types) collected before
/// giving up on a file.
const MAX_READ_PROBLEMS: usize = 100;

/// Our key path of a serde path.
fn key_path_of(path: &serde_path_to_error::Path) -> KeyPath {
    use serde_path_to_error::Segment;
    let mut k = KeyPath::root();
    for seg in path.iter() {
        k = match seg {
            Segment::Map { key } => k.key(key),
            Segment::Seq { index } => k.index(*index),
            Segment::Enum { .. } | Segment::Unknown => k,
        };
    }
    k
}

/// Removes the table key nearest to the end of `path` (the whole key of an
/// array element) and returns its path, or `None` when there is none.
fn remove_key(table: &mut toml::Table, path: &KeyPath) -> Option<KeyPath> {
    let last = path.0.iter().rposition(|s| matches!(s, Seg::Key(_)))?;
    let Seg::Key(name) = &path.0[last] else {
        return None;
    };
    let mut t = table;
    let mut segs = &path.0[..last];
    while let Some((Seg::Key(k), rest)) = segs.split_first() {
        let mut v = t.get_mut(k)?;
        let mut rest = rest;
        while let Some((Seg::Index(i), r)) = rest.split_first() {
            v = v.as_array_mut()?.get_mut(*i)?;
            rest = r;
        }
        t = v.as_table_mut()?;
        segs = rest;
    }
    if !segs.is_empty() {
        return None;
    }
    t.remove(name)?;
    Some(KeyPath(path.0[..=last].to_vec()))
}

/// Collects problems with their key paths during validation.
struct Checker {
    problems: Vec<(KeyPath, String)>,
}

impl Checker {
    fn err(&mut self, path: KeyPath, msg: impl Into<String>) {
        self.problems.push((path, msg.into()));
    }

    /// A finite number in `[lo, hi]` (open at the ends where `*_open`).
    #[allow(clippy::too_many_arguments)]
    fn number(
        &mut self,
        path: KeyPath,
        value: Option<f64>,
        default: f64,
        lo: f64,
        lo_open: bool,
        hi: f64,
        unit: &str,
    ) -> f64 {
        let v = value.unwrap_or(default);
        let below = if lo_open { v <= lo } else { v < lo };
        if !v.is_finite() || below || v > hi {
            let (lo, hi_s) = (num(lo), num(hi));
            let range = match (lo_open, hi.is_finite()) {
                (true, false) => format!("must be greater than {lo}{unit}"),
                (false, false) => format!("must be at least {lo}{unit}"),
                (true, true) => format!("must be greater than {lo} and at most {hi_s}{unit}"),
                (false, true) => format!("must be between {lo} and {hi_s}{unit}"),
            };
            self.err(path, format!("{range}, got {}", num(v)));
            return default;
        }
        v
    }

    fn positive(&mut self, path: KeyPath, value: Option<f64>, default: f64, unit: &str) -> f64 {
        self.number(path, value, default, 0.0, true, f64::INFINITY, unit)
    }

    fn count(&mut self, path: KeyPath, value: Option<i64>, default: i64, lo: i64, hi: i64) -> i64 {
        let v = value.unwrap_or(default);
        if v < lo || v > hi {
            self.err(
                path,
                format!("must be a whole number from {lo} to {hi}, got {v}"),
            );
            return default;
        }
        v
    }

    fn point(&mut self, path: KeyPath, value: &Option<Vec<f64>>) -> Option<DVec3> {
        match value {
            None => {
                self.err(path, "is required: a point [x, y, z] in metres");
                None
            }
            Some(v) if v.len() != 3 => {
                self.err(
                    path,
                    format!("must be [x, y, z] (3 numbers), got {} numbers", v.len()),
                );
                None
            }
            Some(v) if v.iter().any(|x| !x.is_finite()) => {
                self.err(path, "must hold finite numbers");
                None
            }
            Some(v) if v.iter().any(|x| x.abs() > MAX_COORDINATE_M) => {
                self.err(
                    path,
                    format!("coordinates must lie within ±{MAX_COORDINATE_M:e} m, got {v:?}"),
                );
                None
            }
            Some(v) => Some(DVec3::new(v[0], v[1], v[2])),
        }
    }

    fn class(&mut self, path: KeyPath, value: &Option<String>) -> SurfaceClass {
        match value {
            None => SurfaceClass::Unclassified,
            Some(s) => SurfaceClass::from_name(s).unwrap_or_else(|| {
                let names: Vec<&str> = SurfaceClass::ALL.iter().map(|(n, _)| *n).collect();
                self.err(
                    path,
                    format!("unknown class '{s}'; expected one of: {}", names.join(", ")),
                );
                SurfaceClass::Unclassified
            }),
        }
    }
}

/// Reads the axis values of `sigma_*` / `random_walk_*`: one number for all
/// three axes or a list of three, each from 0 to `max` (in the key's unit).
fn axes(
    c: &mut Checker,
    path: KeyPath,
    v: &Option<raw::NumberOrList>,
    default: [f64; 3],
    (scale, max, unit): (f64, f64, &str),
) -> [f64; 3] {
    let vals = match v {
        None => return default,
        Some(raw::NumberOrList::Number(x)) => [*x; 3],
        Some(raw::NumberOrList::List(l)) if l.len() == 3 => [l[0], l[1], l[2]],
        Some(raw::NumberOrList::List(l)) => {
            c.err(
                path,
                format!("must be one number or 3 numbers, got {}", l.len()),
            );
            return default;
        }
    };
    if vals.iter().any(|x| !(*x >= 0.0 && *x <= max)) {
        let worst = vals.iter().copied().fold(0.0, |a: f64, x| {
            if x.is_nan() || x.abs() > a.abs() {
                x
            } else {
                a
            }
        });
        c.err(
            path,
            format!(
                "must be between 0 and {}{unit}, got {}",
                num(max),
                num(worst)
            ),
        );
        return default;
    }
    vals.map(|x| x * scale)
}

/// Reads a `[x, y, z]` or `[roll, pitch, yaw]` list, each at most `max` in
/// magnitude (in the key's unit).
fn triple(
    c: &mut Checker,
    path: KeyPath,
    v: &Option<Vec<f64>>,
    (scale, max, unit): (f64, f64, &str),
) -> [f64; 3] {
    match v {
        None => [0.0; 3],
        Some(l) if l.len() == 3 && l.iter().all(|x| x.abs() <= max) => {
            [l[0] * scale, l[1] * scale, l[2] * scale]
        }
        Some(_) => {
            c.err(
                path,
                format!(
                    "must be a list of 3 numbers from -{0} to {0}{unit}",
                    num(max)
                ),
            );
            [0.0; 3]
        }
    }
}

/// Validates `preset`, `[gnss]`, `[imu]`, `[boresight]` and `[ranging]`.
fn check_navigation(c: &mut Checker, raw: &RawSurvey) -> NavigationErrors {
    let root = KeyPath::root();
    let lookup = |c: &mut Checker, path: KeyPath, name: &Option<String>| match name {
        None => None,
        Some(n) => crate::sensor::navigation::preset(n).or_else(|| {
            c.err(
                path,
                format!(
                    "unknown preset '{n}'; expected one of: {}",
                    crate::sensor::navigation::PRESETS.join(", ")
                ),
            );
            None
        }),
    };
    let top = lookup(c, root.key("preset"), &raw.preset);
    let deg = 1f64.to_radians();
    let group = |c: &mut Checker, key: &str, r: &raw::RawErrors, base: ErrorModel| {
        let p = root.key(key);
        let gnss = key == "gnss";
        let base = match lookup(c, p.key("preset"), &r.preset) {
            Some((g, i)) => {
                if gnss {
                    g
                } else {
                    i
                }
            }
            None => base,
        };
        // [gnss] takes metres, [imu] degrees: the other unit's keys exist in
        // the shared raw table but are errors here.
        // Bounds far beyond any navigation grade (a consumer GNSS errs by
        // metres, an IMU by fractions of a degree) that keep positions and
        // angles meaningful.
        let (bias, sigma, walk, unit) = if gnss {
            (
                &r.bias_m,
                &r.sigma_m,
                &r.random_walk_m,
                (1.0, MAX_GNSS_ERROR_M, " m"),
            )
        } else {
            (
                &r.bias_deg,
                &r.sigma_deg,
                &r.random_walk_deg,
                (deg, MAX_ATTITUDE_ERROR_DEG, "°"),
            )
        };
        let other_unit = if gnss {
            [
                ("bias_deg", r.bias_deg.is_some()),
                ("sigma_deg", r.sigma_deg.is_some()),
                ("random_walk_deg", r.random_walk_deg.is_some()),
            ]
        } else {
            [
                ("bias_m", r.bias_m.is_some()),
                ("sigma_m", r.sigma_m.is_some()),
                ("random_walk_m", r.random_walk_m.is_some()),
            ]
        };
        for (k, _) in other_unit.iter().filter(|(_, set)| *set) {
            let unit = if gnss {
                "metres (_m keys)"
            } else {
                "degrees (_deg keys)"
            };
            c.err(p.key(k), format!("[{key}] takes {unit}"));
        }
        let suffix = if gnss { "_m" } else { "_deg" };
        let mut m = base;
        if bias.is_some() {
            m.bias = triple(c, p.key(&format!("bias{suffix}")), bias, unit);
        }
        m.sigma = axes(c, p.key(&format!("sigma{suffix}")), sigma, m.sigma, unit);
        m.random_walk = axes(
            c,
            p.key(&format!("random_walk{suffix}")),
            walk,
            m.random_walk,
            unit,
        );
        if r.correlation_time_s.is_some() || m.correlation_time_s <= 0.0 {
            m.correlation_time_s = c.number(
                p.key("correlation_time_s"),
                r.correlation_time_s,
                if m.correlation_time_s > 0.0 {
                    m.correlation_time_s
                } else {
                    100.0
                },
                0.0,
                true,
                1e6,
                " s",
            );
        }
        m
    };
    let (g0, i0) = top.unwrap_or_default();
    let gnss = group(c, "gnss", &raw.gnss, g0);
    let imu = group(c, "imu", &raw.imu, i0);
    let bp = root.key("boresight");
    let rp = root.key("ranging");
    NavigationErrors {
        gnss,
        imu,
        boresight_rad: triple(
            c,
            bp.key("angles_deg"),
            &raw.boresight.angles_deg,
            (deg, MAX_ATTITUDE_ERROR_DEG, "°"),
        ),
        lever_arm_m: {
            let [x, y, z] = triple(
                c,
                bp.key("lever_arm_m"),
                &raw.boresight.lever_arm_m,
                (1.0, 100.0, " m"),
            );
            DVec3::new(x, y, z)
        },
        range_sigma_m: c.number(
            rp.key("sigma_m"),
            raw.ranging.sigma_m,
            0.0,
            0.0,
            false,
            100.0,
            " m",
        ),
        encoder_sigma_rad: c.number(
            rp.key("encoder_sigma_deg"),
            raw.ranging.encoder_sigma_deg,
            0.0,
            0.0,
            false,
            10.0,
            "°",
        ) * deg,
    }
}

/// What makes `points` unusable as the outline of an area, if anything:
/// no enclosed area (fewer than three distinct points, or all on a line),
/// or edges that cross or touch each other other than at their shared
/// corners (a bow tie encloses two areas of opposite sense, which cancel).
fn outline_problem(points: &[[f64; 2]]) -> Option<String> {
    let n = points.len();
    let twice_area: f64 = (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    // Orientation of c relative to the line a→b.
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        let v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    };
    let on_segment = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        // Edges sharing a corner with edge i are its neighbours.
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            let (c, d) = (points[j], points[(j + 1) % n]);
            let (o1, o2, o3, o4) = (
                orient(a, b, c),
                orient(a, b, d),
                orient(c, d, a),
                orient(c, d, b),
            );
            let crosses = (o1 != o2 && o3 != o4)
                || (o1 == 0 && on_segment(a, b, c))
                || (o2 == 0 && on_segment(a, b, d))
                || (o3 == 0 && on_segment(c, d, a))
                || (o4 == 0 && on_segment(c, d, b));
            if crosses {
                return Some(format!(
                    "crosses itself: the edge from point {} to point {} meets the edge from \
                     point {} to point {} (points counted from 1); give the corners of the area \
                     in order around it",
                    i + 1,
                    (i + 1) % n + 1,
                    j + 1,
                    (j + 1) % n + 1
                ));
            }
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if twice_area.is_nan() || twice_area.abs() <= 1e-9 * extent * extent {
        return Some(
            "encloses no area: its points lie on one line (or repeat); give the corners of \
             the area in order"
                .into(),
        );
    }
    None
}

/// An outline in plan, from exactly one of `rectangle_m = [x_min, y_min,
/// x_max, y_max]` or `area_m = [[x, y], ...]` of the table at `path`
/// (`[plan]`, `[[forest]]`).
fn outline(
    c: &mut Checker,
    path: &KeyPath,
    rectangle: &Option<Vec<f64>>,
    area: &Option<Vec<Vec<f64>>>,
) -> Option<Vec<[f64; 2]>> {
    match (rectangle, area) {
        (Some(r), None) => {
            if r.len() != 4 || r.iter().any(|v| !v.is_finite()) || r[2] <= r[0] || r[3] <= r[1] {
                c.err(
                    path.key("rectangle_m"),
                    "must be [x_min, y_min, x_max, y_max] with x_max > x_min and y_max > y_min",
                );
                None
            } else {
                Some(vec![[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]])
            }
        }
        (None, Some(a)) => {
            if a.len() < 3
                || a.len() > MAX_POLYGON_VERTICES
                || a.iter().any(|p| {
                    p.len() != 2 || p.iter().any(|v| v.is_nan() || v.abs() > MAX_COORDINATE_M)
                })
            {
                c.err(
                    path.key("area_m"),
                    format!(
                        "must be a list of 3 to {MAX_POLYGON_VERTICES} [x, y] points (the \
                         outline) within ±{} m",
                        num(MAX_COORDINATE_M)
                    ),
                );
                return None;
            }
            let points: Vec<[f64; 2]> = a.iter().map(|p| [p[0], p[1]]).collect();
            match outline_problem(&points) {
                Some(why) => {
                    c.err(path.key("area_m"), why);
                    None
                }
                None => Some(points),
            }
        }
        (Some(_), Some(_)) => {
            c.err(
                path.key("area_m"),
                "give either rectangle_m or area_m, not both",
            );
            None
        }
        (None, None) => {
            c.err(
                path.clone(),
                "needs rectangle_m = [x_min, y_min, x_max, y_max] or area_m = [[x, y], ...]",
            );
            None
        }
    }
}

/// Validates `[plan]` and generates its lines.
fn check_plan(
    c: &mut Checker,
    plan: &raw::RawPlan,
    scene: &Scene,
    scan_half_angle_rad: f64,
) -> Vec<(DVec3, DVec3, f64)> {
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
        -360.0,
        false,
        360.0,
        "°",
    );
    let speed = c.positive(pp.key("speed_mps"), plan.speed_mps, 60.0, " m/s");
    let run_in = c.number(
        pp.key("run_in_m"),
        plan.run_in_m,
        0.0,
        0.0,
        false,
        1e5,
        " m",
    );
    let swath = 2.0 * altitude * scan_half_angle_rad.tan();
    let spacing = match (plan.line_spacing_m, plan.side_overlap) {
        (Some(s), None) => c.positive(pp.key("line_spacing_m"), Some(s), 100.0, " m"),
        (None, Some(o)) => {
            let o = c.number(pp.key("side_overlap"), Some(o), 0.2, 0.0, false, 0.95, "");
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
    let Some(area) = area else { return Vec::new() };
    if spacing <= 0.0 {
        c.err(
            pp.key("side_overlap"),
            "the scan angle gives no swath to space lines by",
        );
        return Vec::new();
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
        return Vec::new();
    }
    // Flying height above the ground at the area's centre.
    let n = area.len() as f64;
    let (cx, cy) = (
        area.iter().map(|p| p[0]).sum::<f64>() / n,
        area.iter().map(|p| p[1]).sum::<f64>() / n,
    );
    let ground = crate::plan::ground_below(
        &crate::accel::Bvh::build(scene.clone()),
        DVec3::new(cx, cy, 1e6),
    );
    // Compass heading (clockwise from north) → yaw (counter-clockwise).
    plan_lines(
        &area,
        -heading.to_radians(),
        spacing,
        run_in,
        ground + altitude,
    )
    .into_iter()
    .map(|(s, e)| (s, e, speed))
    .collect()
}

/// Shortest tree accepted, m (the trunk tapers from breast height, 1.3 m,
/// to the top, so a tree must be clearly taller than that).
pub const MIN_TREE_HEIGHT_M: f64 = 2.0;

/// Validates one `[[tree]]` entry.
fn check_tree(
    c: &mut Checker,
    tp: &KeyPath,
    t: &raw::RawTree,
    survey_seed: u64,
    index: usize,
) -> Option<TreeSpec> {
    let base = c.point(tp.key("position_m"), &t.position_m);
    let species = match t.species.as_deref() {
        None => {
            c.err(
                tp.key("species"),
                "is required: \"pine\", \"spruce\" or \"birch\"",
            );
            None
        }
        Some(name) => Species::from_name(name).or_else(|| {
            let names: Vec<&str> = Species::ALL.iter().map(|(n, _)| *n).collect();
            c.err(
                tp.key("species"),
                format!(
                    "unknown species '{name}'; expected one of: {}",
                    names.join(", ")
                ),
            );
            None
        }),
    };
    let required = |c: &mut Checker, key: &str, v: Option<f64>, what: &str| {
        if v.is_none() {
            c.err(tp.key(key), format!("is required: {what}"));
        }
    };
    required(c, "dbh_m", t.dbh_m, "diameter at breast height in metres");
    required(c, "height_m", t.height_m, "tree height in metres");
    required(
        c,
        "crown_base_m",
        t.crown_base_m,
        "height of the crown base in metres",
    );
    let dbh = c.number(tp.key("dbh_m"), t.dbh_m, 0.2, 0.0, true, 5.0, " m");
    let problems_before = c.problems.len();
    let height = c.number(
        tp.key("height_m"),
        t.height_m,
        15.0,
        MIN_TREE_HEIGHT_M,
        false,
        150.0,
        " m",
    );
    let height_ok = c.problems.len() == problems_before;
    let crown_base = c.number(
        tp.key("crown_base_m"),
        t.crown_base_m,
        5.0,
        0.0,
        false,
        150.0,
        " m",
    );
    if height_ok && crown_base >= height {
        c.err(
            tp.key("crown_base_m"),
            format!("must be below the tree top ({height} m), got {crown_base}"),
        );
    }
    let (base, species) = (base?, species?);
    if t.dbh_m.is_none() || t.height_m.is_none() || t.crown_base_m.is_none() {
        return None;
    }
    let mut tree = TreeSpec::new(base, species, dbh, height, crown_base);
    tree.foliage_reflectance = c.number(
        tp.key("foliage_reflectance"),
        t.foliage_reflectance,
        tree.foliage_reflectance,
        0.0,
        false,
        1.0,
        "",
    );
    tree.bark_reflectance = c.number(
        tp.key("bark_reflectance"),
        t.bark_reflectance,
        tree.bark_reflectance,
        0.0,
        false,
        1.0,
        "",
    );
    tree.crown_radius_m = c.positive(
        tp.key("crown_radius_m"),
        t.crown_radius_m,
        tree.crown_radius_m,
        " m",
    );
    tree.extinction_per_m = c.number(
        tp.key("extinction_per_m"),
        t.extinction_per_m,
        tree.extinction_per_m,
        0.0,
        false,
        100.0,
        " 1/m",
    );
    tree.uniform_density = t
        .uniform_density
        .map(|d| c.number(tp.key("uniform_density"), Some(d), 0.5, 0.0, false, 1.0, ""));
    tree.seed = t.seed.unwrap_or_else(|| {
        crate::rng::mix64(survey_seed ^ (index as u64).wrapping_mul(0x9E37_79B9))
    });
    Some(tree)
}

/// Validates one `[[forest]]` entry.
fn check_forest(
    c: &mut Checker,
    fp: &KeyPath,
    f: &raw::RawForest,
    survey_seed: u64,
    index: usize,
) -> Option<ForestSpec> {
    let area = outline(c, fp, &f.rectangle_m, &f.area_m);
    if f.stems_per_ha.is_none() {
        c.err(
            fp.key("stems_per_ha"),
            "is required: stem density in trees per hectare",
        );
    }
    let stems = c.number(
        fp.key("stems_per_ha"),
        f.stems_per_ha,
        500.0,
        0.0,
        true,
        20_000.0,
        " /ha",
    );
    let mix: Vec<(Species, f64)> = match &f.species {
        None => vec![(Species::Pine, 1.0)],
        Some(m) => {
            let mut mix = Vec::new();
            for (name, w) in m {
                match Species::from_name(name) {
                    Some(s) if *w > 0.0 && *w <= MAX_SPECIES_WEIGHT => mix.push((s, *w)),
                    Some(_) => c.err(
                        fp.key("species").key(name),
                        format!(
                            "weight must be greater than 0 and at most {} (weights are relative \
                             shares), got {}",
                            num(MAX_SPECIES_WEIGHT),
                            num(*w)
                        ),
                    ),
                    None => c.err(
                        fp.key("species").key(name),
                        format!("unknown species '{name}'; expected pine, spruce or birch"),
                    ),
                }
            }
            if m.is_empty() {
                c.err(fp.key("species"), "names no species");
            }
            mix
        }
    };
    let heights = match &f.height_m {
        None => (15.0, 25.0),
        Some(h) if h.len() == 2 && h[0] >= MIN_TREE_HEIGHT_M && h[1] >= h[0] && h[1] <= 150.0 => {
            (h[0], h[1])
        }
        Some(_) => {
            c.err(
                fp.key("height_m"),
                "must be [smallest, largest] tree height in metres, from 2 to 150 m, smallest first",
            );
            (15.0, 25.0)
        }
    };
    let min_spacing_m = c.number(
        fp.key("min_spacing_m"),
        f.min_spacing_m,
        1.0,
        0.0,
        false,
        100.0,
        " m",
    );
    let seed = f
        .seed
        .unwrap_or_else(|| crate::rng::mix64(survey_seed.wrapping_add(0xF0_2E57 + index as u64)));
    if mix.is_empty() {
        return None;
    }
    Some(ForestSpec {
        area: area?,
        stems_per_ha: stems,
        mix,
        height_range_m: heights,
        min_spacing_m,
        seed,
    })
}

/// Validates a `[[terrain]]` entry and adds its tiles to `scene`.
#[allow(clippy::too_many_arguments)]
fn check_terrain(
    c: &mut Checker,
    tp: &KeyPath,
    t: &raw::RawTerrain,
    materials: &HashMap<String, Material>,
    base: &Path,
    survey_seed: u64,
    index: usize,
    scene: &mut Scene,
) {
    let class = match &t.class {
        None => SurfaceClass::Ground,
        some => c.class(tp.key("class"), some),
    };
    let material = match &t.material {
        None => {
            c.err(
                tp.key("material"),
                "is required: the name of a [materials.NAME] table",
            );
            None
        }
        Some(m) => match materials.get(m) {
            Some(mat) => Some(mat.clone()),
            None => {
                let mut names: Vec<&str> = materials.keys().map(String::as_str).collect();
                names.sort();
                c.err(
                    tp.key("material"),
                    format!("unknown material '{m}' (defined: {})", names.join(", ")),
                );
                None
            }
        },
    };
    let offset = match &t.offset_m {
        None => Some(DVec3::ZERO),
        some => c.point(tp.key("offset_m"), some),
    };
    let fbm_keys = [
        ("extent_m", t.extent_m.is_some()),
        ("resolution_m", t.resolution_m.is_some()),
        ("relief_m", t.relief_m.is_some()),
        ("wavelength_m", t.wavelength_m.is_some()),
        ("octaves", t.octaves.is_some()),
        ("seed", t.seed.is_some()),
    ];
    let grid = match (&t.file, &t.generator) {
        (Some(_), Some(_)) => {
            c.err(
                tp.key("generator"),
                "give either `file` (a raster) or `generator`, not both",
            );
            None
        }
        (None, None) => {
            c.err(
                tp.key("file"),
                "is required: a GeoTIFF (.tif) or ESRI ASCII grid (.asc) file, or set \
                 `generator = \"fbm\"`",
            );
            None
        }
        (Some(file), None) => {
            for (key, set) in fbm_keys {
                if set {
                    c.err(
                        tp.key(key),
                        "belongs to `generator = \"fbm\"`; a raster `file` gives its own grid",
                    );
                }
            }
            match crate::io::raster::read_raster(&base.join(file)) {
                Ok(g) => Some(g),
                Err(e) => {
                    c.err(tp.key("file"), e.to_string());
                    None
                }
            }
        }
        (None, Some(generator)) if generator == "fbm" => {
            let extent = match &t.extent_m {
                Some(e)
                    if e.len() == 4
                        && e.iter().all(|v| v.is_finite())
                        && e[2] > e[0]
                        && e[3] > e[1] =>
                {
                    Some([e[0], e[1], e[2], e[3]])
                }
                Some(_) => {
                    c.err(
                        tp.key("extent_m"),
                        "must be [xmin, ymin, xmax, ymax] in metres with xmax > xmin and \
                         ymax > ymin",
                    );
                    None
                }
                None => {
                    c.err(
                        tp.key("extent_m"),
                        "is required: [xmin, ymin, xmax, ymax] in metres",
                    );
                    None
                }
            };
            let resolution_m = c.positive(tp.key("resolution_m"), t.resolution_m, 1.0, " m");
            let relief_m = c.number(tp.key("relief_m"), t.relief_m, 20.0, 0.0, false, 1e4, " m");
            let octaves = c.count(tp.key("octaves"), t.octaves, 6, 1, 16) as u32;
            let Some(extent) = extent else { return };
            let wavelength_m = c.positive(
                tp.key("wavelength_m"),
                t.wavelength_m,
                ((extent[2] - extent[0]).max(extent[3] - extent[1]) / 2.0).max(resolution_m),
                " m",
            );
            let spec = crate::scene::terrain::FbmSpec {
                extent_m: extent,
                resolution_m,
                relief_m,
                wavelength_m,
                octaves,
                seed: t.seed.unwrap_or_else(|| {
                    crate::rng::mix64(survey_seed.wrapping_add(0x7E_4A1 + index as u64))
                }),
            };
            let (cols, rows) = spec.nodes();
            if cols < 2 || rows < 2 {
                c.err(
                    tp.key("resolution_m"),
                    format!("{resolution_m} m leaves fewer than 2 × 2 grid nodes in the extent"),
                );
                return;
            }
            match crate::scene::terrain::generate_fbm(&spec) {
                Ok(g) => Some(g),
                Err(e) => {
                    c.err(tp.key("resolution_m"), e.to_string());
                    None
                }
            }
        }
        (None, Some(other)) => {
            c.err(
                tp.key("generator"),
                format!("unknown generator '{other}'; expected \"fbm\""),
            );
            None
        }
    };
    let (Some(mut grid), Some(material), Some(offset)) = (grid, material, offset) else {
        return;
    };
    grid.shift(offset);
    let m = scene.add_material(material);
    let name = match &t.file {
        Some(f) => format!("terrain[{index}]:{f}"),
        None => format!("terrain[{index}]:fbm"),
    };
    crate::scene::terrain::add_terrain(scene, grid, m, class, name);
}

impl Survey {
    /// Reads and validates a survey file. Mesh paths are relative to it.
    pub fn load(path: &Path) -> Result<Self, SurveyError> {
        Self::load_with_seed(path, None)
    }

    /// [`Survey::load`] with the file's seed replaced by `seed` (the
    /// command line's `--seed`) before anything random is drawn, so that
    /// generated forests and sway follow the new seed too.
    pub fn load_with_seed(path: &Path, seed: Option<u64>) -> Result<Self, SurveyError> {
        let file = path.display().to_string();
        let text = crate::io::input::read_input(path, crate::io::input::MAX_SURVEY_BYTES).map_err(
            |e| SurveyError {
                diagnostics: vec![Diagnostic::file_level(
                    &file,
                    0,
                    format!("cannot read the survey file: {e}"),
                )],
            },
        )?;
        let text = String::from_utf8(text).map_err(|e| {
            let offset = e.utf8_error().valid_up_to();
            let prefix = String::from_utf8_lossy(&e.as_bytes()[..offset]).into_owned();
            let line = prefix.matches('\n').count() + 1;
            SurveyError {
                diagnostics: vec![Diagnostic::file_level(
                    &file,
                    line,
                    format!("the file is not valid UTF-8 (byte {offset}): save it as UTF-8"),
                )],
            }
        })?;
        Self::from_toml_with_seed(&text, Some(path), seed)
    }

    /// Parses and validates survey text; `path` (if any) names the file in
    /// messages and anchors relative mesh paths.
    pub fn from_toml(text: &str, path: Option<&Path>) -> Result<Self, SurveyError> {
        Self::from_toml_with_seed(text, path, None)
    }

    /// [`Survey::from_toml`] with the seed replaced by `seed` if given.
    ///
    /// Every problem is reported at once: unknown keys and values of the
    /// wrong type anywhere in the file (each offending key is set aside and
    /// the rest read again), then the validation of everything else. Only
    /// a TOML syntax error stops at once, since nothing after it can be
    /// trusted.
    pub fn from_toml_with_seed(
        text: &str,
        path: Option<&Path>,
        seed: Option<u64>,
    ) -> Result<Self, SurveyError> {
        let file = path.map_or_else(|| "<survey>".to_string(), |p| p.display().to_string());
        let locator = Locator::new(text);
        let diagnostic = |key: &KeyPath, span: Option<Range<usize>>, message, help| {
            let (line, column) = span.as_ref().map_or((0, 0), |s| locator.line_col(s.start));
            let width = span.map_or(1, |s| text[s].chars().take_while(|&c| c != '\n').count());
            Diagnostic {
                file: file.clone(),
                line,
                column,
                key: key.to_string(),
                message,
                source_line: (line > 0).then(|| locator.line_text(line).to_string()),
                width: width.max(1),
                help,
            }
        };
        let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
            let span = e.span().unwrap_or(0..0);
            let key = locator.path_at(&span);
            let (message, help) = explain(e.message());
            SurveyError {
                diagnostics: vec![diagnostic(&key, Some(span), message, help)],
            }
        })?;
        // Structure: read, set aside the key that failed, read again.
        let mut diagnostics = Vec::new();
        let mut set_aside: Vec<KeyPath> = Vec::new();
        let raw = loop {
            let value = toml::Value::Table(table.clone());
            match serde_path_to_error::deserialize::<_, RawSurvey>(value) {
                Ok(raw) => break Some(raw),
                Err(e) => {
                    let path = key_path_of(e.path());
                    let (message, help) = explain(e.inner().message());
                    let span = if help.is_some() {
                        locator.key_span_of(&path)
                    } else {
                        locator.span_of(&path)
                    };
                    diagnostics.push(diagnostic(&path, span, message, help));
                    match remove_key(&mut table, &path) {
                        Some(removed) if diagnostics.len() < MAX_READ_PROBLEMS => {
                            set_aside.push(removed)
                        }
                        _ => break None,
                    }
                }
            }
        };
        let Some(mut raw) = raw else {
            return Err(SurveyError { diagnostics });
        };
        if seed.is_some() {
            raw.seed = seed;
        }
        // Validation of what could be read; problems of keys set aside
        // above were reported already.
        let related = |p: &KeyPath| {
            set_aside
                .iter()
                .any(|a| p.0.starts_with(&a.0) || a.0.starts_with(&p.0))
        };
        match Self::from_raw(raw, path) {
            Ok(survey) if diagnostics.is_empty() => Ok(survey),
            Ok(_) => Err(diagnostics_in_file_order(diagnostics)),
            Err(problems) => {
                for (key, message) in problems {
                    if related(&key) {
                        continue;
                    }
                    diagnostics.push(diagnostic(&key, locator.span_of(&key), message, None));
                }
                Err(diagnostics_in_file_order(diagnostics))
            }
        }
    }

    /// Validates a raw survey; on failure returns every problem with its
    /// key path.
    pub fn from_raw(raw: RawSurvey, path: Option<&Path>) -> Result<Self, Vec<(KeyPath, String)>> {
        let mut c = Checker {
            problems: Vec::new(),
        };
        let root = KeyPath::root();
        let seed = raw.seed.unwrap_or(DEFAULT_SEED);

        // [scanner]
        let s = &raw.scanner;
        let sp = root.key("scanner");
        let prf_hz = c.positive(sp.key("prf_hz"), s.prf_hz, 100_000.0, " Hz");
        if prf_hz > MAX_PRF_HZ {
            c.err(
                sp.key("prf_hz"),
                format!(
                    "must be at most {MAX_PRF_HZ} Hz (10 MHz, beyond any airborne scanner), \
                     got {prf_hz:e}"
                ),
            );
        }
        let scan_frequency_hz = c.positive(
            sp.key("scan_frequency_hz"),
            s.scan_frequency_hz,
            50.0,
            " Hz",
        );
        if scan_frequency_hz > prf_hz / 4.0 {
            c.err(
                sp.key("scan_frequency_hz"),
                format!(
                    "must be at most prf_hz / 4 = {} Hz, got {}: the mirror would sweep its \
                     scan line with fewer than two pulses",
                    num(prf_hz / 4.0),
                    num(scan_frequency_hz)
                ),
            );
        }
        let scan_angle_given = match s.scan_angle_deg {
            Some(a) if a >= 90.0 => {
                c.err(
                    sp.key("scan_angle_deg"),
                    format!(
                        "must be between 0 and 89°, got {a}: at 90° or more from nadir the beam \
                         points at or above the horizon and meets no ground"
                    ),
                );
                None
            }
            other => other,
        };
        let scan_angle_deg = c.number(
            sp.key("scan_angle_deg"),
            scan_angle_given,
            20.0,
            0.0,
            false,
            89.0,
            "°",
        );
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
        let divergence_mrad = c.number(
            sp.key("divergence_mrad"),
            s.divergence_mrad,
            0.3,
            0.0,
            false,
            100.0,
            " mrad",
        );
        let subrays = c.count(sp.key("subrays"), s.subrays, 19, 1, 10_000) as usize;
        let pulse_fwhm_ns = match s.pulse_fwhm_ns {
            Some(v) if v > 0.0 && v < MIN_PULSE_FWHM_NS => {
                let hint = if v < 1e-6 {
                    format!(
                        ": the key is in nanoseconds and {} looks like seconds ({} ns)",
                        num(v),
                        num(v * 1e9)
                    )
                } else {
                    String::new()
                };
                c.err(
                    sp.key("pulse_fwhm_ns"),
                    format!(
                        "must be at least {MIN_PULSE_FWHM_NS} ns (airborne pulses last 1 to 10 \
                         ns), got {}{hint}",
                        num(v)
                    ),
                );
                None
            }
            other => Some(c.number(
                sp.key("pulse_fwhm_ns"),
                other,
                4.0,
                0.0,
                true,
                1000.0,
                " ns",
            )),
        };
        let pulse_ok = pulse_fwhm_ns.is_some();
        let pulse_fwhm_ns = pulse_fwhm_ns.unwrap_or(4.0);
        let pulse = match s.pulse_shape.as_deref() {
            None | Some("gaussian") => PulseShape::Gaussian {
                fwhm_s: pulse_fwhm_ns * 1e-9,
            },
            Some("rise-tail") | Some("rise_tail") => PulseShape::RiseTail {
                fwhm_s: pulse_fwhm_ns * 1e-9,
            },
            Some(other) => {
                c.err(
                    sp.key("pulse_shape"),
                    format!(
                        "unknown pulse shape '{other}'; expected \"gaussian\" or \"rise-tail\""
                    ),
                );
                PulseShape::Gaussian {
                    fwhm_s: pulse_fwhm_ns * 1e-9,
                }
            }
        };
        let max_returns = c.count(sp.key("max_returns"), s.max_returns, 5, 1, 15) as usize;
        let selection = match s.return_selection.as_deref() {
            None => ReturnSelection::default(),
            Some(name) => ReturnSelection::from_name(name).unwrap_or_else(|| {
                c.err(
                    sp.key("return_selection"),
                    format!(
                        "unknown rule '{name}'; expected \"first-and-last\" (the default: the \
                         first max_returns − 1 echoes and the last) or \"first\""
                    ),
                );
                ReturnSelection::default()
            }),
        };
        let min_range_m = c.number(
            sp.key("min_range_m"),
            s.min_range_m,
            1.0,
            0.0,
            false,
            f64::INFINITY,
            " m",
        );
        let max_range_m = c.number(
            sp.key("max_range_m"),
            s.max_range_m,
            10_000.0,
            0.0,
            true,
            MAX_RANGE_M,
            " m",
        );
        if max_range_m <= min_range_m {
            c.err(
                sp.key("max_range_m"),
                format!("must be greater than min_range_m ({min_range_m} m)"),
            );
        }
        let reference_range_m = c.number(
            sp.key("reference_range_m"),
            s.reference_range_m,
            1000.0,
            1.0,
            false,
            MAX_RANGE_M,
            " m",
        );
        let wavelength_nm = c.positive(sp.key("wavelength_nm"), s.wavelength_nm, 1064.0, " nm");

        // [receiver]
        let r = &raw.receiver;
        let rp = root.key("receiver");
        let bin_ps = c.number(rp.key("bin_ps"), r.bin_ps, 500.0, 0.0, true, 1e6, " ps");
        // Amplitudes are in units of the echo of a white plane filling the
        // beam at the reference range: a noise or path radiance above it
        // would hide every echo.
        let noise = c.number(rp.key("noise"), r.noise, 0.0, 0.0, false, 1.0, "");
        let atmosphere = c.number(rp.key("atmosphere"), r.atmosphere, 0.0, 0.0, false, 1.0, "");
        let speckle_looks = c.positive(rp.key("speckle_looks"), r.speckle_looks, 1.0, "");
        let threshold_sigma = c.positive(rp.key("threshold_sigma"), r.threshold_sigma, 4.0, "");
        let min_amplitude = c.positive(rp.key("min_amplitude"), r.min_amplitude, 0.005, "");
        let intensity_gain = c.positive(rp.key("intensity_gain"), r.intensity_gain, 10_000.0, "");
        if pulse_ok && bin_ps * 1e-3 > pulse_fwhm_ns {
            c.err(
                rp.key("bin_ps"),
                format!(
                    "a {} ps bin cannot sample a {} ns pulse; use a bin at most the pulse width",
                    num(bin_ps),
                    num(pulse_fwhm_ns)
                ),
            );
        }
        // The work of a pulse grows with the samples of the pulse shape
        // (each return is convolved with it) and its memory with the
        // samples of the range window.
        if pulse_ok {
            let (before, after) = pulse.support_s();
            let shape_samples = (before + after) / (bin_ps * 1e-12);
            let window_samples =
                range_to_bin(max_range_m - min_range_m, bin_ps * 1e-12) + shape_samples;
            let finest = ((before + after) / MAX_PULSE_SAMPLES as f64 * 1e12)
                .max(range_to_bin(max_range_m - min_range_m, 1e-12) / MAX_WINDOW_SAMPLES as f64);
            if shape_samples > MAX_PULSE_SAMPLES as f64 {
                c.err(
                    rp.key("bin_ps"),
                    format!(
                        "a {} ps bin samples the {} ns pulse (its shape spans {:.1} ns) with {} \
                         samples; at most {MAX_PULSE_SAMPLES}: use bin_ps of at least {:.2} ps",
                        num(bin_ps),
                        num(pulse_fwhm_ns),
                        (before + after) * 1e9,
                        num(shape_samples.round()),
                        finest
                    ),
                );
            } else if window_samples > MAX_WINDOW_SAMPLES as f64 {
                c.err(
                    rp.key("bin_ps"),
                    format!(
                        "a {} ps bin needs {} samples for the range window from \
                         scanner.min_range_m to scanner.max_range_m ({} m); at most \
                         {MAX_WINDOW_SAMPLES}: use bin_ps of at least {:.2} ps or narrow the \
                         range window",
                        num(bin_ps),
                        num(window_samples.round()),
                        num(max_range_m - min_range_m),
                        finest
                    ),
                );
            }
        }

        // [platform]
        let p = &raw.platform;
        let pp = root.key("platform");
        let sway_on = p.sway.unwrap_or(false);
        let d = SwayConfig::default();
        let roll = c.number(
            pp.key("roll_amplitude_deg"),
            p.roll_amplitude_deg,
            d.roll_amplitude_rad.to_degrees(),
            0.0,
            false,
            30.0,
            "°",
        );
        let pitch = c.number(
            pp.key("pitch_amplitude_deg"),
            p.pitch_amplitude_deg,
            d.pitch_amplitude_rad.to_degrees(),
            0.0,
            false,
            30.0,
            "°",
        );
        let yaw = c.number(
            pp.key("yaw_amplitude_deg"),
            p.yaw_amplitude_deg,
            d.yaw_amplitude_rad.to_degrees(),
            0.0,
            false,
            30.0,
            "°",
        );
        let freqs = match &p.sway_frequencies_hz {
            None => d.frequencies_hz.clone(),
            Some(f)
                if f.is_empty()
                    || f.len() > MAX_SWAY_FREQUENCIES
                    || f.iter()
                        .any(|x| !(x.is_finite() && *x > 0.0 && *x <= 100.0)) =>
            {
                c.err(
                    pp.key("sway_frequencies_hz"),
                    format!(
                        "must be a list of 1 to {MAX_SWAY_FREQUENCIES} frequencies greater than 0 \
                         and at most 100 Hz (an aircraft sways at a few tenths of a hertz), got {} \
                         entries",
                        f.len()
                    ),
                );
                d.frequencies_hz.clone()
            }
            Some(f) => f.clone(),
        };
        let sway = sway_on.then(|| SwayConfig {
            roll_amplitude_rad: roll.to_radians(),
            pitch_amplitude_rad: pitch.to_radians(),
            yaw_amplitude_rad: yaw.to_radians(),
            frequencies_hz: freqs,
        });
        let turn_time_s = c.number(
            pp.key("turn_time_s"),
            p.turn_time_s,
            30.0,
            0.0,
            false,
            f64::INFINITY,
            " s",
        );

        // Navigation errors: preset first, then the tables' own keys.
        let navigation = check_navigation(&mut c, &raw);

        // [[flight_line]]: straight lines as given (timed further down, once
        // plans and trajectory files are known).
        let mut straight: Vec<(DVec3, DVec3, f64)> = Vec::new();
        for (i, l) in raw.flight_lines.iter().enumerate() {
            let lp = root.key("flight_line").index(i);
            let start = c.point(lp.key("start_m"), &l.start_m);
            let end = c.point(lp.key("end_m"), &l.end_m);
            let speed = c.positive(lp.key("speed_mps"), l.speed_mps, 60.0, " m/s");
            if l.speed_mps.is_none() {
                c.err(lp.key("speed_mps"), "is required: ground speed in m/s");
            }
            let altitude = l
                .altitude_m
                .map(|a| c.number(lp.key("altitude_m"), Some(a), 0.0, -1e4, false, 1e5, " m"));
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
                        "the line would take {hours:.3e} h at {speed} m/s; a flight line may \
                         take at most {MAX_LINE_HOURS} h"
                    ),
                );
                continue;
            }
            straight.push((start, end, speed));
        }
        let drift = match &p.drift_m {
            None => None,
            Some(d) if d.len() == 2 && d.iter().all(|x| x.is_finite() && *x >= 0.0) => {
                Some([d[0], d[1]])
            }
            Some(_) => {
                c.err(
                    pp.key("drift_m"),
                    "must be [lateral, vertical] peak drift in metres, both at least 0",
                );
                None
            }
        };
        let drift_period_s = c.positive(pp.key("drift_period_s"), p.drift_period_s, 30.0, " s");

        // [output]
        let o = &raw.output;
        let op = root.key("output");
        let mut formats = Formats {
            las: false,
            las_waveform: false,
            laz: false,
            ply: false,
            xyz: false,
        };
        match &o.formats {
            None => formats.las = true,
            Some(list) => {
                for (i, f) in list.iter().enumerate() {
                    match f.as_str() {
                        "las" if formats.las_waveform => c.err(
                            op.key("formats").index(i),
                            "\"las\" and \"las-waveform\" both write points.las; keep one",
                        ),
                        "las" => formats.las = true,
                        "las-waveform" if formats.las && !formats.las_waveform => c.err(
                            op.key("formats").index(i),
                            "\"las\" and \"las-waveform\" both write points.las; keep one",
                        ),
                        "las-waveform" => {
                            formats.las = true;
                            formats.las_waveform = true;
                        }
                        "laz" => formats.laz = true,
                        "ply" => formats.ply = true,
                        "xyz" => formats.xyz = true,
                        other => c.err(
                            op.key("formats").index(i),
                            format!(
                                "unknown format '{other}'; expected \"las\", \"las-waveform\", \
                                 \"laz\", \"ply\" or \"xyz\""
                            ),
                        ),
                    }
                }
            }
        }
        let (crs_wkt, crs_epsg) = match (&o.crs, &o.crs_wkt) {
            (Some(_), Some(_)) => {
                c.err(
                    op.key("crs_wkt"),
                    "give the CRS once: `crs = \"EPSG:code\"` or `crs_wkt`, not both",
                );
                (None, None)
            }
            (Some(text), None) => match crate::output::crs::parse_epsg(text) {
                None => {
                    c.err(
                        op.key("crs"),
                        format!("must be \"EPSG:code\", got '{text}'"),
                    );
                    (None, None)
                }
                Some(code) => match crate::output::crs::wkt_for_epsg(code) {
                    Some(wkt) => (Some(wkt), Some(code)),
                    None => {
                        c.err(
                            op.key("crs"),
                            format!(
                                "EPSG:{code} is not in the built-in table (UTM zones on WGS 84 \
                                 32601–32660/32701–32760, ETRS89 25828–25838, NAD83 \
                                 26901–26923, ETRS-TM35FIN 3067); give its WKT with `crs_wkt` \
                                 instead (e.g. from epsg.io or `projinfo EPSG:{code} -o WKT1_GDAL`)"
                            ),
                        );
                        (None, None)
                    }
                },
            },
            (None, Some(wkt)) => match crate::output::crs::check_wkt(wkt) {
                Ok(()) => (Some(wkt.trim().to_string()), None),
                Err(m) => {
                    c.err(op.key("crs_wkt"), m);
                    (None, None)
                }
            },
            (None, None) => (None, None),
        };
        let offset_m = match &o.offset_m {
            None => DVec3::ZERO,
            Some(v) => c
                .point(op.key("offset_m"), &Some(v.clone()))
                .unwrap_or(DVec3::ZERO),
        };
        if formats.las_waveform {
            let bin_ps = raw.receiver.bin_ps.unwrap_or(500.0);
            if bin_ps.fract() != 0.0 || bin_ps > f64::from(u32::MAX) {
                c.err(
                    root.key("receiver").key("bin_ps"),
                    format!(
                        "must be a whole number of picoseconds for \"las-waveform\" output (the \
                         LAS waveform descriptor stores the sample spacing in whole ps), got {bin_ps}"
                    ),
                );
            }
        }
        // Inertial systems record at 50 to 2000 Hz; finer rows add bytes,
        // not information.
        let trajectory_interval_s = c.number(
            op.key("trajectory_interval_s"),
            o.trajectory_interval_s,
            0.001,
            1e-4,
            false,
            3600.0,
            " s",
        );
        let gps_start_time_s = o.gps_start_time_s.map(|g| {
            c.number(
                op.key("gps_start_time_s"),
                Some(g),
                0.0,
                0.0,
                false,
                1e10,
                " s",
            )
        });
        let las_scale_m = c.number(
            op.key("las_scale_m"),
            o.las_scale_m,
            0.001,
            0.0,
            true,
            1.0,
            " m",
        );

        // [materials]
        let mut materials: HashMap<String, Material> = HashMap::new();
        for (name, m) in &raw.materials {
            let mp = root.key("materials").key(name);
            if m.reflectance.is_none() {
                c.err(
                    mp.key("reflectance"),
                    "is required: reflectance from 0 to 1",
                );
            }
            let reflectance = c.number(
                mp.key("reflectance"),
                m.reflectance,
                0.0,
                0.0,
                false,
                1.0,
                "",
            );
            let incidence_exponent = c.number(
                mp.key("incidence_exponent"),
                m.incidence_exponent,
                1.0,
                0.0,
                false,
                1000.0,
                "",
            );
            materials.insert(
                name.clone(),
                Material {
                    name: name.clone(),
                    reflectance,
                    incidence_exponent,
                },
            );
        }
        let known = |materials: &HashMap<String, Material>| {
            let mut names: Vec<&String> = materials.keys().collect();
            names.sort();
            if names.is_empty() {
                "no [materials.NAME] table is defined".to_string()
            } else {
                format!(
                    "defined: {}",
                    names
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        };

        // Scene: polygons, then meshes. `owners` says which entry added
        // which primitives (from its first on), to name it in messages.
        let mut scene = Scene::default();
        let mut owners: Vec<(KeyPath, usize)> = Vec::new();
        for (i, poly) in raw.polygons.iter().enumerate() {
            let pp = root.key("polygon").index(i);
            owners.push((pp.key("vertices_m"), scene.primitives.len()));
            let class = c.class(pp.key("class"), &poly.class);
            let material = match &poly.material {
                None => {
                    c.err(
                        pp.key("material"),
                        "is required: the name of a [materials.NAME] table",
                    );
                    None
                }
                Some(m) => match materials.get(m) {
                    Some(mat) => Some(mat.clone()),
                    None => {
                        c.err(
                            pp.key("material"),
                            format!("unknown material '{m}' ({})", known(&materials)),
                        );
                        None
                    }
                },
            };
            let vertices = match &poly.vertices_m {
                None => {
                    c.err(
                        pp.key("vertices_m"),
                        "is required: a list of [x, y, z] points",
                    );
                    None
                }
                Some(vs) if vs.len() > MAX_POLYGON_VERTICES => {
                    c.err(
                        pp.key("vertices_m"),
                        format!(
                            "has {} vertices; a polygon may have at most {MAX_POLYGON_VERTICES}: \
                             give detailed shapes as a mesh ([[mesh]], OBJ or glTF)",
                            vs.len()
                        ),
                    );
                    None
                }
                Some(vs) => {
                    let mut ok = Vec::with_capacity(vs.len());
                    for (j, v) in vs.iter().enumerate() {
                        if let Some(p) = c.point(pp.key("vertices_m").index(j), &Some(v.clone())) {
                            ok.push(p);
                        }
                    }
                    (ok.len() == vs.len()).then_some(ok)
                }
            };
            let Some(vertices) = vertices else { continue };
            match Polygon::new(vertices) {
                Ok(poly) => {
                    if let Some(mat) = material {
                        let m = scene.add_material(mat);
                        let object = scene.add_object(format!("polygon[{i}]"));
                        scene.primitives.push(Primitive {
                            shape: Shape::Polygon(Box::new(poly)),
                            material: m,
                            class,
                            object,
                        });
                    }
                }
                Err(e) => c.err(pp.key("vertices_m"), e.to_string()),
            }
        }
        let base = path
            .and_then(|p| p.parent())
            .map(Path::to_path_buf)
            .unwrap_or_default();
        for (i, mesh) in raw.meshes.iter().enumerate() {
            let mp = root.key("mesh").index(i);
            owners.push((mp.key("offset_m"), scene.primitives.len()));
            let class = c.class(mp.key("class"), &mesh.class);
            let offset = match &mesh.offset_m {
                None => Some(DVec3::ZERO),
                some => c.point(mp.key("offset_m"), some),
            };
            let scale = c.positive(mp.key("scale"), mesh.scale, 1.0, "");
            let rotation = c.number(
                mp.key("rotation_z_deg"),
                mesh.rotation_z_deg,
                0.0,
                -360.0,
                false,
                360.0,
                "°",
            );
            let default_material = match &mesh.material {
                None => None,
                Some(m) => match materials.get(m) {
                    Some(mat) => Some(mat.clone()),
                    None => {
                        c.err(
                            mp.key("material"),
                            format!("unknown material '{m}' ({})", known(&materials)),
                        );
                        continue;
                    }
                },
            };
            let Some(file) = &mesh.file else {
                c.err(
                    mp.key("file"),
                    "is required: path of an OBJ, glTF (.gltf) or binary glTF (.glb) file",
                );
                continue;
            };
            let mut class_map = Vec::new();
            for (pattern, name) in mesh.classes.iter().flatten() {
                let key = mp.key("classes").key(pattern);
                if pattern.is_empty() {
                    c.err(key, "an empty pattern matches nothing");
                    continue;
                }
                class_map.push((pattern.clone(), c.class(key, &Some(name.clone()))));
            }
            let Some(offset) = offset else { continue };
            let placement = MeshPlacement {
                scale,
                rotation_z_rad: rotation.to_radians(),
                offset_m: offset,
                default_class: class,
                default_material,
                class_map,
            };
            let full = base.join(file);
            let is_gltf = full
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"));
            let loaded = if is_gltf {
                crate::io::gltf::load_gltf(&full, &placement, &materials, &mut scene)
            } else {
                load_obj(&full, &placement, &materials, &mut scene)
            };
            if let Err(e) = loaded {
                let key = match &e {
                    crate::io::obj::MeshError::UnmatchedClassPattern { pattern, .. } => {
                        mp.key("classes").key(pattern)
                    }
                    _ => mp.key("file"),
                };
                c.err(key, e.to_string());
            }
        }
        for (i, t) in raw.terrains.iter().enumerate() {
            let tp = root.key("terrain").index(i);
            owners.push((tp.clone(), scene.primitives.len()));
            check_terrain(&mut c, &tp, t, &materials, &base, seed, i, &mut scene);
        }
        for (i, pc) in raw.point_clouds.iter().enumerate() {
            let pp = root.key("point_cloud").index(i);
            owners.push((pp.key("offset_m"), scene.primitives.len()));
            let class = pc
                .class
                .as_ref()
                .map(|_| c.class(pp.key("class"), &pc.class));
            let voxel_m = c.number(
                pp.key("voxel_m"),
                pc.voxel_m,
                0.5,
                0.01,
                false,
                1000.0,
                " m",
            );
            let offset = match &pc.offset_m {
                None => Some(DVec3::ZERO),
                some => c.point(pp.key("offset_m"), some),
            };
            let material = match &pc.material {
                None => {
                    c.err(
                        pp.key("material"),
                        "is required: the name of a [materials.NAME] table",
                    );
                    None
                }
                Some(m) => match materials.get(m) {
                    Some(mat) => Some(mat.clone()),
                    None => {
                        c.err(
                            pp.key("material"),
                            format!("unknown material '{m}' ({})", known(&materials)),
                        );
                        None
                    }
                },
            };
            let Some(file) = &pc.file else {
                c.err(pp.key("file"), "is required: path of a LAS or LAZ file");
                continue;
            };
            let (Some(material), Some(offset)) = (material, offset) else {
                continue;
            };
            let placement = crate::scene::cloud::CloudPlacement {
                voxel_m,
                offset_m: offset,
                material: scene.add_material(material),
                class,
            };
            if let Err(e) =
                crate::io::cloud::load_point_cloud(&base.join(file), &placement, &mut scene)
            {
                c.err(pp.key("file"), e.to_string());
            }
        }
        // [vegetation], [[tree]], [[forest]]
        let v = &raw.vegetation;
        let vp = root.key("vegetation");
        let return_model = match v.return_model.as_deref() {
            None => ReturnModel::default(),
            Some(name) => ReturnModel::from_name(name).unwrap_or_else(|| {
                c.err(
                    vp.key("return_model"),
                    format!(
                        "unknown return model '{name}'; expected \"physical\" (the default) or \
                         \"specification\""
                    ),
                );
                ReturnModel::default()
            }),
        };
        // Partial blocking removes energy the lottery already accounts for:
        // only the specification's model has it.
        let partial_blocking = match return_model {
            ReturnModel::Specification => c.number(
                vp.key("partial_blocking"),
                v.partial_blocking,
                0.5,
                0.0,
                false,
                10.0,
                "",
            ),
            ReturnModel::Physical => {
                if v.partial_blocking.is_some() {
                    c.err(
                        vp.key("partial_blocking"),
                        "applies only with return_model = \"specification\": in the physical \
                         model a sub-ray that passes the foliage keeps its energy (the \
                         interception lottery already removes what the foliage intercepts)",
                    );
                }
                0.0
            }
        };
        let canopy = CanopyConfig {
            step_m: c.number(vp.key("step_m"), v.step_m, 0.3, 0.01, false, 10.0, " m"),
            partial_blocking,
            return_model,
        };
        let whorl = c.number(
            vp.key("whorl_spacing_m"),
            v.whorl_spacing_m,
            0.3,
            0.0,
            true,
            10.0,
            " m",
        );
        for (i, t) in raw.trees.iter().enumerate() {
            let tp = root.key("tree").index(i);
            owners.push((tp.key("position_m"), scene.primitives.len()));
            if let Some(tree) = check_tree(&mut c, &tp, t, seed, i) {
                scene.add_tree(&tree, whorl, format!("tree[{i}]"));
            }
        }
        let mut forest_trees = Vec::new();
        let mut warnings = Vec::new();
        if !raw.forests.is_empty() {
            // Trees stand on the ground (or road, water) below them, else on
            // any surface, else at z = 0.
            let ground = crate::accel::Bvh::build(scene.clone());
            let ground_z = |x: f64, y: f64| {
                crate::plan::ground_below(&ground, DVec3::new(x, y, 1e6)).max(-1e5)
            };
            let mut planned = raw.trees.len() as f64;
            for (i, f) in raw.forests.iter().enumerate() {
                let fp = root.key("forest").index(i);
                let Some(spec) = check_forest(&mut c, &fp, f, seed, i) else {
                    forest_trees.push(0);
                    continue;
                };
                let stand =
                    crate::scene::forest::polygon_area(&spec.area) / 10_000.0 * spec.stems_per_ha;
                planned += stand;
                if planned > MAX_TREES {
                    c.err(
                        fp.key("stems_per_ha"),
                        format!(
                            "the stand would hold {} trees ({} ha at {} stems/ha), {} in the \
                             survey; a survey may hold at most {} trees",
                            num(stand.round()),
                            num(crate::scene::forest::polygon_area(&spec.area) / 10_000.0),
                            num(spec.stems_per_ha),
                            num(planned.round()),
                            num(MAX_TREES)
                        ),
                    );
                    forest_trees.push(0);
                    continue;
                }
                let trees = generate(&spec, &ground_z);
                let wanted = (crate::scene::forest::polygon_area(&spec.area) / 10_000.0
                    * spec.stems_per_ha)
                    .round() as usize;
                if trees.len() < wanted {
                    warnings.push(format!(
                        "key `{fp}`: placed {} of {wanted} trees: min_spacing_m = {} m leaves no \
                         room for {} stems/ha",
                        trees.len(),
                        spec.min_spacing_m,
                        spec.stems_per_ha
                    ));
                }
                forest_trees.push(trees.len());
                owners.push((fp.clone(), scene.primitives.len()));
                for (j, tree) in trees.iter().enumerate() {
                    scene.add_tree(tree, whorl, format!("forest[{i}].tree[{j}]"));
                }
            }
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
        if let Some(plan) = &raw.plan {
            straight.extend(check_plan(
                &mut c,
                plan,
                &scene,
                scan_angle_deg.to_radians(),
            ));
        }
        let tracks = match &p.trajectory_file {
            None => Vec::new(),
            Some(file) => {
                let full = base.join(file);
                match crate::io::trajectory::read_trajectory(&full, interpolation) {
                    Ok(t) => t,
                    Err(e) => {
                        c.err(pp.key("trajectory_file"), e);
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
                // Only generated lines get here: [[flight_line]] entries
                // were checked above.
                c.err(
                    root.key("plan"),
                    format!(
                        "a generated line would take {hours:.3e} h; a flight line may take at \
                         most {MAX_LINE_HOURS} h"
                    ),
                );
                break;
            }
            let index = lines.len() as u32;
            let line = FlightLine {
                index,
                start_m: start,
                end_m: end,
                speed_mps: speed,
                start_time_s: t,
                sway: sway.as_ref().map(|cfg| Sway::new(cfg, seed, index)),
                nav_errors: LineErrors::default(),
                drift: drift.map(|d| Drift::new(d, drift_period_s, seed, index)),
                track: None,
            };
            t += line.duration_s() + turn_time_s;
            let nav_errors = LineErrors::new(&navigation, seed, index, line.duration_s());
            lines.push(FlightLine { nav_errors, ..line });
        }
        for (start_time_s, track) in tracks {
            let index = lines.len() as u32;
            let (start_m, end_m) = track.ends();
            let duration = track.duration_s();
            let hours = duration / 3600.0;
            if hours.is_nan() || hours > MAX_LINE_HOURS || !start_time_s.is_finite() {
                c.err(
                    pp.key("trajectory_file"),
                    format!(
                        "line {} of the trajectory lasts {:.3e} h; a flight line may take at \
                         most {MAX_LINE_HOURS} h",
                        index + 1,
                        duration / 3600.0
                    ),
                );
                break;
            }
            lines.push(FlightLine {
                index,
                start_m,
                end_m,
                speed_mps: track.length_m().max(1e-9) / duration,
                start_time_s,
                sway: None,
                nav_errors: LineErrors::new(&navigation, seed, index, duration),
                drift: None,
                track: Some(std::sync::Arc::new(track)),
            });
        }

        // Polygons, meshes (after placement) and trees far beyond any
        // projected coordinate system cannot be traced in the BVH's f32
        // boxes; say so instead of simulating a scene no pulse can hit.
        let bounds = scene.bounds();
        if !bounds.is_empty() {
            let far = bounds.min.abs().max(bounds.max.abs()).max_element();
            if far > MAX_COORDINATE_M {
                // The first entry whose primitives reach that far.
                let reach = |range: std::ops::Range<usize>| {
                    scene.primitives[range].iter().fold(0.0f64, |m, p| {
                        let b = p.bounds();
                        m.max(b.min.abs().max(b.max.abs()).max_element())
                    })
                };
                let key = owners
                    .iter()
                    .enumerate()
                    .find(|(k, (_, from))| {
                        let to = owners
                            .get(k + 1)
                            .map_or(scene.primitives.len(), |(_, t)| *t);
                        reach(*from..to) > MAX_COORDINATE_M
                    })
                    .map_or_else(KeyPath::root, |(_, (key, _))| key.clone());
                c.err(
                    key,
                    format!(
                        "this part of the scene reaches {} m from the origin: coordinates must \
                         lie within ±{MAX_COORDINATE_M:e} m (shift them, e.g. by a mesh's offset_m)",
                        num(far)
                    ),
                );
            }
        }
        // LAS stores coordinates as 32-bit integers of the scale: every
        // point must fit, receiver noise anywhere within range included.
        if formats.las || formats.laz {
            let mut reach = if bounds.is_empty() {
                crate::geometry::Aabb::EMPTY
            } else {
                bounds
            };
            for l in &lines {
                for p in [l.start_m, l.end_m] {
                    let r = DVec3::splat(max_range_m);
                    reach = reach.union_point(p - r).union_point(p + r);
                }
            }
            if !reach.is_empty() {
                let span = reach.extent().max_element();
                let finest = span / f64::from(i32::MAX);
                if las_scale_m < finest {
                    c.err(
                        op.key("las_scale_m"),
                        format!(
                            "LAS stores coordinates as 32-bit integers of las_scale_m: points of \
                             this survey may lie {} m apart (the scene, and everything within \
                             scanner.max_range_m of the flight lines), which needs las_scale_m of \
                             at least {} m, got {}",
                            num(span),
                            num(finest),
                            num(las_scale_m)
                        ),
                    );
                }
            }
        }
        if scene.primitives.is_empty() && c.problems.is_empty() {
            c.err(
                root,
                "the scene is empty: add [[polygon]], [[mesh]], [[terrain]], [[point_cloud]], \
                 [[tree]] or [[forest]] entries \
                 for the laser to hit",
            );
        }

        if !c.problems.is_empty() {
            return Err(c.problems);
        }
        Ok(Survey {
            seed,
            scanner: ScannerSettings {
                prf_hz,
                mirror: Mirror {
                    profile,
                    scan_frequency_hz,
                    scan_half_angle_rad: scan_angle_deg.to_radians(),
                },
                divergence_rad: divergence_mrad * 1e-3,
                subrays,
                min_range_m,
                max_range_m,
                wavelength_nm,
            },
            receiver: ReceiverConfig {
                bin_s: bin_ps * 1e-12,
                pulse,
                noise_sigma: noise,
                atmosphere,
                reference_range_m,
            },
            detector: DetectorConfig {
                threshold_sigma,
                min_amplitude,
                max_returns,
                selection,
            },
            speckle_looks: r.speckle.unwrap_or(false).then_some(speckle_looks),
            intensity_gain,
            sway,
            turn_time_s,
            lines,
            canopy,
            navigation,
            forest_trees,
            warnings,
            output: OutputSettings {
                formats,
                trajectory_interval_s,
                gps_start_time_s,
                las_scale_m,
                extra_bytes: o.extra_bytes.unwrap_or(true),
                crs_wkt,
                crs_epsg,
                offset_m,
            },
            scene,
            raw,
            source: path.map(Path::to_path_buf),
        })
    }

    /// Number of pulses of a flight line: ticks `k = 0, 1, …` while
    /// `k / PRF` is before the end of the line.
    pub fn pulses_of(&self, line: &FlightLine) -> u64 {
        (line.duration_s() * self.scanner.prf_hz).ceil().max(0.0) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[[flight_line]]
start_m = [0.0, -100.0, 500.0]
end_m = [0.0, 100.0, 500.0]
speed_mps = 50.0

[materials.grass]
reflectance = 0.4

[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
"#;

    #[test]
    fn defaults_fill_a_minimal_survey() {
        let s = Survey::from_toml(MINIMAL, None).unwrap();
        assert_eq!(s.scanner.prf_hz, 100_000.0);
        assert_eq!(s.scanner.subrays, 19);
        assert_eq!(s.receiver.bin_s, 500e-12);
        assert_eq!(s.lines.len(), 1);
        assert_eq!(s.pulses_of(&s.lines[0]), 400_000);
        assert_eq!(s.scene.primitives.len(), 1);
        assert!(s.output.formats.las && !s.output.formats.xyz);
    }

    fn diagnostics(text: &str) -> Vec<Diagnostic> {
        Survey::from_toml(text, Some(Path::new("s.toml")))
            .unwrap_err()
            .diagnostics
    }

    #[test]
    fn problems_name_line_and_key() {
        let bad = MINIMAL.replace("speed_mps = 50.0", "speed_mps = -5.0");
        let d = diagnostics(&bad);
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].key, "flight_line[0].speed_mps");
        assert_eq!(d[0].line, 5);
        assert!(d[0].message.contains("greater than 0"));
        let text = d[0].to_string();
        assert_eq!(
            text,
            "key `flight_line[0].speed_mps`: must be greater than 0 m/s, got -5\n \
             --> s.toml:5:13\n  |\n5 | speed_mps = -5.0\n  |             ^^^^"
        );

        let unknown = format!("[scanner]\nprff_hz = 3\n{MINIMAL}");
        let d = diagnostics(&unknown);
        assert_eq!(d[0].line, 2);
        assert!(d[0].message.contains("prff_hz"), "{}", d[0].message);
        assert_eq!(d[0].help.as_deref(), Some("did you mean `prf_hz`?"));
        assert_eq!((d[0].column, d[0].width), (1, 7));
        let far = diagnostics(&format!("[scanner]\nbananas = 3\n{MINIMAL}"));
        let help = far[0].help.as_deref().unwrap();
        assert!(help.starts_with("valid keys here: prf_hz, "), "{help}");
        assert_eq!(edit_distance("scan_angel_deg", "scan_angle_deg"), 2);
        assert!(d[0].key.contains("scanner"), "{}", d[0].key);

        let wrong_type = format!("[scanner]\nprf_hz = \"fast\"\n{MINIMAL}");
        let d = diagnostics(&wrong_type);
        assert_eq!((d[0].line, d[0].key.as_str()), (2, "scanner.prf_hz"));

        let several = format!(
            "[scanner]\nprf_hz = 0\nsubrays = 0\n{}",
            MINIMAL.replace("\"grass\"\nclass", "\"gras\"\nclass")
        );
        let d = diagnostics(&several);
        let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            ["scanner.prf_hz", "scanner.subrays", "polygon[0].material"]
        );
        assert!(d[2].message.contains("defined: grass"));
    }

    #[test]
    fn unknown_keys_wrong_types_and_ranges_anywhere_are_reported_together() {
        // Five problems in four tables: two unknown keys, two wrong types
        // (one inside an array of tables), one value out of range.
        let text = "[scanner]\nprf_hz = \"fast\"\nscan_angel_deg = 10\nsubrays = 0\n\n\
                    [[flight_line]]\nstart_m = [0.0, -500.0, 1000.0]\n\
                    end_m = [0.0, 500.0, \"high\"]\nspeed_mps = 60.0\n\n\
                    [materials.grass]\nreflectance = 0.4\ncolour = \"green\"\n\n\
                    [[polygon]]\nmaterial = \"grass\"\nclass = \"ground\"\n\
                    vertices_m = [[-600, -700, 0], [600, -700, 0], [600, 700, 0]]\n";
        let d = diagnostics(text);
        let got: Vec<(usize, usize, &str)> = d
            .iter()
            .map(|d| (d.line, d.column, d.key.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                (2, 10, "scanner.prf_hz"),
                (3, 1, "scanner.scan_angel_deg"),
                (4, 11, "scanner.subrays"),
                (8, 22, "flight_line[0].end_m[2]"),
                (13, 1, "materials.grass.colour"),
            ],
            "{d:#?}"
        );
        assert_eq!(
            d[0].message,
            "invalid type: string \"fast\", expected a number"
        );
        assert_eq!(d[0].width, 6); // "fast" with its quotes
        assert_eq!(d[1].help.as_deref(), Some("did you mean `scan_angle_deg`?"));
        assert!(d[2].message.contains("from 1 to 10000"), "{}", d[2].message);
        assert!(d[4].help.as_deref().unwrap().contains("reflectance"));
        // A syntax error stops reading, with its place.
        let d = diagnostics("[scanner]\nprf_hz = = 3\n");
        assert_eq!((d.len(), d[0].line), (1, 2), "{d:#?}");
        assert!(d[0].to_string().contains("2 | prf_hz = = 3"), "{}", d[0]);
    }

    #[test]
    fn trees_and_forests_are_validated_together() {
        let bad = format!(
            "{MINIMAL}\n[[tree]]\nposition_m = [0, 0, 0]\nspecies = \"oak\"\ndbh_m = -1\n\
             height_m = 200\ncrown_base_m = 20\n\n[[forest]]\nrectangle_m = [0, 0, -5, 5]\n\
             stems_per_ha = 100\nspecies = {{ elm = 1.0 }}\nheight_m = [1.0, 5.0]\n"
        );
        let d = diagnostics(&bad);
        let keys: Vec<&str> = d.iter().map(|d| d.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "tree[0].species",
                "tree[0].dbh_m",
                "tree[0].height_m",
                "forest[0].rectangle_m",
                "forest[0].species.elm",
                "forest[0].height_m"
            ],
            "{d:#?}"
        );
    }

    #[test]
    fn forests_stand_on_the_ground_and_follow_the_seed() {
        let text = format!(
            "{}\n[[forest]]\nrectangle_m = [-50, -50, 50, 50]\nstems_per_ha = 300\n",
            MINIMAL.replace(
                "[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]",
                "[-300, -300, -7], [300, -300, -7], [300, 300, -7], [-300, 300, -7]"
            )
        );
        let a = Survey::from_toml(&text, None).unwrap();
        assert_eq!(a.forest_trees, [300]);
        let trunks = |s: &Survey| -> Vec<crate::geometry::Aabb> {
            s.scene
                .primitives
                .iter()
                .filter(|p| matches!(p.shape, Shape::Trunk(_)))
                .map(|p| p.bounds())
                .collect()
        };
        assert!(trunks(&a).iter().all(|b| b.min.z == -7.0));
        let b = Survey::from_toml_with_seed(&text, None, Some(99)).unwrap();
        assert_ne!(trunks(&a)[0], trunks(&b)[0]);
        assert!(a.warnings.is_empty());
        // Too many stems for the spacing: placed anyway, with a warning.
        let crowded = text.replace(
            "stems_per_ha = 300",
            "stems_per_ha = 5000\nmin_spacing_m = 4",
        );
        let c = Survey::from_toml(&crowded, None).unwrap();
        assert!(c.forest_trees[0] < 5000);
        assert!(c.warnings[0].contains("forest[0]"), "{:?}", c.warnings);
    }

    #[test]
    fn bad_polygons_are_reported() {
        let empty = MINIMAL.replace(
            "vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]",
            "vertices_m = []",
        );
        let d = diagnostics(&empty);
        assert_eq!(d[0].key, "polygon[0].vertices_m");
        assert!(d[0].message.contains("at least 3"));
        let warped = MINIMAL.replace("[300, 300, 0]", "[300, 300, 5]");
        let d = diagnostics(&warped);
        assert!(d[0].message.contains("not planar"), "{}", d[0].message);
        assert_eq!(d[0].line, 13);
    }

    #[test]
    fn mesh_class_patterns_map_groups_and_name_their_key() {
        let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/x.toml");
        let text = |classes: &str| {
            format!(
                "[[flight_line]]\nstart_m = [0, -50, 300]\nend_m = [0, 50, 300]\nspeed_mps = 50\n\
                 [[mesh]]\nfile = \"house.obj\"\nclass = \"roof\"\nclasses = {{ {classes} }}\n"
            )
        };
        let s = Survey::from_toml(&text("\"wall*\" = \"bridge\""), Some(&base))
            .unwrap_or_else(|e| panic!("{e}"));
        let count = |c: SurfaceClass| s.scene.primitives.iter().filter(|p| p.class == c).count();
        // house.obj: the gable walls (south, north) are pentagons of three
        // triangles, east and west quads of two: 10 triangles become
        // bridge, no wall is left.
        assert_eq!(count(SurfaceClass::Bridge), 10);
        assert_eq!(count(SurfaceClass::Wall), 0);
        assert!(count(SurfaceClass::Roof) > 0);

        let e = Survey::from_toml(&text("\"wal*\" = \"wall\", roofs = \"roof\""), Some(&base))
            .unwrap_err();
        assert_eq!(e.diagnostics.len(), 1, "{e}");
        assert_eq!(e.diagnostics[0].key, "mesh[0].classes.roofs");
        assert!(
            e.diagnostics[0]
                .message
                .contains("no group or object name matches 'roofs'")
        );
        assert_eq!(e.diagnostics[0].line, 8);
        let e = Survey::from_toml(&text("\"wall*\" = \"lava\""), Some(&base)).unwrap_err();
        assert!(
            e.diagnostics[0].message.contains("unknown class 'lava'"),
            "{e}"
        );
        assert_eq!(e.diagnostics[0].line, 8);
    }

    #[test]
    fn terrain_example_loads_with_trees_on_the_terrain() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/terrain.toml");
        let s = Survey::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let b = s.scene.bounds();
        // The fBm terrain: extent [-300, -200, 300, 200] on a 2 m grid,
        // relief 35 m from z = 0; tree crowns reach higher.
        assert_eq!(
            (b.min.x, b.min.y, b.max.x, b.max.y),
            (-300.0, -200.0, 300.0, 200.0)
        );
        assert_eq!(b.min.z, 0.0);
        let terrain = s
            .scene
            .primitives
            .iter()
            .filter(|p| matches!(p.shape, Shape::Terrain(_)))
            .count();
        // 300 × 200 cells in 16-cell tiles: ceil(300/16) × ceil(200/16).
        assert_eq!(terrain, 19 * 13);
        // Every trunk stands on the terrain: its base is within the relief.
        for p in &s.scene.primitives {
            if let Shape::Trunk(_) = &p.shape {
                let z = p.bounds().min.z;
                assert!((0.0..=35.0001).contains(&z), "trunk base at {z}");
            }
        }
        assert!(s.forest_trees[0] > 1000, "{:?}", s.forest_trees);
    }
}
