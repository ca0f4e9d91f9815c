//! `lidarsim twin`: a survey that re-flies a real airborne scan, made from
//! the scan alone.
//!
//! From the bottom up: the scan's ground ([`crate::scan::ground`]: a DTM
//! from its ground returns, or flat for a height-normalised cloud), its
//! trees ([`trees`]: tops, crowns and heights from the canopy height
//! model), how it was flown ([`acquisition`]: strips, tracks, mirror,
//! pulse rate), and the files that make the survey ([`mod@write`]:
//! `survey.toml`, `trees.csv`, `dtm.tif`, `twin.json`). [`twin`] does it
//! all; [`Twin::summary_lines`] and `twin.json` say what was inferred and
//! how sure it is.

pub mod acquisition;
mod summary;
pub mod trees;
pub mod write;

use serde::Serialize;

use crate::message::num;
use crate::scan::grid::Grid;
use crate::scan::ground::{GroundModel, ground_model};
use crate::scan::{Progress, ScanCloud, ScanError};
use acquisition::AcquisitionSettings;
use acquisition::combine::{self, Acquisition};
use trees::{TreeReport, TreeSettings, TwinTree};

/// Why a scan could not be twinned.
#[derive(Debug, thiserror::Error)]
pub enum TwinError {
    /// The scan could not be read.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// No GPS times or no scan angles, and no planned lines asked for.
    #[error(
        "{file}: has {missing} (LAS point format {point_format}): its strips, their speed and the \
         mirror cannot be read from it. Give --heading-deg, --altitude-m and --scan-angle-deg to \
         fly it with lines planned over it (--line-spacing-m, --speed-mps and \
         --scan-frequency-hz optional)"
    )]
    NoTiming {
        /// The scan.
        file: String,
        /// What it lacks.
        missing: String,
        /// Its point format.
        point_format: u8,
    },
    /// Not an airborne line scan.
    #[error(
        "{file}: does not look like an airborne line scan: {why}. lidarsim twin re-flies \
         airborne scans; a terrestrial or mobile scan has no strips to read (if it is airborne, \
         give --altitude-m and --scan-angle-deg)"
    )]
    NotAirborne {
        /// The scan.
        file: String,
        /// What gave it away.
        why: String,
    },
    /// No strip shows the flying height.
    #[error("{file}: the flying height cannot be read from any strip ({why}): give --altitude-m")]
    NoHeight {
        /// The scan.
        file: String,
        /// Each strip's problem.
        why: String,
    },
    /// No strip shows the mirror.
    #[error(
        "{file}: no strip is long enough to read a mirror from ({why}): give \
         --scan-frequency-hz (and --scan-angle-deg)"
    )]
    NoMirror {
        /// The scan.
        file: String,
        /// Each strip's problem.
        why: String,
    },
    /// No strip holds enough points.
    #[error(
        "{file}: no strip holds {min} first returns or more ({strips} strips, split at pauses of \
         {gap_s} s in the GPS time): too little to read how it was flown"
    )]
    NoStrips {
        /// The scan.
        file: String,
        /// Strips found.
        strips: usize,
        /// First returns needed.
        min: usize,
        /// The pause that splits strips, s.
        gap_s: f64,
    },
    /// The scan's area is too large to grid.
    #[error(
        "{file}: covers {km2} km², too large to grid at {cell_m} m (give a larger --chm-cell-m)"
    )]
    TooLarge {
        /// The scan.
        file: String,
        /// Its area, km².
        km2: String,
        /// The cell, m.
        cell_m: f64,
    },
    /// A bad option.
    #[error("{option}: {why}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong.
        why: String,
    },
    /// Writing the survey's files failed.
    #[error(transparent)]
    Write(#[from] crate::output::WriteError),
    /// The survey written does not check (a bug: it is reported, not
    /// hidden).
    #[error("the twin's survey does not check: {0}")]
    Survey(#[from] crate::survey::SurveyError),
}

/// What a twin is made with.
#[derive(Clone, Debug, Default)]
pub struct TwinOptions {
    /// How trees are found.
    pub trees: TreeSettings,
    /// What the user gives about the acquisition.
    pub acquisition: AcquisitionSettings,
    /// An instrument preset (`[scanner] preset`).
    pub instrument: Option<String>,
}

/// The twin of a scan: its ground, trees and acquisition.
#[derive(Clone, Debug)]
pub struct Twin {
    /// The scan's name.
    pub source: String,
    /// The ground.
    pub ground: GroundModel,
    /// The trees.
    pub trees: Vec<TwinTree>,
    /// How they were found.
    pub tree_report: TreeReport,
    /// How it is flown.
    pub acquisition: Acquisition,
    /// The scan's area: a grid whose cells holding points are > 0.
    pub area: Grid,
    /// Facts of the scan, for the report.
    pub scan: ScanSummary,
    /// The scan's CRS as WKT, when its file has one.
    pub scan_wkt: Option<String>,
    /// The options it was made with.
    pub options: TwinOptions,
}

/// What the scan is, for the report.
#[derive(Clone, Debug, Serialize)]
pub struct ScanSummary {
    /// The file.
    pub file: String,
    /// LAS version.
    pub las_version: String,
    /// Point format.
    pub point_format: u8,
    /// Points.
    pub points: usize,
    /// First returns.
    pub first_returns: usize,
    /// Whether it holds first returns only (its pulses had more).
    pub first_returns_only: bool,
    /// Horizontal bounds, m.
    pub bounds_m: [f64; 4],
    /// The area its points cover, m².
    pub area_m2: f64,
    /// Its CRS, as the file names it.
    pub crs: Option<String>,
}

/// Makes the twin of `cloud`, reporting long steps to `progress`.
pub fn twin(
    cloud: &ScanCloud,
    options: &TwinOptions,
    progress: Progress<'_>,
) -> Result<Twin, TwinError> {
    check_options(options)?;
    let strips_readable = acquisition::check_timing(cloud, &options.acquisition)?;
    progress("ground", 0.0);
    let too_large = |cell_m: f64| TwinError::TooLarge {
        file: cloud.name.clone(),
        km2: {
            let b = cloud.bounds();
            num(((b[2] - b[0]) * (b[3] - b[1]) / 1e6 * 100.0).round() / 100.0)
        },
        cell_m,
    };
    let cloud = &*cloud.without_noise();
    let ground = ground_model(cloud).ok_or_else(|| too_large(0.5))?;
    let (kept, h) = &without_outliers(cloud, &ground);
    let cloud = kept.as_ref().unwrap_or(cloud);
    let first = |k: usize| cloud.is_first(k);
    let overall =
        crate::scan::density::density((&cloud.x, &cloud.y), first).ok_or_else(|| too_large(0.5))?;
    let area = crate::scan::density::occupancy(
        (&cloud.x, &cloud.y),
        first,
        cloud.bounds(),
        overall.cell_m,
    )
    .ok_or_else(|| too_large(overall.cell_m))?;
    progress("trees", 0.2);
    let (trees, tree_report) = trees::detect_trees(cloud, h, &ground, &area, &options.trees);
    progress("acquisition", 0.7);
    let b = cloud.bounds();
    let centre = [(b[0] + b[2]) / 2.0, (b[1] + b[3]) / 2.0];
    let scene = combine::Scene {
        file: &cloud.name,
        bounds: b,
        ground_z_m: ground.z_at(centre[0], centre[1]),
        density_per_m2: overall.per_m2,
        max_returns_seen: cloud.number_of_returns.iter().copied().max().unwrap_or(0),
        max_angle_deg: cloud
            .scan_angle_deg
            .iter()
            .fold(0.0f64, |m, &a| m.max(f64::from(a).abs())),
    };
    let acquisition = if strips_readable {
        let strips = acquisition::read_strips(cloud, h);
        if strips.is_empty() {
            let first: Vec<usize> = (0..cloud.len()).filter(|&k| cloud.is_first(k)).collect();
            return Err(TwinError::NoStrips {
                file: cloud.name.clone(),
                strips: acquisition::strips::split_strips(
                    &first,
                    &cloud.gps_time,
                    &cloud.point_source_id,
                )
                .len(),
                min: acquisition::MIN_STRIP_POINTS,
                gap_s: acquisition::strips::STRIP_GAP_S,
            });
        }
        combine::combine(&strips, &options.acquisition, &scene)?
    } else {
        combine::planned(&options.acquisition, &scene)
    };
    progress("acquisition", 1.0);
    Ok(Twin {
        source: cloud.name.clone(),
        ground,
        trees,
        tree_report,
        acquisition,
        scan: ScanSummary {
            file: cloud.name.clone(),
            las_version: cloud.facts.version.clone(),
            point_format: cloud.facts.point_format,
            points: cloud.len(),
            first_returns: (0..cloud.len()).filter(|&k| cloud.is_first(k)).count(),
            first_returns_only: cloud.first_returns_only(),
            bounds_m: b,
            area_m2: overall.area_m2,
            crs: cloud
                .facts
                .epsg
                .map(|c| format!("EPSG:{c}"))
                .or_else(|| cloud.facts.wkt.as_ref().map(|_| "WKT".to_string())),
        },
        area,
        scan_wkt: cloud.facts.wkt.clone(),
        options: options.clone(),
    })
}

/// Tallest tree a survey takes, m (`[[tree]] height_m`).
const MAX_TREE_HEIGHT_M: f64 = 150.0;

/// `cloud` without the points no tree or ground can be (`None` when it
/// has none): more than 5 m below the ground, or above the 99.99th
/// percentile of the heights plus 10 m or 150 m (birds, clouds, multipath
/// echoes that no noise class marks); and every point's height.
fn without_outliers(cloud: &ScanCloud, ground: &GroundModel) -> (Option<ScanCloud>, Vec<f64>) {
    let h = ground.heights(cloud);
    let [top] = trees::percentiles(h.clone(), [0.9999]);
    let ceiling = (top + 10.0).min(MAX_TREE_HEIGHT_M);
    if h.iter().all(|&v| (-5.0..=ceiling).contains(&v)) {
        return (None, h);
    }
    let kept = cloud.retain(|k| (-5.0..=ceiling).contains(&h[k]));
    let h = ground.heights(&kept);
    (Some(kept), h)
}

/// Refuses options out of range, naming the option.
fn check_options(options: &TwinOptions) -> Result<(), TwinError> {
    let a = &options.acquisition;
    let checks: [(&'static str, Option<f64>, f64, f64); 7] = [
        ("--altitude-m", a.altitude_m, 1.0, 100_000.0),
        ("--speed-mps", a.speed_mps, 0.1, 1000.0),
        ("--prf-hz", a.prf_hz, 1.0, crate::survey::MAX_PRF_HZ),
        ("--scan-frequency-hz", a.scan_frequency_hz, 0.01, 100_000.0),
        ("--scan-angle-deg", a.scan_angle_deg, 0.0, 89.0),
        ("--heading-deg", a.heading_deg, -360.0, 360.0),
        ("--line-spacing-m", a.line_spacing_m, 0.1, 1e6),
    ];
    for (option, value, lo, hi) in checks {
        if let Some(v) = value
            && !(v.is_finite() && v >= lo && v <= hi)
        {
            return Err(TwinError::Option {
                option,
                why: format!("must be from {} to {}, got {}", num(lo), num(hi), num(v)),
            });
        }
    }
    if let Some(cell) = options.trees.chm_cell_m
        && !(cell.is_finite() && (0.05..=10.0).contains(&cell))
    {
        return Err(TwinError::Option {
            option: "--chm-cell-m",
            why: format!("must be from 0.05 to 10 m, got {}", num(cell)),
        });
    }
    if let Some(id) = &options.instrument
        && crate::survey::preset::find(id).is_none()
    {
        return Err(TwinError::Option {
            option: "--instrument",
            why: format!(
                "unknown instrument '{id}'; presets: {}",
                crate::survey::preset::PRESETS
                    .iter()
                    .map(|p| p.id)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bird 300 m up (unclassified) and a noise point (class 7) leave
    /// the canopy as it is: no tree or ground is made of them.
    #[test]
    fn noise_and_outliers_are_left_out() {
        let mut c = ScanCloud::default();
        for i in 0..40_000 {
            let (x, y) = ((i % 200) as f64 * 0.5, (i / 200) as f64 * 0.5);
            let canopy = (x / 5.0).round() as i64 % 2 == 0;
            c.x.push(x);
            c.y.push(y);
            c.z.push(if canopy { 20.0 } else { 0.0 });
            c.classification.push(if canopy { 5 } else { 2 });
        }
        for (z, class) in [(300.0, 1), (-40.0, 7), (250.0, 18)] {
            c.x.push(50.0);
            c.y.push(50.0);
            c.z.push(z);
            c.classification.push(class);
        }
        let n = c.len();
        c.intensity = vec![0; n];
        c.return_number = vec![1; n];
        c.number_of_returns = vec![1; n];
        c.gps_time = vec![0.0; n];
        c.scan_angle_deg = vec![0.0; n];
        c.point_source_id = vec![0; n];
        let clean = c.without_noise();
        assert_eq!(clean.len(), c.len() - 2);
        let ground = ground_model(&clean).unwrap();
        let (kept, h) = without_outliers(&clean, &ground);
        assert_eq!(kept.unwrap().len(), c.len() - 3);
        assert!(h.iter().all(|&v| (-0.5..=20.5).contains(&v)));
    }
}
