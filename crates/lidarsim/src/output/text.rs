//! Numbers as decimal text, digit for digit as the standard formatter
//! writes them but without its slow path: the point text file's columns
//! and the trajectory files' rows.

use std::io::Write;

/// Appends the decimal digits of `v`.
pub fn push_u64(out: &mut Vec<u8>, mut v: u64) {
    let mut digits = [0u8; 20];
    let mut i = digits.len();
    loop {
        i -= 1;
        digits[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    out.extend_from_slice(&digits[i..]);
}

/// Appends `v` with `decimals` digits after the point, exactly as
/// `format!("{v:.decimals$}")` writes it — the exact binary value rounded to
/// nearest, ties to even — except that a value that rounds to zero is
/// written without a sign (`0.000`, where the standard formatter writes
/// `-0.000` for `-0.0` and for tiny negatives). The scaling by `10^decimals` (exact as a double) is one
/// correctly rounded multiplication, and rounding is monotonic: below 2⁵²
/// every half-integer is a double, so an exact product below a half-integer
/// cannot come out above it, nor one above below it. Unless the scaled
/// value is exactly a half-integer, it therefore rounds to the same integer
/// as the exact product, and the digits are printed from that integer. At
/// a half-integer (a tie, or the rounding of a product next to one),
/// beyond 2⁵² and for values that are not finite, the standard formatter
/// writes it.
pub fn push_fixed(out: &mut Vec<u8>, v: f64, decimals: u32) {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    let scale = 10u64.pow(decimals);
    let t = v.abs() * scale as f64;
    let f = t - t.floor();
    if t < TWO_52 && f != 0.5 {
        let q = t.round() as u64;
        if v.is_sign_negative() && q != 0 {
            out.push(b'-');
        }
        push_u64(out, q / scale);
        if decimals > 0 {
            out.push(b'.');
            let frac = q % scale;
            let mut digits = [b'0'; 20];
            let d = decimals as usize;
            let mut x = frac;
            for slot in digits[..d].iter_mut().rev() {
                *slot = b'0' + (x % 10) as u8;
                x /= 10;
            }
            out.extend_from_slice(&digits[..d]);
        }
    } else {
        // Writing into a vector cannot fail.
        let start = out.len();
        let _ = write!(out, "{v:.prec$}", prec = decimals as usize);
        if out[start] == b'-' && out[start + 1..].iter().all(|&b| b == b'0' || b == b'.') {
            out.remove(start);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixed(v: f64, d: u32) -> String {
        let mut b = Vec::new();
        push_fixed(&mut b, v, d);
        String::from_utf8(b).unwrap()
    }

    /// Against the standard formatter, digit for digit (less the sign of
    /// a negative zero): random values of every magnitude the columns
    /// hold, values at and next to ties (exact binary halves such as
    /// 0.125, and decimal halves that binary cannot hold), signed zeros,
    /// tiny negatives, huge and non-finite values.
    #[test]
    fn fixed_point_digits_equal_the_standard_formatter() {
        let mut rng = crate::rng::Stream::new(11, 0, 0, crate::rng::Purpose::Test);
        let mut values = vec![
            0.0,
            -0.0,
            -0.0001,
            -0.00049,
            0.0005,
            0.125,
            0.375,
            1.0625,
            2.5,
            -2.5,
            0.1 + 0.2,
            1e15,
            4.6e15,
            1e300,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for _ in 0..200_000 {
            let mag = 10f64.powf(rng.uniform() * 16.0 - 6.0);
            let sign = if rng.uniform() < 0.3 { -1.0 } else { 1.0 };
            values.push(sign * mag * rng.uniform());
        }
        // Decimal halves at each precision, and their neighbours.
        for k in 0..20_000u64 {
            for d in [3u32, 4, 6, 9] {
                let half = (k as f64 * 7.3 + 0.5) / 10f64.powi(d as i32);
                values.extend([half, half.next_up(), half.next_down(), -half]);
            }
        }
        let mut checked = 0;
        for &v in &values {
            for d in [0u32, 3, 4, 6, 9] {
                let std = format!("{v:.prec$}", prec = d as usize);
                let want = match std.strip_prefix('-') {
                    Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
                    _ => std,
                };
                assert_eq!(fixed(v, d), want, "{v:e} to {d} decimals");
                checked += 1;
            }
        }
        assert!(checked > 1_000_000);
        // Issue 49: the demo's XYZ file held 304 065 heights as "-0.000".
        for (v, d, want) in [
            (-0.0, 3, "0.000"),
            (-0.0004, 3, "0.000"),
            (-0.0006, 3, "-0.001"),
            (-0.4, 0, "0"),
            (-0.5, 0, "0"),
            (-1.5, 0, "-2"),
        ] {
            assert_eq!(fixed(v, d), want, "{v} to {d} decimals");
        }
        let mut b = Vec::new();
        for v in [0, 7, 10, 65_535, u64::MAX] {
            b.clear();
            push_u64(&mut b, v);
            assert_eq!(b, v.to_string().into_bytes());
        }
    }
}
