//! `lidarsim compare`: two point clouds side by side with the field's
//! metrics over their common area ([`area`]), overall and per grid cell
//! ([`cells`]), optionally after thinning the denser to the other's pulse
//! density ([`thin`]). The metrics are in [`metrics`]; a [`Comparison`]
//! is written as `compare.json` (serde), as a table ([`table`]) and as a
//! self-contained page with plots and maps ([`html`]).

pub mod area;
pub mod cells;
pub mod html;
pub mod metrics;
pub mod prepare;
mod svg;
pub mod table;
pub mod thin;

use serde::Serialize;

use crate::scan::ScanCloud;
use crate::scan::ground::ground_model;
use cells::Cells;
use metrics::{Distributions, SCALARS, Values};

/// What a comparison is made with.
#[derive(Clone, Debug)]
pub struct CompareOptions {
    /// Compare only within `[xmin, ymin, xmax, ymax]`, m.
    pub area: Option<[f64; 4]>,
    /// Edge of the cells of the per-cell metrics, m.
    pub cell_m: f64,
    /// Thin the cloud of more pulses per m² to the other's first.
    pub match_density: bool,
    /// Seed of the thinning.
    pub seed: u64,
    /// The clouds' names.
    pub labels: [String; 2],
}

impl Default for CompareOptions {
    fn default() -> Self {
        Self {
            area: None,
            cell_m: 20.0,
            match_density: false,
            seed: 1,
            labels: ["A".into(), "B".into()],
        }
    }
}

/// Why two clouds could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// They share no area.
    #[error(
        "{a} ({ba}) and {b} ({bb}) share no area{within}: check that both are in the same \
         coordinates (a simulation writes [output] offset_m added)"
    )]
    Disjoint {
        /// The first cloud.
        a: String,
        /// Its bounds in words.
        ba: String,
        /// The second cloud.
        b: String,
        /// Its bounds in words.
        bb: String,
        /// " within the --area" when one was given.
        within: &'static str,
    },
    /// A bad option.
    #[error("{option}: {why}")]
    Option {
        /// The option.
        option: &'static str,
        /// What is wrong.
        why: String,
    },
    /// A cloud's ground could not be gridded.
    #[error("{0}: covers too large an area to grid its ground")]
    TooLarge(String),
}

/// One cloud's side of a comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Side {
    /// Its name.
    pub label: String,
    /// Its file.
    pub file: String,
    /// Its points in the common area (after any thinning).
    pub points: usize,
    /// Whether it holds first returns only.
    pub first_returns_only: bool,
    /// Its ground.
    pub ground: String,
    /// Whether its ground returns are class 2 (else the band near the
    /// ground).
    pub ground_by_class: bool,
    /// Share of its pulses kept by the density matching.
    pub kept_share: f64,
    /// Its metrics, by key.
    pub metrics: serde_json::Map<String, serde_json::Value>,
    /// Its distributions.
    pub distributions: Distributions,
}

/// A comparison of two clouds.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// The version that compared them.
    pub lidarsim_version: &'static str,
    /// The common area, m².
    pub area_m2: f64,
    /// Its bounds, m.
    pub bounds_m: [f64; 4],
    /// The first cloud.
    pub a: Side,
    /// The second.
    pub b: Side,
    /// B − A of each metric, by key.
    pub difference: serde_json::Map<String, serde_json::Value>,
    /// Whether the denser cloud was thinned to the other's pulse density.
    pub density_matched: bool,
    /// The per-cell metrics.
    pub cells: Cells,
    /// What the reader should know (first returns only, no ground class,
    /// thinning).
    pub notes: Vec<String>,
    /// The values as computed (for the table and the page).
    #[serde(skip)]
    pub values: [Values; 2],
}

/// Compares `a` with `b`.
pub fn compare(
    a: &ScanCloud,
    b: &ScanCloud,
    options: &CompareOptions,
) -> Result<Comparison, CompareError> {
    if !(options.cell_m.is_finite() && options.cell_m >= 1.0 && options.cell_m <= 10_000.0) {
        return Err(CompareError::Option {
            option: "--cell-m",
            why: format!("must be from 1 to 10000 m, got {}", options.cell_m),
        });
    }
    let (a, b) = (&*a.without_noise(), &*b.without_noise());
    let area = area::common_area(a, b, options.area, options.cell_m).ok_or_else(|| {
        let words = |c: &ScanCloud| {
            let b = c.bounds();
            format!("x {:.1}…{:.1}, y {:.1}…{:.1}", b[0], b[2], b[1], b[3])
        };
        CompareError::Disjoint {
            a: a.name.clone(),
            ba: words(a),
            b: b.name.clone(),
            bb: words(b),
            within: if options.area.is_some() {
                " within the --area"
            } else {
                ""
            },
        }
    })?;
    let ground =
        |c: &ScanCloud| ground_model(c).ok_or_else(|| CompareError::TooLarge(c.name.clone()));
    let (ga, gb) = (ground(a)?, ground(b)?);
    let (pa, pb) = (prepare::prepare(a, &ga), prepare::prepare(b, &gb));
    let inside = |c: &ScanCloud| -> Vec<bool> {
        (0..c.len())
            .map(|k| area.contains(c.x[k], c.y[k]))
            .collect()
    };
    let (mut keep_a, mut keep_b) = (inside(a), inside(b));
    let kept = if options.match_density {
        match_density((a, &mut keep_a), (b, &mut keep_b), options.seed)
    } else {
        [1.0, 1.0]
    };
    let idx = |keep: &[bool]| (0..keep.len()).filter(|&k| keep[k]).collect::<Vec<usize>>();
    let (ia, ib) = (idx(&keep_a), idx(&keep_b));
    let values = [
        metrics::values(&pa, &ia, area.area_m2),
        metrics::values(&pb, &ib, area.area_m2),
    ];
    let top =
        |p: &metrics::Prepared<'_>, i: &[usize]| i.iter().map(|&k| p.h[k]).fold(0.0f64, f64::max);
    let bins = (top(&pa, &ia).max(top(&pb, &ib)).ceil() as usize + 1).min(200);
    let cells = cells::cell_metrics((&pa, &keep_a), (&pb, &keep_b), &area);
    let side = |p: &metrics::Prepared<'_>,
                i: &[usize],
                v: &Values,
                label: &str,
                kept: f64,
                g: &crate::scan::ground::GroundModel| Side {
        label: label.to_string(),
        file: p.cloud.name.clone(),
        points: i.len(),
        first_returns_only: p.first_only,
        ground: g.describe(),
        ground_by_class: p.ground_by_class,
        kept_share: kept,
        metrics: keyed(v),
        distributions: metrics::distributions(p, i, bins),
    };
    let sa = side(&pa, &ia, &values[0], &options.labels[0], kept[0], &ga);
    let sb = side(&pb, &ib, &values[1], &options.labels[1], kept[1], &gb);
    let b0 = area.fine.corner_m;
    let notes = notes(&sa, &sb, options.match_density);
    Ok(Comparison {
        lidarsim_version: env!("CARGO_PKG_VERSION"),
        area_m2: area.area_m2,
        bounds_m: [
            b0[0],
            b0[1],
            b0[0] + area.fine.cols as f64 * area.fine.cell_m,
            b0[1] + area.fine.rows as f64 * area.fine.cell_m,
        ],
        difference: keyed(&difference(&values)),
        a: sa,
        b: sb,
        density_matched: options.match_density,
        cells,
        notes,
        values,
    })
}

/// Thins the cloud of more pulses (first returns among the points its
/// `keep` accepts) to the other's by pulse; returns the share of each
/// cloud's pulses kept.
fn match_density(
    (a, keep_a): (&ScanCloud, &mut [bool]),
    (b, keep_b): (&ScanCloud, &mut [bool]),
    seed: u64,
) -> [f64; 2] {
    let pulses = |c: &ScanCloud, keep: &[bool]| {
        (0..c.len()).filter(|&k| keep[k] && c.is_first(k)).count() as f64
    };
    let (na, nb) = (pulses(a, keep_a), pulses(b, keep_b));
    let (dense, keep, share, slot) = if na > nb {
        (a, keep_a, nb / na, 0)
    } else {
        (b, keep_b, na / nb.max(1.0), 1)
    };
    let thinned = thin::thin_by_pulse(dense, share, seed);
    keep.iter_mut().zip(thinned).for_each(|(k, t)| *k &= t);
    let mut kept = [1.0, 1.0];
    kept[slot] = share;
    kept
}

/// B − A of each metric.
fn difference(v: &[Values; 2]) -> Values {
    std::array::from_fn(|m| Some(v[1][m]? - v[0][m]?))
}

/// Metric values by key (`null` where there is none).
fn keyed(v: &Values) -> serde_json::Map<String, serde_json::Value> {
    SCALARS
        .iter()
        .zip(v)
        .map(|(s, x)| {
            (
                s.key.to_string(),
                x.map_or(serde_json::Value::Null, serde_json::Value::from),
            )
        })
        .collect()
}

/// What the reader should know about the two sides.
fn notes(a: &Side, b: &Side, matched: bool) -> Vec<String> {
    let mut out = Vec::new();
    for s in [a, b] {
        if s.first_returns_only {
            out.push(format!(
                "{} holds first returns only (its pulses had more): the metrics of later \
                 returns are left out for it, and its pulses are compared by their first \
                 return's number of returns",
                s.label
            ));
        }
        if !s.ground_by_class {
            out.push(format!(
                "{} has no ground class: its returns within {} m of its ground count as ground",
                s.label,
                metrics::GROUND_BAND_M
            ));
        }
        if matched && s.kept_share < 1.0 {
            out.push(format!(
                "{} thinned by pulse to the other's pulse density: {:.1} % of its pulses kept",
                s.label,
                100.0 * s.kept_share
            ));
        }
    }
    out.push(
        "intensities of different instruments are not comparable: compare the ratios, not \
         the means"
            .into(),
    );
    out
}

/// The files `lidarsim compare` writes and the marker of its directory.
pub const OWN: crate::owned::OwnFiles = crate::owned::OwnFiles {
    command: "compare",
    files: &["compare.json", "compare.html"],
    marker: ".lidarsim-compare",
};

/// Writes `compare.json` and `compare.html` into `dir` (see
/// [`crate::owned`] for which directories it may write).
pub fn write_comparison(
    c: &Comparison,
    dir: &std::path::Path,
    overwrite: bool,
) -> Result<(), crate::output::WriteError> {
    OWN.claim(dir, overwrite)?;
    let json = serde_json::to_string_pretty(c).map_err(|e| {
        crate::output::WriteError::new(
            &dir.join("compare.json"),
            crate::output::WriteCause::Unsupported(e.to_string()),
        )
    })?;
    for (name, text) in [
        ("compare.json", json + "\n"),
        ("compare.html", html::page(c)),
    ] {
        let path = dir.join(name);
        crate::output::write_atomic(&path, text.as_bytes())?;
    }
    OWN.mark(dir)
}
