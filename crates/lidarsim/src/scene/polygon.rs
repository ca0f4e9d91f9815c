//! Planar polygons of any vertex count (specification, "2/3D polyline
//! (closed polygonal chain) – planar polygons").

use crate::geometry::{Aabb, DVec3, Ray};

/// Why a list of vertices is not a usable planar polygon.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PolygonError {
    /// Fewer than three vertices.
    #[error("a polygon needs at least 3 vertices, got {0}")]
    TooFewVertices(usize),
    /// A coordinate is NaN or infinite.
    #[error("vertex {0} has a coordinate that is not a finite number")]
    NotFinite(usize),
    /// All vertices lie on a line (or coincide): no plane is defined.
    #[error("the vertices are collinear or coincide, so they define no plane")]
    Degenerate,
    /// A vertex lies off the plane fitted to all vertices.
    #[error(
        "the polygon is not planar: vertex {vertex} lies {distance_m:.4} m off the plane \
         of the others (tolerance {tolerance_m} m)"
    )]
    NotPlanar {
        /// Index of the vertex farthest from the plane.
        vertex: usize,
        /// Its distance from the plane, m.
        distance_m: f64,
        /// The tolerance that was exceeded, m.
        tolerance_m: f64,
    },
}

/// Largest distance of a vertex from the polygon's plane that is accepted
/// as planar, m (hand-typed coordinates carry millimetre rounding).
pub const PLANARITY_TOLERANCE_M: f64 = 1e-3;

/// A planar polygon `Ax + By + Cz + D = 0` with its vertices, bounding box
/// and the axis pair used for the point-in-polygon test.
#[derive(Clone, Debug)]
pub struct Polygon {
    vertices: Vec<DVec3>,
    /// Unit normal `(A, B, C)`.
    normal: DVec3,
    /// `D` of the plane equation for the unit normal.
    d: f64,
    /// Index (0 = x, 1 = y, 2 = z) of the axis dropped when projecting on
    /// the dominant axis pair.
    drop_axis: usize,
    /// The vertices projected on the kept axis pair.
    projected: Vec<[f64; 2]>,
    bounds: Aabb,
}

impl Polygon {
    /// Bytes the polygon owns besides itself (its vertex lists).
    pub fn heap_bytes(&self) -> usize {
        self.vertices.capacity() * std::mem::size_of::<DVec3>()
            + self.projected.capacity() * std::mem::size_of::<[f64; 2]>()
    }

    /// Builds the polygon from its vertices in order (either winding).
    ///
    /// The plane comes from all vertices by Newell's method (Newell, Newell &
    /// Sancha 1972; Sutherland, Sproull & Schumacker 1974), which gives the
    /// same `(A, B, C)` as the specification's determinant solution for three
    /// points but stays defined when the plane passes through the origin
    /// (where the specification's `D = 0` and its Cramer's-rule solution
    /// divides by zero) and uses every vertex.
    pub fn new(vertices: Vec<DVec3>) -> Result<Self, PolygonError> {
        if vertices.len() < 3 {
            return Err(PolygonError::TooFewVertices(vertices.len()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(PolygonError::NotFinite(i));
        }
        let centroid = vertices.iter().copied().sum::<DVec3>() / vertices.len() as f64;
        let mut n = DVec3::ZERO;
        for (i, a) in vertices.iter().enumerate() {
            let a = *a - centroid;
            let b = vertices[(i + 1) % vertices.len()] - centroid;
            n += DVec3::new(
                (a.y - b.y) * (a.z + b.z),
                (a.z - b.z) * (a.x + b.x),
                (a.x - b.x) * (a.y + b.y),
            );
        }
        let scale = vertices
            .iter()
            .map(|v| (*v - centroid).length())
            .fold(0.0, f64::max);
        // |n| is twice the projected area: compare with the size squared.
        if scale == 0.0 || n.length() <= 1e-12 * scale * scale {
            return Err(PolygonError::Degenerate);
        }
        let normal = n.normalize();
        let d = -normal.dot(centroid);
        let (worst, dist) = vertices
            .iter()
            .map(|v| (normal.dot(*v) + d).abs())
            .enumerate()
            .fold((0, 0.0), |acc, (i, x)| if x > acc.1 { (i, x) } else { acc });
        if dist > PLANARITY_TOLERANCE_M {
            return Err(PolygonError::NotPlanar {
                vertex: worst,
                distance_m: dist,
                tolerance_m: PLANARITY_TOLERANCE_M,
            });
        }
        // Drop the coordinate in which the plane varies least: the axis of
        // the largest normal component (specification: use yz- or
        // xz-projections for vertical walls, xy for level surfaces).
        let a = normal.abs();
        let drop_axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let projected = vertices.iter().map(|v| project(*v, drop_axis)).collect();
        let bounds = Aabb::from_points(&vertices);
        Ok(Self {
            vertices,
            normal,
            d,
            drop_axis,
            projected,
            bounds,
        })
    }

    /// The vertices as given.
    pub fn vertices(&self) -> &[DVec3] {
        &self.vertices
    }

    /// Unit normal `(A, B, C)` of the plane.
    pub fn normal(&self) -> DVec3 {
        self.normal
    }

    /// `D` of `Ax + By + Cz + D = 0` for the unit normal.
    pub fn plane_d(&self) -> f64 {
        self.d
    }

    /// Bounding box of the vertices.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Signed distance of `p` from the plane, m.
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }

    /// Even-odd (crossing number) point-in-polygon test of a point on the
    /// plane, in the projection on the dominant axis pair (specification,
    /// Fig. 12: "If the count is even, the point is out").
    pub fn contains_on_plane(&self, p: DVec3) -> bool {
        let [px, py] = project(p, self.drop_axis);
        let mut inside = false;
        let n = self.projected.len();
        let mut j = n - 1;
        for i in 0..n {
            let [xi, yi] = self.projected[i];
            let [xj, yj] = self.projected[j];
            // Half-open rule on y so a vertex on the half-line counts once.
            if (yi > py) != (yj > py) {
                let x_cross = xi + (py - yi) * (xj - xi) / (yj - yi);
                if px < x_cross {
                    inside = !inside;
                }
            }
            j = i;
        }
        inside
    }

    /// Distance along the ray to the polygon, if the ray hits it within
    /// `(t_min, t_max)`.
    ///
    /// Specification Eq. 3: `t = ((p1 − p) · n) / (dir · n)`; then the hit
    /// point is tested against the bounding box first and the polygon
    /// second, as the specification recommends.
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let denom = ray.dir.dot(self.normal);
        if denom.abs() < 1e-12 {
            return None; // ray parallel to the plane
        }
        let t = -(self.normal.dot(ray.origin) + self.d) / denom;
        if !(t > t_min && t < t_max) {
            return None;
        }
        let p = ray.at(t);
        let tol = 1e-9 * (1.0 + t);
        if !self.bounds.contains(p, tol) {
            return None;
        }
        self.contains_on_plane(p).then_some(t)
    }
}

#[inline]
fn project(v: DVec3, drop_axis: usize) -> [f64; 2] {
    match drop_axis {
        0 => [v.y, v.z],
        1 => [v.z, v.x],
        _ => [v.x, v.y],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn plane_matches_specification_determinants() {
        // Specification: a = -d/D |1 y z|, b = -d/D |x 1 z|, c = -d/D |x y 1|
        // for three points; compare directions with Newell's normal.
        let p = [v(1.0, 2.0, 3.0), v(4.0, 1.0, 2.5), v(2.0, 5.0, 4.0)];
        let det = |m: [[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let rows = |f: &dyn Fn(DVec3) -> [f64; 3]| [f(p[0]), f(p[1]), f(p[2])];
        let big_d = det(rows(&|q| [q.x, q.y, q.z]));
        let d = 1.0;
        let a = -d / big_d * det(rows(&|q| [1.0, q.y, q.z]));
        let b = -d / big_d * det(rows(&|q| [q.x, 1.0, q.z]));
        let c = -d / big_d * det(rows(&|q| [q.x, q.y, 1.0]));
        let spec = DVec3::new(a, b, c);
        let poly = Polygon::new(p.to_vec()).unwrap();
        assert!(spec.normalize().cross(poly.normal()).length() < 1e-12);
        for q in p {
            assert!(poly.signed_distance(q).abs() < 1e-12);
            assert!((spec.dot(q) + d).abs() < 1e-9);
        }
    }

    #[test]
    fn concave_polygon_point_in_polygon() {
        // An L-shaped hexagon in a vertical wall (x = 5): the projection on
        // the xy plane is a line, so the dominant-axis projection must be yz.
        let l = Polygon::new(vec![
            v(5.0, 0.0, 0.0),
            v(5.0, 4.0, 0.0),
            v(5.0, 4.0, 1.0),
            v(5.0, 1.0, 1.0),
            v(5.0, 1.0, 3.0),
            v(5.0, 0.0, 3.0),
        ])
        .unwrap();
        assert!(l.contains_on_plane(v(5.0, 0.5, 2.0)));
        assert!(l.contains_on_plane(v(5.0, 3.0, 0.5)));
        assert!(!l.contains_on_plane(v(5.0, 3.0, 2.0))); // the notch
        assert!(!l.contains_on_plane(v(5.0, -0.1, 1.0)));
        let down = Ray::new(v(0.0, 0.5, 2.0), DVec3::X);
        assert!((l.intersect(&down, 0.0, 100.0).unwrap() - 5.0).abs() < 1e-12);
        let miss = Ray::new(v(0.0, 3.0, 2.0), DVec3::X);
        assert!(l.intersect(&miss, 0.0, 100.0).is_none());
    }

    #[test]
    fn rejects_bad_polygons() {
        assert_eq!(
            Polygon::new(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)]).unwrap_err(),
            PolygonError::TooFewVertices(2)
        );
        assert_eq!(
            Polygon::new(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(2.0, 0.0, 0.0)]).unwrap_err(),
            PolygonError::Degenerate
        );
        let e = Polygon::new(vec![
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(1.0, 1.0, 0.5),
            v(0.0, 1.0, 0.0),
        ])
        .unwrap_err();
        assert!(matches!(e, PolygonError::NotPlanar { .. }));
        assert!(matches!(
            Polygon::new(vec![
                v(0.0, 0.0, f64::NAN),
                v(1.0, 0.0, 0.0),
                v(0.0, 1.0, 0.0)
            ]),
            Err(PolygonError::NotFinite(0))
        ));
    }

    #[test]
    fn plane_through_origin_is_fine() {
        let p = Polygon::new(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 1.0), v(0.0, 1.0, 0.0)]).unwrap();
        assert!(p.plane_d().abs() < 1e-12);
    }
}
