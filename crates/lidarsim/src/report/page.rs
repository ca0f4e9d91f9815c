//! The page: survey parameters, the figures of `summary.json`, the maps,
//! the cross-section, returns per pulse, the point density, the flight
//! with the georeferencing errors, and the sample waveforms.

use std::fmt::Write as _;

use super::markup::{esc, img_tag, table_rows};
use super::{ReportSink, attitude_plot, trajectory_error_plots};
use crate::render::{WaveformPlot, fixed};
use crate::sensor::platform::FlightLine;
use crate::summary::Summary;
use crate::survey::Survey;

/// The pulse shape in words: "Gaussian, 4.0 ns FWHM".
fn pulse_words(p: &crate::waveform::PulseShape) -> String {
    use crate::waveform::PulseShape;
    let name = match p {
        PulseShape::Gaussian { .. } => "Gaussian",
        PulseShape::RiseTail { .. } => "rise-tail (fast rise, long tail)",
    };
    format!("{name}, {} ns FWHM", fixed(p.fwhm_s() * 1e9, 1))
}

/// "1st", "2nd", "3rd", "4th", …
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (1, x) if x != 11 => "st",
        (2, x) if x != 12 => "nd",
        (3, x) if x != 13 => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

/// The whole page.
pub fn html(
    survey: &Survey,
    lines: &[FlightLine],
    summary: &Summary,
    sink: &ReportSink,
    waveforms: &[(String, WaveformPlot)],
) -> Result<String, png::EncodingError> {
    let mut h = String::new();
    head(&mut h);
    survey_section(&mut h, survey, lines, summary);
    pattern_section(&mut h, survey, lines, summary)?;
    summary_section(&mut h, summary);
    top_views_section(&mut h, sink)?;
    cross_section(&mut h, sink)?;
    returns_section(&mut h, sink);
    density_section(&mut h, summary, sink)?;
    flight_section(&mut h, survey, lines, sink)?;
    waveforms_section(&mut h, waveforms)?;
    let _ = writeln!(h, "</body></html>");
    Ok(h)
}

/// The scan pattern of the first flight line's first scan lines.
fn pattern_section(
    h: &mut String,
    survey: &Survey,
    lines: &[FlightLine],
    summary: &Summary,
) -> Result<(), png::EncodingError> {
    let (Some(line), Some(plan)) = (lines.first(), summary.plan.lines.first()) else {
        return Ok(());
    };
    let height = plan.height_above_ground_m.max(1.0);
    let _ = write!(
        h,
        "<h2>Scan pattern</h2><p>Where the pulses of the first scan lines meet level ground \
         {height:.0} m below the scanner at {} m/s (the first flight line's height and speed), \
         from above, flight direction up, coloured by time from dark (first) to light (last): \
         {}.</p>{}",
        line.speed_mps,
        esc(&survey.scanner.deflector.describe()),
        img_tag(
            &super::scan_pattern_plot(survey, height, line.speed_mps),
            "scan pattern"
        )?
    );
    Ok(())
}

/// The page's head, its style and its title.
fn head(h: &mut String) {
    let _ = write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>lidarsim report</title>\
         <style>body{{font-family:sans-serif;margin:2em;max-width:1400px}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 8px;text-align:left}}\
         img{{max-width:100%;border:1px solid #ddd}}.bar{{background:#3b528b;height:14px}}</style>\
         </head><body><h1>lidarsim report</h1>"
    );
}

/// The survey's parameters: its source, seed, scanner, pulse and flight.
fn survey_section(h: &mut String, survey: &Survey, lines: &[FlightLine], summary: &Summary) {
    let s = &survey.scanner;
    let _ = write!(
        h,
        "<h2>Survey</h2><table>\
         <tr><th>source</th><td>{}</td></tr>\
         <tr><th>seed</th><td>{}</td></tr>\
         <tr><th>PRF</th><td>{} Hz</td></tr>\
         <tr><th>deflector</th><td>{}</td></tr>\
         <tr><th>beam</th><td>{:.3} mrad, {} sub-rays</td></tr>\
         <tr><th>pulse</th><td>{}</td></tr>\
         <tr><th>flight lines</th><td>{}</td></tr>\
         <tr><th>scene primitives</th><td>{}</td></tr></table>",
        esc(&survey
            .source
            .as_ref()
            .map_or_else(|| "built-in demo".to_string(), |p| p.display().to_string())),
        summary.seed,
        s.prf_hz,
        esc(&s.deflector.describe()),
        s.divergence_rad * 1e3,
        s.subrays,
        pulse_words(&survey.receiver.pulse),
        lines.len(),
        summary.scene_primitives
    );
}

/// The figures of `summary.json` and its warnings.
fn summary_section(h: &mut String, summary: &Summary) {
    let _ = write!(h, "<h2>Summary</h2><table>");
    let by_return = summary
        .points_by_return
        .iter()
        .enumerate()
        .map(|(i, n)| format!("{} return: {n}", ordinal(i + 1)))
        .collect::<Vec<_>>()
        .join(", ");
    let rows = [
        ("pulses", summary.pulses.to_string()),
        ("points", summary.points.to_string()),
        ("pulses with an echo", summary.pulses_with_echo.to_string()),
        ("points by return", by_return),
        ("expected swath", format!("{:.1} m", summary.swath_width_m)),
        (
            "expected density (one line)",
            format!("{:.2} /m²", summary.point_density_per_m2),
        ),
        (
            "footprint at nadir",
            format!("{:.3} m", summary.footprint_diameter_m),
        ),
        (
            "wall time",
            format!(
                "{:.2} s on {} thread(s)",
                summary.wall_time_s, summary.threads
            ),
        ),
        (
            "pulses per second",
            format!("{:.0}", summary.pulses_per_second),
        ),
        ("GPS time", summary.gps_time.to_string()),
    ];
    table_rows(h, rows);
    let _ = write!(h, "</table>");
    for w in &summary.warnings {
        let _ = write!(h, "<p><b>warning:</b> {}</p>", esc(w));
    }
}

/// The top views by height, intensity and class, with their ranges.
fn top_views_section(h: &mut String, sink: &ReportSink) -> Result<(), png::EncodingError> {
    let (heights, intensities) = (
        sink.height_palette().range(),
        sink.intensity_palette().range(),
    );
    let _ = write!(
        h,
        "<h2>Top views</h2><p>Highest point per {:.2} m pixel; hatched grey where no point fell \
         (one-pixel gaps between scan lines take a neighbour's colour). Height and intensity \
         colours run from the 0.1st to the 99.9th percentile of the pixels (heights {} m to {} \
         m, intensities {} to {}); the few pixels beyond take the end colours, as the arrows on \
         the colour bar show.</p>{}{}{}",
        sink.resolution_m(),
        fixed(heights.0, 2),
        fixed(heights.1, 2),
        fixed(intensities.0, 0),
        fixed(intensities.1, 0),
        img_tag(&sink.height_map(), "top view by height")?,
        img_tag(&sink.intensity_map(), "top view by intensity")?,
        img_tag(&sink.class_map(), "top view by class")?
    );
    Ok(())
}

/// The cross-section and the heights it spans.
fn cross_section(h: &mut String, sink: &ReportSink) -> Result<(), png::EncodingError> {
    let span = match sink.profile_heights() {
        Some((lo, hi)) => format!(
            " Its points lie from {} m to {} m; heights are stretched to fill the picture (the \
             exaggeration is written under it).",
            fixed(lo, 2),
            fixed(hi, 2)
        ),
        None => " No point lies in it.".to_string(),
    };
    let _ = write!(
        h,
        "<h2>Cross-section</h2><p>West to east through the middle, 2 m wide, by class.{span}</p>{}",
        img_tag(&sink.profile_image(), "cross-section")?
    );
    Ok(())
}

/// The pulses by number of returns, with bars.
fn returns_section(h: &mut String, sink: &ReportSink) {
    let total: u64 = sink.returns_per_pulse.iter().sum();
    let _ = write!(
        h,
        "<h2>Returns per pulse</h2><table><tr><th>returns</th><th>pulses</th><th></th></tr>"
    );
    for (n, &c) in sink.returns_per_pulse.iter().enumerate().skip(1) {
        if c == 0 {
            continue;
        }
        let pct = 100.0 * c as f64 / total.max(1) as f64;
        let _ = write!(
            h,
            "<tr><td>{n}</td><td>{c} ({pct:.1} %)</td><td><div class=\"bar\" style=\"width:{:.0}px\"></div></td></tr>",
            4.0 * pct
        );
    }
    let _ = write!(h, "</table>");
}

/// The point density against the planned one.
fn density_section(
    h: &mut String,
    summary: &Summary,
    sink: &ReportSink,
) -> Result<(), png::EncodingError> {
    let (density, mean) = sink.density_map(summary.point_density_per_m2);
    let _ = write!(
        h,
        "<h2>Point density</h2><p>All returns per m², colour bar from 0 to at least twice the planned \
         single-line density of {:.2} /m² (overlapping lines add up). Median over cells of about \
         5 m with points: {:.2} /m².</p>{}",
        summary.point_density_per_m2,
        mean,
        img_tag(&density, "point density")?
    );
    Ok(())
}

/// The sample waveforms, if any.
fn waveforms_section(
    h: &mut String,
    waveforms: &[(String, WaveformPlot)],
) -> Result<(), png::EncodingError> {
    if !waveforms.is_empty() {
        let _ = write!(h, "<h2>Sample waveforms</h2>");
        for (title, plot) in waveforms {
            let _ = write!(
                h,
                "<h3>{}</h3>{}",
                esc(title),
                img_tag(&plot.render(), title)?
            );
        }
    }
    Ok(())
}

/// The flight: attitude against time and, with navigation errors, the
/// observed minus true trajectory and the points' georeferencing errors.
fn flight_section(
    h: &mut String,
    survey: &Survey,
    lines: &[FlightLine],
    sink: &ReportSink,
) -> Result<(), png::EncodingError> {
    if lines.is_empty() {
        return Ok(());
    }
    let offset = survey.output.gps_start_time_s.unwrap_or(0.0);
    let clock = if offset == 0.0 {
        "the GPS time of the points".to_string()
    } else {
        format!("their GPS time − {offset} s")
    };
    let _ = write!(
        h,
        "<h2>Flight</h2><p>Attitude of the aircraft as flown (roll ω, pitch φ, and yaw κ less \
         the line's heading, degrees) against the time since the survey's start ({clock}); \
         the turns between flight lines are left out.</p>{}",
        img_tag(&attitude_plot(lines), "attitude against time")?
    );
    if survey.navigation.is_zero() {
        let _ = write!(
            h,
            "<p>The survey has no navigation errors: the observed trajectory is the true one \
             and the points carry no georeferencing error.</p>"
        );
        return Ok(());
    }
    let (position, attitude) = trajectory_error_plots(survey, lines);
    let _ = write!(
        h,
        "<h3>Observed − true trajectory</h3><p>What the GNSS/IMU measured minus the path \
         flown: biases and correlated errors (the white noise of each pulse comes on top). \
         Position in m:</p>{}<p>Attitude in degrees:</p>{}",
        img_tag(&position, "observed minus true position")?,
        img_tag(&attitude, "observed minus true attitude")?
    );
    let e = &sink.errors;
    if e.count == 0 {
        return Ok(());
    }
    let m = |v: f64| format!("{} m", fixed(v, 3));
    let [rx, ry, rz] = e.rms_m();
    let [mx, my, mz] = e.mean_m();
    let rows = [
        ("points", e.count.to_string()),
        (
            "RMS error x, y, z",
            format!("{}, {}, {} m", fixed(rx, 3), fixed(ry, 3), fixed(rz, 3)),
        ),
        ("RMS horizontal error", m(e.rms_horizontal_m())),
        ("RMS vertical error", m(rz)),
        ("largest horizontal error", m(e.max_horizontal_m)),
        ("largest vertical error", m(e.max_vertical_m)),
        (
            "mean error vector (x, y, z)",
            format!("({}, {}, {}) m", fixed(mx, 3), fixed(my, 3), fixed(mz, 3)),
        ),
    ];
    let _ = write!(
        h,
        "<h3>Georeferencing errors of the points</h3><p>Computed minus true position of every \
         point (the error_x, error_y, error_z extra bytes of points.las), over all points.</p>\
         <table>"
    );
    table_rows(h, rows);
    let _ = write!(h, "</table>");
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::survey::Survey;

    /// The page of a short survey with navigation errors and a height
    /// that dips just below zero: human words for the pulse and mirror, no
    /// "-0.0", the flight plots and the error statistics.
    #[test]
    fn the_page_shows_flight_and_errors_in_words() {
        let text = r#"seed = 5
preset = "uav"
[scanner]
prf_hz = 20000
scan_frequency_hz = 40
scan_angle_deg = 15
subrays = 3
[[flight_line]]
start_m = [0.0, -15.0, 300.0]
end_m = [0.0, 15.0, 300.0]
speed_mps = 50.0
[[flight_line]]
start_m = [30.0, 15.0, 300.0]
end_m = [30.0, -15.0, 300.0]
speed_mps = 50.0
[output]
formats = ["xyz"]
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, -0.04], [300, -300, -0.04], [300, 300, -0.04], [-300, 300, -0.04]]
"#;
        let survey = Survey::from_toml(text, None).unwrap();
        let dir = std::env::temp_dir().join(format!("lidarsim-report-page-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let progress = |_| {};
        let flight = crate::Flight::build(survey).unwrap();
        crate::run::run(&flight, &dir, &crate::run::RunOptions::new(1, &progress)).unwrap();
        let page = std::fs::read_to_string(dir.join("report.html")).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        for words in [
            "Gaussian, 4.0 ns FWHM",
            "triangle (constant angular speed)",
            "1st return:",
            "alt=\"attitude against time\"",
            "alt=\"observed minus true position\"",
            "alt=\"observed minus true attitude\"",
            "Georeferencing errors of the points",
            "RMS horizontal error",
        ] {
            assert!(page.contains(words), "no '{words}'");
        }
        for bad in ["fwhm_s", "Triangle", "-0.0 ", "-0.00 ", "[", "{ "] {
            let text_only: String = page
                .split("<img")
                .map(|part| part.split_once('>').map_or(part, |(_, rest)| rest))
                .collect();
            assert!(!text_only.contains(bad), "'{bad}' in the page");
        }
        // The single-echo pulse is shown once.
        assert_eq!(page.matches("<h3>Line ").count(), 1, "one sample pulse");
    }
}
