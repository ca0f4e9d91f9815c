//! Point clouds as scene geometry: a LAS/LAZ cloud (real vegetation, a
//! scanned building) becomes solid voxels, so that it can be scanned again
//! with another sensor, altitude or pattern.
//!
//! The cloud is binned into a grid of cubes of edge `voxel_m`, aligned to
//! multiples of `voxel_m` in world coordinates (after the entry's offset);
//! every occupied cube becomes one opaque axis-aligned box (a [`Voxel`]),
//! the approach of HELIOS++'s voxel scene parts. A box's class is the most
//! frequent ASPRS classification of its points (ties: the lower code),
//! mapped by [`SurfaceClass::from_asprs`], unless the survey entry sets a
//! class for all.

use std::path::{Path, PathBuf};

use super::{MaterialId, Primitive, Scene, Shape, SurfaceClass};
use crate::geometry::{Aabb, DVec3, Ray};

/// Why a point cloud could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum CloudError {
    /// The LAS/LAZ reader failed.
    #[error("cannot read point cloud '{path}': {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The reader's message.
        reason: String,
    },
    /// The file holds no point.
    #[error("'{path}' holds no point")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Too many voxels for memory.
    #[error(
        "'{path}' gives {voxels} voxels of {voxel_m} m, more than the limit of {limit}; use a \
         larger voxel_m"
    )]
    TooMany {
        /// The file.
        path: PathBuf,
        /// Voxels found.
        voxels: usize,
        /// Edge length, m.
        voxel_m: f64,
        /// The limit.
        limit: usize,
    },
}

/// Largest number of voxels one cloud may become.
pub const MAX_VOXELS: usize = 20_000_000;

/// An opaque axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Voxel {
    /// The box.
    pub bounds: Aabb,
}

impl Voxel {
    /// Distance to where the ray enters the box, within `(t_min, t_max)`
    /// (slab test, Kay & Kajiya 1986). A ray starting inside does not hit.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            let (o, d) = (ray.origin[k], ray.dir[k]);
            if d == 0.0 {
                if o < self.bounds.min[k] || o > self.bounds.max[k] {
                    return None;
                }
                continue;
            }
            let a = (self.bounds.min[k] - o) / d;
            let b = (self.bounds.max[k] - o) / d;
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1 && t0 > t_min && t0 < t_max).then_some(t0)
    }

    /// Outward normal of the face nearest to `p`.
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        let (lo, hi) = (p - self.bounds.min, self.bounds.max - p);
        let mut best = (f64::INFINITY, DVec3::Z);
        for k in 0..3 {
            let mut n = DVec3::ZERO;
            n[k] = -1.0;
            if lo[k].abs() < best.0 {
                best = (lo[k].abs(), n);
            }
            n[k] = 1.0;
            if hi[k].abs() < best.0 {
                best = (hi[k].abs(), n);
            }
        }
        best.1
    }
}

impl SurfaceClass {
    /// The class of an ASPRS classification code (LAS 1.4 R15 Table 17):
    /// 2 ground, 3–5 vegetation, 6 building (as roof), 9 water, 11 road,
    /// 17 bridge, anything else unclassified.
    pub fn from_asprs(code: u8) -> SurfaceClass {
        match code {
            2 => SurfaceClass::Ground,
            3..=5 => SurfaceClass::Vegetation,
            6 => SurfaceClass::Roof,
            9 => SurfaceClass::Water,
            11 => SurfaceClass::Road,
            17 => SurfaceClass::Bridge,
            _ => SurfaceClass::Unclassified,
        }
    }
}

/// Where a cloud goes and what it becomes.
#[derive(Clone, Debug)]
pub struct CloudPlacement {
    /// Voxel edge, m.
    pub voxel_m: f64,
    /// Added to every point, m.
    pub offset_m: DVec3,
    /// Material of all voxels.
    pub material: MaterialId,
    /// Class of all voxels; `None` takes it from the points.
    pub class: Option<SurfaceClass>,
}

/// A LAS reader error in words: a truncated file, a header pointing
/// outside the file, or the reader's own message.
pub fn describe_las_error(e: &las::Error) -> String {
    match e {
        las::Error::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends early: it is truncated or not a LAS file".to_string()
        }
        las::Error::Io(io) if io.kind() == std::io::ErrorKind::InvalidInput => {
            "its header points outside the file (point count or offsets too large)".to_string()
        }
        _ => e.to_string(),
    }
}

/// Opens a LAS or LAZ file for reading, after checking the header's point
/// count against the file's size (a LAS point takes its record length; LAZ
/// can pack a smooth cloud into less than a byte per point, so it is not
/// checked and its reader stops at the end of the data): a header that
/// promises more points than the file holds is refused before any large
/// allocation. Errors say what is wrong, without the path.
pub fn open_las(path: &Path) -> Result<las::Reader, String> {
    let size = super::input::check_input(path, super::input::MAX_INPUT_BYTES)
        .map_err(|e| e.to_string())?;
    let reader = las::Reader::from_path(path).map_err(|e| describe_las_error(&e))?;
    let header = reader.header();
    let t = header.transforms();
    for (axis, tr) in [("x", t.x), ("y", t.y), ("z", t.z)] {
        if !(tr.scale.is_finite() && tr.scale != 0.0 && tr.offset.is_finite()) {
            return Err(format!(
                "the header's {axis} scale factor is {} and offset {}: coordinates are stored as \
                 integers times a non-zero scale plus the offset (LAS 1.4 R15, Table 4)",
                tr.scale, tr.offset
            ));
        }
    }
    let count = header.number_of_points();
    let record = u64::from(header.point_format().len());
    let compressed = header.point_format().is_compressed
        || header.vlrs().iter().any(|v| v.user_id == "laszip encoded")
        || path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("laz"));
    match count.checked_mul(record) {
        Some(bytes) if bytes <= size || compressed => Ok(reader),
        _ => Err(format!(
            "the header counts {count} points of {record} bytes, more than the file's {size} \
             bytes hold: it is truncated or its header is wrong"
        )),
    }
}

/// Loads a LAS or LAZ file into `scene` as voxels of one new object;
/// returns (points read, voxels added).
pub fn load_point_cloud(
    path: &Path,
    placement: &CloudPlacement,
    scene: &mut Scene,
) -> Result<(u64, usize), CloudError> {
    let bad = |e: las::Error| CloudError::Read {
        path: path.to_path_buf(),
        reason: describe_las_error(&e),
    };
    let mut reader = open_las(path).map_err(|reason| CloudError::Read {
        path: path.to_path_buf(),
        reason,
    })?;
    let mut not_finite = 0u64;
    let v = placement.voxel_m;
    // (voxel index, classification) of every point, then sorted and
    // grouped: no hash map of counters.
    let mut cells: Vec<([i64; 3], u8)> = Vec::new();
    let mut read = 0u64;
    loop {
        let batch = reader.read_points(1 << 20).map_err(bad)?;
        if batch.is_empty() {
            break;
        }
        for p in batch.points() {
            let p = p.map_err(bad)?;
            read += 1;
            let q = DVec3::new(p.x, p.y, p.z) + placement.offset_m;
            if !q.is_finite() {
                not_finite += 1;
                continue;
            }
            let cell = (q / v).floor();
            // Beyond 2^52 cells the indices would no longer be exact.
            if cell.abs().max_element() > 4.5e15 {
                return Err(CloudError::Read {
                    path: path.to_path_buf(),
                    reason: format!(
                        "the point at ({}, {}, {}) m is more than 2^52 voxels of {v} m from the \
                         origin: use a larger voxel_m",
                        q.x, q.y, q.z
                    ),
                });
            }
            let key = [cell.x as i64, cell.y as i64, cell.z as i64];
            cells.push((key, u8::from(p.classification)));
        }
    }
    if cells.is_empty() && not_finite > 0 {
        return Err(CloudError::Read {
            path: path.to_path_buf(),
            reason: format!(
                "none of its {not_finite} points has finite coordinates (check the header's \
                 scale and offset)"
            ),
        });
    }
    if cells.is_empty() {
        return Err(CloudError::Empty {
            path: path.to_path_buf(),
        });
    }
    cells.sort_unstable();
    let object = scene.add_object(format!("point_cloud:{}", path.display()));
    let mut added = 0usize;
    let mut start = 0;
    while start < cells.len() {
        let key = cells[start].0;
        let mut end = start;
        // Within a voxel the entries are sorted by code: count runs.
        let (mut best, mut best_n) = (cells[start].1, 0usize);
        while end < cells.len() && cells[end].0 == key {
            let code = cells[end].1;
            let run_start = end;
            while end < cells.len() && cells[end].0 == key && cells[end].1 == code {
                end += 1;
            }
            if end - run_start > best_n {
                (best, best_n) = (code, end - run_start);
            }
        }
        start = end;
        added += 1;
        if added > MAX_VOXELS {
            return Err(CloudError::TooMany {
                path: path.to_path_buf(),
                voxels: added,
                voxel_m: v,
                limit: MAX_VOXELS,
            });
        }
        let min = DVec3::new(key[0] as f64, key[1] as f64, key[2] as f64) * v;
        scene.primitives.push(Primitive {
            shape: Shape::Voxel(Voxel {
                bounds: Aabb {
                    min,
                    max: min + DVec3::splat(v),
                },
            }),
            material: placement.material,
            class: placement
                .class
                .unwrap_or_else(|| SurfaceClass::from_asprs(best)),
            object,
        });
    }
    Ok((read, added))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voxel_slab_hits_entry_face_with_its_normal() {
        let v = Voxel {
            bounds: Aabb {
                min: DVec3::new(0.0, 0.0, 0.0),
                max: DVec3::new(1.0, 2.0, 3.0),
            },
        };
        let down = Ray::new(DVec3::new(0.5, 1.0, 10.0), -DVec3::Z);
        assert_eq!(v.intersect(&down, 0.0, 100.0), Some(7.0));
        assert_eq!(v.normal_at(down.at(7.0)), DVec3::Z);
        let side = Ray::new(DVec3::new(-4.0, 1.0, 1.0), DVec3::new(1.0, 0.0, 0.0));
        assert_eq!(v.intersect(&side, 0.0, 100.0), Some(4.0));
        assert_eq!(v.normal_at(side.at(4.0)), -DVec3::X);
        // Oblique: enters through the top at z = 3.
        let oblique = Ray::new(DVec3::new(0.5, 0.0, 4.0), DVec3::new(0.0, 1.0, -1.0));
        let t = v.intersect(&oblique, 0.0, 100.0).unwrap();
        assert!((t - 2f64.sqrt()).abs() < 1e-12);
        // Misses, out of range, starts inside.
        let miss = Ray::new(DVec3::new(1.5, 1.0, 10.0), -DVec3::Z);
        assert_eq!(v.intersect(&miss, 0.0, 100.0), None);
        assert_eq!(v.intersect(&down, 0.0, 6.0), None);
        let inside = Ray::new(DVec3::new(0.5, 1.0, 1.0), -DVec3::Z);
        assert_eq!(v.intersect(&inside, 0.0, 100.0), None);
    }

    #[test]
    fn asprs_codes_round_trip_through_classes() {
        for code in [2u8, 3, 4, 5, 6, 9, 11, 17, 1, 0, 7, 64] {
            let class = SurfaceClass::from_asprs(code);
            let back = class.asprs_code(if code == 3 {
                0.1
            } else if code == 4 {
                1.0
            } else {
                5.0
            });
            let expect = match code {
                2 | 3 | 4 | 5 | 6 | 9 | 11 | 17 => code,
                _ => 1,
            };
            assert_eq!(back, expect, "code {code}");
        }
    }
}
