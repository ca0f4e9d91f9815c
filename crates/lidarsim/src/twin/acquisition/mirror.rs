//! The pulse rate and the mirror of a strip, from the times and scan
//! angles of its first returns.
//!
//! **Pulse rate.** Consecutive pulses are 1/PRF apart; pulses without an
//! echo, or dropped from the file, leave multiples of it. The period is
//! the 10th percentile of the time steps between first returns, refined
//! as the median of each short step over its multiple of it.
//!
//! **Mirror.** The first returns split into sweeps — runs without a pause
//! longer than the greater of 20 pulse periods and four times the median
//! step (the beam leaving the scan's area), cut again where the angle
//! turns back by more than the hysteresis (a swath wholly inside the
//! area). The scan angle of each sweep against time is a line: its slope
//! is the beam's angular speed and its sign the sweep's direction, and
//! where it crosses the strip's median angle gives the sweep a time. An
//! oscillating mirror sweeps both ways, each way once per cycle: the
//! crossings of one direction are one period apart. A rotating polygon
//! sweeps one way, one scan line per facet. A triangle mirror of
//! amplitude θₘ and frequency f turns the beam at 4·θₘ·f; a polygon of N
//! facets turns it through 720°/N per line.

/// The scan pattern read from a strip.
#[derive(Clone, Debug, PartialEq)]
pub struct Mirror {
    /// Whether the sweeps go both ways (an oscillating mirror) or one
    /// (a rotating polygon).
    pub both_ways: bool,
    /// Mirror cycles per second (both ways) or scan lines per second.
    pub frequency_hz: f64,
    /// The beam's angular speed, degrees per second.
    pub angular_speed_deg_s: f64,
    /// Sweeps read.
    pub sweeps: usize,
    /// Relative spread of the periods between sweeps (robust: the median
    /// absolute deviation over the median).
    pub period_spread: f64,
}

/// Why a strip's mirror could not be read.
#[derive(Clone, Debug, PartialEq)]
pub enum MirrorProblem {
    /// Fewer sweeps than [`MIN_SWEEPS`] crossed the strip's median angle.
    TooFewSweeps(usize),
}

/// Sweeps needed to read a mirror.
pub const MIN_SWEEPS: usize = 6;

/// The pulse period of time-sorted first returns `t`, s (`None` for
/// fewer than 10 distinct times).
pub fn pulse_period_s(t: &[f64]) -> Option<f64> {
    let mut dt: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if dt.len() < 10 {
        return None;
    }
    dt.sort_by(f64::total_cmp);
    let p0 = dt[dt.len() / 10];
    let mut ratios: Vec<f64> = dt
        .iter()
        .filter(|&&d| d <= 10.5 * p0)
        .map(|&d| d / (d / p0).round().max(1.0))
        .collect();
    ratios.sort_by(f64::total_cmp);
    Some(ratios[ratios.len() / 2])
}

/// A sweep: its time at the reference angle and its slope, deg/s.
#[derive(Clone, Copy, Debug)]
struct Sweep {
    crossing_s: f64,
    slope_deg_s: f64,
}

/// Reads the mirror from time-sorted times `t` and scan angles `a`
/// (degrees), stored in steps of `step_deg`, pulses `period_s` apart.
pub fn read_mirror(
    t: &[f64],
    a: &[f64],
    step_deg: f64,
    period_s: f64,
) -> Result<Mirror, MirrorProblem> {
    let mut sorted = a.to_vec();
    sorted.sort_by(f64::total_cmp);
    let reference = sorted[sorted.len() / 2];
    let runs = runs(t, a, step_deg, period_s);
    let sweeps: Vec<Sweep> = runs
        .iter()
        .filter_map(|r| sweep(&t[r.clone()], &a[r.clone()], reference, step_deg))
        .collect();
    let up = sweeps.iter().filter(|s| s.slope_deg_s > 0.0).count();
    let both_ways = up * 5 > sweeps.len() && (sweeps.len() - up) * 5 > sweeps.len();
    let mut gaps = Vec::new();
    for direction in [true, false] {
        let times: Vec<f64> = sweeps
            .iter()
            .filter(|s| !both_ways || (s.slope_deg_s > 0.0) == direction)
            .map(|s| s.crossing_s)
            .collect();
        gaps.extend(times.windows(2).map(|w| w[1] - w[0]));
        if !both_ways {
            break;
        }
    }
    if gaps.len() < MIN_SWEEPS - 2 {
        return Err(MirrorProblem::TooFewSweeps(sweeps.len()));
    }
    let period0 = median(&mut gaps.clone());
    let mut periods: Vec<f64> = gaps
        .iter()
        .map(|g| g / (g / period0).round().max(1.0))
        .collect();
    let period = median(&mut periods);
    let mut dev: Vec<f64> = periods.iter().map(|p| (p - period).abs()).collect();
    let mut speeds: Vec<f64> = sweeps.iter().map(|s| s.slope_deg_s.abs()).collect();
    Ok(Mirror {
        both_ways,
        frequency_hz: 1.0 / period,
        angular_speed_deg_s: median(&mut speeds),
        sweeps: sweeps.len(),
        period_spread: median(&mut dev) / period,
    })
}

/// The runs of points between pauses and turns of the angle.
fn runs(t: &[f64], a: &[f64], step_deg: f64, period_s: f64) -> Vec<std::ops::Range<usize>> {
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let pause = (20.0 * period_s).max(4.0 * median(&mut steps));
    let hysteresis = (2.0 * step_deg).max(0.5);
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=t.len() {
        if i == t.len() || t[i] - t[i - 1] > pause {
            split_turns(&a[start..i], hysteresis, start, &mut out);
            start = i;
        }
    }
    out
}

/// Splits the run of angles `a` (from index `offset`) where it turns back
/// by more than `hysteresis`, at the turning point.
fn split_turns(a: &[f64], hysteresis: f64, offset: usize, out: &mut Vec<std::ops::Range<usize>>) {
    let (mut start, mut hi, mut lo, mut dir) = (0usize, 0usize, 0usize, 0i8);
    for i in 1..a.len() {
        if a[i] > a[hi] {
            hi = i;
        }
        if a[i] < a[lo] {
            lo = i;
        }
        let turn = match dir {
            0 if a[i] - a[lo] >= hysteresis => {
                dir = 1;
                None
            }
            0 if a[hi] - a[i] >= hysteresis => {
                dir = -1;
                None
            }
            1 if a[hi] - a[i] >= hysteresis => Some(hi),
            -1 if a[i] - a[lo] >= hysteresis => Some(lo),
            _ => None,
        };
        if let Some(at) = turn {
            out.push(offset + start..offset + at + 1);
            start = at + 1;
            (hi, lo, dir) = (i, i, -dir);
            for j in start..=i {
                if a[j] > a[hi] {
                    hi = j;
                }
                if a[j] < a[lo] {
                    lo = j;
                }
            }
        }
    }
    if start < a.len() {
        out.push(offset + start..offset + a.len());
    }
}

/// A sweep of times `t` and angles `a` crossing `reference`: the line
/// `a = c + d·t` fitted by least squares (the angle the response: its
/// rounding to `step_deg` adds noise, no bias), and the time it crosses
/// the reference. `None` for fewer than 4 points, an angle span under two
/// steps, or a sweep that does not reach the reference.
fn sweep(t: &[f64], a: &[f64], reference: f64, step_deg: f64) -> Option<Sweep> {
    let (lo, hi) = a
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if t.len() < 4 || hi - lo < 2.0 * step_deg || reference < lo || reference > hi {
        return None;
    }
    let n = t.len() as f64;
    let (mt, ma) = (t.iter().sum::<f64>() / n, a.iter().sum::<f64>() / n);
    let (mut stt, mut sta) = (0.0, 0.0);
    for (&ti, &ai) in t.iter().zip(a) {
        stt += (ti - mt) * (ti - mt);
        sta += (ti - mt) * (ai - ma);
    }
    let d = sta / stt;
    if !d.is_finite() || d == 0.0 {
        return None;
    }
    Some(Sweep {
        crossing_s: mt + (reference - ma) / d,
        slope_deg_s: d,
    })
}

/// The median of `v` (reordered); 0 for none.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pulses of a triangle mirror (amplitude 20°, 40 Hz, 100 kHz)
    /// that land between 2° and 12° (a tile off to one side), every third
    /// pulse dropped, angles rounded to whole degrees as LAS 1.2 stores
    /// them.
    fn triangle(step: f64) -> (Vec<f64>, Vec<f64>) {
        let (prf, f, amp) = (100_000.0, 40.0, 20.0);
        let (mut t, mut a) = (Vec::new(), Vec::new());
        for k in 0..60_000u64 {
            if k % 3 == 2 {
                continue;
            }
            let time = 1000.0 + k as f64 / prf;
            let p = (f * (time - 1000.0)).fract();
            let theta = if p < 0.25 {
                4.0 * amp * p
            } else if p < 0.75 {
                amp * (2.0 - 4.0 * p)
            } else {
                amp * (4.0 * p - 4.0)
            };
            if (2.0..12.0).contains(&theta) {
                t.push(time);
                a.push((theta / step).round() * step);
            }
        }
        (t, a)
    }

    #[test]
    fn a_triangle_mirror_is_read_from_a_tile_to_one_side() {
        for step in [1.0, 0.006] {
            let (t, a) = triangle(step);
            let period = pulse_period_s(&t).unwrap();
            assert!((period - 1e-5).abs() < 1e-9, "{period}");
            let m = read_mirror(&t, &a, step, period).unwrap();
            assert!(m.both_ways);
            assert!((m.frequency_hz - 40.0).abs() < 0.05, "{m:?}");
            // 4 × 20° × 40 Hz.
            let rel = m.angular_speed_deg_s / 3200.0 - 1.0;
            assert!(rel.abs() < 0.02, "{m:?}");
        }
    }

    /// A polygon sweeps one way: every line crosses the tile, one line
    /// per facet.
    #[test]
    fn a_polygon_sweeps_one_way() {
        let (prf, lines, fov) = (200_000.0, 100.0, 90.0);
        let (mut t, mut a) = (Vec::new(), Vec::new());
        for k in 0..40_000u64 {
            let time = k as f64 / prf;
            let theta = fov * (0.5 - (lines * time).fract());
            if (-10.0..25.0).contains(&theta) {
                t.push(time);
                a.push(theta);
            }
        }
        let period = pulse_period_s(&t).unwrap();
        let m = read_mirror(&t, &a, 0.006, period).unwrap();
        assert!(!m.both_ways);
        assert!((m.frequency_hz - 100.0).abs() < 0.05, "{m:?}");
        assert!((m.angular_speed_deg_s + 0.0 - 9000.0).abs() < 90.0, "{m:?}");
    }

    #[test]
    fn too_few_sweeps_are_refused() {
        let (t, a) = triangle(1.0);
        let cut = t.iter().position(|&x| x > 1000.06).unwrap();
        let e = read_mirror(&t[..cut], &a[..cut], 1.0, 1e-5).unwrap_err();
        assert!(
            matches!(e, MirrorProblem::TooFewSweeps(n) if n < 6),
            "{e:?}"
        );
    }
}
