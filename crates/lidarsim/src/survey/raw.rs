//! The survey file as written: plain serde mirrors of the TOML tables.
//!
//! Every key is optional here (except where a table makes no sense without
//! it); defaults and range checks live in the validation step
//! ([`super::Survey::from_raw`]), which can then report all problems with
//! their keys at once. Integers that must be positive are read as `i64`
//! so that a negative value gets our message rather than the parser's.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_with::skip_serializing_none;

/// Top level of a survey file.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSurvey {
    /// Seed of all random streams.
    pub seed: Option<u64>,
    /// Navigation error preset for GNSS and IMU (`"survey-grade"`, `"uav"`).
    pub preset: Option<String>,
    /// `[scanner]`.
    #[serde(default)]
    pub scanner: RawScanner,
    /// `[receiver]`.
    #[serde(default)]
    pub receiver: RawReceiver,
    /// `[platform]`.
    #[serde(default)]
    pub platform: RawPlatform,
    /// `[output]`.
    #[serde(default)]
    pub output: RawOutput,
    /// `[[flight_line]]`.
    #[serde(default, rename = "flight_line")]
    pub flight_lines: Vec<RawFlightLine>,
    /// `[plan]`: flight lines generated over an area.
    pub plan: Option<RawPlan>,
    /// `[materials.NAME]`.
    #[serde(default)]
    pub materials: BTreeMap<String, RawMaterial>,
    /// `[[polygon]]`.
    #[serde(default, rename = "polygon", skip_serializing_if = "Vec::is_empty")]
    pub polygons: Vec<RawPolygon>,
    /// `[[mesh]]`.
    #[serde(default, rename = "mesh", skip_serializing_if = "Vec::is_empty")]
    pub meshes: Vec<RawMesh>,
    /// `[[terrain]]`: height grids from rasters or a generator.
    #[serde(default, rename = "terrain", skip_serializing_if = "Vec::is_empty")]
    pub terrains: Vec<RawTerrain>,
    /// `[[point_cloud]]`: LAS/LAZ clouds turned into voxels.
    #[serde(default, rename = "point_cloud", skip_serializing_if = "Vec::is_empty")]
    pub point_clouds: Vec<RawPointCloud>,
    /// `[gnss]`: position errors of the observed trajectory.
    #[serde(default, skip_serializing_if = "RawErrors::is_empty")]
    pub gnss: RawErrors,
    /// `[imu]`: attitude errors of the observed trajectory.
    #[serde(default, skip_serializing_if = "RawErrors::is_empty")]
    pub imu: RawErrors,
    /// `[boresight]`: scanner misalignment and lever-arm error.
    #[serde(default, skip_serializing_if = "RawBoresight::is_empty")]
    pub boresight: RawBoresight,
    /// `[ranging]`: measurement noise.
    #[serde(default, skip_serializing_if = "RawRanging::is_empty")]
    pub ranging: RawRanging,
    /// `[vegetation]`: how sub-rays march through crowns.
    #[serde(default)]
    pub vegetation: RawVegetation,
    /// `[[tree]]`.
    #[serde(default, rename = "tree", skip_serializing_if = "Vec::is_empty")]
    pub trees: Vec<RawTree>,
    /// `[[forest]]`.
    #[serde(default, rename = "forest", skip_serializing_if = "Vec::is_empty")]
    pub forests: Vec<RawForest>,
    /// `[[tree_table]]`: trees from a CSV file, one a row.
    #[serde(default, rename = "tree_table", skip_serializing_if = "Vec::is_empty")]
    pub tree_tables: Vec<RawTreeTable>,
}

/// `[scanner]`: the laser, mirror and beam.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawScanner {
    /// An instrument whose datasheet values fill the keys not given
    /// (`survey::preset`).
    pub preset: Option<String>,
    pub prf_hz: Option<f64>,
    pub scan_frequency_hz: Option<f64>,
    pub scan_angle_deg: Option<f64>,
    /// `"oscillating"` (default), `"polygon"`, `"palmer"`, `"risley"`,
    /// `"fibre"`.
    pub deflector: Option<String>,
    pub mirror: Option<String>,
    /// Polygon: mirror facets.
    pub facets: Option<i64>,
    /// Palmer: half-angle of the cone along the track (default: as across).
    pub scan_angle_along_deg: Option<f64>,
    /// Risley: deviation of each prism, degrees.
    pub prism_deviation_deg: Option<Vec<f64>>,
    /// Risley: turns per second of each prism (negative: the other way).
    pub rotor_frequency_hz: Option<Vec<f64>>,
    /// Fibre array: fibres in the fan.
    pub fibres: Option<i64>,
    /// `[[scanner.channels]]`: the beams of a multi-channel head, firing
    /// in turn.
    pub channels: Option<Vec<RawChannel>>,
    pub divergence_mrad: Option<f64>,
    /// Divergence along the track for an elliptical beam (default: as
    /// `divergence_mrad`, which is then the divergence across).
    pub divergence_along_mrad: Option<f64>,
    pub subrays: Option<i64>,
    /// Rays sampling a cell across a resolved discontinuity: 16
    /// (default), 64 or 256.
    pub edge_rays: Option<i64>,
    pub pulse_fwhm_ns: Option<f64>,
    pub pulse_shape: Option<String>,
    pub max_returns: Option<i64>,
    /// Which echoes are kept beyond `max_returns`: `"first-and-last"`
    /// (default) or `"first"`.
    pub return_selection: Option<String>,
    /// How echoes become returns: `"discrete"` (default) or `"waveform"`.
    pub echo_detection: Option<String>,
    /// Least range between two returns of a pulse, m.
    pub min_return_separation_m: Option<f64>,
    pub min_range_m: Option<f64>,
    pub max_range_m: Option<f64>,
    pub reference_range_m: Option<f64>,
    pub wavelength_nm: Option<f64>,
}

/// `[[scanner.channels]]`: one beam of a multi-channel head.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawChannel {
    /// Tilt along the track, degrees, positive forward.
    pub along_tilt_deg: Option<f64>,
    /// Turn about the scanner's z axis, degrees, positive to the left.
    pub yaw_deg: Option<f64>,
    /// Full divergence across, mrad (default: the scanner's).
    pub divergence_mrad: Option<f64>,
    /// Full divergence along, mrad (default: as across when that is given,
    /// else the scanner's).
    pub divergence_along_mrad: Option<f64>,
    /// Wavelength, nm (default: the scanner's).
    pub wavelength_nm: Option<f64>,
    /// Pulses of each firing cycle on this channel (default 1): its share
    /// of the PRF is this over the channels' sum.
    pub pulses_per_cycle: Option<i64>,
}

/// `[receiver]`: sampling, noise and detection.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawReceiver {
    pub bin_ps: Option<f64>,
    pub noise: Option<f64>,
    pub atmosphere: Option<f64>,
    pub speckle: Option<bool>,
    pub speckle_looks: Option<f64>,
    pub threshold_sigma: Option<f64>,
    pub min_amplitude: Option<f64>,
    pub intensity_gain: Option<f64>,
}

/// `[platform]`: attitude sway and turns.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPlatform {
    pub preset: Option<String>,
    pub sway: Option<bool>,
    pub drift_m: Option<Vec<f64>>,
    pub drift_period_s: Option<f64>,
    pub trajectory_file: Option<String>,
    pub interpolation: Option<String>,
    pub roll_amplitude_deg: Option<f64>,
    pub pitch_amplitude_deg: Option<f64>,
    pub yaw_amplitude_deg: Option<f64>,
    pub sway_frequencies_hz: Option<Vec<f64>>,
    pub turn_time_s: Option<f64>,
}

/// `[[flight_line]]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawFlightLine {
    pub start_m: Option<Vec<f64>>,
    pub end_m: Option<Vec<f64>>,
    pub altitude_m: Option<f64>,
    pub speed_mps: Option<f64>,
}

/// `[output]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawOutput {
    pub formats: Option<Vec<String>>,
    pub trajectory_interval_s: Option<f64>,
    pub gps_start_time_s: Option<f64>,
    pub las_scale_m: Option<f64>,
    pub extra_bytes: Option<bool>,
    pub crs: Option<String>,
    pub crs_wkt: Option<String>,
    pub offset_m: Option<Vec<f64>>,
    /// `"single"` (default), `"strips"` (a LAS/LAZ file per flight line)
    /// or `"tiles"` (per square tile of `tile_m`).
    pub layout: Option<String>,
    pub tile_m: Option<f64>,
}

/// `[materials.NAME]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawMaterial {
    pub reflectance: Option<f64>,
    pub incidence_exponent: Option<f64>,
    /// `[[nm, reflectance], ...]` by increasing wavelength, instead of
    /// `reflectance`.
    pub reflectance_spectrum: Option<Vec<Vec<f64>>>,
}

/// `[[polygon]]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPolygon {
    pub material: Option<String>,
    pub class: Option<String>,
    pub vertices_m: Option<Vec<Vec<f64>>>,
}

/// `[[mesh]]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawMesh {
    pub file: Option<String>,
    pub offset_m: Option<Vec<f64>>,
    pub scale: Option<f64>,
    pub rotation_z_deg: Option<f64>,
    pub class: Option<String>,
    pub material: Option<String>,
    /// Group/object name pattern (`*` matches any run of characters) →
    /// class.
    pub classes: Option<BTreeMap<String, String>>,
}

/// `[[terrain]]`: a raster DEM (`file`) or a generated one (`generator`).
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawTerrain {
    pub file: Option<String>,
    pub generator: Option<String>,
    pub extent_m: Option<Vec<f64>>,
    pub resolution_m: Option<f64>,
    pub relief_m: Option<f64>,
    pub wavelength_m: Option<f64>,
    pub octaves: Option<i64>,
    pub seed: Option<u64>,
    pub offset_m: Option<Vec<f64>>,
    pub material: Option<String>,
    pub class: Option<String>,
}

/// `[[point_cloud]]`: a LAS/LAZ cloud loaded as voxels.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPointCloud {
    pub file: Option<String>,
    pub voxel_m: Option<f64>,
    pub offset_m: Option<Vec<f64>>,
    pub material: Option<String>,
    pub class: Option<String>,
}

/// `[vegetation]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawVegetation {
    pub step_m: Option<f64>,
    /// How plant area fills the crowns: `"physical"` (default) or
    /// `"specification"`.
    pub foliage: Option<String>,
    /// Edge of the physical model's clump cells, m.
    pub clump_m: Option<f64>,
    /// Share of the physical model's clump cells that hold foliage.
    pub clump_fraction: Option<f64>,
    /// Depth of the physical model's foliated shell, m.
    pub shell_m: Option<f64>,
    pub whorl_spacing_m: Option<f64>,
    pub partial_blocking: Option<f64>,
    /// How intercepting foliage returns a sub-ray: `"physical"` (default)
    /// or `"specification"`.
    pub return_model: Option<String>,
    /// How sub-rays are taken through crowns: `"pulse"` (default) or
    /// `"sub-ray"`.
    pub march: Option<String>,
}

/// `[[tree]]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawTree {
    pub position_m: Option<Vec<f64>>,
    pub species: Option<String>,
    pub dbh_m: Option<f64>,
    pub height_m: Option<f64>,
    pub crown_base_m: Option<f64>,
    pub foliage_reflectance: Option<f64>,
    pub bark_reflectance: Option<f64>,
    pub crown_radius_m: Option<f64>,
    pub extinction_per_m: Option<f64>,
    pub uniform_density: Option<f64>,
    pub seed: Option<u64>,
}

/// `[[tree_table]]`: a CSV file of trees, one a row, with a header naming
/// the columns (`x_m`, `y_m`, `z_m`, `height_m` and optional `[[tree]]`
/// keys).
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawTreeTable {
    pub file: Option<String>,
    /// Added to every tree's position, m.
    pub offset_m: Option<Vec<f64>>,
    /// Species of rows without a `species` column or value.
    pub species: Option<String>,
}

/// `[[forest]]`: a generated stand.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawForest {
    pub rectangle_m: Option<Vec<f64>>,
    pub area_m: Option<Vec<Vec<f64>>>,
    pub stems_per_ha: Option<f64>,
    pub species: Option<BTreeMap<String, f64>>,
    pub height_m: Option<Vec<f64>>,
    pub min_spacing_m: Option<f64>,
    pub seed: Option<u64>,
}

/// `[gnss]` (metres) or `[imu]` (degrees). A number for `sigma_*` and
/// `random_walk_*` applies to all three axes; a list gives them per axis.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawErrors {
    pub preset: Option<String>,
    pub bias_m: Option<Vec<f64>>,
    pub sigma_m: Option<NumberOrList>,
    pub random_walk_m: Option<NumberOrList>,
    pub bias_deg: Option<Vec<f64>>,
    pub sigma_deg: Option<NumberOrList>,
    pub random_walk_deg: Option<NumberOrList>,
    pub correlation_time_s: Option<f64>,
}

impl RawErrors {
    /// True when no key is set.
    pub fn is_empty(&self) -> bool {
        self.preset.is_none()
            && self.bias_m.is_none()
            && self.sigma_m.is_none()
            && self.random_walk_m.is_none()
            && self.bias_deg.is_none()
            && self.sigma_deg.is_none()
            && self.random_walk_deg.is_none()
            && self.correlation_time_s.is_none()
    }
}

/// One number for all axes, or one per axis.
#[skip_serializing_none]
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
#[allow(missing_docs)]
pub enum NumberOrList {
    Number(f64),
    List(Vec<f64>),
}

/// `[boresight]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawBoresight {
    pub angles_deg: Option<Vec<f64>>,
    pub lever_arm_m: Option<Vec<f64>>,
}

impl RawBoresight {
    /// True when no key is set.
    pub fn is_empty(&self) -> bool {
        self.angles_deg.is_none() && self.lever_arm_m.is_none()
    }
}

/// `[ranging]`.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawRanging {
    pub sigma_m: Option<f64>,
    pub encoder_sigma_deg: Option<f64>,
}

impl RawRanging {
    /// True when no key is set.
    pub fn is_empty(&self) -> bool {
        self.sigma_m.is_none() && self.encoder_sigma_deg.is_none()
    }
}

/// `[plan]`: parallel flight lines over an area.
#[skip_serializing_none]
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPlan {
    pub rectangle_m: Option<Vec<f64>>,
    pub area_m: Option<Vec<Vec<f64>>>,
    pub altitude_m: Option<f64>,
    pub heading_deg: Option<f64>,
    pub line_spacing_m: Option<f64>,
    pub side_overlap: Option<f64>,
    pub speed_mps: Option<f64>,
    pub run_in_m: Option<f64>,
}
