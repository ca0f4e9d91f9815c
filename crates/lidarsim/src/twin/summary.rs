//! A twin in a few lines of text: what was read from the scan, where each
//! value came from and how far the strips agree (`lidarsim twin` prints
//! them; `twin.json` holds the same and more).

use super::Twin;
use super::acquisition::combine::{Deflector, Estimate, Flight};
use crate::message::num;

/// `v` rounded to `digits` decimals, as text.
fn r(v: f64, digits: i32) -> String {
    let f = 10f64.powi(digits);
    num((v * f).round() / f)
}

/// An estimate with its unit, source and the strips' range: "77.8 Hz
/// (read; strips 77.5–78.1)".
fn est(e: &Estimate, digits: i32, unit: &str) -> String {
    let range = e
        .range
        .map(|[lo, hi]| format!("; strips {}–{}", r(lo, digits), r(hi, digits)))
        .unwrap_or_default();
    format!("{}{unit} ({}{range})", r(e.value, digits), e.source)
}

/// One strip in a line.
fn strip_line(strip: &super::acquisition::StripReport) -> String {
    let track = strip.track.as_ref().map_or_else(
        || strip.track_problem.clone().unwrap_or_default(),
        |tr| {
            format!(
                "heading {} deg, {} m/s, {} ± {} m above ground",
                r(tr.heading_deg, 0),
                r(tr.speed_mps, 1),
                r(tr.height_m, 0),
                r(tr.height_se_m, 0)
            )
        },
    );
    format!(
        "strip {}: {} first returns over {} s, angles {}…{} deg, {} per m²; {track}",
        strip.strip,
        strip.first_returns,
        r(strip.duration_s, 2),
        r(strip.scan_angle_deg[0], 1),
        r(strip.scan_angle_deg[1], 1),
        r(strip.pulse_density_per_m2, 2),
    )
}

impl Twin {
    /// The twin in lines of text.
    pub fn summary_lines(&self) -> Vec<String> {
        let s = &self.scan;
        let a = &self.acquisition;
        let t = &self.tree_report;
        let mut out = vec![
            format!(
                "scan: LAS {} point format {}, {} points{}, {} ha{}",
                s.las_version,
                s.point_format,
                s.points,
                if s.first_returns_only {
                    " (first returns only)"
                } else {
                    ""
                },
                r(s.area_m2 / 10_000.0, 2),
                s.crs.as_ref().map(|c| format!(", {c}")).unwrap_or_default()
            ),
            format!("ground: {}", self.ground.describe()),
            format!(
                "trees: {} ({} per ha, species {}), heights {} / {} / {} m (5th, 50th, 95th \
                 percentile), crown radii {} / {} / {} m",
                t.trees,
                r(t.trees_per_ha, 0),
                t.species,
                r(t.height_m[0], 1),
                r(t.height_m[1], 1),
                r(t.height_m[2], 1),
                r(t.crown_radius_m[0], 1),
                r(t.crown_radius_m[1], 1),
                r(t.crown_radius_m[2], 1),
            ),
            format!(
                "canopy: {} % of the area above 2 m; the crowns cover {} % of it (discs of \
                 each crown's area would cover {} %) and {} % of the gaps",
                r(100.0 * t.canopy_share, 0),
                r(100.0 * t.crowns_cover_of_canopy, 0),
                r(100.0 * t.equal_area_cover_of_canopy, 0),
                r(100.0 * t.crowns_cover_of_gaps, 0),
            ),
        ];
        out.extend(a.strips.iter().map(strip_line));
        let sc = &a.scanner;
        let deflector = match sc.deflector {
            Deflector::Oscillating => "oscillating mirror (triangle)".to_string(),
            Deflector::Polygon { facets } => format!("rotating polygon of {facets} facets"),
        };
        out.push(format!(
            "scanner: {deflector}, {}, ±{}, PRF {}{}, up to {} returns",
            est(&sc.scan_frequency_hz, 2, " Hz"),
            est(&sc.scan_angle_deg, 1, " deg"),
            est(&sc.prf_hz, 0, " Hz"),
            a.timing_prf_hz
                .map(|p| format!(" (the time steps show {} Hz)", r(p, 0)))
                .unwrap_or_default(),
            sc.max_returns,
        ));
        out.push(format!(
            "flight: {}, flying height {}, speed {}, {} first returns per m²",
            match &a.flight {
                Flight::Lines(l) => format!("{} lines, one per strip", l.len()),
                Flight::Plan(p) => format!(
                    "lines planned {} m apart at heading {} deg",
                    r(p.line_spacing_m, 1),
                    r(p.heading_deg, 0)
                ),
            },
            est(&a.flying_height_m, 0, " m"),
            est(&a.speed_mps, 1, " m/s"),
            r(a.pulse_density_per_m2, 2),
        ));
        for sp in &a.line_spacing {
            out.push(format!(
                "strips {} and {}: {} m apart, side overlap {} %",
                sp.strips[0],
                sp.strips[1],
                r(sp.distance_m, 0),
                r(100.0 * sp.side_overlap, 0)
            ));
        }
        out.extend(a.notes.iter().map(|n| format!("note: {n}")));
        out.extend(
            super::write::NOT_MODELLED
                .iter()
                .map(|n| format!("not modelled: {n}")),
        );
        out
    }
}
