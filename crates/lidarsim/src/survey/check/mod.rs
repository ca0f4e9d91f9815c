//! The second stage: the raw survey's values checked, table by table, into
//! settings the rest of the program trusts. Every problem is collected
//! with its key path; nothing here reads a file or builds geometry (that
//! is [`crate::world`]'s).

pub(crate) mod channel;
pub(crate) mod deflector;
pub(crate) mod lines;
pub(crate) mod navigation;
pub(crate) mod output;
pub(crate) mod platform;
pub(crate) mod scanner;
pub(crate) mod scene;
pub(crate) mod vegetation;

use std::collections::HashMap;

use super::{KeyPath, MAX_COORDINATE_M, MAX_POLYGON_VERTICES, num, raw};
use crate::geometry::DVec3;
use crate::scene::{Material, SurfaceClass};

/// The range a number of a survey must lie in, and its unit for messages.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bounds<'u> {
    lo: f64,
    lo_open: bool,
    hi: f64,
    unit: &'u str,
}

impl<'u> Bounds<'u> {
    /// `lo ≤ v ≤ hi`.
    pub fn between(lo: f64, hi: f64, unit: &'u str) -> Self {
        Self {
            lo,
            lo_open: false,
            hi,
            unit,
        }
    }

    /// `lo ≤ v`.
    pub fn at_least(lo: f64, unit: &'u str) -> Self {
        Self::between(lo, f64::INFINITY, unit)
    }

    /// `lo < v`.
    pub fn above(lo: f64, unit: &'u str) -> Self {
        Self {
            lo_open: true,
            ..Self::at_least(lo, unit)
        }
    }

    /// These bounds, with `v ≤ hi` besides.
    pub fn at_most(self, hi: f64) -> Self {
        Self { hi, ..self }
    }

    /// Whether `v` is finite and within the bounds.
    fn holds(&self, v: f64) -> bool {
        let below = if self.lo_open {
            v <= self.lo
        } else {
            v < self.lo
        };
        v.is_finite() && !below && v <= self.hi
    }

    /// What the bounds ask, as a message says it.
    fn describe(&self) -> String {
        let (lo, hi, unit) = (num(self.lo), num(self.hi), self.unit);
        match (self.lo_open, self.hi.is_finite()) {
            (true, false) => format!("must be greater than {lo}{unit}"),
            (false, false) => format!("must be at least {lo}{unit}"),
            (true, true) => format!("must be greater than {lo} and at most {hi}{unit}"),
            (false, true) => format!("must be between {lo} and {hi}{unit}"),
        }
    }
}

/// Collects problems with their key paths during validation.
pub(crate) struct Checker {
    pub problems: Vec<(KeyPath, String)>,
}

impl Checker {
    /// A checker with no problem yet.
    pub fn new() -> Self {
        Self {
            problems: Vec::new(),
        }
    }

    pub fn err(&mut self, path: KeyPath, msg: impl Into<String>) {
        self.problems.push((path, msg.into()));
    }

    /// Reports the unknown `id` at `path` among `ids` (a `what`: an
    /// instrument, a platform), naming the nearest id when one is close.
    pub fn unknown_id(&mut self, path: KeyPath, what: &str, id: &str, ids: &[&str]) {
        let near = ids
            .iter()
            .min_by_key(|p| crate::message::edit_distance(p, id))
            .filter(|p| crate::message::edit_distance(p, id) <= 3)
            .map(|p| format!(" (did you mean \"{p}\"?)"))
            .unwrap_or_default();
        self.err(
            path,
            format!("unknown {what} '{id}'{near}; presets: {}", ids.join(", ")),
        );
    }

    /// A finite number within `bounds` (`default` when the key is absent
    /// or at fault).
    pub fn number(
        &mut self,
        path: KeyPath,
        value: Option<f64>,
        default: f64,
        bounds: Bounds<'_>,
    ) -> f64 {
        let v = value.unwrap_or(default);
        if !bounds.holds(v) {
            self.err(path, format!("{}, got {}", bounds.describe(), num(v)));
            return default;
        }
        v
    }

    pub fn positive(&mut self, path: KeyPath, value: Option<f64>, default: f64, unit: &str) -> f64 {
        self.number(path, value, default, Bounds::above(0.0, unit))
    }

    pub fn count(
        &mut self,
        path: KeyPath,
        value: Option<i64>,
        default: i64,
        lo: i64,
        hi: i64,
    ) -> i64 {
        let v = value.unwrap_or(default);
        if v < lo || v > hi {
            self.err(
                path,
                format!("must be a whole number from {lo} to {hi}, got {v}"),
            );
            return default;
        }
        v
    }

    pub fn point(&mut self, path: KeyPath, value: &Option<Vec<f64>>) -> Option<DVec3> {
        match value {
            None => {
                self.err(path, "is required: a point [x, y, z] in metres");
                None
            }
            Some(v) if v.len() != 3 => {
                self.err(
                    path,
                    format!("must be [x, y, z] (3 numbers), got {} numbers", v.len()),
                );
                None
            }
            Some(v) if v.iter().any(|x| !x.is_finite()) => {
                self.err(path, "must hold finite numbers");
                None
            }
            Some(v) if v.iter().any(|x| x.abs() > MAX_COORDINATE_M) => {
                self.err(
                    path,
                    format!("coordinates must lie within ±{MAX_COORDINATE_M:e} m, got {v:?}"),
                );
                None
            }
            Some(v) => Some(DVec3::new(v[0], v[1], v[2])),
        }
    }

    pub fn class(&mut self, path: KeyPath, value: &Option<String>) -> SurfaceClass {
        match value {
            None => SurfaceClass::Unclassified,
            Some(s) => SurfaceClass::from_name(s).unwrap_or_else(|| {
                let names: Vec<&str> = SurfaceClass::ALL.iter().map(|(n, _)| *n).collect();
                self.err(
                    path,
                    format!("unknown class '{s}'; expected one of: {}", names.join(", ")),
                );
                SurfaceClass::Unclassified
            }),
        }
    }
}

/// Reads the axis values of `sigma_*` / `random_walk_*`: one number for all
/// three axes or a list of three, each from 0 to `max` (in the key's unit).
pub(crate) fn axes(
    c: &mut Checker,
    path: KeyPath,
    v: &Option<raw::NumberOrList>,
    default: [f64; 3],
    (scale, max, unit): (f64, f64, &str),
) -> [f64; 3] {
    let vals = match v {
        None => return default,
        Some(raw::NumberOrList::Number(x)) => [*x; 3],
        Some(raw::NumberOrList::List(l)) if l.len() == 3 => [l[0], l[1], l[2]],
        Some(raw::NumberOrList::List(l)) => {
            c.err(
                path,
                format!("must be one number or 3 numbers, got {}", l.len()),
            );
            return default;
        }
    };
    if vals.iter().any(|x| !(*x >= 0.0 && *x <= max)) {
        let worst = vals.iter().copied().fold(0.0, |a: f64, x| {
            if x.is_nan() || x.abs() > a.abs() {
                x
            } else {
                a
            }
        });
        c.err(
            path,
            format!(
                "must be between 0 and {}{unit}, got {}",
                num(max),
                num(worst)
            ),
        );
        return default;
    }
    vals.map(|x| x * scale)
}

/// Reads a `[x, y, z]` or `[roll, pitch, yaw]` list, each at most `max` in
/// magnitude (in the key's unit).
pub(crate) fn triple(
    c: &mut Checker,
    path: KeyPath,
    v: &Option<Vec<f64>>,
    (scale, max, unit): (f64, f64, &str),
) -> [f64; 3] {
    match v {
        None => [0.0; 3],
        Some(l) if l.len() == 3 && l.iter().all(|x| x.abs() <= max) => {
            [l[0] * scale, l[1] * scale, l[2] * scale]
        }
        Some(_) => {
            c.err(
                path,
                format!(
                    "must be a list of 3 numbers from -{0} to {0}{unit}",
                    num(max)
                ),
            );
            [0.0; 3]
        }
    }
}

/// What makes `points` unusable as the outline of an area, if anything:
/// no enclosed area (fewer than three distinct points, or all on a line),
/// or edges that cross or touch each other other than at their shared
/// corners (a bow tie encloses two areas of opposite sense, which cancel).
fn outline_problem(points: &[[f64; 2]]) -> Option<String> {
    let n = points.len();
    let twice_area: f64 = (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    // Orientation of c relative to the line a→b.
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        let v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    };
    let on_segment = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        // Edges sharing a corner with edge i are its neighbours.
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            let (c, d) = (points[j], points[(j + 1) % n]);
            let (o1, o2, o3, o4) = (
                orient(a, b, c),
                orient(a, b, d),
                orient(c, d, a),
                orient(c, d, b),
            );
            let crosses = (o1 != o2 && o3 != o4)
                || (o1 == 0 && on_segment(a, b, c))
                || (o2 == 0 && on_segment(a, b, d))
                || (o3 == 0 && on_segment(c, d, a))
                || (o4 == 0 && on_segment(c, d, b));
            if crosses {
                return Some(format!(
                    "crosses itself: the edge from point {} to point {} meets the edge from \
                     point {} to point {} (points counted from 1); give the corners of the area \
                     in order around it",
                    i + 1,
                    (i + 1) % n + 1,
                    j + 1,
                    (j + 1) % n + 1
                ));
            }
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if twice_area.is_nan() || twice_area.abs() <= 1e-9 * extent * extent {
        return Some(
            "encloses no area: its points lie on one line (or repeat); give the corners of \
             the area in order"
                .into(),
        );
    }
    None
}

/// An outline in plan, from exactly one of `rectangle_m = [x_min, y_min,
/// x_max, y_max]` or `area_m = [[x, y], ...]` of the table at `path`
/// (`[plan]`, `[[forest]]`).
pub(crate) fn outline(
    c: &mut Checker,
    path: &KeyPath,
    rectangle: &Option<Vec<f64>>,
    area: &Option<Vec<Vec<f64>>>,
) -> Option<Vec<[f64; 2]>> {
    match (rectangle, area) {
        (Some(r), None) => {
            if r.len() != 4 || r.iter().any(|v| !v.is_finite()) || r[2] <= r[0] || r[3] <= r[1] {
                c.err(
                    path.key("rectangle_m"),
                    "must be [x_min, y_min, x_max, y_max] with x_max > x_min and y_max > y_min",
                );
                None
            } else {
                Some(vec![[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]])
            }
        }
        (None, Some(a)) => {
            if a.len() < 3
                || a.len() > MAX_POLYGON_VERTICES
                || a.iter().any(|p| {
                    p.len() != 2 || p.iter().any(|v| v.is_nan() || v.abs() > MAX_COORDINATE_M)
                })
            {
                c.err(
                    path.key("area_m"),
                    format!(
                        "must be a list of 3 to {MAX_POLYGON_VERTICES} [x, y] points (the \
                         outline) within ±{} m",
                        num(MAX_COORDINATE_M)
                    ),
                );
                return None;
            }
            let points: Vec<[f64; 2]> = a.iter().map(|p| [p[0], p[1]]).collect();
            match outline_problem(&points) {
                Some(why) => {
                    c.err(path.key("area_m"), why);
                    None
                }
                None => Some(points),
            }
        }
        (Some(_), Some(_)) => {
            c.err(
                path.key("area_m"),
                "give either rectangle_m or area_m, not both",
            );
            None
        }
        (None, None) => {
            c.err(
                path.clone(),
                "needs rectangle_m = [x_min, y_min, x_max, y_max] or area_m = [[x, y], ...]",
            );
            None
        }
    }
}

/// The survey's materials by name, and how to say which exist.
pub(crate) struct Materials(pub HashMap<String, Material>);

impl Materials {
    /// "defined: a, b" (or that none is), for messages.
    fn known(&self) -> String {
        let mut names: Vec<&str> = self.0.keys().map(String::as_str).collect();
        names.sort_unstable();
        if names.is_empty() {
            "no [materials.NAME] table is defined".to_string()
        } else {
            format!("defined: {}", names.join(", "))
        }
    }

    /// The material named at `path`: `None` (with a problem) when it is
    /// unknown, or missing and `required`.
    pub fn named(
        &self,
        c: &mut Checker,
        path: KeyPath,
        name: &Option<String>,
        required: bool,
    ) -> Option<Material> {
        match name {
            None => {
                if required {
                    c.err(path, "is required: the name of a [materials.NAME] table");
                }
                None
            }
            Some(m) => match self.0.get(m) {
                Some(mat) => Some(mat.clone()),
                None => {
                    c.err(path, format!("unknown material '{m}' ({})", self.known()));
                    None
                }
            },
        }
    }
}
