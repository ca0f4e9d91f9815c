//! Top views of a cloud: the highest point of each pixel, north up, with
//! one-pixel holes between scan lines filled and real gaps hatched.

use super::RenderPoint;
use super::figure::Figure;
use super::frame::{framed, hatched};
use super::limits::{TooLarge, cells, fit_resolution};
use super::palette::{ColorBy, Palette};

/// Pixel size for a top view of `w × h` m holding `n` points: about four
/// points per pixel on average, at most 1600 px on the longer side.
fn auto_resolution(w: f64, h: f64, n: usize) -> f64 {
    // About four points per pixel on average (scan lines leave gaps
    // finer than the mean spacing), at most 1600 px.
    let by_density = (w * h / (n.max(1) as f64) * 4.0).sqrt();
    by_density.max(w.max(h) / 1600.0).max(1e-3)
}

/// The pixel whose colour an empty pixel `k` of a `w × h` grid takes: its
/// highest filled neighbour when at least four of its eight neighbours
/// hold points. This closes the one-pixel gaps left where scan lines lie
/// further apart than a pixel (at the swath edges of a zigzag pattern)
/// while the outer edge of the data, with at most three filled neighbours
/// along a straight edge, stays empty.
pub fn hole_source(
    w: usize,
    h: usize,
    k: usize,
    filled: impl Fn(usize) -> bool,
    z: impl Fn(usize) -> f64,
) -> Option<usize> {
    let (i, j) = (k % w, k / w);
    let mut best: Option<(f64, usize)> = None;
    let mut count = 0;
    for (di, dj) in [
        (-1i64, -1i64),
        (0, -1),
        (1, -1),
        (-1, 0),
        (1, 0),
        (-1, 1),
        (0, 1),
        (1, 1),
    ] {
        let (ni, nj) = (i as i64 + di, j as i64 + dj);
        if ni < 0 || nj < 0 || ni >= w as i64 || nj >= h as i64 {
            continue;
        }
        let n = nj as usize * w + ni as usize;
        if filled(n) {
            count += 1;
            let zn = z(n);
            if best.is_none_or(|b| zn > b.0) {
                best = Some((zn, n));
            }
        }
    }
    best.filter(|_| count >= 4).map(|b| b.1)
}

/// A top view: for every pixel the colour of its highest point; pixels
/// without points are hatched as "no data", except one-pixel holes inside
/// the data, which take a neighbour's colour ([`hole_source`]). Height and
/// intensity are coloured over the robust range of the pixels
/// shown. `resolution_m` is the pixel size (default: from the point
/// density, coarsened if needed to fit the limits); a requested one at
/// which the map would exceed [`MAX_SIDE_PX`](super::MAX_SIDE_PX) or
/// [`MAX_MAP_PIXELS`](super::MAX_MAP_PIXELS) is an error that says the
/// smallest one that fits.
pub fn top_view(
    points: &[RenderPoint],
    by: ColorBy,
    resolution_m: Option<f64>,
) -> Result<Figure, TooLarge> {
    let (mut x0, mut y0, mut x1, mut y1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
    for p in points {
        x0 = x0.min(p.x);
        y0 = y0.min(p.y);
        x1 = x1.max(p.x);
        y1 = y1.max(p.y);
    }
    if points.is_empty() {
        (x0, y0, x1, y1) = (0.0, 0.0, 1.0, 1.0);
    }
    let (ew, eh) = (x1 - x0, y1 - y0);
    let res = fit_resolution(ew, eh, resolution_m, || {
        auto_resolution(ew, eh, points.len())
    })?;
    let (w, h) = (cells(ew, res) as usize, cells(eh, res) as usize);
    // The highest point of each pixel (the first of equals).
    const NONE: usize = usize::MAX;
    let mut top = vec![NONE; w * h];
    for (n, p) in points.iter().enumerate() {
        let i = (((p.x - x0) / res) as usize).min(w - 1);
        // North up: row 0 is the largest y.
        let j = h - 1 - (((p.y - y0) / res) as usize).min(h - 1);
        let k = j * w + i;
        if top[k] == NONE || p.z > points[top[k]].z {
            top[k] = n;
        }
    }
    let shown = top.iter().filter(|&&n| n != NONE).map(|&n| &points[n]);
    let palette = Palette::new(shown, by).with_no_data();
    let mut img = hatched(w, h);
    let filled = |k: usize| top[k] != NONE;
    let z = |k: usize| points[top[k]].z;
    for k in 0..w * h {
        let source = if filled(k) {
            Some(k)
        } else {
            hole_source(w, h, k, filled, z)
        };
        if let Some(s) = source {
            img.set(k % w, k / w, palette.color(&points[top[s]]));
        }
    }
    Ok(framed(img, &palette, res))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::frame::LEGEND_WIDTH;
    use crate::render::testing::{map_px, pt};
    use crate::render::{NO_DATA, class_color, ramp};

    /// Position of a colour on the ramp (nearest of 1001 samples).
    fn ramp_position(c: [u8; 3]) -> f64 {
        (0..=1000)
            .map(|i| i as f64 / 1000.0)
            .min_by_key(|v| {
                let r = ramp(*v);
                (0..3)
                    .map(|k| (i32::from(r[k]) - i32::from(c[k])).pow(2))
                    .sum::<i32>()
            })
            .unwrap()
    }

    #[test]
    fn a_height_ramp_gives_a_monotonic_colour_ramp() {
        // A plane rising eastwards, 1 point per 0.5 m.
        let pts: Vec<RenderPoint> = (0..200)
            .flat_map(|i| {
                (0..40).map(move |j| pt(i as f64 * 0.5, j as f64 * 0.5, i as f64 * 0.1, 2))
            })
            .collect();
        let img = top_view(&pts, ColorBy::Height, Some(0.5))
            .unwrap()
            .to_image();
        let row = 10;
        let pos: Vec<f64> = (0..200).map(|x| ramp_position(img.get(x, row))).collect();
        assert!(pos.windows(2).all(|w| w[1] >= w[0]), "not monotonic");
        assert!(pos[0] < 0.05 && pos[199] > 0.95);
    }

    #[test]
    fn two_classes_give_two_legend_colours_in_place() {
        // West half ground, east half building.
        let pts: Vec<RenderPoint> = (0..100)
            .flat_map(|i| {
                (0..50).map(move |j| {
                    let x = i as f64;
                    pt(x, j as f64, 0.0, if x < 50.0 { 2 } else { 6 })
                })
            })
            .collect();
        let img = top_view(&pts, ColorBy::Class, Some(1.0))
            .unwrap()
            .to_image();
        let (ground, building) = (class_color(2).0, class_color(6).0);
        let mut seen = std::collections::BTreeSet::new();
        for y in 0..50 {
            for x in 0..100 {
                let c = img.get(x, y);
                seen.insert(c);
                assert_eq!(c, if x < 50 { ground } else { building }, "({x}, {y})");
            }
        }
        assert_eq!(seen.len(), 2);
        // The legend shows exactly those two swatches, in class order.
        assert_eq!(img.get(100 + 10 + 5, 6 + 5), ground);
        assert_eq!(img.get(100 + 10 + 5, 22 + 5), building);
    }

    #[test]
    fn one_pixel_gaps_between_scan_lines_are_filled_and_real_gaps_left_as_no_data() {
        // Rows of points along x every 0.1 m, the rows 1.5 m apart: at
        // 1 m pixels every third row of pixels holds no point. Between
        // x = 20 m and 25 m there are no points at all.
        let pts: Vec<RenderPoint> = (0..=20)
            .flat_map(|k| {
                (0..=500).filter_map(move |i| {
                    let x = i as f64 * 0.1;
                    (!(20.0..25.0).contains(&x)).then(|| pt(x, k as f64 * 1.5, 0.0, 2))
                })
            })
            .collect();
        let img = top_view(&pts, ColorBy::Class, Some(1.0))
            .unwrap()
            .to_image();
        let (w, h) = (img.width - LEGEND_WIDTH, map_px(30.0, 1.0) as usize);
        assert_eq!(w, 51);
        let ground = class_color(2).0;
        let is_no_data = |x: usize, y: usize| NO_DATA.contains(&img.get(x, y));
        for y in 0..h {
            for x in 0..w {
                let xm = x as f64 + 0.5;
                if (21.0..24.0).contains(&xm) {
                    // Inside the 5 m gap, more than a pixel from its edges.
                    assert!(is_no_data(x, y), "({x}, {y}) should be empty");
                } else if !(20.0..25.0).contains(&xm) {
                    assert_eq!(img.get(x, y), ground, "({x}, {y})");
                }
            }
        }
        // The legend explains the hatching.
        assert!(is_no_data(w + 10 + 6, 6 + 16 + 5) || is_no_data(w + 10 + 5, 6 + 16 + 5));
    }
}
