//! How large a picture may be: the limits on a map's side and pixel count,
//! the pixel size that keeps a map within them, and the error that says
//! which pixel size would fit when a requested one does not.

/// Largest side of a picture's map (without legend and scale bar), px.
pub const MAX_SIDE_PX: usize = 8192;
/// Largest number of pixels of a picture's map: 16 million, about 200 MB
/// while a top view is drawn (a point index and a colour per pixel).
pub const MAX_MAP_PIXELS: usize = 16_000_000;

/// A picture whose map would exceed [`MAX_SIDE_PX`] or [`MAX_MAP_PIXELS`]
/// at the pixel size asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct TooLarge {
    /// The pixel size asked for, m.
    pub resolution_m: f64,
    /// Width of the map it would give, px (possibly huge or infinite).
    pub width_px: f64,
    /// Height of the map it would give, px.
    pub height_px: f64,
    /// The smallest pixel size that fits, rounded up to three significant
    /// digits, m; `None` when the points span too far for any.
    pub smallest_resolution_m: Option<f64>,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let px = |v: f64| {
            if v < 1e12 {
                format!("{v:.0}")
            } else {
                format!("{v:.2e}")
            }
        };
        write!(
            f,
            "a pixel size of {} m would make a picture of {} × {} px, over the limit of \
             {MAX_SIDE_PX} px a side and {MAX_MAP_PIXELS} pixels",
            self.resolution_m,
            px(self.width_px),
            px(self.height_px)
        )?;
        match self.smallest_resolution_m {
            Some(r) => write!(f, "; the smallest pixel size that fits is {r} m"),
            None => write!(f, "; the points span too far to be drawn at any pixel size"),
        }
    }
}

impl std::error::Error for TooLarge {}

/// Pixels along `len_m` at `res` m per pixel (as `f64`: it may not fit a
/// `usize`).
pub(super) fn cells(len_m: f64, res: f64) -> f64 {
    (len_m / res).floor() + 1.0
}

/// Whether a `w × h` px map is within the limits.
fn fits(w: f64, h: f64) -> bool {
    w <= MAX_SIDE_PX as f64 && h <= MAX_SIDE_PX as f64 && w * h <= MAX_MAP_PIXELS as f64
}

/// The smallest pixel size, rounded up to three significant digits (so
/// that the printed value fits too), at which `w_m × h_m` fits.
fn smallest_fitting(w_m: f64, h_m: f64) -> Option<f64> {
    if !(w_m.is_finite() && h_m.is_finite()) {
        return None;
    }
    let ok = |r: f64| fits(cells(w_m, r), cells(h_m, r));
    // At a pixel as long as the longer side the map is at most 2 × 2 px.
    let mut hi = w_m.max(h_m).max(f64::MIN_POSITIVE);
    while !ok(hi) {
        hi *= 2.0;
    }
    let mut lo = hi;
    while ok(lo) {
        lo /= 2.0;
        if lo < f64::MIN_POSITIVE {
            return Some(hi);
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if ok(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let e = hi.log10().floor() as i32 - 2;
    let decimals = usize::try_from(-e).unwrap_or(0);
    let step = 10f64.powi(e);
    let mut k = (hi / step).ceil();
    loop {
        let text = format!("{:.decimals$}", k * step);
        if let Ok(r) = text.parse::<f64>()
            && ok(r)
        {
            return Some(r);
        }
        k += 1.0;
    }
}

/// The pixel size of a map of `w_m × h_m`: the one requested, if the map
/// fits the limits at it (else an error saying what would fit), or the
/// automatic one, coarsened as far as needed to fit.
pub(super) fn fit_resolution(
    w_m: f64,
    h_m: f64,
    requested: Option<f64>,
    auto: impl FnOnce() -> f64,
) -> Result<f64, TooLarge> {
    let res = requested.unwrap_or_else(auto);
    let (w, h) = (cells(w_m, res), cells(h_m, res));
    if fits(w, h) {
        return Ok(res);
    }
    let smallest = smallest_fitting(w_m, h_m);
    match (requested, smallest) {
        (None, Some(s)) => Ok(s.max(res)),
        _ => Err(TooLarge {
            resolution_m: res,
            width_px: w,
            height_px: h,
            smallest_resolution_m: smallest,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::frame::{FOOTER_HEIGHT, LEGEND_WIDTH};
    use crate::render::testing::{map_px, pt};
    use crate::render::{ColorBy, RenderPoint, profile, top_view};

    /// Points on a regular grid over `w_m × h_m` from the origin, every
    /// `step` m, at height 0.
    fn grid(w_m: f64, h_m: f64, step: f64) -> Vec<RenderPoint> {
        let (nx, ny) = ((w_m / step) as usize, (h_m / step) as usize);
        (0..=nx)
            .flat_map(|i| (0..=ny).map(move |j| pt(i as f64 * step, j as f64 * step, 0.0, 2)))
            .collect()
    }

    #[test]
    fn a_resolution_too_fine_is_refused_with_the_smallest_that_fits() {
        // 1000 m × 500 m: the pixel limit binds first, at
        // √(1000 · 500 / 16 000 000) = 0.1768 m (the side limit needs only
        // 1000 / 8191 = 0.122 m).
        let pts = grid(1000.0, 500.0, 25.0);
        for res in [1e-9, 1e-4, 0.1] {
            let e = top_view(&pts, ColorBy::Height, Some(res)).unwrap_err();
            assert_eq!(e.resolution_m, res);
            let s = e.smallest_resolution_m.unwrap();
            assert!(
                (0.1767..0.1790).contains(&s),
                "{s}: three significant digits, rounded up"
            );
            assert!(map_px(1000.0, s) * map_px(500.0, s) <= MAX_MAP_PIXELS as f64);
            let text = e.to_string();
            for words in [
                "8192 px a side",
                "16000000 pixels",
                &format!("fits is {s} m"),
            ] {
                assert!(text.contains(words), "{words}: {text}");
            }
            // The resolution offered works.
            let img = top_view(&pts, ColorBy::Height, Some(s)).unwrap();
            assert_eq!(img.width - LEGEND_WIDTH, map_px(1000.0, s) as usize);
        }
        // A long thin strip: the side limit binds, 20 000 / 8191 = 2.4417 m.
        let strip: Vec<RenderPoint> = (0..=200)
            .map(|i| pt(i as f64 * 100.0, 0.0, 0.0, 2))
            .collect();
        let e = top_view(&strip, ColorBy::Class, Some(0.5)).unwrap_err();
        let s = e.smallest_resolution_m.unwrap();
        assert!((2.4417..2.46).contains(&s), "{s}");
        assert!(map_px(20_000.0, s) <= MAX_SIDE_PX as f64);
        // A cross-section 10 000 km long at 1 cm per pixel.
        let e = profile(
            &pts,
            (0.0, 0.0),
            (1e7, 0.0),
            5.0,
            ColorBy::Class,
            Some(0.01),
        );
        let s = e.unwrap_err().smallest_resolution_m.unwrap();
        assert!((1e7 / 8191.0..1e7 / 8191.0 * 1.01).contains(&s), "{s}");
    }

    #[test]
    fn an_automatic_resolution_is_coarsened_to_fit() {
        // A 10 m section whose heights span 1000 km (an outlier): at the
        // automatic 5 cm the picture would be 20 million px tall.
        let mut pts = grid(10.0, 1.0, 0.5);
        pts.push(pt(5.0, 0.5, 1e6, 7));
        let img = profile(&pts, (0.0, 0.5), (10.0, 0.5), 2.0, ColorBy::Class, None).unwrap();
        assert!(img.height <= MAX_SIDE_PX + FOOTER_HEIGHT, "{}", img.height);
        // A top view 4000 km across.
        let far = [pt(0.0, 0.0, 0.0, 2), pt(4e6, 3e6, 10.0, 2)];
        let img = top_view(&far, ColorBy::Height, None).unwrap();
        assert!(img.width - LEGEND_WIDTH <= 1601 && img.height <= 1601 + FOOTER_HEIGHT);
    }
}
