//! A real airborne scan as columns of numbers, for `lidarsim twin` and
//! `lidarsim compare`: the points of a LAS or LAZ file (read through
//! [`crate::io::cloud::open_las`], the one LAS reader) or of a simulation
//! in memory, with what the file says about itself (point format, whether
//! it has GPS times and how finely it stores scan angles, its CRS).
//!
//! On top of the points: [`grid`], rasters over the scan's area (per cell
//! the highest or lowest point, a count, gaps filled from their
//! neighbours), and [`ground`], the ground model heights are measured
//! from: a DTM from the ground-classified returns, or a flat ground for a
//! height-normalised cloud.

pub mod density;
pub mod grid;
pub mod ground;
mod read;

pub use read::{read_scan, scan_from_records};

use std::path::PathBuf;

/// Why a scan could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ScanError {
    /// The LAS/LAZ reader failed, or the file is not one.
    #[error("{path}: {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What is wrong, in words.
        reason: String,
    },
    /// The file holds no point with finite coordinates.
    #[error("{path}: holds no point{why}")]
    Empty {
        /// The file.
        path: PathBuf,
        /// Why, when there is more to say.
        why: String,
    },
}

/// What a scan's file says about itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ScanFacts {
    /// LAS version, `"1.2"`, `"1.4"` (empty for points in memory).
    pub version: String,
    /// LAS point data format (0–10).
    pub point_format: u8,
    /// Whether the points carry a GPS time.
    pub has_gps_time: bool,
    /// The step of the stored scan angles, degrees: 1 for the scan angle
    /// rank of point formats 0–5, 0.006 for formats 6–10.
    pub scan_angle_step_deg: f64,
    /// The CRS as an EPSG code, from the GeoTIFF keys (LAS 1.0–1.3) or
    /// the WKT (LAS 1.4) when it names one.
    pub epsg: Option<u32>,
    /// The CRS as OGC WKT (LAS 1.4's WKT record), if the file has one.
    pub wkt: Option<String>,
}

/// The points of a scan, as columns (one entry per point, in file order).
#[derive(Clone, Debug, Default)]
pub struct ScanCloud {
    /// The file's path, or a name for points given in memory.
    pub name: String,
    /// Easting, m.
    pub x: Vec<f64>,
    /// Northing, m.
    pub y: Vec<f64>,
    /// Height, m.
    pub z: Vec<f64>,
    /// LAS intensity.
    pub intensity: Vec<u16>,
    /// Return number, from 1 (0 in a broken file).
    pub return_number: Vec<u8>,
    /// Number of returns of the point's pulse.
    pub number_of_returns: Vec<u8>,
    /// ASPRS classification.
    pub classification: Vec<u8>,
    /// GPS time, s (zeros when the format has none).
    pub gps_time: Vec<f64>,
    /// Scan angle, degrees (LAS convention: negative to the left of the
    /// flight direction).
    pub scan_angle_deg: Vec<f32>,
    /// Point source ID (the flight line, where the file sets it).
    pub point_source_id: Vec<u16>,
    /// What the file says about itself.
    pub facts: ScanFacts,
}

impl ScanCloud {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether it holds no point.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Whether point `i` is its pulse's first return (return number 1,
    /// or 0 in files that leave it unset).
    pub fn is_first(&self, i: usize) -> bool {
        self.return_number[i] <= 1
    }

    /// Whether point `i` is its pulse's last return.
    pub fn is_last(&self, i: usize) -> bool {
        self.return_number[i] >= self.number_of_returns[i]
    }

    /// Whether the cloud holds only first returns while its pulses had
    /// more (a file that keeps `number_of_returns` but drops the later
    /// returns, as lidR's example data does).
    pub fn first_returns_only(&self) -> bool {
        let later = self.return_number.iter().any(|&r| r > 1);
        let multi = self.number_of_returns.iter().any(|&n| n > 1);
        !later && multi
    }

    /// Horizontal bounds `[xmin, ymin, xmax, ymax]`, m.
    pub fn bounds(&self) -> [f64; 4] {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (&x, &y) in self.x.iter().zip(&self.y) {
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
        b
    }

    /// Whether its scan angles say anything (any non-zero).
    pub fn has_scan_angles(&self) -> bool {
        self.scan_angle_deg.iter().any(|&a| a != 0.0)
    }

    /// Whether its GPS times say anything (the format has them and they
    /// are not all equal).
    pub fn has_gps_times(&self) -> bool {
        self.facts.has_gps_time
            && self
                .gps_time
                .first()
                .is_some_and(|&t0| self.gps_time.iter().any(|&t| t != t0))
    }
}

/// ASPRS classes of noise (LAS 1.4 R15, Table 17: 7 low point, 18 high
/// noise): left out of twins and comparisons.
pub const NOISE_CLASSES: [u8; 2] = [7, 18];

impl ScanCloud {
    /// The points `keep` accepts, in order (the same cloud otherwise).
    pub fn retain(&self, keep: impl Fn(usize) -> bool) -> ScanCloud {
        let idx: Vec<usize> = (0..self.len()).filter(|&k| keep(k)).collect();
        fn pick<T: Copy>(v: &[T], idx: &[usize]) -> Vec<T> {
            idx.iter().map(|&k| v[k]).collect()
        }
        ScanCloud {
            name: self.name.clone(),
            x: pick(&self.x, &idx),
            y: pick(&self.y, &idx),
            z: pick(&self.z, &idx),
            intensity: pick(&self.intensity, &idx),
            return_number: pick(&self.return_number, &idx),
            number_of_returns: pick(&self.number_of_returns, &idx),
            classification: pick(&self.classification, &idx),
            gps_time: pick(&self.gps_time, &idx),
            scan_angle_deg: pick(&self.scan_angle_deg, &idx),
            point_source_id: pick(&self.point_source_id, &idx),
            facts: self.facts.clone(),
        }
    }

    /// The cloud without its noise points ([`NOISE_CLASSES`]), copied only
    /// when it has some.
    pub fn without_noise(&self) -> std::borrow::Cow<'_, ScanCloud> {
        let noise = |k: usize| NOISE_CLASSES.contains(&self.classification[k]);
        if (0..self.len()).any(noise) {
            std::borrow::Cow::Owned(self.retain(|k| !noise(k)))
        } else {
            std::borrow::Cow::Borrowed(self)
        }
    }
}

/// How a long step reports progress: the step's name and the share done
/// (0 to 1).
pub type Progress<'a> = &'a (dyn Fn(&str, f64) + Sync);

/// A [`Progress`] that reports nothing.
pub fn no_progress(_: &str, _: f64) {}
