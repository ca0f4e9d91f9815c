//! Plain-text point output: one point per line, space separated, with a
//! header line naming the columns.

use std::io::{self, Write};
use std::path::Path;

use super::{AtomicFile, PointRecord, PointSink};

/// The column names of the header line, in order.
pub const XYZ_COLUMNS: &str = "x y z intensity return_number number_of_returns classification \
                               gps_time scan_angle_deg point_source_id amplitude echo_width_ns \
                               range_m component";

/// Writes `points.xyz`.
#[derive(Debug)]
pub struct XyzWriter {
    file: AtomicFile,
    origin_m: [f64; 3],
    /// The lines of the block being written.
    block: Vec<u8>,
}

impl XyzWriter {
    /// Creates `path` (as `path.partial` until finished) and writes the
    /// header line; `origin_m` is added to every position.
    pub fn create(path: &Path, origin_m: [f64; 3]) -> io::Result<Self> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file.writer(), "{XYZ_COLUMNS}").map_err(|e| file.error(e))?;
        Ok(Self {
            file,
            origin_m,
            block: Vec::with_capacity(1 << 16),
        })
    }

    /// Continues `path`, finished early by an interrupted run when it held
    /// `len` bytes: points are appended after them.
    pub fn resume(path: &Path, len: u64, origin_m: [f64; 3]) -> io::Result<Self> {
        Ok(Self {
            file: AtomicFile::reopen(path, len)?,
            origin_m,
            block: Vec::with_capacity(1 << 16),
        })
    }
}

impl PointSink for XyzWriter {
    fn write(&mut self, points: &[PointRecord]) -> io::Result<()> {
        let o = self.origin_m;
        // The columns after the first, each after a space.
        let fixed = |b: &mut Vec<u8>, v: f64, decimals: u32| {
            b.push(b' ');
            push_fixed(b, v, decimals);
        };
        let integer = |b: &mut Vec<u8>, v: u64| {
            b.push(b' ');
            push_u64(b, v);
        };
        self.block.clear();
        for p in points {
            let b = &mut self.block;
            // In `XYZ_COLUMNS` order.
            push_fixed(b, p.position_m.x + o[0], 3);
            fixed(b, p.position_m.y + o[1], 3);
            fixed(b, p.position_m.z + o[2], 3);
            integer(b, u64::from(p.intensity));
            integer(b, u64::from(p.return_number));
            integer(b, u64::from(p.number_of_returns));
            integer(b, u64::from(p.classification));
            fixed(b, p.gps_time_s, 9);
            fixed(b, p.scan_angle_deg, 3);
            integer(b, u64::from(p.point_source_id));
            fixed(b, p.amplitude, 6);
            fixed(b, p.echo_width_ns, 3);
            fixed(b, p.range_m, 4);
            integer(b, u64::from(p.component));
            b.push(b'\n');
        }
        if let Err(e) = self.file.writer().write_all(&self.block) {
            return Err(self.file.error(e));
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> io::Result<()> {
        self.file.commit()
    }

    fn suspend(self: Box<Self>) -> io::Result<()> {
        self.file.suspend()
    }

    fn discard(self: Box<Self>) {}
}

/// Appends the decimal digits of `v`.
fn push_u64(out: &mut Vec<u8>, mut v: u64) {
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
/// `format!("{v:.decimals$}")` writes it: the exact binary value rounded to
/// nearest, ties to even, and a minus sign whenever the sign bit is set
/// (`-0.000`). The scaling by `10^decimals` (exact as a double) is one
/// correctly rounded multiplication, and rounding is monotonic: below 2⁵²
/// every half-integer is a double, so an exact product below a half-integer
/// cannot come out above it, nor one above below it. Unless the scaled
/// value is exactly a half-integer, it therefore rounds to the same integer
/// as the exact product, and the digits are printed from that integer. At
/// a half-integer (a tie, or the rounding of a product next to one),
/// beyond 2⁵² and for values that are not finite, the standard formatter
/// writes it.
fn push_fixed(out: &mut Vec<u8>, v: f64, decimals: u32) {
    const TWO_52: f64 = 4_503_599_627_370_496.0;
    let scale = 10u64.pow(decimals);
    let t = v.abs() * scale as f64;
    let f = t - t.floor();
    if t < TWO_52 && f != 0.5 {
        let q = t.round() as u64;
        if v.is_sign_negative() {
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
        let _ = write!(out, "{v:.prec$}", prec = decimals as usize);
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

    /// Against the standard formatter, digit for digit: random values of
    /// every magnitude the columns hold, values at and next to ties (exact
    /// binary halves such as 0.125, and decimal halves that binary cannot
    /// hold), signed zeros, tiny negatives, huge and non-finite values.
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
                let want = format!("{v:.prec$}", prec = d as usize);
                assert_eq!(fixed(v, d), want, "{v:e} to {d} decimals");
                checked += 1;
            }
        }
        assert!(checked > 1_000_000);
        let mut b = Vec::new();
        for v in [0, 7, 10, 65_535, u64::MAX] {
            b.clear();
            push_u64(&mut b, v);
            assert_eq!(b, v.to_string().into_bytes());
        }
    }
}
