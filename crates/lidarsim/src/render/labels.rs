//! Numbers written on pictures: fixed decimals that never read "-0.0",
//! and round tick values for axes.

/// `v` with `decimals` decimals, never as "-0.0": a value that rounds to
/// zero is printed without a sign.
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

/// Round values from `lo` to `hi`, at most `max_ticks` of them (steps of
/// 1, 2 or 5 times a power of ten), and the decimals their labels need.
pub fn nice_ticks(lo: f64, hi: f64, max_ticks: usize) -> (Vec<f64>, usize) {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return (vec![lo], 1);
    }
    let raw = span / max_ticks.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|f| f * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let decimals = usize::try_from(-(step.log10().floor() as i64)).unwrap_or(0);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let ticks = (first..=last).map(|k| k as f64 * step).collect();
    (ticks, decimals)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_are_never_negative_zero() {
        assert_eq!(fixed(-0.04, 1), "0.0");
        assert_eq!(fixed(-0.0, 1), "0.0");
        assert_eq!(fixed(-0.004, 2), "0.00");
        assert_eq!(fixed(-0.06, 1), "-0.1");
        assert_eq!(fixed(-0.4, 0), "0");
        assert_eq!(fixed(12.25, 1), "12.2");
    }
}
