//! Triangles and the one ray–triangle test of the simulator: closed and
//! watertight on shared edges, for one ray ([`Triangle::intersect`]) or for
//! the sub-rays of a pulse at once ([`TriangleFan`]); mesh triangles and
//! terrain cells alike.

use crate::geometry::{DVec3, Ray};

/// A triangle: its corners as given (so that neighbours sharing an edge
/// share its corners to the bit). The normal is computed when needed,
/// which keeps a million-triangle terrain 24 MB smaller.
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    v: [DVec3; 3],
}

impl Triangle {
    /// The triangle through three points, or `None` when they are collinear
    /// or not finite.
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Option<Self> {
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            return None;
        }
        let e1 = b - a;
        let e2 = c - a;
        let n = e1.cross(e2);
        let scale = e1.length_squared().max(e2.length_squared());
        if n.length_squared() <= 1e-24 * scale * scale || scale == 0.0 {
            return None;
        }
        Some(Self { v: [a, b, c] })
    }

    /// The triangle through three corners known to be finite and not
    /// collinear (the two halves of a terrain cell, whose corners differ in
    /// plan).
    #[inline]
    pub(crate) fn from_corners(a: DVec3, b: DVec3, c: DVec3) -> Self {
        Self { v: [a, b, c] }
    }

    /// The three corners.
    pub fn vertices(&self) -> [DVec3; 3] {
        self.v
    }

    /// Unit normal (right-hand rule over the corner order).
    #[inline]
    pub fn normal(&self) -> DVec3 {
        let [a, b, c] = self.v;
        (b - a).cross(c - a).normalize()
    }

    /// Ray/triangle intersection within `(t_min, t_max)`.
    ///
    /// The test is closed and watertight on shared edges: with the corners
    /// `a, b, c` taken relative to the ray origin, the direction `d` meets
    /// the triangle exactly when the triple products `d·(a×b)`, `d·(b×c)`,
    /// `d·(c×a)` share their sign (zero included), at `t = n·a / n·d`. Two
    /// triangles sharing an edge compute that edge's product from the same
    /// two corners with opposite sign, so no ray slips between them (the
    /// Möller & Trumbore 1997 test, used before, lets about one ray in a
    /// million through). [`TriangleFan`] runs the same arithmetic for many
    /// rays from one origin, with identical results.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        TriangleFan::new(self, ray.origin).intersect(ray.dir, t_min, t_max)
    }
}

/// A triangle seen from one ray origin: the per-origin part of
/// [`Triangle::intersect`], computed once for all rays of a pulse.
#[derive(Clone, Copy, Debug)]
pub struct TriangleFan {
    nab: DVec3,
    nbc: DVec3,
    nca: DVec3,
    /// First corner relative to the origin.
    a: DVec3,
    n: DVec3,
    num: f64,
}

/// Which rays of a bundle can meet a triangle ([`TriangleFan::coverage`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// None of them.
    None,
    /// All of them pass the edge tests; only the distance remains to check.
    All,
    /// Undecided: test them one by one ([`TriangleFan::edge_test`] says on
    /// which edges).
    Some(Straddle),
}

impl Coverage {
    /// The coverage given, per edge (bit `i` for `ab`, `bc`, `ca`), whether
    /// every ray's triple product on it has one sign (`certain`) and, for
    /// those, whether that sign is positive (`positive`, a subset): two
    /// certain edges of opposite signs exclude every ray, three of one sign
    /// admit every ray ([`TriangleFan::coverage`]).
    #[inline]
    pub fn of_edges(certain: u8, positive: u8) -> Self {
        let (certain, positive) = (certain & 0b111, positive & certain & 0b111);
        let pos = positive.count_ones();
        let neg = (certain & !positive).count_ones();
        if pos > 0 && neg > 0 {
            Coverage::None
        } else if pos == 3 || neg == 3 {
            Coverage::All
        } else {
            Coverage::Some(Straddle {
                uncertain: !certain & 0b111,
                positive: pos > 0,
            })
        }
    }
}

/// Which edges of a triangle a bundle straddles ([`Coverage::Some`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Straddle {
    /// Bit `i` set: the rays' triple products on edge `i` (`ab`, `bc`, `ca`)
    /// may have either sign.
    uncertain: u8,
    /// The sign (true: positive) every ray has on the other edges; unused
    /// when all three are uncertain.
    positive: bool,
}

/// The per-ray part of the edge test for the rays of a bundle that
/// straddles a triangle ([`TriangleFan::edge_test`]). An edge certain of its
/// sign is certain of it strictly (never zero), so a ray passes exactly when
/// its products on the uncertain edges have that sign or are zero. Each
/// uncertain edge is turned (negated, which is exact) so that passing means
/// `d·e ≥ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EdgeTest {
    /// One uncertain edge.
    One(DVec3),
    /// Two uncertain edges.
    Two(DVec3, DVec3),
    /// All three uncertain: the full test of [`TriangleFan::intersect`].
    Three,
}

impl TriangleFan {
    /// Prepares `tri` for rays starting at `origin`.
    #[inline]
    pub fn new(tri: &Triangle, origin: DVec3) -> Self {
        let mut fan = Self::edges(tri, origin);
        fan.complete(tri);
        fan
    }

    /// The edge planes only: enough for [`TriangleFan::coverage`];
    /// [`TriangleFan::complete`] must follow before any intersection.
    #[inline]
    pub fn edges(tri: &Triangle, origin: DVec3) -> Self {
        let a = tri.v[0] - origin;
        let b = tri.v[1] - origin;
        let c = tri.v[2] - origin;
        Self {
            nab: a.cross(b),
            nbc: b.cross(c),
            nca: c.cross(a),
            a,
            n: DVec3::ZERO,
            num: 0.0,
        }
    }

    /// Adds the plane of `tri` (the one given to [`TriangleFan::edges`]).
    #[inline]
    pub fn complete(&mut self, tri: &Triangle) {
        self.n = tri.normal();
        self.num = self.n.dot(self.a);
    }

    /// Classifies a bundle of directions `d` that all lie within
    /// `|d − axis| ≤ spread` against the three edge planes. A ray meets the
    /// triangle only if its three triple products `d·(a×b)`, `d·(b×c)`,
    /// `d·(c×a)` share their sign; over the bundle each lies within
    /// `spread·|a×b|` of `axis·(a×b)` (Cauchy–Schwarz), so an edge whose
    /// product at the axis is farther than that from zero has one sign for
    /// every ray. Two edges certain of opposite signs exclude every ray; three
    /// certain of one sign admit every ray. `spread` must include a margin
    /// for rounding (see [`bundle_spread`]).
    #[inline]
    pub fn coverage(&self, axis: DVec3, spread: f64) -> Coverage {
        let s2 = spread * spread;
        let (mut certain, mut positive) = (0u8, 0u8);
        for (i, e) in [self.nab, self.nbc, self.nca].into_iter().enumerate() {
            let w = axis.dot(e);
            if w * w > s2 * e.length_squared() {
                certain |= 1 << i;
                if w > 0.0 {
                    positive |= 1 << i;
                }
            }
        }
        Coverage::of_edges(certain, positive)
    }

    /// The edge-plane normals `a×b`, `b×c`, `c×a` of the corners relative
    /// to the origin: a direction passes the edge tests when its products
    /// with them share their sign ([`TriangleFan::passes`]).
    #[inline]
    pub fn edge_normals(&self) -> [DVec3; 3] {
        [self.nab, self.nbc, self.nca]
    }

    /// The fan with edge-plane normals `a×b`, `b×c`, `c×a` and first corner
    /// `a`, the corners taken relative to the origin, as
    /// [`TriangleFan::edges`] computes them (for a computation of the same
    /// products elsewhere, four lanes at once); [`TriangleFan::complete`]
    /// must follow before any intersection.
    #[inline]
    pub fn from_edges(edge_normals: [DVec3; 3], a: DVec3) -> Self {
        let [nab, nbc, nca] = edge_normals;
        Self {
            nab,
            nbc,
            nca,
            a,
            n: DVec3::ZERO,
            num: 0.0,
        }
    }

    /// The edge tests left for each ray of a bundle with coverage
    /// `Some(straddle)`: only the uncertain edges, turned so that a ray
    /// passes when `d·e ≥ 0` ([`EdgeTest`]).
    #[inline]
    pub fn edge_test(&self, straddle: Straddle) -> EdgeTest {
        let turn = |e: DVec3| if straddle.positive { e } else { -e };
        let [ab, bc, ca] = [self.nab, self.nbc, self.nca].map(turn);
        match straddle.uncertain {
            0b001 => EdgeTest::One(ab),
            0b010 => EdgeTest::One(bc),
            0b100 => EdgeTest::One(ca),
            0b011 => EdgeTest::Two(ab, bc),
            0b101 => EdgeTest::Two(ab, ca),
            0b110 => EdgeTest::Two(bc, ca),
            _ => EdgeTest::Three,
        }
    }

    /// The triangle's unit normal ([`Triangle::normal`]); zero before
    /// [`TriangleFan::complete`].
    #[inline]
    pub fn normal(&self) -> DVec3 {
        self.n
    }

    /// Distance along the unit direction `d` to the triangle, if within
    /// `(t_min, t_max)`.
    #[inline]
    pub fn intersect(&self, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        if !self.passes(d) {
            return None;
        }
        self.hit(d, t_min, t_max).map(|(t, _)| t)
    }

    /// Whether the unit direction `d` passes the three edge tests (its
    /// triple products share their sign, zero included).
    #[inline]
    pub fn passes(&self, d: DVec3) -> bool {
        let (w0, w1, w2) = (d.dot(self.nab), d.dot(self.nbc), d.dot(self.nca));
        (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) | (w0 <= 0.0 && w1 <= 0.0 && w2 <= 0.0)
    }

    /// [`TriangleFan::intersect`] for a direction known to pass the edge
    /// tests ([`Coverage::All`]): the same distance, to the bit, and the
    /// unit normal turned to face the ray (negated where `n·d > 0`, the
    /// rule of [`crate::accel::Hit::normal`], from the same `n·d` that gives
    /// the distance).
    #[inline]
    pub fn hit(&self, d: DVec3, t_min: f64, t_max: f64) -> Option<(f64, DVec3)> {
        let nd = self.n.dot(d);
        let t = self.num / nd;
        (t > t_min && t < t_max).then(|| (t, if nd > 0.0 { -self.n } else { self.n }))
    }
}

/// Axis and spread of a bundle of unit directions for
/// [`TriangleFan::coverage`]: their mean, and the largest distance of any of
/// them from it, widened by a margin (1e-9, six orders of magnitude above the
/// rounding of the triple products of unit vectors) so that the
/// classification is never wrong.
pub fn bundle_spread(dirs: &[DVec3]) -> (DVec3, f64) {
    bundle_cone(dirs, dirs.iter().fold(DVec3::ZERO, |s, d| s + *d))
}

/// [`bundle_spread`] given the sum of the directions (added in order from
/// zero).
#[inline]
pub fn bundle_cone(dirs: &[DVec3], sum: DVec3) -> (DVec3, f64) {
    let axis = sum / dirs.len().max(1) as f64;
    let spread = dirs
        .iter()
        .map(|d| (*d - axis).length_squared())
        .fold(0.0f64, |m, x| if x > m { x } else { m })
        .sqrt();
    (axis, spread * (1.0 + 1e-9) + 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_hits_inside_misses_outside() {
        let t = Triangle::new(
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(0.0, 2.0, 0.0),
        )
        .unwrap();
        let down = |x, y| Ray::new(DVec3::new(x, y, 10.0), -DVec3::Z);
        assert!((t.intersect(&down(0.5, 0.5), 0.0, 1e9).unwrap() - 10.0).abs() < 1e-12);
        assert!(t.intersect(&down(1.5, 1.5), 0.0, 1e9).is_none());
        assert!(t.intersect(&down(0.5, 0.5), 0.0, 5.0).is_none());
        assert!(Triangle::new(DVec3::ZERO, DVec3::X, DVec3::X * 2.0).is_none());
    }

    /// No ray slips through a triangulated height grid: rays aimed at
    /// points along its shared edges all hit one of the two triangles.
    /// (Rays aimed exactly at a vertex, to the last bit, can still slip
    /// where six triangles meet: the edge products are then all rounding
    /// noise. Random directions never come that close.)
    #[test]
    fn triangle_grids_are_watertight() {
        let z = |i: usize, j: usize| ((i * 7 + j * 13) % 5) as f64 * 0.37;
        let n = 12;
        let v = |i: usize, j: usize| DVec3::new(i as f64 * 0.57, j as f64 * 0.61, z(i, j));
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push(Triangle::new(v(i, j), v(i + 1, j), v(i + 1, j + 1)).unwrap());
                tris.push(Triangle::new(v(i, j), v(i + 1, j + 1), v(i, j + 1)).unwrap());
            }
        }
        let origin = DVec3::new(1.3, -2.1, 480.0);
        let mut targets = Vec::new();
        for j in 1..n {
            for i in 1..n {
                for f in [0.5, 0.1234567, 0.987654321] {
                    targets.push(v(i, j).lerp(v(i + 1, j), f));
                    targets.push(v(i, j).lerp(v(i, j + 1), f));
                    targets.push(v(i, j).lerp(v(i + 1, j + 1), f));
                }
            }
        }
        for target in targets {
            let ray = Ray::new(origin, target - origin);
            let hit = tris
                .iter()
                .filter_map(|t| t.intersect(&ray, 0.0, 1e9))
                .next();
            let t = hit.unwrap_or_else(|| panic!("ray to {target} slipped through"));
            assert!((ray.at(t) - target).length() < 1e-9);
            // The fan form gives the same answer to the bit.
            for tri in &tris {
                assert_eq!(
                    tri.intersect(&ray, 0.0, 1e9),
                    TriangleFan::new(tri, origin).intersect(ray.dir, 0.0, 1e9)
                );
            }
        }
    }

    /// The bundle classification never contradicts the ray-by-ray test:
    /// `None` only when no ray meets the triangle, `All` only when every
    /// ray passes the edge tests (so that [`TriangleFan::distance`] is
    /// exact). Bundles of 19 directions within a cone, from nearly parallel
    /// to wide, against triangles of all sizes and distances; every outcome
    /// occurs.
    #[test]
    fn bundle_coverage_agrees_with_each_ray() {
        let mut rng = crate::rng::Stream::new(3, 0, 0, crate::rng::Purpose::Test);
        let mut seen = [0usize; 3];
        for case in 0..20_000 {
            let mut u = || rng.uniform() - 0.5;
            let scale = [0.1, 1.0, 30.0][(case / 2) % 3];
            let centre = DVec3::new(u() * 40.0, u() * 40.0, u() * 10.0);
            let Some(tri) = Triangle::new(
                centre + DVec3::new(u(), u(), u()) * scale,
                centre + DVec3::new(u(), u(), u()) * scale,
                centre + DVec3::new(u(), u(), u()) * scale,
            ) else {
                continue;
            };
            let origin = DVec3::new(u() * 60.0, u() * 60.0, 300.0 + u() * 100.0);
            // Aimed at a point of the triangle, or near it.
            let [p, q, r] = tri.vertices();
            let (f, g) = (u() + 0.5, u() + 0.5);
            let target = if case % 2 == 0 {
                let (f, g) = if f + g > 1.0 {
                    (1.0 - f, 1.0 - g)
                } else {
                    (f, g)
                };
                p + (q - p) * f + (r - p) * g
            } else {
                centre + DVec3::new(u(), u(), 0.0) * 2.0 * scale
            };
            let axis = (target - origin).normalize();
            let spread = [1e-6, 3e-4, 1e-2][(case / 6) % 3];
            let (a, b) = (
                axis.any_orthonormal_vector(),
                axis.cross(axis.any_orthonormal_vector()),
            );
            let dirs: Vec<DVec3> = (0..19)
                .map(|i| {
                    let r = spread * (i as f64 / 18.0).sqrt();
                    let ang = i as f64 * 2.4;
                    (axis + a * (r * ang.cos()) + b * (r * ang.sin())).normalize()
                })
                .collect();
            let (cone_axis, cone_spread) = bundle_spread(&dirs);
            let fan = TriangleFan::new(&tri, origin);
            let edges = |d: DVec3| [d.dot(fan.nab), d.dot(fan.nbc), d.dot(fan.nca)];
            let passes = |d: DVec3| {
                let w = edges(d);
                w.iter().all(|&x| x >= 0.0) || w.iter().all(|&x| x <= 0.0)
            };
            match fan.coverage(cone_axis, cone_spread) {
                Coverage::None => {
                    seen[0] += 1;
                    assert!(dirs.iter().all(|d| !passes(*d)), "case {case}");
                }
                Coverage::All => {
                    seen[1] += 1;
                    assert!(dirs.iter().all(|d| passes(*d)), "case {case}");
                    for d in &dirs {
                        let hit = fan.hit(*d, 0.0, 1e9);
                        assert_eq!(hit.map(|h| h.0), fan.intersect(*d, 0.0, 1e9));
                        // The normal faces the ray: n·d ≤ 0.
                        let n = tri.normal();
                        let facing = if n.dot(*d) > 0.0 { -n } else { n };
                        assert!(hit.is_none_or(|h| h.1 == facing), "case {case}");
                    }
                }
                Coverage::Some(straddle) => {
                    seen[2] += 1;
                    // The per-ray tests on the uncertain edges alone decide
                    // as the full test does.
                    let test = fan.edge_test(straddle);
                    for d in &dirs {
                        let short = match test {
                            EdgeTest::One(e) => d.dot(e) >= 0.0,
                            EdgeTest::Two(e, f) => d.dot(e) >= 0.0 && d.dot(f) >= 0.0,
                            EdgeTest::Three => passes(*d),
                        };
                        assert_eq!(short, passes(*d), "case {case}");
                    }
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 500), "{seen:?}");
    }
}
