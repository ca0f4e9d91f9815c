//! A comparison as a table of text: each metric's value in both clouds,
//! B − A, and the per-cell mean difference against its standard error and
//! the first cloud's cell spread.

use super::Comparison;
use super::metrics::{SCALARS, Scalar};

/// `v` in `s`'s unit for reading: shares in per cent.
pub fn shown(s: &Scalar, v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(v) if s.unit == "%" => format!("{:.1} %", 100.0 * v),
        Some(v) if s.unit == "m" => format!("{v:.2} m"),
        Some(v) if s.unit == "/m²" => format!("{v:.2}"),
        Some(v) if v.abs() >= 100.0 => format!("{v:.0}"),
        Some(v) => format!("{v:.3}"),
    }
}

/// A difference in `s`'s unit, with its sign.
pub fn shown_difference(s: &Scalar, v: Option<f64>) -> String {
    match v {
        None => "–".into(),
        Some(v) if s.unit == "%" => format!("{:+.1} pt", 100.0 * v),
        Some(v) if s.unit == "m" => format!("{v:+.2} m"),
        Some(v) if v.abs() >= 100.0 => format!("{v:+.0}"),
        Some(v) => format!("{v:+.3}"),
    }
}

/// One row per metric: label, A, B, B − A, per-cell mean difference ± its
/// standard error (z), the first cloud's cell spread.
pub fn rows(c: &Comparison) -> Vec<[String; 6]> {
    SCALARS
        .iter()
        .enumerate()
        .map(|(m, s)| {
            let cell = &c.cells.metrics[m];
            let per_cell = match (cell.mean_difference, cell.se_difference, cell.z) {
                (Some(d), Some(se), Some(z)) => format!(
                    "{} ± {} (z {z:+.1})",
                    shown_difference(s, Some(d)),
                    shown_difference(s, Some(se)).trim_start_matches('+'),
                ),
                _ => "–".into(),
            };
            [
                s.label.to_string(),
                shown(s, c.values[0][m]),
                shown(s, c.values[1][m]),
                shown_difference(s, c.values[1][m].zip(c.values[0][m]).map(|(b, a)| b - a)),
                per_cell,
                cell.sd_a.map_or("–".into(), |v| {
                    shown_difference(s, Some(v))
                        .trim_start_matches('+')
                        .to_string()
                }),
            ]
        })
        .collect()
}

/// The table as text, columns aligned.
pub fn text(c: &Comparison) -> String {
    let header = [
        "metric".to_string(),
        c.a.label.clone(),
        c.b.label.clone(),
        format!("{} − {}", c.b.label, c.a.label),
        format!("per {} m cell: mean ± se (z)", c.cells.cell_m),
        format!("sd {} cells", c.a.label),
    ];
    let mut all = vec![header];
    all.extend(rows(c));
    for (k, name) in [(0usize, "pulses with"), (1, "returns numbered")] {
        for n in 0..5 {
            let get = |side: &super::Side| {
                let d = &side.distributions;
                if k == 0 {
                    d.number_of_returns[n]
                } else {
                    d.return_number[n]
                }
            };
            let (a, b) = (get(&c.a), get(&c.b));
            let plus = if n == 4 {
                "≥5"
            } else {
                ["1", "2", "3", "4"][n.min(3)]
            };
            let what = if k == 0 { "returns" } else { "" };
            all.push([
                format!("{name} {plus} {what}").trim_end().to_string(),
                format!("{:.1} %", 100.0 * a),
                format!("{:.1} %", 100.0 * b),
                format!("{:+.1} pt", 100.0 * (b - a)),
                String::new(),
                String::new(),
            ]);
        }
    }
    let widths: Vec<usize> = (0..6)
        .map(|i| all.iter().map(|r| r[i].chars().count()).max().unwrap_or(0))
        .collect();
    let mut out = String::new();
    for row in &all {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let pad = widths[i] - v.chars().count();
                if i == 0 {
                    format!("{v}{}", " ".repeat(pad))
                } else {
                    format!("{}{v}", " ".repeat(pad))
                }
            })
            .collect();
        out.push_str(cells.join("  ").trim_end());
        out.push('\n');
    }
    out
}
