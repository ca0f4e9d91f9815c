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

use super::{MaterialId, SurfaceClass};
use crate::geometry::{Aabb, DVec3, Ray};

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
    /// ([`Aabb::ray_interval`]). A ray starting inside does not hit.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let (t0, _) = self
            .bounds
            .ray_interval(ray, f64::NEG_INFINITY, f64::INFINITY)?;
        (t0 > t_min && t0 < t_max).then_some(t0)
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
