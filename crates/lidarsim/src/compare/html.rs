//! `compare.html`: one self-contained page (inline SVG, no script, no
//! network) — the table, the distributions, the vertical profiles and
//! height percentiles, and per-cell maps of both clouds and of their
//! difference with a histogram of the differences against their standard
//! error and the cells' own spread.

use std::fmt::Write as _;

use super::Comparison;
use super::metrics::{PERCENTILES, SCALARS};
use super::svg::{self, COLOUR_A, COLOUR_B, esc};
use super::table::rows;

/// The metrics mapped cell by cell, by key.
const MAPPED: [&str; 7] = [
    "pulse_density_per_m2",
    "canopy_cover",
    "first_p95",
    "single_return_share",
    "canopy_single_share",
    "first_ground_share",
    "returns_per_pulse",
];

/// The page.
pub fn page(c: &Comparison) -> String {
    let mut h = String::from(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>lidarsim compare</title>\
         <style>body{font-family:sans-serif;margin:2em;max-width:1400px}\
         table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;\
         text-align:right}td:first-child,th:first-child{text-align:left}\
         .plots{display:flex;flex-wrap:wrap;gap:12px}</style></head><body>",
    );
    let (a, b) = (&c.a, &c.b);
    let _ = write!(
        h,
        "<h1>{} against {}</h1><p>{}: <code>{}</code>, {} points; {}: <code>{}</code>, {} \
         points; common area {:.0} m² within x {:.1}…{:.1}, y {:.1}…{:.1}{}.</p><ul>",
        esc(&b.label),
        esc(&a.label),
        esc(&a.label),
        esc(&a.file),
        a.points,
        esc(&b.label),
        esc(&b.file),
        b.points,
        c.area_m2,
        c.bounds_m[0],
        c.bounds_m[2],
        c.bounds_m[1],
        c.bounds_m[3],
        if c.density_matched {
            ", the denser thinned by pulse to the other's pulse density"
        } else {
            ""
        }
    );
    for n in &c.notes {
        let _ = write!(h, "<li>{}</li>", esc(n));
    }
    let _ = write!(
        h,
        "<li>{}: ground {}</li><li>{}: ground {}</li></ul>",
        esc(&a.label),
        esc(&a.ground),
        esc(&b.label),
        esc(&b.ground)
    );
    table(&mut h, c);
    distributions(&mut h, c);
    maps(&mut h, c);
    h.push_str("</body></html>\n");
    h
}

/// The table of metrics.
fn table(h: &mut String, c: &Comparison) {
    let _ = write!(
        h,
        "<h2>Metrics</h2><table><tr><th>metric</th><th>{}</th><th>{}</th><th>{} − {}</th>\
         <th>per {} m cell: mean difference ± se (z)</th><th>sd of {}'s cells</th></tr>",
        esc(&c.a.label),
        esc(&c.b.label),
        esc(&c.b.label),
        esc(&c.a.label),
        c.cells.cell_m,
        esc(&c.a.label)
    );
    for row in rows(c) {
        h.push_str("<tr>");
        for cell in row {
            let _ = write!(h, "<td>{}</td>", esc(&cell));
        }
        h.push_str("</tr>");
    }
    h.push_str(
        "</table><p>z is the cells' mean difference over its standard error: within ±2 the \
         two clouds agree within their sampling spread. A metric the cloud cannot give (first \
         returns only, no ground in a cell, fewer than 10 vegetation returns) is –.</p>",
    );
}

/// Returns per pulse, return numbers, profiles and percentiles.
fn distributions(h: &mut String, c: &Comparison) {
    let labels = [c.a.label.as_str(), c.b.label.as_str()];
    let cats = ["1", "2", "3", "4", "≥5"];
    let (da, db) = (&c.a.distributions, &c.b.distributions);
    h.push_str("<h2>Distributions</h2><div class=\"plots\">");
    h.push_str(&svg::bars(
        "Pulses by number of returns",
        &cats,
        [&da.number_of_returns, &db.number_of_returns],
        labels,
        "share of pulses",
    ));
    h.push_str(&svg::bars(
        "Returns by return number",
        &cats,
        [&da.return_number, &db.return_number],
        labels,
        "share of returns",
    ));
    let profile = |p: &[f64]| {
        p.iter()
            .enumerate()
            .map(|(k, &v)| (v, k as f64 + 0.5))
            .collect::<Vec<_>>()
    };
    h.push_str(&svg::lines(
        "Vertical profile (solid all returns, dashed first)",
        &[
            ("all", profile(&da.profile_all), COLOUR_A, false),
            ("first", profile(&da.profile_first), COLOUR_A, true),
            ("all", profile(&db.profile_all), COLOUR_B, false),
            ("first", profile(&db.profile_first), COLOUR_B, true),
        ],
        labels,
        ("share of returns per metre", "height above ground, m"),
    ));
    let pct = |v: &super::Values, from: usize| {
        PERCENTILES
            .iter()
            .enumerate()
            .filter_map(|(i, &q)| v[from + i].map(|x| (f64::from(q), x)))
            .collect::<Vec<_>>()
    };
    h.push_str(&svg::lines(
        "Vegetation height percentiles (solid all, dashed first)",
        &[
            ("all", pct(&c.values[0], 17), COLOUR_A, false),
            ("first", pct(&c.values[0], 10), COLOUR_A, true),
            ("all", pct(&c.values[1], 17), COLOUR_B, false),
            ("first", pct(&c.values[1], 10), COLOUR_B, true),
        ],
        labels,
        ("percentile", "height above ground, m"),
    ));
    h.push_str("</div>");
}

/// For each mapped metric: both clouds' cells, their difference, and the
/// histogram of the differences.
fn maps(h: &mut String, c: &Comparison) {
    let g = &c.cells;
    let _ = write!(h, "<h2>Per cell ({} m)</h2>", g.cell_m);
    for key in MAPPED {
        let Some(m) = SCALARS.iter().position(|s| s.key == key) else {
            continue;
        };
        let (s, cm) = (&SCALARS[m], &g.metrics[m]);
        let scale = if s.unit == "%" { 100.0 } else { 1.0 };
        let unit = if s.unit == "%" { "%" } else { s.unit };
        // Back onto the whole grid: the used cells hold the values in order.
        let spread = |v: &[Option<f64>]| {
            let mut it = v.iter();
            (0..g.used.len())
                .map(|i| {
                    if g.used[i] {
                        it.next().copied().flatten().map(|x| x * scale)
                    } else {
                        None
                    }
                })
                .collect::<Vec<_>>()
        };
        let (va, vb) = (spread(&cm.a), spread(&cm.b));
        let diff: Vec<Option<f64>> = va
            .iter()
            .zip(&vb)
            .map(|(x, y)| Some((*y)? - (*x)?))
            .collect();
        let range = va
            .iter()
            .chain(&vb)
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &v| {
                (l.min(v), u.max(v))
            });
        if !range.0.is_finite() {
            continue;
        }
        let dr = diff.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let _ = write!(h, "<h3>{}</h3><div class=\"plots\">", esc(s.label));
        h.push_str(&svg::map(
            &c.a.label,
            (g.cols, g.rows),
            &va,
            range,
            false,
            unit,
        ));
        h.push_str(&svg::map(
            &c.b.label,
            (g.cols, g.rows),
            &vb,
            range,
            false,
            unit,
        ));
        h.push_str(&svg::map(
            &format!("{} − {}", c.b.label, c.a.label),
            (g.cols, g.rows),
            &diff,
            (-dr, dr),
            true,
            unit,
        ));
        let d: Vec<f64> = diff.iter().flatten().copied().collect();
        let mut marks = Vec::new();
        let mark = |v: Option<f64>| v.map(|x| x * scale);
        if let (Some(mean), Some(se)) = (mark(cm.mean_difference), mark(cm.se_difference)) {
            marks.push((mean, COLOUR_B, "mean"));
            marks.push((mean - 2.0 * se, "#999", "−2 se"));
            marks.push((mean + 2.0 * se, "#999", "+2 se"));
        }
        if let Some(sd) = mark(cm.sd_a) {
            marks.push((sd, COLOUR_A, "sd of A's cells"));
            marks.push((-sd, COLOUR_A, ""));
        }
        h.push_str(&svg::histogram("Differences per cell", &d, &marks, unit));
        h.push_str("</div>");
    }
}
