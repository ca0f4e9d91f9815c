//! The survey file as written: plain serde mirrors of the TOML tables.
//!
//! Every key is optional here (except where a table makes no sense without
//! it); defaults and range checks live in the validation step
//! ([`super::Survey::from_raw`]), which can then report all problems with
//! their keys at once. Integers that must be positive are read as `i64`
//! so that a negative value gets our message rather than the parser's.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Top level of a survey file.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSurvey {
    /// Seed of all random streams.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Navigation error preset for GNSS and IMU (`"survey-grade"`, `"uav"`).
    #[serde(skip_serializing_if = "Option::is_none")]
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
    #[serde(skip_serializing_if = "Option::is_none")]
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
}

/// `[scanner]`: the laser, mirror and beam.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawScanner {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prf_hz: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_frequency_hz: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_angle_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mirror: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub divergence_mrad: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub subrays: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pulse_fwhm_ns: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pulse_shape: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_returns: Option<i64>,
    /// Which echoes are kept beyond `max_returns`: `"first-and-last"`
    /// (default) or `"first"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub return_selection: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_range_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_range_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_range_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wavelength_nm: Option<f64>,
}

/// `[receiver]`: sampling, noise and detection.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawReceiver {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bin_ps: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub atmosphere: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speckle: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speckle_looks: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threshold_sigma: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_amplitude: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub intensity_gain: Option<f64>,
}

/// `[platform]`: attitude sway and turns.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPlatform {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sway: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift_period_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trajectory_file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolation: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub roll_amplitude_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pitch_amplitude_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yaw_amplitude_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sway_frequencies_hz: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub turn_time_s: Option<f64>,
}

/// `[[flight_line]]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawFlightLine {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub end_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_mps: Option<f64>,
}

/// `[output]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawOutput {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub formats: Option<Vec<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trajectory_interval_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gps_start_time_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub las_scale_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extra_bytes: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crs: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crs_wkt: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<Vec<f64>>,
}

/// `[materials.NAME]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawMaterial {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reflectance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub incidence_exponent: Option<f64>,
}

/// `[[polygon]]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPolygon {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vertices_m: Option<Vec<Vec<f64>>>,
}

/// `[[mesh]]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawMesh {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotation_z_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    /// Group/object name pattern (`*` matches any run of characters) →
    /// class.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub classes: Option<BTreeMap<String, String>>,
}

/// `[[terrain]]`: a raster DEM (`file`) or a generated one (`generator`).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawTerrain {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extent_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resolution_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relief_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wavelength_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub octaves: Option<i64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
}

/// `[[point_cloud]]`: a LAS/LAZ cloud loaded as voxels.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPointCloud {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voxel_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
}

/// `[vegetation]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawVegetation {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub step_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub whorl_spacing_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub partial_blocking: Option<f64>,
    /// How intercepting foliage returns a sub-ray: `"physical"` (default)
    /// or `"specification"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub return_model: Option<String>,
}

/// `[[tree]]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawTree {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub position_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub species: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dbh_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crown_base_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub foliage_reflectance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bark_reflectance: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crown_radius_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extinction_per_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uniform_density: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

/// `[[forest]]`: a generated stand.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawForest {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rectangle_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_m: Option<Vec<Vec<f64>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stems_per_ha: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub species: Option<BTreeMap<String, f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_spacing_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
}

/// `[gnss]` (metres) or `[imu]` (degrees). A number for `sigma_*` and
/// `random_walk_*` applies to all three axes; a list gives them per axis.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawErrors {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_m: Option<NumberOrList>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random_walk_m: Option<NumberOrList>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_deg: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_deg: Option<NumberOrList>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub random_walk_deg: Option<NumberOrList>,
    #[serde(skip_serializing_if = "Option::is_none")]
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
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
#[allow(missing_docs)]
pub enum NumberOrList {
    Number(f64),
    List(Vec<f64>),
}

/// `[boresight]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawBoresight {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub angles_deg: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lever_arm_m: Option<Vec<f64>>,
}

impl RawBoresight {
    /// True when no key is set.
    pub fn is_empty(&self) -> bool {
        self.angles_deg.is_none() && self.lever_arm_m.is_none()
    }
}

/// `[ranging]`.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawRanging {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub encoder_sigma_deg: Option<f64>,
}

impl RawRanging {
    /// True when no key is set.
    pub fn is_empty(&self) -> bool {
        self.sigma_m.is_none() && self.encoder_sigma_deg.is_none()
    }
}

/// `[plan]`: parallel flight lines over an area.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct RawPlan {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rectangle_m: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_m: Option<Vec<Vec<f64>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub altitude_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub line_spacing_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub side_overlap: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_mps: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub run_in_m: Option<f64>,
}
