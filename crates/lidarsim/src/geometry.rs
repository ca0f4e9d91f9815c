//! Rays, boxes and the rotations between the scanner and the world.
//!
//! World frame (docs/survey.md, "Conventions"): right-handed,
//! X east, Y north, Z up, metres, `f64`. Scanner frame (specification,
//! Fig. 8): `y` forward, `z` down, `x` to the left.

pub use glam::{DMat3, DVec3};

/// Speed of light in vacuum, m/s.
pub const SPEED_OF_LIGHT_MPS: f64 = 299_792_458.0;

/// Largest coordinate magnitude accepted anywhere in a scene or flight, m
/// (beyond any projected coordinate system; the BVH keeps f32 boxes
/// relative to the scene).
pub const MAX_COORDINATE_M: f64 = 1e8;

/// A half-line `origin + t · dir`, `t ≥ 0`, with a unit direction
/// (the specification's pulse path `p + t × dir`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start of the ray (sensor position), world metres.
    pub origin: DVec3,
    /// Unit direction.
    pub dir: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir` (normalised here).
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Self {
            origin,
            dir: dir.normalize(),
        }
    }

    /// The point at distance `t` along the ray (specification Eq. 1 with
    /// `t = c·t_pulse/2`).
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

/// An axis-aligned bounding box (specification, "bounding box").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// The smallest box holding all `points`.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a DVec3>) -> Self {
        points
            .into_iter()
            .fold(Self::EMPTY, |b, p| b.union_point(*p))
    }

    /// This box grown to hold `p`.
    pub fn union_point(self, p: DVec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding both boxes.
    pub fn union(self, other: Aabb) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Edge lengths.
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// Surface area (used by the surface-area heuristic of the BVH).
    pub fn surface_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// True when `p` lies inside the box grown by `tol` on every side.
    pub fn contains(&self, p: DVec3, tol: f64) -> bool {
        p.cmpge(self.min - DVec3::splat(tol)).all() && p.cmple(self.max + DVec3::splat(tol)).all()
    }

    /// The interval `[t0, t1]` of `ray.origin + t·ray.dir` inside the box
    /// (not empty),
    /// within `[t_min, t_max]`, if not empty: the slab test (Kay & Kajiya
    /// 1986), the one ray–box test in f64. On each axis the line crosses
    /// the box's planes at `(min − o)/d` and `(max − o)/d`; a line
    /// parallel to a pair of planes lies between them or never meets the
    /// box.
    #[inline]
    pub fn ray_interval(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for k in 0..3 {
            let (o, d) = (ray.origin[k], ray.dir[k]);
            if d == 0.0 {
                if o < self.min[k] || o > self.max[k] {
                    return None;
                }
                continue;
            }
            let a = (self.min[k] - o) / d;
            let b = (self.max[k] - o) / d;
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 <= t1).then_some((t0, t1))
    }

    /// The distances within `[t_min, t_max]` at which a ray of a cone may
    /// be inside the box, if any: the rays leave `origin` and each one's
    /// point at distance `t` lies within `t·spread` of `origin + t·axis`
    /// (`axis` the mean of unit directions and `spread` the largest
    /// distance of one from it, as for [`VerticalCylinder::may_meet_cone`]),
    /// so a ray inside the box at `t ≤ t_max` puts `origin + t·axis` inside
    /// the box grown by `t_max·spread`. Every point of the box that a ray
    /// of the cone reaches at a distance up to `t_max` lies at a distance
    /// within the interval; `None` means no ray reaches the box.
    pub fn cone_interval(
        &self,
        origin: DVec3,
        axis: DVec3,
        spread: f64,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, f64)> {
        let margin = DVec3::splat((spread * (1.0 + 1e-9) + 1e-9) * t_max);
        let grown = Aabb {
            min: self.min - margin,
            max: self.max + margin,
        };
        grown.ray_interval(&Ray { origin, dir: axis }, t_min, t_max)
    }
}

/// An upright cylinder: the bounds of a tree's stem or crown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VerticalCylinder {
    /// Horizontal position of the axis, m.
    pub axis: (f64, f64),
    /// Radius, m.
    pub radius: f64,
    /// Bottom and top, world z.
    pub z: (f64, f64),
}

impl VerticalCylinder {
    /// The cylinder grown by `margin_m` in radius and at both ends.
    pub fn grown(&self, margin_m: f64) -> Self {
        Self {
            axis: self.axis,
            radius: self.radius + margin_m,
            z: (self.z.0 - margin_m, self.z.1 + margin_m),
        }
    }

    /// The interval of `ray` inside the cylinder, within `(t_min, t_max)`
    /// (`ray.dir` need not be a unit vector).
    pub fn span(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
        let r = self.radius;
        let (z_base, z_top) = self.z;
        let (ox, oy) = (ray.origin.x - self.axis.0, ray.origin.y - self.axis.1);
        let (dx, dy) = (ray.dir.x, ray.dir.y);
        let (mut t0, mut t1) = (t_min, t_max);
        // Side of the cylinder.
        let a = dx * dx + dy * dy;
        if a < 1e-18 {
            if ox * ox + oy * oy > r * r {
                return None;
            }
        } else {
            let b = ox * dx + oy * dy;
            let c = ox * ox + oy * oy - r * r;
            let disc = b * b - a * c;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            t0 = t0.max((-b - sq) / a);
            t1 = t1.min((-b + sq) / a);
        }
        // Caps.
        if ray.dir.z.abs() < 1e-18 {
            if ray.origin.z < z_base || ray.origin.z > z_top {
                return None;
            }
        } else {
            let ta = (z_base - ray.origin.z) / ray.dir.z;
            let tb = (z_top - ray.origin.z) / ray.dir.z;
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Whether some ray of a cone may meet the cylinder within
    /// `(t_min, t_max]`: the rays leave `origin` and each one's point at
    /// distance `t` lies within `t·spread` of `origin + t·axis` (`axis` the
    /// mean of unit directions and `spread` the largest distance of one
    /// from it), so a ray meeting the cylinder at `t` puts that line within
    /// `t·spread` of it. `false` means no ray meets it.
    pub fn may_meet_cone(
        &self,
        origin: DVec3,
        axis: DVec3,
        spread: f64,
        t_min: f64,
        t_max: f64,
    ) -> bool {
        // Up to the distance where the cone is a metre wide, a cylinder
        // grown by a metre bounds where the line can come near enough;
        // within that stretch, by the cone's width at its far end.
        const SLACK_M: f64 = 1.0;
        let line = Ray { origin, dir: axis };
        let t_cap = if spread > 0.0 {
            t_max.min(SLACK_M / spread)
        } else {
            t_max
        };
        if t_cap < t_max
            && self
                .grown(spread * t_max)
                .span(&line, t_cap, t_max)
                .is_some()
        {
            return true;
        }
        let Some((_, t_far)) = self.grown(SLACK_M).span(&line, t_min, t_cap) else {
            return false;
        };
        let margin = spread * t_far * (1.0 + 1e-9) + 1e-9 * t_far;
        self.grown(margin.min(SLACK_M))
            .span(&line, t_min, t_far)
            .is_some()
    }
}

/// Right-handed rotation by `a` radians about the world/body x axis.
pub fn rot_x(a: f64) -> DMat3 {
    DMat3::from_rotation_x(a)
}

/// Right-handed rotation by `a` radians about the y axis.
pub fn rot_y(a: f64) -> DMat3 {
    DMat3::from_rotation_y(a)
}

/// Right-handed rotation by `a` radians about the z axis.
pub fn rot_z(a: f64) -> DMat3 {
    DMat3::from_rotation_z(a)
}

/// Maps scanner axes (x left, y forward, z down; specification Fig. 8) to
/// world axes for an aircraft flying north, level: x → west, y → north,
/// z → down. It is a half turn about the forward axis.
pub const SCANNER_TO_LEVEL_NORTH: DMat3 = DMat3::from_cols(
    DVec3::new(-1.0, 0.0, 0.0),
    DVec3::new(0.0, 1.0, 0.0),
    DVec3::new(0.0, 0.0, -1.0),
);

/// Attitude of the aircraft, radians.
///
/// All three are right-handed rotations: `yaw` about the world vertical
/// (0 = flying north, positive turns the nose towards the west), `pitch`
/// about the across-track axis pointing to the right wing (positive = nose
/// up), `roll` about the along-track axis pointing forward (positive = right
/// wing down). They are the specification's omega/phi/kappa ("roll, pitch,
/// heading", Fig. 17), named after the motion they describe: with the
/// aircraft flying along the world y axis as in the specification, roll
/// turns about y and pitch about x.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Attitude {
    /// Rotation about the forward axis, rad.
    pub roll_rad: f64,
    /// Rotation about the right-wing axis, rad.
    pub pitch_rad: f64,
    /// Heading: rotation about the vertical, rad, 0 = north, counter-clockwise.
    pub yaw_rad: f64,
}

impl Attitude {
    /// Rotation from the aircraft's level-north frame to the world:
    /// `Rz(yaw) · Rx(pitch) · Ry(roll)` (yaw, then pitch, then roll, as
    /// intrinsic rotations: the aviation order).
    pub fn body_to_world(&self) -> DMat3 {
        rot_z(self.yaw_rad) * rot_x(self.pitch_rad) * rot_y(self.roll_rad)
    }

    /// Rotation from the scanner frame (specification Fig. 8) to the world.
    /// A unit vector in the scanner frame times this matrix is the world
    /// direction `dir` of the specification ("Rotate it to World
    /// xyz-system: R × [x, 0, z]_LiDAR").
    pub fn scanner_to_world(&self) -> DMat3 {
        self.body_to_world() * SCANNER_TO_LEVEL_NORTH
    }
}

/// Unit vector of the horizontal direction to the right of a heading
/// `yaw_rad` (the positive across-track direction used for LAS scan angles).
pub fn right_of(yaw_rad: f64) -> DVec3 {
    DVec3::new(yaw_rad.cos(), yaw_rad.sin(), 0.0)
}

/// Unit vector of the horizontal direction of flight for a heading.
pub fn forward_of(yaw_rad: f64) -> DVec3 {
    DVec3::new(-yaw_rad.sin(), yaw_rad.cos(), 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    /// Every ray of a cone that is inside a box at some distance finds
    /// that distance within the box's cone interval; boxes beside the cone
    /// have none.
    #[test]
    fn cone_intervals_hold_every_ray_inside_the_box() {
        let mut rng = crate::rng::Stream::new(5, 0, 0, crate::rng::Purpose::Test);
        let (mut inside, mut apart) = (0, 0);
        for case in 0..2000 {
            let mut u = || rng.uniform() - 0.5;
            let origin = DVec3::new(u() * 100.0, u() * 100.0, 400.0 + u() * 100.0);
            let centre = DVec3::new(u() * 20.0, u() * 20.0, u() * 20.0);
            let size = DVec3::new(u() + 0.5, u() + 0.5, u() + 0.5) * [0.05, 1.0, 8.0][case % 3];
            let b = Aabb {
                min: centre - size,
                max: centre + size,
            };
            let aim = (centre + DVec3::new(u(), u(), u()) * 6.0 - origin).normalize();
            let (e1, e2) = (
                aim.any_orthonormal_vector(),
                aim.cross(aim.any_orthonormal_vector()),
            );
            let width = [1e-4, 3e-3, 2e-2][(case / 3) % 3];
            let dirs: Vec<DVec3> = (0..19)
                .map(|i| {
                    let r = width * (i as f64 / 18.0).sqrt();
                    let a = i as f64 * 2.4;
                    (aim + e1 * (r * a.cos()) + e2 * (r * a.sin())).normalize()
                })
                .collect();
            let (axis, spread) = crate::scene::bundle_spread(&dirs);
            let interval = b.cone_interval(origin, axis, spread, 0.0, 1e4);
            let mut met = false;
            for d in &dirs {
                if let Some((t0, t1)) = b.ray_interval(&Ray { origin, dir: *d }, 0.0, 1e4) {
                    met = true;
                    let (lo, hi) = interval.unwrap_or_else(|| panic!("case {case}"));
                    assert!(
                        lo <= t0 && t1 <= hi,
                        "case {case}: [{t0}, {t1}] in [{lo}, {hi}]"
                    );
                }
            }
            if met {
                inside += 1;
            } else if interval.is_none() {
                apart += 1;
            }
        }
        assert!(inside > 200 && apart > 200, "{inside} {apart}");
    }

    #[test]
    fn level_north_scanner_axes() {
        let r = Attitude::default().scanner_to_world();
        // Beam straight down the scanner z axis points to the ground.
        assert!(close(r * DVec3::Z, -DVec3::Z));
        // Scanner x is to the left of a north-flying aircraft: west.
        assert!(close(r * DVec3::X, -DVec3::X));
        assert!(close(r * DVec3::Y, DVec3::Y));
    }

    #[test]
    fn yaw_turns_heading_counter_clockwise() {
        let east = Attitude {
            yaw_rad: -std::f64::consts::FRAC_PI_2,
            ..Default::default()
        };
        let r = east.scanner_to_world();
        assert!(close(r * DVec3::Y, DVec3::X));
        assert!(close(forward_of(east.yaw_rad), DVec3::X));
        // Flying east, the left side is north.
        assert!(close(r * DVec3::X, DVec3::Y));
        assert!(close(right_of(east.yaw_rad), -DVec3::Y));
    }

    #[test]
    fn roll_right_wing_down_moves_nadir_beam_left() {
        // Right wing down tilts the scanner's down axis towards the left
        // (west when flying north): the nadir footprint moves left.
        let a = Attitude {
            roll_rad: 0.1,
            ..Default::default()
        };
        let d = a.scanner_to_world() * DVec3::Z;
        assert!((d.x - (-(0.1f64).sin())).abs() < 1e-12);
        assert!(d.y.abs() < 1e-12);
    }

    #[test]
    fn pitch_nose_up_moves_nadir_beam_forward() {
        // Nose up turns the belly, and the down axis with it, forwards.
        let a = Attitude {
            pitch_rad: 0.1,
            ..Default::default()
        };
        let d = a.scanner_to_world() * DVec3::Z;
        assert!((d.y - (0.1f64).sin()).abs() < 1e-12);
        assert!(d.x.abs() < 1e-12);
    }

    #[test]
    fn matches_independent_matrices() {
        // Compare with matrices written out element by element.
        let (r, p, y) = (0.03f64, -0.02f64, 0.7f64);
        let rx =
            DMat3::from_cols_array(&[1.0, 0.0, 0.0, 0.0, p.cos(), p.sin(), 0.0, -p.sin(), p.cos()]);
        let ry =
            DMat3::from_cols_array(&[r.cos(), 0.0, -r.sin(), 0.0, 1.0, 0.0, r.sin(), 0.0, r.cos()]);
        let rz =
            DMat3::from_cols_array(&[y.cos(), y.sin(), 0.0, -y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0]);
        let want = rz * rx * ry;
        let got = Attitude {
            roll_rad: r,
            pitch_rad: p,
            yaw_rad: y,
        }
        .body_to_world();
        for (a, b) in want.to_cols_array().iter().zip(got.to_cols_array()) {
            assert!((a - b).abs() < 1e-12);
        }
    }
}
