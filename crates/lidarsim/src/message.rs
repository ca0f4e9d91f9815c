//! How messages show what they are about: numbers in a readable form and
//! the nearest of several names (for "did you mean").

/// A number as messages show it: plainly for ordinary magnitudes, in
/// exponent form for very large or small ones (`1e300`, not 301 digits).
pub fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-4..1e9).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A number as figures show it: `decimals` places for ordinary
/// magnitudes, exponent form with three significant digits beyond them
/// (`1.00e300 m`, not 301 digits; `4.00e-9 s`, not `0.00 s`).
pub fn fixed(v: f64, decimals: usize) -> String {
    let a = v.abs();
    let smallest = 0.5 * 10f64.powi(-(decimals as i32));
    if v == 0.0 || !v.is_finite() || (smallest..1e9).contains(&a) {
        format!("{v:.decimals$}")
    } else {
        format!("{v:.2e}")
    }
}

/// Levenshtein distance between two short strings.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distances_of_known_pairs() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("hosue.obj", "house.obj"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
    }

    #[test]
    fn large_and_small_numbers_in_exponent_form() {
        assert_eq!(num(1e300), "1e300");
        assert_eq!(num(4e-9), "4e-9");
        assert_eq!(num(0.001), "0.001");
        assert_eq!(num(123456.5), "123456.5");
        assert_eq!(num(0.0), "0");
        assert_eq!(num(f64::NAN), "NaN");
        assert_eq!(fixed(1e300, 1), "1.00e300");
        assert_eq!(fixed(-2.5e12, 2), "-2.50e12");
        assert_eq!(fixed(4e-9, 2), "4.00e-9");
        assert_eq!(fixed(0.004, 2), "4.00e-3");
        assert_eq!(fixed(123.456, 1), "123.5");
        assert_eq!(fixed(0.0, 3), "0.000");
    }
}
