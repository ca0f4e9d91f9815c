//! The survey file in its first two stages: **parse** (text into
//! [`RawSurvey`], which mirrors the TOML file, with source spans; module
//! `read`) and **check** (the raw values into [`Survey`], settings the
//! rest of the program trusts, units converted — degrees to radians, ns to
//! s — one small checker per table in `check`). A survey is settings only:
//! its scene entries and line sources ([`spec`]) are built, once, by
//! [`crate::world`]. Every problem is reported as a [`Diagnostic`] naming
//! the file, line, column and key; all problems of a stage are reported
//! together.

mod check;
pub mod data;
mod diagnostic;
mod locate;
pub mod platform_preset;
pub mod preset;
pub mod raw;
mod read;
pub mod size;
pub mod spec;

pub use diagnostic::{Diagnostic, SurveyError};
pub use locate::{KeyPath, Locator, Seg};
pub use raw::RawSurvey;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::canopy::CanopyConfig;
use crate::detection::DetectorConfig;
use crate::geometry::DVec3;
pub use crate::message::num;
use crate::scene::Material;
use crate::sensor::beam::Fineness;
use crate::sensor::channel::Channel;
use crate::sensor::deflector::Deflector;
use crate::sensor::navigation::NavigationErrors;
use crate::sensor::platform::{DriftConfig, FlightLine, SwayConfig};
use crate::waveform::ReceiverConfig;
use check::Checker;
use diagnostic::{Diagnose, diagnostics_in_file_order};
use spec::{LineSpec, SceneSpec};

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

pub use crate::scene::tree::MIN_TREE_HEIGHT_M;

/// Scanner settings after validation.
#[derive(Clone, Debug, PartialEq)]
pub struct ScannerSettings {
    /// Pulse repetition frequency, Hz.
    pub prf_hz: f64,
    /// What deflects the beam.
    pub deflector: Deflector,
    /// The beams of the head, firing in their cycle (one for most
    /// scanners), each with its own divergence and wavelength.
    pub channels: Vec<Channel>,
    /// Full beam divergence, rad (the channels' default).
    pub divergence_rad: f64,
    /// Full beam divergence along the track (the beam's y axis), rad:
    /// `divergence_rad` for a round beam.
    pub divergence_along_rad: f64,
    /// Sub-rays per pulse.
    pub subrays: usize,
    /// How finely a sub-ray's cell is sampled across a discontinuity the
    /// receiver resolves.
    pub edge_fineness: Fineness,
    /// Closest range the receiver records, m.
    pub min_range_m: f64,
    /// Farthest range the receiver records, m.
    pub max_range_m: f64,
    /// Laser wavelength, nm (the channels' default).
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
    /// Interval between rows of `trajectory_true.csv`, s.
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
    /// How the LAS and LAZ points are laid out in files.
    pub layout: Layout,
}

/// How the LAS and LAZ points of a run are laid out in files.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Layout {
    /// One file: `points.las`, `points.laz`.
    #[default]
    Single,
    /// One file per flight line: `strips/line-NNNN.las` (`.laz`).
    Strips,
    /// One file per square tile of this edge, m, aligned to its multiples
    /// in output coordinates: `tiles/tile_X_Y.las` (`.laz`), with
    /// `tiles/index.geojson`.
    Tiles(f64),
}

/// A checked survey: settings only. [`crate::world::World::build`] makes
/// its scene, index and flight lines.
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
    /// Turbulence drift when it is on.
    pub drift: Option<DriftConfig>,
    /// Where the flight lines come from.
    pub line_spec: LineSpec,
    /// How sub-rays march through tree crowns.
    pub canopy: CanopyConfig,
    /// GNSS/IMU, boresight, lever-arm, ranging and encoder errors.
    pub navigation: NavigationErrors,
    /// Things that are allowed but probably not what was meant, each
    /// naming its key (printed by the command line, kept in the summary).
    pub warnings: Vec<String>,
    /// The instrument preset `[scanner] preset` named, and what it set.
    pub preset: Option<preset::PresetUse>,
    /// The platform preset `[platform] preset` named, and what it set.
    pub platform_preset: Option<platform_preset::PlatformPresetUse>,
    /// What to write.
    pub output: OutputSettings,
    /// The survey's materials by name.
    pub materials: HashMap<String, Material>,
    /// The scene's entries.
    pub scene_spec: SceneSpec,
    /// The raw form it was checked from (for the summary and `--export`).
    pub raw: RawSurvey,
    /// The file it was read from, if any.
    pub source: Option<PathBuf>,
    /// Its text, to place problems the world finds in it.
    pub(crate) text: Option<Arc<str>>,
}

impl Survey {
    /// Reads and checks a survey file. File paths are relative to it.
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

    /// Parses and checks survey text; `path` (if any) names the file in
    /// messages and anchors relative file paths.
    pub fn from_toml(text: &str, path: Option<&Path>) -> Result<Self, SurveyError> {
        Self::from_toml_with_seed(text, path, None)
    }

    /// [`Survey::from_toml`] with the seed replaced by `seed` if given.
    ///
    /// Every problem is reported at once: unknown keys and values of the
    /// wrong type anywhere in the file (each offending key is set aside and
    /// the rest read again), then the checks of everything else. Only a
    /// TOML syntax error stops at once, since nothing after it can be
    /// trusted.
    pub fn from_toml_with_seed(
        text: &str,
        path: Option<&Path>,
        seed: Option<u64>,
    ) -> Result<Self, SurveyError> {
        let file = path.map_or_else(|| "<survey>".to_string(), |p| p.display().to_string());
        let text = crate::io::input::strip_bom(text);
        size::check(text, &file)?;
        let locator = Locator::new(text);
        let diagnose = Diagnose {
            file: &file,
            text: Some((text, &locator)),
        };
        let (mut raw, mut diagnostics, set_aside) = read::read_raw(text, &locator, &diagnose)?;
        if seed.is_some() {
            raw.seed = seed;
        }
        // Problems of keys set aside above were reported already.
        let related = |p: &KeyPath| {
            set_aside
                .iter()
                .any(|a| p.0.starts_with(&a.0) || a.0.starts_with(&p.0))
        };
        match Self::from_raw(raw, path) {
            Ok(mut survey) if diagnostics.is_empty() => {
                survey.text = Some(Arc::from(text));
                Ok(survey)
            }
            Ok(_) => Err(diagnostics_in_file_order(diagnostics)),
            Err(problems) => {
                for (key, message) in problems {
                    if related(&key) {
                        continue;
                    }
                    diagnostics.push(diagnose.at(&key, locator.span_of(&key), message, None));
                }
                Err(diagnostics_in_file_order(diagnostics))
            }
        }
    }

    /// Checks a raw survey; on failure returns every problem with its key
    /// path.
    pub fn from_raw(raw: RawSurvey, path: Option<&Path>) -> Result<Self, Vec<(KeyPath, String)>> {
        let mut c = Checker::new();
        let seed = raw.seed.unwrap_or(DEFAULT_SEED);
        if seed > i64::MAX as u64 {
            c.err(
                KeyPath::root().key("seed"),
                format!("must be at most {} (a TOML integer), got {seed}", i64::MAX),
            );
        }
        let base = path
            .and_then(|p| p.parent())
            .map(Path::to_path_buf)
            .unwrap_or_default();
        let sensor = check::scanner::scanner(&mut c, &raw);
        let platform = check::platform::platform(&mut c, &raw);
        let navigation = check::navigation::check_navigation(&mut c, &raw);
        let output = check::output::output(&mut c, &raw);
        let materials = check::scene::materials(&mut c, &raw);
        let (canopy, foliage) = check::vegetation::vegetation(&mut c, &raw);
        let scene_spec = SceneSpec {
            polygons: check::scene::polygons(&mut c, &raw, &materials),
            meshes: check::scene::meshes(&mut c, &raw, &materials, &base),
            terrains: check::scene::terrains(&mut c, &raw, &materials, &base, seed),
            clouds: check::scene::clouds(&mut c, &raw, &materials, &base),
            trees: check::vegetation::trees(&mut c, &raw, seed),
            forests: check::vegetation::forests(&mut c, &raw, seed),
            tree_tables: check::vegetation::tree_tables(&mut c, &raw, &base, seed),
            foliage,
        };
        let mut warnings = sensor.warnings;
        let line_spec = check::lines::lines(
            &mut c,
            &raw,
            sensor.scanner.deflector.across_half_angle_rad(),
            &base,
            &mut warnings,
        );
        if !c.problems.is_empty() {
            return Err(c.problems);
        }
        Ok(Survey {
            seed,
            scanner: sensor.scanner,
            receiver: sensor.receiver,
            detector: sensor.detector,
            speckle_looks: sensor.speckle_looks,
            intensity_gain: sensor.intensity_gain,
            sway: platform.sway,
            turn_time_s: platform.turn_time_s,
            drift: platform.drift,
            line_spec,
            canopy,
            navigation,
            warnings,
            preset: sensor.preset,
            platform_preset: platform.preset,
            output,
            materials: materials.0,
            scene_spec,
            raw,
            source: path.map(Path::to_path_buf),
            text: None,
        })
    }

    /// Number of pulses of a flight line: ticks `k = 0, 1, …` while
    /// `k / PRF` is before the end of the line.
    pub fn pulses_of(&self, line: &FlightLine) -> u64 {
        (line.duration_s() * self.scanner.prf_hz).ceil().max(0.0) as u64
    }

    /// The survey's file name for messages (`<survey>` without one).
    pub fn file_name(&self) -> String {
        self.source
            .as_ref()
            .map_or_else(|| "<survey>".to_string(), |p| p.display().to_string())
    }

    /// The diagnostics of problems found in this survey after it was
    /// checked (by the world, reading the files it names).
    pub fn diagnose(&self, problems: Vec<(KeyPath, String)>) -> SurveyError {
        let file = self.file_name();
        let locator = self.text.as_deref().map(Locator::new);
        let diagnose = Diagnose {
            file: &file,
            text: self.text.as_deref().zip(locator.as_ref()),
        };
        diagnose.problems(problems)
    }
}

#[cfg(test)]
#[cfg(test)]
mod tests;
