//! The cells of a sub-ray pattern and the outlines of targets, in the
//! pattern's plane: a direction `(X, s·Y, 1)` of the undeflected beam is the
//! point `(X, Y)`, `s` the elliptical stretch, so that the round beam's
//! geometry serves both shapes (beam.rs).
//!
//! A sub-ray's cell is its Voronoi cell — the points nearer to it than to
//! any other sub-ray — within the disk that holds 99.99 % of the beam's
//! energy: the cells tile the beam, so that a target anywhere in it lies in
//! some cell. A refined cell is sampled by a `k × k` jittered grid mapped
//! onto it area for area (a fan of triangles from the sub-ray; the first
//! coordinate picks the triangle and the place along its outer edge by
//! area, the square root of the second the distance out from the sub-ray).
//!
//! Which cells a target covers: the target's outline is the convex hull of
//! the points it projects to, clipped to each cell whose disk meets its box
//! (Sutherland & Hodgman); where the two convex polygons are apart the
//! clipping leaves nothing, so that no test of their meeting is needed
//! first (the tests check it against the separating-axis theorem).

/// Corners of the polygon that the cells of the outer ring are clipped
/// to: a regular polygon around the disk of [`Cell::reach`] (its sides
/// touch the disk).
pub(super) const RIM_CORNERS: usize = 32;

/// A point of the pattern's plane.
pub type PlanePoint = [f64; 2];

/// One sub-ray's cell: a convex polygon around it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Cell {
    /// The sub-ray, inside the polygon.
    site: PlanePoint,
    /// Corners, counter-clockwise.
    corners: Vec<PlanePoint>,
    /// Cumulative areas of the triangles (site, corner k, corner k + 1).
    fan: Vec<f64>,
    /// Largest distance of a corner from the site.
    radius: f64,
    /// Its edges' half-planes, corner by corner: see [`Edge`].
    edges: Vec<Edge>,
}

/// One edge of a cell, from corner `k` to corner `k + 1`, as clipping
/// uses it, computed once: the outward normal `out` with the cell where
/// `x · out ≤ c`.
#[derive(Clone, Debug, PartialEq)]
struct Edge {
    out: PlanePoint,
    c: f64,
}

impl Edge {
    /// The edge from `corners[k]` to the next corner.
    fn of(corners: &[PlanePoint], k: usize) -> Self {
        let (a, b) = (corners[k], corners[next(k, corners.len())]);
        let e = sub(b, a);
        let out = [e[1], -e[0]];
        Self {
            out,
            c: dot(a, out),
        }
    }
}

fn sub(a: PlanePoint, b: PlanePoint) -> PlanePoint {
    [a[0] - b[0], a[1] - b[1]]
}

fn cross(a: PlanePoint, b: PlanePoint) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

fn dot(a: PlanePoint, b: PlanePoint) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// The index after corner `k` of a polygon of `n` corners, the last
/// closing to the first (a comparison: cheaper than `%` in the hot loops).
#[inline]
fn next(k: usize, n: usize) -> usize {
    if k + 1 == n { 0 } else { k + 1 }
}

/// The sides of the polygon `poly`, corner `k` to corner `k + 1` in order
/// of `k`, the last closing to the first.
#[inline]
fn sides(poly: &[PlanePoint]) -> impl Iterator<Item = (PlanePoint, PlanePoint)> + '_ {
    let closing = poly.last().copied().zip(poly.first().copied());
    (poly.windows(2).map(|w| (w[0], w[1]))).chain(closing)
}

fn dist(a: PlanePoint, b: PlanePoint) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The part of the convex polygon `poly` where `dot(x, n) ≤ c`
/// (Sutherland & Hodgman 1974, one plane), into `out`: its sides in
/// order, each corner's distance worked out once.
fn clip(poly: &[PlanePoint], n: PlanePoint, c: f64, out: &mut Vec<PlanePoint>) {
    out.clear();
    let Some(&first) = poly.first() else {
        return;
    };
    let (mut a, mut da) = (first, dot(first, n) - c);
    for &b in poly[1..].iter().chain([&first]) {
        let db = dot(b, n) - c;
        if da <= 0.0 {
            out.push(a);
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            let f = da / (da - db);
            out.push([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])]);
        }
        (a, da) = (b, db);
    }
}

impl Cell {
    /// The Voronoi cell of `sites[i]` within the rim polygon around the
    /// disk of radius `reach`; `near` lists the other sites by increasing
    /// distance (distance, index).
    pub(super) fn voronoi(
        sites: &[PlanePoint],
        i: usize,
        near: &[(f64, usize)],
        reach: f64,
    ) -> Self {
        let site = sites[i];
        let step = std::f64::consts::TAU / RIM_CORNERS as f64;
        let rim = reach / (step / 2.0).cos();
        let mut corners: Vec<PlanePoint> = (0..RIM_CORNERS)
            .map(|k| {
                let (s, c) = (k as f64 * step).sin_cos();
                [rim * c, rim * s]
            })
            .collect();
        let mut work = Vec::with_capacity(RIM_CORNERS + 8);
        for &(d, j) in near {
            // A site farther than twice the farthest corner cannot cut.
            let farthest = corners.iter().map(|&c| dist(c, site)).fold(0.0, f64::max);
            if d > 2.0 * farthest {
                break;
            }
            // Nearer to the site than to sites[j]: (x − mid)·(pⱼ − site) ≤ 0.
            let n = sub(sites[j], site);
            let mid = [(site[0] + sites[j][0]) / 2.0, (site[1] + sites[j][1]) / 2.0];
            clip(&corners, n, dot(mid, n), &mut work);
            std::mem::swap(&mut corners, &mut work);
        }
        let mut fan = Vec::with_capacity(corners.len());
        let mut total = 0.0;
        for (a, b) in sides(&corners) {
            total += 0.5 * cross(sub(a, site), sub(b, site)).max(0.0);
            fan.push(total);
        }
        let radius = corners.iter().map(|&c| dist(c, site)).fold(0.0, f64::max);
        let edges = (0..corners.len()).map(|k| Edge::of(&corners, k)).collect();
        Self {
            site,
            corners,
            fan,
            radius,
            edges,
        }
    }

    /// Area of the cell.
    pub(super) fn area(&self) -> f64 {
        self.fan.last().copied().unwrap_or(0.0)
    }

    /// The sub-ray, and the largest distance of a point of the cell from
    /// it.
    pub(super) fn disk(&self) -> (PlanePoint, f64) {
        (self.site, self.radius)
    }

    /// The point of the cell that `(a, b)` of the unit square maps to, area
    /// for area: `a` picks the triangle of the fan and the place along its
    /// outer edge, `√b` the distance from the site towards that place (a
    /// triangle's area out to a fraction `f` of its height grows as `f²`).
    pub(super) fn sample(&self, a: f64, b: f64) -> PlanePoint {
        let s = a * self.area();
        let k = self
            .fan
            .iter()
            .position(|&c| c > s)
            .unwrap_or(self.fan.len() - 1);
        let before = if k == 0 { 0.0 } else { self.fan[k - 1] };
        let width = self.fan[k] - before;
        let t = if width > 0.0 {
            ((s - before) / width).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let (p, q) = (self.corners[k], self.corners[next(k, self.corners.len())]);
        let edge = [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
        let f = b.sqrt();
        [
            self.site[0] + f * (edge[0] - self.site[0]),
            self.site[1] + f * (edge[1] - self.site[1]),
        ]
    }

    /// Whether `p` lies in the cell (its edges included, within `tol`).
    #[cfg(test)]
    pub(super) fn contains(&self, p: PlanePoint, tol: f64) -> bool {
        sides(&self.corners).all(|(a, b)| {
            let e = sub(b, a);
            cross(e, sub(p, a)) >= -tol * e[0].hypot(e[1])
        })
    }

    /// Whether the disk around the site that holds the cell meets the
    /// box of `outline` (a cheap test: `true` may still be apart).
    pub(super) fn may_meet(&self, outline: &Outline) -> bool {
        let Some((lo, hi)) = outline.bounds() else {
            return false;
        };
        let dx = (lo[0] - self.site[0]).max(self.site[0] - hi[0]).max(0.0);
        let dy = (lo[1] - self.site[1]).max(self.site[1] - hi[1]).max(0.0);
        dx.hypot(dy) <= self.radius
    }
}

/// An outline's fan of triangles ([`Outline::with_fan`]).
pub(super) struct Fan<'a> {
    hull: &'a [PlanePoint],
    /// The mean of the corners.
    site: PlanePoint,
    /// The area of the triangle from `site` to each side.
    tris: &'a [f64],
    /// Their sum.
    total: f64,
}

impl Fan<'_> {
    /// The point that `(a, b)` of the unit square maps to, area for area,
    /// as [`Cell::sample`] maps it onto a cell: `a` picks the triangle and
    /// the place along its outer side, `√b` the distance from the site
    /// towards it. Needs an area.
    pub(super) fn sample(&self, a: f64, b: f64) -> PlanePoint {
        let (h, tris, site) = (self.hull, self.tris, self.site);
        let mut s = a * self.total;
        let mut k = 0;
        while k + 1 < h.len() && s >= tris[k] {
            s -= tris[k];
            k += 1;
        }
        let width = tris[k];
        let t = if width > 0.0 {
            (s / width).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let (p, q) = (h[k], h[next(k, h.len())]);
        let edge = [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
        let f = b.sqrt();
        [
            site[0] + f * (edge[0] - site[0]),
            site[1] + f * (edge[1] - site[1]),
        ]
    }
}

/// The convex outline of a target in a pattern's plane: the hull of the
/// points given ([`Outline::push`]), made by
/// [`super::BeamPattern::close_outline`]. It keeps its storage between
/// targets.
#[derive(Clone, Debug, Default)]
pub struct Outline {
    /// Corners, counter-clockwise (one or two for a point or a segment).
    hull: Vec<PlanePoint>,
    /// The points given, then working storage.
    points: Vec<PlanePoint>,
}

impl Outline {
    /// Forgets the points.
    pub fn clear(&mut self) {
        self.hull.clear();
        self.points.clear();
    }

    /// Adds a point of the target.
    pub fn push(&mut self, p: PlanePoint) {
        self.points.push(p);
    }

    /// The convex hull of the points given, clipped to the square
    /// `|X|, |Y| ≤ half_side` (Andrew's monotone chain, 1979).
    pub(super) fn close(&mut self, half_side: f64) {
        self.hull_of_points();
        self.clip_to_square(half_side);
    }

    /// The convex hull of the points given, into `hull`.
    fn hull_of_points(&mut self) {
        let pts = &mut self.points;
        pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        pts.dedup();
        let hull = &mut self.hull;
        hull.clear();
        if pts.len() < 3 {
            hull.extend_from_slice(pts);
        } else {
            // The lower chain left to right, then the upper one back.
            let turns_left =
                |h: &[PlanePoint], p: PlanePoint| cross(sub(h[1], h[0]), sub(p, h[0])) > 0.0;
            for &p in pts.iter() {
                while hull.len() >= 2 && !turns_left(&hull[hull.len() - 2..], p) {
                    hull.pop();
                }
                hull.push(p);
            }
            let lower = hull.len() + 1;
            for &p in pts.iter().rev().skip(1) {
                while hull.len() >= lower && !turns_left(&hull[hull.len() - 2..], p) {
                    hull.pop();
                }
                hull.push(p);
            }
            hull.pop();
        }
    }

    /// The hull clipped to the square `|X|, |Y| ≤ half_side`.
    fn clip_to_square(&mut self, half_side: f64) {
        let (hull, pts) = (&mut self.hull, &mut self.points);
        // Clipped to the square: the beam lies inside it, and far corners
        // of a large surface would only cost precision.
        if hull.len() >= 3 {
            for (n, c) in [
                ([1.0, 0.0], half_side),
                ([-1.0, 0.0], half_side),
                ([0.0, 1.0], half_side),
                ([0.0, -1.0], half_side),
            ] {
                clip(hull, n, c, pts);
                std::mem::swap(hull, pts);
            }
        } else if let [a, b] = hull[..] {
            // A segment: its part within the square, or nothing.
            hull.clear();
            clip_segment(a, b, half_side, hull);
        } else if let [a] = hull[..]
            && (a[0].abs() > half_side || a[1].abs() > half_side)
        {
            hull.clear();
        }
    }

    /// The corners of the outline.
    pub fn corners(&self) -> &[PlanePoint] {
        &self.hull
    }

    /// Makes this outline its part within the convex `cell`: the
    /// intersection of two convex polygons, by clipping to each of the
    /// cell's edges (empty when they share no area).
    pub(super) fn clip_to_cell(&mut self, cell: &Cell) {
        if self.hull.len() < 3 {
            self.hull.clear();
            return;
        }
        for e in &cell.edges {
            // Inside: left of the edge, cross(e, x − a) ≥ 0. An edge with
            // the whole outline inside leaves it as it is.
            if self.hull.iter().all(|&p| dot(p, e.out) <= e.c) {
                continue;
            }
            clip(&self.hull, e.out, e.c, &mut self.points);
            std::mem::swap(&mut self.hull, &mut self.points);
            if self.hull.len() < 3 {
                self.hull.clear();
                return;
            }
        }
    }

    /// Whether the outline holds the whole disk of radius `r` around `c`
    /// (every edge's line at least `r` from `c`, on its inner side, with a
    /// margin for rounding): a cell inside that disk is inside the outline.
    /// Distances compared squared: the margin is far above the rounding
    /// that adds.
    pub(super) fn holds_disk(&self, c: PlanePoint, r: f64) -> bool {
        let h = &self.hull;
        let reach = r * (1.0 + 1e-9);
        h.len() >= 3
            && sides(h).all(|(a, b)| {
                let e = sub(b, a);
                let d = cross(e, sub(c, a));
                d >= 0.0 && d * d >= reach * reach * dot(e, e)
            })
    }

    /// Copies `other`'s corners, keeping this outline's storage.
    pub fn copy_from(&mut self, other: &Outline) {
        self.hull.clear();
        self.hull.extend_from_slice(&other.hull);
        self.points.clear();
    }

    /// Its area (0 for a point or a segment).
    pub fn area(&self) -> f64 {
        let h = &self.hull;
        if h.len() < 3 {
            return 0.0;
        }
        let o = h[0];
        (1..h.len() - 1)
            .map(|k| 0.5 * cross(sub(h[k], o), sub(h[k + 1], o)))
            .sum()
    }

    /// The mean of its corners: a point inside it.
    fn centre(&self) -> PlanePoint {
        let n = self.hull.len() as f64;
        let (x, y) = self
            .hull
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [x / n, y / n]
    }

    /// Whether `p` lies inside it or on its edge (an outline without area
    /// holds no point).
    pub fn contains(&self, p: PlanePoint) -> bool {
        let h = &self.hull;
        h.len() >= 3 && sides(h).all(|(a, b)| cross(sub(b, a), sub(p, a)) >= 0.0)
    }

    /// `f` given the outline's fan: the triangles from the mean of its
    /// corners (inside the convex outline) to each side, which
    /// [`Fan::sample`] maps the unit square onto. Their areas are worked
    /// out once here, on the stack for up to 32 corners.
    pub(super) fn with_fan<R>(&self, f: impl FnOnce(&Fan) -> R) -> R {
        let h = &self.hull;
        let mut stack = [0.0; 32];
        let mut heap = Vec::new();
        let tris = if h.len() <= stack.len() {
            &mut stack[..h.len()]
        } else {
            heap.resize(h.len(), 0.0);
            &mut heap[..]
        };
        let site = self.centre();
        for (k, t) in tris.iter_mut().enumerate() {
            *t = 0.5 * cross(sub(h[k], site), sub(h[next(k, h.len())], site)).max(0.0);
        }
        let total = tris.iter().sum();
        f(&Fan {
            hull: h,
            site,
            tris,
            total,
        })
    }

    /// Lower and upper corners of its box (`None`: empty).
    fn bounds(&self) -> Option<(PlanePoint, PlanePoint)> {
        let first = *self.hull.first()?;
        Some(self.hull.iter().fold((first, first), |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        }))
    }

    /// Its smallest width: over its edges, the largest distance of a
    /// corner from the edge's line (a convex polygon's narrowest strip has
    /// an edge on one side); 0 for a point or a segment.
    pub fn width(&self) -> f64 {
        let h = &self.hull;
        if h.len() < 3 {
            return 0.0;
        }
        sides(h)
            .map(|(a, b)| {
                let e = sub(b, a);
                let len = e[0].hypot(e[1]);
                if len == 0.0 {
                    return f64::INFINITY;
                }
                h.iter()
                    .map(|&p| cross(e, sub(p, a)).abs() / len)
                    .fold(0.0, f64::max)
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The part of the segment `a`–`b` within the square `|X|, |Y| ≤ h`, its
/// two ends pushed to `out` (nothing when it misses the square; Liang &
/// Barsky 1984).
fn clip_segment(a: PlanePoint, b: PlanePoint, h: f64, out: &mut Vec<PlanePoint>) {
    let d = sub(b, a);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d[0], a[0] + h),
        (d[0], h - a[0]),
        (-d[1], a[1] + h),
        (d[1], h - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 <= t1 {
        out.push([a[0] + t0 * d[0], a[1] + t0 * d[1]]);
        out.push([a[0] + t1 * d[0], a[1] + t1 * d[1]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lower and upper bounds of `p · n` over the points `p` of `poly`.
    fn range(poly: &[PlanePoint], n: PlanePoint) -> (f64, f64) {
        poly.iter()
            .map(|&p| dot(p, n))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            })
    }

    /// Whether the ranges `(alo, ahi)` and `(blo, bhi)` of two polygons
    /// along an axis are apart, with a margin of rounding: touching is
    /// meeting.
    fn apart((alo, ahi): (f64, f64), (blo, bhi): (f64, f64)) -> bool {
        let tol = 1e-12 * (alo.abs().max(ahi.abs()) + blo.abs().max(bhi.abs()));
        ahi < blo - tol || bhi < alo - tol
    }

    /// Whether an edge of the convex polygon `edges` separates the convex
    /// polygons `a` and `b` (their projections on its normal are apart).
    /// A polygon of one or two points is a point or a segment: a
    /// segment's two edges are one line, its normal the axis.
    fn separates(edges: &[PlanePoint], a: &[PlanePoint], b: &[PlanePoint]) -> bool {
        sides(edges).any(|(p, q)| {
            let n = [p[1] - q[1], q[0] - p[0]];
            if n == [0.0, 0.0] {
                return false;
            }
            apart(range(a, n), range(b, n))
        })
    }

    /// Whether `cell` meets the convex outline `o`, by the separating-axis
    /// theorem (no edge of either separates them): the exact answer the
    /// cheap test and clipping are checked against.
    fn meets(cell: &Cell, o: &Outline) -> bool {
        let (c, h) = (&cell.corners, &o.hull);
        !(h.is_empty() || separates(c, c, h) || separates(h, c, h))
    }

    fn outline(points: &[PlanePoint]) -> Outline {
        let mut o = Outline::default();
        for &p in points {
            o.push(p);
        }
        o.close(10.0);
        o
    }

    #[test]
    fn hulls_widths_and_clipping() {
        // A square with a point inside: its four corners, width 2.
        let o = outline(&[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [1.0, 1.0]]);
        assert_eq!(o.corners().len(), 4);
        assert!((o.width() - 2.0).abs() < 1e-12);
        // A thin strip at 45°: its width, not its box's.
        let s = 0.01 / 2f64.sqrt();
        let o = outline(&[[0.0, 0.0], [5.0, 5.0], [5.0 - s, 5.0 + s], [-s, s]]);
        assert!((o.width() - 0.01).abs() < 1e-9, "{}", o.width());
        // Clipped to the square: a huge triangle keeps its part inside.
        let o = outline(&[[-100.0, -100.0], [100.0, -100.0], [0.0, 100.0]]);
        let inside = |p: &PlanePoint| p[0].abs() <= 10.0 + 1e-9 && p[1].abs() <= 10.0 + 1e-9;
        assert!(o.corners().iter().all(inside), "{:?}", o.corners());
        assert!(o.width() > 19.0);
        // A segment crossing the square keeps its part inside it.
        let o = outline(&[[-20.0, 0.0], [20.0, 0.0]]);
        assert_eq!(o.corners(), &[[-10.0, 0.0], [10.0, 0.0]]);
        assert_eq!(o.width(), 0.0);
        let o = outline(&[[20.0, 20.0], [30.0, 0.0]]);
        assert!(o.corners().is_empty());
    }

    /// Voronoi cells of `n` random sites in the square `[−1, 1]²`, within
    /// the rim around radius 1.5.
    fn random_cells(rng: &mut crate::rng::Stream, n: usize) -> Vec<Cell> {
        let sites: Vec<PlanePoint> = (0..n)
            .map(|_| [rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0])
            .collect();
        (0..sites.len())
            .map(|i| {
                let mut near: Vec<(f64, usize)> = (0..sites.len())
                    .filter(|&j| j != i)
                    .map(|j| (dist(sites[i], sites[j]), j))
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0));
                Cell::voronoi(&sites, i, &near, 1.5)
            })
            .collect()
    }

    /// `k` random points within `size` of `centre` (a square of that
    /// side around it).
    fn random_points(
        rng: &mut crate::rng::Stream,
        centre: PlanePoint,
        size: f64,
        k: usize,
    ) -> Vec<PlanePoint> {
        (0..k)
            .map(|_| {
                [
                    centre[0] + size * (rng.uniform() - 0.5),
                    centre[1] + size * (rng.uniform() - 0.5),
                ]
            })
            .collect()
    }

    /// A random convex outline: the hull of 3 to 8 points spread over
    /// `size` around a centre within `spread` of the origin (each axis),
    /// `size` uniform in `min + [0, span)`; and the points.
    fn random_outline(
        rng: &mut crate::rng::Stream,
        spread: f64,
        (min, span): (f64, f64),
    ) -> (Vec<PlanePoint>, Outline) {
        let c = [
            rng.uniform() * 2.0 * spread - spread,
            rng.uniform() * 2.0 * spread - spread,
        ];
        let size = min + rng.uniform() * span;
        let k = 3 + (rng.uniform() * 6.0) as usize;
        let pts = random_points(rng, c, size, k);
        let o = outline(&pts);
        (pts, o)
    }

    /// An outline that holds a cell's disk holds the whole cell: every
    /// corner of it inside the outline, the cell meeting it, and the
    /// outline clipped to the cell the whole cell. Over random cells and
    /// random convex outlines (hulls of 3 to 8 points) of all sizes.
    #[test]
    fn an_outline_holding_the_disk_holds_the_cell() {
        let mut rng = crate::rng::Stream::new(9, 0, 0, crate::rng::Purpose::Test);
        let cells = random_cells(&mut rng, 40);
        let (mut held, mut not_held) = (0, 0);
        for _ in 0..400 {
            let (pts, o) = random_outline(&mut rng, 1.0, (0.5, 5.0));
            for cell in &cells {
                let (site, radius) = cell.disk();
                if !o.holds_disk(site, radius) {
                    not_held += 1;
                    continue;
                }
                held += 1;
                assert!(cell.corners.iter().all(|&p| o.contains(p)), "{pts:?}");
                assert!(meets(cell, &o), "{pts:?}");
                let mut part = Outline::default();
                part.copy_from(&o);
                part.clip_to_cell(cell);
                assert!((part.area() / cell.area() - 1.0).abs() < 1e-9, "{pts:?}");
            }
        }
        // Both answers are given often: the test can tell a wrong one.
        assert!(held > 200 && not_held > 1000, "{held} {not_held}");
    }

    /// Cone sampling clips an outline to every cell whose disk meets the
    /// outline's box, instead of testing first whether they meet: where
    /// the separating-axis test finds them apart, clipping leaves no area
    /// (and where the cheap test says apart, so does the exact one). Over
    /// random cells and outlines, many of them beside a cell.
    #[test]
    fn outlines_apart_from_a_cell_clip_to_nothing() {
        let mut rng = crate::rng::Stream::new(10, 0, 0, crate::rng::Purpose::Test);
        let cells = random_cells(&mut rng, 20);
        let (mut near_but_apart, mut met) = (0, 0);
        for _ in 0..1000 {
            let (_, o) = random_outline(&mut rng, 1.5, (0.02, 1.5));
            for cell in &cells {
                let exact = meets(cell, &o);
                if !cell.may_meet(&o) {
                    assert!(!exact, "{o:?}");
                    continue;
                }
                let mut part = Outline::default();
                part.copy_from(&o);
                part.clip_to_cell(cell);
                if exact {
                    met += 1;
                } else {
                    near_but_apart += 1;
                    assert_eq!(part.area(), 0.0, "{o:?}");
                }
            }
        }
        assert!(
            near_but_apart > 1000 && met > 1000,
            "{near_but_apart} {met}"
        );
    }

    /// A cell meets an outline exactly when some point lies in both:
    /// against a fine grid of points, over random cells and outlines.
    #[test]
    fn cells_meet_outlines_that_share_a_point() {
        let mut rng = crate::rng::Stream::new(8, 0, 0, crate::rng::Purpose::Test);
        let cells = random_cells(&mut rng, 12);
        let (mut met, mut apart) = (0, 0);
        for _ in 0..300 {
            let c = [rng.uniform() * 3.0 - 1.5, rng.uniform() * 3.0 - 1.5];
            let size = rng.uniform() * 0.3;
            let pts = random_points(&mut rng, c, size, 3);
            let o = outline(&pts);
            for cell in &cells {
                // Points of the triangle, on a fine barycentric grid.
                let n = 40;
                let shared = (0..=n).any(|u| {
                    (0..=n - u).any(|v| {
                        let (a, b) = (u as f64 / n as f64, v as f64 / n as f64);
                        let p = [
                            pts[0][0] + a * (pts[1][0] - pts[0][0]) + b * (pts[2][0] - pts[0][0]),
                            pts[0][1] + a * (pts[1][1] - pts[0][1]) + b * (pts[2][1] - pts[0][1]),
                        ];
                        cell.contains(p, 0.0)
                    })
                });
                if shared {
                    assert!(meets(cell, &o), "{pts:?}");
                    met += 1;
                } else if !meets(cell, &o) {
                    apart += 1;
                }
            }
        }
        assert!(met > 100 && apart > 1000, "{met} {apart}");
    }
}
