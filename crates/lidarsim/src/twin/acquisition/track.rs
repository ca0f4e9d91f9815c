//! The aircraft's track over one strip, from where its points lie and at
//! which scan angle and time.
//!
//! A beam at scan angle θ from an aircraft at height H above a point of
//! height h meets the ground at `q = (H − h)·tan θ` across the track, so
//! the lines of equal scan angle run along the track and tan θ grows
//! across it at 1/H per metre:
//!
//! ```text
//! tan θ · (1 − h/H) = α + β · (p − p̄)        (p the point's x, y)
//! ```
//!
//! a plane fitted to the points by least squares (the scan angle the
//! response, so that the integer scan angle ranks of LAS 1.0–1.3 add
//! noise but no bias), h/H refined twice. |β| = 1/H, β/|β| is the across
//! direction û (towards positive angles), the track runs along ŵ ⊥ û
//! through the points of θ = 0. The along-track coordinate s of the
//! points then follows the time, `s = s₀ + v·t + κ·q`: v is the ground
//! speed and κ the skew of the scan lines from the across direction (a
//! crab angle, or a scanner whose lines are not square to the track),
//! fitted with it so that a strip cut diagonally by the tile's edge does
//! not bias the speed.

use crate::scan::ScanCloud;

/// The fitted track of a strip.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// A point of the nadir track at time `t0_s`, m.
    pub origin_m: [f64; 2],
    /// The time of `origin_m`, s.
    pub t0_s: f64,
    /// Unit vector along the flight direction.
    pub along: [f64; 2],
    /// Ground speed, m/s.
    pub speed_mps: f64,
    /// Flying height above the ground, m.
    pub height_m: f64,
    /// Its standard error from the fit, m.
    pub height_se_m: f64,
    /// Skew of the scan lines from square to the track, degrees.
    pub skew_deg: f64,
    /// Residual of the plane fit, degrees of scan angle.
    pub residual_deg: f64,
    /// Whether positive scan angles lie to the right of the flight
    /// direction (the LAS convention).
    pub positive_right: bool,
}

impl Track {
    /// The compass heading of the flight direction, degrees (0 north, 90
    /// east).
    pub fn heading_deg(&self) -> f64 {
        self.along[0]
            .atan2(self.along[1])
            .to_degrees()
            .rem_euclid(360.0)
    }

    /// The nadir position at time `t_s`, m.
    pub fn at(&self, t_s: f64) -> [f64; 2] {
        let d = self.speed_mps * (t_s - self.t0_s);
        [
            self.origin_m[0] + d * self.along[0],
            self.origin_m[1] + d * self.along[1],
        ]
    }
}

/// Why a strip's track could not be fitted.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackProblem {
    /// Its scan angles span less than this many degrees.
    NarrowAngles(f64),
    /// Its points lie on a line or span no time.
    Degenerate,
}

/// Fits the track of the points `pts` of `cloud` (heights above ground
/// `h`).
pub fn fit_track(cloud: &ScanCloud, h: &[f64], pts: &[usize]) -> Result<Track, TrackProblem> {
    let n = pts.len() as f64;
    let (lo, hi) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &k| {
            let a = f64::from(cloud.scan_angle_deg[k]);
            (l.min(a), u.max(a))
        });
    if hi - lo < 2.0 * cloud.facts.scan_angle_step_deg.max(0.5) {
        return Err(TrackProblem::NarrowAngles(hi - lo));
    }
    let mean = |f: &dyn Fn(usize) -> f64| pts.iter().map(|&k| f(k)).sum::<f64>() / n;
    let (mx, my, mt) = (
        mean(&|k| cloud.x[k]),
        mean(&|k| cloud.y[k]),
        mean(&|k| cloud.gps_time[k]),
    );
    let tan = |k: usize| f64::from(cloud.scan_angle_deg[k]).to_radians().tan();
    let mut height = f64::INFINITY;
    let mut plane = [0.0; 3];
    let mut residual = 0.0;
    for _ in 0..3 {
        let rows = pts.iter().map(|&k| {
            let r = tan(k) * (1.0 - h[k] / height);
            ([1.0, cloud.x[k] - mx, cloud.y[k] - my], r)
        });
        (plane, residual) = least_squares(rows).ok_or(TrackProblem::Degenerate)?;
        let g = plane[1].hypot(plane[2]);
        if g.is_nan() || g <= 0.0 {
            return Err(TrackProblem::Degenerate);
        }
        height = 1.0 / g;
    }
    let across = [plane[1] * height, plane[2] * height];
    let mut along = [across[1], -across[0]];
    // The nadir track (θ = 0) lies at q = −α·H across from the mean point.
    let q0 = -plane[0] * height;
    let rows = pts.iter().map(|&k| {
        let (dx, dy) = (cloud.x[k] - mx, cloud.y[k] - my);
        let s = dx * along[0] + dy * along[1];
        let q = dx * across[0] + dy * across[1];
        ([1.0, cloud.gps_time[k] - mt, q - q0], s)
    });
    let (fit, _) = least_squares(rows).ok_or(TrackProblem::Degenerate)?;
    let [s0, mut v, kappa] = fit;
    let origin_m = [
        mx + q0 * across[0] + s0 * along[0],
        my + q0 * across[1] + s0 * along[1],
    ];
    if v < 0.0 {
        along = [-along[0], -along[1]];
        v = -v;
    }
    // Right of the flight direction (x east, y north) is (w_y, −w_x).
    let positive_right = across[0] * along[1] - across[1] * along[0] > 0.0;
    let sd_q = across_spread(cloud, pts, mx, my, across);
    Ok(Track {
        origin_m,
        t0_s: mt,
        along,
        speed_mps: v,
        height_m: height,
        // H = 1/|β|: its error is H² times that of the slope |β|.
        height_se_m: height * height * residual / (sd_q * n.sqrt()).max(1e-12),
        skew_deg: kappa.atan().to_degrees(),
        residual_deg: residual.atan().to_degrees(),
        positive_right,
    })
}

/// The standard deviation of the points' positions across the track, m.
fn across_spread(cloud: &ScanCloud, pts: &[usize], mx: f64, my: f64, across: [f64; 2]) -> f64 {
    let n = pts.len() as f64;
    let q: Vec<f64> = pts
        .iter()
        .map(|&k| (cloud.x[k] - mx) * across[0] + (cloud.y[k] - my) * across[1])
        .collect();
    let m = q.iter().sum::<f64>() / n;
    (q.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt()
}

/// Least squares of `y ≈ c · x` over the rows `(x, y)`: the coefficients
/// and the residual's standard deviation (normal equations, solved by
/// Gaussian elimination with partial pivoting); `None` when singular.
pub fn least_squares(rows: impl Iterator<Item = ([f64; 3], f64)>) -> Option<([f64; 3], f64)> {
    let mut a = [[0.0f64; 4]; 3];
    let mut stored: Vec<([f64; 3], f64)> = Vec::new();
    for (x, y) in rows {
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += x[i] * x[j];
            }
            a[i][3] += x[i] * y;
        }
        stored.push((x, y));
    }
    for col in 0..3 {
        let pivot = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        a.swap(col, pivot);
        if a[col][col].abs() < 1e-300 {
            return None;
        }
        let pivot_row = a[col];
        for (row, r) in a.iter_mut().enumerate() {
            if row != col {
                let f = r[col] / pivot_row[col];
                for (v, p) in r.iter_mut().zip(pivot_row).skip(col) {
                    *v -= f * p;
                }
            }
        }
    }
    let c = [a[0][3] / a[0][0], a[1][3] / a[1][1], a[2][3] / a[2][2]];
    if c.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let n = stored.len().max(1) as f64;
    let ss: f64 = stored
        .iter()
        .map(|(x, y)| (y - (c[0] * x[0] + c[1] * x[1] + c[2] * x[2])).powi(2))
        .sum();
    Some((c, (ss / n).sqrt()))
}
