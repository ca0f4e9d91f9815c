//! Small SVG plots written as text, for a page that needs no script, font
//! file or network: grouped bars, lines, cell maps and histograms.

use std::fmt::Write as _;

/// The first cloud's colour.
pub const COLOUR_A: &str = "#3b528b";
/// The second cloud's colour.
pub const COLOUR_B: &str = "#e6550d";

/// Plot size and margins, px.
const W: f64 = 420.0;
const H: f64 = 260.0;
const LEFT: f64 = 52.0;
const RIGHT: f64 = 12.0;
const TOP: f64 = 28.0;
const BOTTOM: f64 = 40.0;

/// `s` with `&`, `<`, `>` and `"` escaped.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A number for an axis: few digits.
fn tick(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else if v.abs() >= 1.0 {
        format!("{:.1}", v).trim_end_matches(".0").to_string()
    } else {
        format!("{v:.2}")
    }
}

/// Round steps covering `lo..hi` (about five).
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / 5.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p);
    let first = (lo / step - 1e-9).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    (first..=last.min(first + 12))
        .map(|k| k as f64 * step)
        .collect()
}

/// A plot frame: the SVG start, title, axes with ticks; returns the text
/// and the functions from data to pixels.
fn frame(
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    (x_label, y_label): (&str, &str),
) -> (String, impl Fn(f64) -> f64, impl Fn(f64) -> f64) {
    let px = move |x: f64| LEFT + (x - x0) / (x1 - x0).max(1e-12) * (W - LEFT - RIGHT);
    let py = move |y: f64| H - BOTTOM - (y - y0) / (y1 - y0).max(1e-12) * (H - TOP - BOTTOM);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" \
         font-family=\"sans-serif\" font-size=\"11\"><text x=\"{}\" y=\"16\" \
         text-anchor=\"middle\" font-weight=\"bold\">{}</text>",
        W / 2.0,
        esc(title)
    );
    for t in ticks(y0, y1) {
        let y = py(t);
        let _ = write!(
            s,
            "<line x1=\"{LEFT}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/>\
             <text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            W - RIGHT,
            LEFT - 4.0,
            y + 4.0,
            tick(t)
        );
    }
    for t in ticks(x0, x1) {
        let x = px(t);
        let _ = write!(
            s,
            "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            H - BOTTOM + 14.0,
            tick(t)
        );
    }
    let _ = write!(
        s,
        "<rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{}\" height=\"{}\" fill=\"none\" \
         stroke=\"#888\"/><text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\
         <text transform=\"translate(12,{}) rotate(-90)\" text-anchor=\"middle\">{}</text>",
        W - LEFT - RIGHT,
        H - TOP - BOTTOM,
        (LEFT + W - RIGHT) / 2.0,
        H - 6.0,
        esc(x_label),
        (TOP + H - BOTTOM) / 2.0,
        esc(y_label)
    );
    (s, px, py)
}

/// A legend of the two clouds at the top right.
fn legend(s: &mut String, labels: [&str; 2]) {
    for (i, (label, colour)) in labels.iter().zip([COLOUR_A, COLOUR_B]).enumerate() {
        let y = TOP + 10.0 + 14.0 * i as f64;
        let _ = write!(
            s,
            "<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{colour}\"/>\
             <text x=\"{}\" y=\"{}\">{}</text>",
            W - RIGHT - 110.0,
            y - 9.0,
            W - RIGHT - 96.0,
            y,
            esc(label)
        );
    }
}

/// Grouped bars: `values[s][c]` of series s (the two clouds) in category
/// c.
pub fn bars(
    title: &str,
    categories: &[&str],
    values: [&[f64]; 2],
    labels: [&str; 2],
    y_label: &str,
) -> String {
    let top = values
        .iter()
        .flat_map(|v| v.iter())
        .fold(0.0f64, |m, &v| m.max(v))
        * 1.1;
    let n = categories.len() as f64;
    let (mut s, px, py) = frame(title, (0.0, n), (0.0, top.max(1e-9)), ("", y_label));
    s = s.replace(
        "text-anchor=\"middle\">0</text>",
        "text-anchor=\"middle\"></text>",
    );
    for (c, name) in categories.iter().enumerate() {
        for (k, (v, colour)) in values.iter().zip([COLOUR_A, COLOUR_B]).enumerate() {
            let value = v.get(c).copied().unwrap_or(0.0);
            let x = px(c as f64 + 0.1 + 0.4 * k as f64);
            let w = px(0.4) - px(0.0);
            let _ = write!(
                s,
                "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"{w:.1}\" height=\"{:.1}\" fill=\"{colour}\"><title>{}: {value:.4}</title></rect>",
                py(value),
                py(0.0) - py(value),
                esc(name)
            );
        }
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            px(c as f64 + 0.5),
            H - BOTTOM + 26.0,
            esc(name)
        );
    }
    legend(&mut s, labels);
    s + "</svg>"
}

/// A line of a plot: its name, `(x, y)` points, colour and whether it is
/// dashed.
pub type Series<'a> = (&'a str, Vec<(f64, f64)>, &'a str, bool);

/// Lines through `(x, y)` points, each of its colour, dashed or not.
pub fn lines(
    title: &str,
    series: &[Series<'_>],
    labels: [&str; 2],
    (x_label, y_label): (&str, &str),
) -> String {
    let all = series.iter().flat_map(|s| s.1.iter());
    let (mut x0, mut x1, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
    for &(x, y) in all {
        (x0, x1, y1) = (x0.min(x), x1.max(x), y1.max(y));
    }
    if !x0.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    let (mut s, px, py) = frame(
        title,
        (x0.min(0.0), x1),
        (0.0, y1 * 1.05),
        (x_label, y_label),
    );
    for (name, points, colour, dashed) in series {
        let path: Vec<String> = points
            .iter()
            .map(|&(x, y)| format!("{:.1},{:.1}", px(x), py(y)))
            .collect();
        let _ = write!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.6\"{}><title>{}</title></polyline>",
            path.join(" "),
            if *dashed {
                " stroke-dasharray=\"4 3\""
            } else {
                ""
            },
            esc(name)
        );
    }
    legend(&mut s, labels);
    s + "</svg>"
}

/// The colour of `v` in `range`: viridis, or blue–white–red when
/// `diverging` (0 white).
fn colour(v: f64, (lo, hi): (f64, f64), diverging: bool) -> String {
    if diverging {
        let m = lo.abs().max(hi.abs()).max(1e-12);
        let t = (v / m).clamp(-1.0, 1.0);
        let (r, g, b) = if t < 0.0 {
            (255.0 * (1.0 + t), 255.0 * (1.0 + t), 255.0)
        } else {
            (255.0, 255.0 * (1.0 - t), 255.0 * (1.0 - t))
        };
        format!("rgb({:.0},{:.0},{:.0})", r, g, b)
    } else {
        let [r, g, b] = crate::render::ramp((v - lo) / (hi - lo).max(1e-12));
        format!("rgb({r},{g},{b})")
    }
}

/// A map of cell values (`values[row · cols + col]`, row 0 the south),
/// `None` hatched grey, with a colour bar.
pub fn map(
    title: &str,
    (cols, rows): (usize, usize),
    values: &[Option<f64>],
    range: (f64, f64),
    diverging: bool,
    unit: &str,
) -> String {
    let size = (220.0 / cols.max(rows).max(1) as f64).clamp(2.0, 40.0);
    let (w, h) = (cols as f64 * size, rows as f64 * size);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0}\" height=\"{:.0}\" \
         font-family=\"sans-serif\" font-size=\"11\"><text x=\"4\" y=\"14\" \
         font-weight=\"bold\">{}</text>",
        w.max(160.0) + 70.0,
        h + 30.0,
        esc(title)
    );
    for r in 0..rows {
        for c in 0..cols {
            let (x, y) = (c as f64 * size, 22.0 + (rows - 1 - r) as f64 * size);
            let fill = values[r * cols + c]
                .map_or_else(|| "#eee".to_string(), |v| colour(v, range, diverging));
            let tip = values[r * cols + c]
                .map_or_else(|| "no value".to_string(), |v| format!("{v:.4} {unit}"));
            let _ = write!(
                s,
                "<rect x=\"{x:.1}\" y=\"{y:.1}\" width=\"{size:.1}\" height=\"{size:.1}\" fill=\"{fill}\"><title>{}</title></rect>",
                esc(&tip)
            );
        }
    }
    // The colour bar: ten steps from the bottom (low) to the top (high).
    let bx = w.max(160.0) + 8.0;
    for k in 0..10 {
        let v = range.0 + (range.1 - range.0) * (k as f64 + 0.5) / 10.0;
        let _ = write!(
            s,
            "<rect x=\"{bx:.1}\" y=\"{:.1}\" width=\"12\" height=\"{:.1}\" fill=\"{}\"/>",
            22.0 + h * (9 - k) as f64 / 10.0,
            h / 10.0,
            colour(v, range, diverging)
        );
    }
    let _ = write!(
        s,
        "<text x=\"{:.1}\" y=\"30\">{}</text><text x=\"{:.1}\" y=\"{:.1}\">{}</text></svg>",
        bx + 15.0,
        esc(&format!("{} {unit}", tick(range.1))),
        bx + 15.0,
        22.0 + h,
        esc(&format!("{} {unit}", tick(range.0)))
    );
    s
}

/// A histogram of `values` with vertical marks `(x, colour, name)`.
pub fn histogram(
    title: &str,
    values: &[f64],
    marks: &[(f64, &str, &str)],
    x_label: &str,
) -> String {
    let (mut lo, mut hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    for &(m, _, _) in marks {
        (lo, hi) = (lo.min(m), hi.max(m));
    }
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        (lo, hi) = (lo - 1.0, hi + 1.0);
    }
    let bins = 20usize;
    let mut counts = vec![0.0f64; bins];
    for &v in values {
        let b = (((v - lo) / (hi - lo)) * bins as f64)
            .floor()
            .clamp(0.0, (bins - 1) as f64) as usize;
        counts[b] += 1.0;
    }
    let top = counts.iter().fold(1.0f64, |m, &c| m.max(c));
    let (mut s, px, py) = frame(title, (lo, hi), (0.0, top * 1.1), (x_label, "cells"));
    let step = (hi - lo) / bins as f64;
    for (b, &c) in counts.iter().enumerate() {
        let x = lo + b as f64 * step;
        let _ = write!(
            s,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#9ecae1\" stroke=\"#fff\"/>",
            px(x),
            py(c),
            px(x + step) - px(x),
            py(0.0) - py(c)
        );
    }
    for (i, &(m, colour, name)) in marks.iter().enumerate() {
        let _ = write!(
            s,
            "<line x1=\"{0:.1}\" x2=\"{0:.1}\" y1=\"{TOP}\" y2=\"{1}\" stroke=\"{colour}\" stroke-width=\"2\"/>\
             <text x=\"{2:.1}\" y=\"{3}\" fill=\"{colour}\">{4}</text>",
            px(m),
            H - BOTTOM,
            px(m) + 3.0,
            TOP + 12.0 + 12.0 * i as f64,
            esc(name)
        );
    }
    s + "</svg>"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let t = ticks(0.0, 1.0);
        assert_eq!(t.len(), 6);
        assert!(
            t.iter()
                .enumerate()
                .all(|(k, v)| (v - 0.2 * k as f64).abs() < 1e-12)
        );
        assert_eq!(ticks(3.0, 47.0), vec![10.0, 20.0, 30.0, 40.0]);
        assert!(ticks(-5.0, 5.0).contains(&0.0));
    }

    #[test]
    fn plots_are_whole_svg_elements_with_escaped_text() {
        let b = bars(
            "a < b",
            &["1", "2"],
            [&[0.5, 0.25], &[0.4, 0.3]],
            ["x&y", "B"],
            "share",
        );
        assert!(b.starts_with("<svg") && b.ends_with("</svg>") && b.contains("a &lt; b"));
        assert!(b.contains("x&amp;y") && !b.contains("x&y"));
        let m = map("m", (2, 1), &[Some(1.0), None], (0.0, 2.0), false, "m");
        assert_eq!(m.matches("<rect").count(), 2 + 10);
        let h = histogram("h", &[1.0, 2.0, 2.5], &[(2.0, COLOUR_A, "mean")], "d");
        assert!(h.contains("mean") && h.ends_with("</svg>"));
    }
}
