//! Cross-sections of a cloud: the points of a band along a segment, by
//! distance along it and height, with a height axis, optionally with the
//! heights stretched to fill the picture.

use super::figure::{Anchor, Figure, LABEL_PX};
use super::frame::{FOOTER_HEIGHT, LEGEND_WIDTH, scale_bar};
use super::image::{BACKGROUND, INK};
use super::labels::{fixed, nice_ticks};
use super::limits::{MAX_SIDE_PX, TooLarge, cells, fit_resolution};
use super::palette::{ColorBy, Palette};
use super::{Image, RenderPoint};

/// Background of a cross-section: air, where no point is expected.
pub const EMPTY: [u8; 3] = [235, 235, 235];
/// Width of the height axis left of a cross-section, px.
pub const PROFILE_AXIS_PX: usize = 48;

/// The points of a cross-section band, by distance along it.
struct Section<'a> {
    /// (distance along the segment, point).
    sel: Vec<(f64, &'a RenderPoint)>,
    /// Length of the segment, m.
    len: f64,
    /// Heights of the bottom and top of the picture, m (the points' range
    /// and 1 m more on each side).
    z0: f64,
    z1: f64,
}

impl<'a> Section<'a> {
    fn select(points: &'a [RenderPoint], a: (f64, f64), b: (f64, f64), width_m: f64) -> Self {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy).max(1e-9);
        let (ux, uy) = (dx / len, dy / len);
        let sel: Vec<(f64, &RenderPoint)> = points
            .iter()
            .filter_map(|p| {
                let (rx, ry) = (p.x - a.0, p.y - a.1);
                let along = rx * ux + ry * uy;
                let across = -rx * uy + ry * ux;
                ((0.0..=len).contains(&along) && across.abs() <= 0.5 * width_m)
                    .then_some((along, p))
            })
            .collect();
        let (z0, z1) = sel.iter().fold((f64::MAX, f64::MIN), |(lo, hi), (_, p)| {
            (lo.min(p.z), hi.max(p.z))
        });
        let (z0, z1) = if sel.is_empty() {
            (0.0, 1.0)
        } else {
            (z0 - 1.0, z1 + 1.0)
        };
        Self { sel, len, z0, z1 }
    }

    /// The picture at `res_h` m per pixel along the segment and `res_v` m
    /// per pixel in height: heights on an axis to the left, the legend to
    /// the right, a scale bar below (with the vertical exaggeration when
    /// the two differ). Each point is a 2 × 2 px dot, so that a thin
    /// layer (a road, a roof) shows as a line.
    fn draw(&self, by: ColorBy, res_h: f64, res_v: f64) -> Figure {
        let w = cells(self.len, res_h) as usize;
        let h = cells(self.z1 - self.z0, res_v) as usize;
        let palette = Palette::new(self.sel.iter().map(|(_, p)| *p), by);
        let left = PROFILE_AXIS_PX;
        let mut fig = Figure::new(
            left + w + LEGEND_WIDTH,
            (h + FOOTER_HEIGHT).max(200),
            BACKGROUND,
        );
        let mut dots = Image::new(w, h, EMPTY);
        for (along, p) in &self.sel {
            let i = ((along / res_h) as usize).min(w - 1);
            let j = h - 1 - (((p.z - self.z0) / res_v) as usize).min(h - 1);
            dots.fill(i, j, 2, 2, palette.color(p));
        }
        fig.raster(left, 0, dots);
        self.height_axis(&mut fig, h, res_v);
        palette.draw(&mut fig, left + w + 10, 0, h.max(200 - FOOTER_HEIGHT));
        let end = scale_bar(&mut fig, left + 10, h + 18, w, res_h);
        let exaggeration = res_h / res_v;
        if (exaggeration - 1.0).abs() > 0.01 {
            let words = format!("heights × {}", fixed(exaggeration, 1));
            fig.text(
                end + 18.0,
                h as f64 + 13.0,
                &words,
                LABEL_PX,
                Anchor::Start,
                INK,
            );
        }
        fig
    }

    /// The height axis left of a `h` px tall picture: ticks at round
    /// heights at least 30 px apart, labelled, and the axis's name.
    fn height_axis(&self, fig: &mut Figure, h: usize, res_v: f64) {
        let left = PROFILE_AXIS_PX as f64;
        let z_top = self.z0 + h as f64 * res_v;
        let (ticks, decimals) = nice_ticks(self.z0, z_top, (h / 30).max(2));
        for t in ticks {
            let j = (h - 1 - (((t - self.z0) / res_v) as usize).min(h - 1)) as f64;
            fig.rect(left - 4.0, j, 4.0, 1.0, INK);
            let y = (j - 7.0).clamp(0.0, (h as f64 - 14.0).max(0.0));
            fig.text(
                left - 6.0,
                y,
                &fixed(t, decimals),
                LABEL_PX,
                Anchor::End,
                INK,
            );
        }
        fig.rect(left - 1.0, 0.0, 1.0, h as f64, INK);
        fig.text(2.0, h as f64 + 13.0, "z, m", LABEL_PX, Anchor::Start, INK);
    }
}

/// A cross-section: the points within `width_m / 2` of the segment from
/// `a` to `b` (x, y), drawn by distance along it (horizontal) and height
/// (vertical), at `resolution_m` per pixel in both directions (default:
/// 1200 px along the segment, at least 5 cm, coarsened if needed to fit
/// the limits; a requested one at which the map would exceed them is an
/// error).
pub fn profile(
    points: &[RenderPoint],
    a: (f64, f64),
    b: (f64, f64),
    width_m: f64,
    by: ColorBy,
    resolution_m: Option<f64>,
) -> Result<Figure, TooLarge> {
    let s = Section::select(points, a, b, width_m);
    let res = fit_resolution(s.len, s.z1 - s.z0, resolution_m, || {
        (s.len / 1200.0).max(0.05)
    })?;
    Ok(s.draw(by, res, res))
}

/// A cross-section like [`profile`] with its heights stretched (or
/// squeezed) to fill `height_px` rows, at `resolution_m` per pixel along
/// the segment (coarsened to at most [`MAX_SIDE_PX`] columns); the scale
/// bar states the vertical exaggeration.
pub fn profile_exaggerated(
    points: &[RenderPoint],
    a: (f64, f64),
    b: (f64, f64),
    width_m: f64,
    by: ColorBy,
    resolution_m: f64,
    height_px: usize,
) -> Figure {
    let s = Section::select(points, a, b, width_m);
    let res_h = resolution_m.max(s.len / (MAX_SIDE_PX - 1) as f64);
    let rows = height_px.clamp(2, 2000);
    // A little under (z1 − z0) / (rows − 1), so that rounding never adds
    // a row.
    let res_v = (s.z1 - s.z0) / (rows as f64 - 0.5);
    s.draw(by, res_h, res_v)
}

/// The row of a profile image at height `z` for a profile whose points span
/// `[z_min, z_max]` at `resolution_m` (the inverse of the mapping above).
pub fn profile_row(z: f64, z_min: f64, z_max: f64, resolution_m: f64) -> usize {
    let (z0, z1) = (z_min - 1.0, z_max + 1.0);
    let h = cells(z1 - z0, resolution_m) as usize;
    h - 1 - (((z - z0) / resolution_m) as usize).min(h - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::testing::pt;

    #[test]
    fn a_gabled_roof_profile_puts_the_roof_line_at_its_rows() {
        // Roof across x: eaves at x = ±10 (z = 6), ridge at x = 0 (z = 12).
        let pts: Vec<RenderPoint> = (-100..=100)
            .flat_map(|i| {
                let x = i as f64 * 0.1;
                (0..5).map(move |j| pt(x, j as f64 * 0.2, 12.0 - 0.6 * x.abs(), 6))
            })
            .collect();
        let res = 0.1;
        let img = profile(
            &pts,
            (-10.0, 0.4),
            (10.0, 0.4),
            2.0,
            ColorBy::Class,
            Some(res),
        )
        .unwrap()
        .to_image();
        let ink = |x: usize| (0..img.height - FOOTER_HEIGHT).find(|&y| img.get(x, y) != EMPTY);
        for (x_m, z) in [(0.0, 12.0), (-5.0, 9.0), (5.0, 9.0), (-9.9, 6.06)] {
            let col = PROFILE_AXIS_PX + ((x_m + 10.0) / res) as usize;
            let want = profile_row(z, 6.0, 12.0, res);
            let got = ink(col).unwrap();
            assert!(got.abs_diff(want) <= 1, "x {x_m}: row {got} vs {want}");
        }
    }

    #[test]
    fn an_exaggerated_profile_fills_its_height() {
        // The gabled roof again, eaves at 6 m and ridge at 12 m: with 1 m
        // margins the picture spans 5–13 m over 300 rows.
        let pts: Vec<RenderPoint> = (-100..=100)
            .map(|i| {
                let x = i as f64 * 0.1;
                pt(x, 0.0, 12.0 - 0.6 * x.abs(), 6)
            })
            .collect();
        let img = profile_exaggerated(
            &pts,
            (-10.0, 0.0),
            (10.0, 0.0),
            2.0,
            ColorBy::Class,
            0.1,
            300,
        )
        .to_image();
        let ink = |x: usize| (0..300).find(|&y| img.get(x, y) != EMPTY);
        let row = |z: f64| (13.0 - z) / 8.0 * 300.0;
        for (x_m, z) in [(0.0, 12.0), (-10.0, 6.0), (5.0, 9.0)] {
            let col = PROFILE_AXIS_PX + ((x_m + 10.0) / 0.1) as usize;
            let got = ink(col.min(PROFILE_AXIS_PX + 200)).unwrap() as f64;
            // Within 3 rows (1 %): a column may also hold the next point.
            assert!(
                (got - row(z)).abs() <= 3.0,
                "z {z}: row {got} vs {}",
                row(z)
            );
        }
        // Rows 300 and below are the footer.
        assert!((300..img.height).all(|y| img.get(PROFILE_AXIS_PX + 100, y) != EMPTY));
    }
}
