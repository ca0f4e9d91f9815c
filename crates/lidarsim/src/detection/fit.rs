//! The shape of an echo from its samples: the peak's sub-bin position
//! and height by a Gaussian fit, the width at a level, the energy.

/// Sub-bin offset of the maximum and the fitted peak value: a Gaussian
/// fitted to the samples within `half` bins of `p` (bounded by
/// `[lo, hi]`), as a parabola in the logarithm of the samples by weighted
/// least squares with weights `s²` (the variance of `ln s` under additive
/// noise is `σ²/s²`; Caruana's algorithm as weighted by Guo, "A simple
/// algorithm for fitting a Gaussian function", IEEE SPM 2011). Falls back to
/// the sample itself when fewer than three positive samples are available.
pub(super) fn refine(s: &[f64], p: usize, half: usize, lo: usize, hi: usize) -> (f64, f64) {
    let a = lo.max(p.saturating_sub(half));
    let b = hi.min(p + half).min(s.len() - 1);
    // Normal equations of the weighted fit ln s = c0 + c1 x + c2 x², with
    // x relative to p for conditioning.
    // The matrix is symmetric: Σw·x^(r+c) for r, c in 0..3, five sums.
    let mut mom = [0.0f64; 5];
    let mut v = [0.0f64; 3];
    let mut used = 0;
    // Small integers: stepping `x` by one is exact.
    let mut x = a as f64 - p as f64 - 1.0;
    for &y in s.get(a..=b).unwrap_or_default() {
        x += 1.0;
        if y <= 0.0 {
            continue;
        }
        let w = y * y;
        let wly = w * y.ln();
        let x2 = x * x;
        mom[0] += w;
        mom[1] += w * x;
        mom[2] += w * x2;
        mom[3] += w * x2 * x;
        mom[4] += w * x2 * x2;
        v[0] += wly;
        v[1] += wly * x;
        v[2] += wly * x2;
        used += 1;
    }
    let m = [
        [mom[0], mom[1], mom[2]],
        [mom[1], mom[2], mom[3]],
        [mom[2], mom[3], mom[4]],
    ];
    if used >= 3
        && let Some([c0, c1, c2]) = solve3(m, v)
        && c2 < 0.0
    {
        let d = -c1 / (2.0 * c2);
        if d.abs() <= half.max(1) as f64 {
            return (d, (c0 - c1 * c1 / (4.0 * c2)).exp());
        }
    }
    (0.0, s[p])
}

/// Solves a 3×3 linear system by Cramer's rule.
fn solve3(m: [[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut out = [0.0; 3];
    for (i, o) in out.iter_mut().enumerate() {
        let mut mi = m;
        for r in 0..3 {
            mi[r][i] = v[r];
        }
        *o = det(mi) / d;
    }
    Some(out)
}

/// Full width at half maximum of the peak at `p`, in bins, searching no
/// further than `[lo, hi]`; crossings interpolated linearly.
pub(super) fn half_max_width(s: &[f64], p: usize, lo: usize, hi: usize) -> f64 {
    width_at(s, p, lo, hi, 0.5 * s[p])
}

/// Width of the peak at `p` where it crosses `level`, in bins, searching no
/// further than `[lo, hi]`; crossings interpolated linearly.
pub(super) fn width_at(s: &[f64], p: usize, lo: usize, hi: usize, level: f64) -> f64 {
    let mut left = lo as f64;
    for i in (lo..p).rev() {
        if s[i] < level {
            left = i as f64 + (level - s[i]) / (s[i + 1] - s[i]);
            break;
        }
    }
    let mut right = hi as f64;
    for i in p + 1..=hi {
        if s[i] < level {
            right = (i - 1) as f64 + (s[i - 1] - level) / (s[i - 1] - s[i]);
            break;
        }
    }
    (right - left).max(1.0)
}

/// Sum of the samples within two widths of the peak, bounded by `[lo, hi]`.
pub(super) fn energy(s: &[f64], p: usize, width: f64, lo: usize, hi: usize) -> f64 {
    let reach = (2.0 * width).ceil() as usize;
    let a = lo.max(p.saturating_sub(reach));
    let b = hi.min(p + reach);
    s[a..=b].iter().sum()
}
