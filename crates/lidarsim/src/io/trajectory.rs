//! Trajectory files: CSV with a header naming the columns, the format
//! lidarsim writes (`trajectory.csv`), flown again as flight lines.

use std::path::Path;

use crate::geometry::{DVec3, MAX_COORDINATE_M};
use crate::message::num;
use crate::sensor::platform::{Interpolation, Track};

/// One row of a trajectory file: time, position, attitude.
type TrackSample = (f64, DVec3, crate::geometry::Attitude);

/// Reads a trajectory file: CSV with a header naming the columns `time_s`
/// (or `gps_time_s`), `x_m`, `y_m`, `z_m`, `roll_deg`, `pitch_deg`,
/// `yaw_deg` and optionally `line` (the format lidarsim writes). Rows of one
/// `line` value form one flight line; times are seconds, the first row is
/// the start of the flight. Returns each line's start time and track.
pub fn read_trajectory(
    path: &Path,
    interpolation: Interpolation,
) -> Result<Vec<(f64, Track)>, String> {
    let text = crate::io::input::read_text(path, crate::io::input::MAX_TRAJECTORY_BYTES)
        .map_err(|e| format!("cannot read trajectory file '{}': {e}", path.display()))?;
    let mut rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = rows.next() else {
        return Err(format!("'{}' is empty", path.display()));
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    if let Some((i, name)) = names
        .iter()
        .enumerate()
        .find(|(i, n)| names[..*i].contains(n))
    {
        return Err(format!(
            "'{}' line 1: column {} is named `{name}`, as column {} is: name each column once",
            path.display(),
            i + 1,
            names.iter().position(|n| n == name).unwrap_or(0) + 1
        ));
    }
    // Columns of one meaning under two of its names are just as ambiguous.
    let col = |want: &[&str]| -> Result<Option<usize>, String> {
        let found: Vec<usize> = (0..names.len())
            .filter(|&i| want.contains(&names[i]))
            .collect();
        match found.as_slice() {
            [] => Ok(None),
            [i] => Ok(Some(*i)),
            [i, j, ..] => Err(format!(
                "'{}' line 1: columns {} (`{}`) and {} (`{}`) both give {}: keep one",
                path.display(),
                i + 1,
                names[*i],
                j + 1,
                names[*j],
                want[0]
            )),
        }
    };
    let need = [
        col(&["time_s", "gps_time_s", "time"])?,
        col(&["x_m", "x"])?,
        col(&["y_m", "y"])?,
        col(&["z_m", "z"])?,
        col(&["roll_deg", "roll"])?,
        col(&["pitch_deg", "pitch"])?,
        col(&["yaw_deg", "yaw"])?,
    ];
    let wanted = [
        "time_s",
        "x_m",
        "y_m",
        "z_m",
        "roll_deg",
        "pitch_deg",
        "yaw_deg",
    ];
    let mut idx = [0usize; 7];
    for (k, c) in need.iter().enumerate() {
        match c {
            Some(i) => idx[k] = *i,
            None => {
                return Err(format!(
                    "'{}' line 1: no column `{}` (the header must name: {})",
                    path.display(),
                    wanted[k],
                    wanted.join(", ")
                ));
            }
        }
    }
    let line_col = col(&["line"])?;
    // Consecutive rows of one `line` value, as (line value, samples).
    let mut segments: Vec<(String, Vec<TrackSample>)> = Vec::new();
    for (n, row) in rows {
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(format!(
                "'{}' line {}: {} values for the header's {} columns ({}); every row needs one \
                 value per column",
                path.display(),
                n + 1,
                cells.len(),
                names.len(),
                names.join(", ")
            ));
        }
        let value = |k: usize| -> Result<f64, String> {
            let cell = cells.get(idx[k]).copied().unwrap_or("");
            cell.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "'{}' line {}: `{}` is '{cell}', not a number",
                        path.display(),
                        n + 1,
                        wanted[k]
                    )
                })
        };
        let v: Vec<f64> = (0..7).map(value).collect::<Result<_, _>>()?;
        if let Some(k) = (1..4).find(|&k| v[k].abs() > MAX_COORDINATE_M) {
            return Err(format!(
                "'{}' line {}: `{}` is {}, beyond ±{} m",
                path.display(),
                n + 1,
                wanted[k],
                num(v[k]),
                num(MAX_COORDINATE_M)
            ));
        }
        if let Some(k) = (4..7).find(|&k| v[k].abs() > 360.0) {
            return Err(format!(
                "'{}' line {}: `{}` is {}°, beyond ±360°",
                path.display(),
                n + 1,
                wanted[k],
                num(v[k])
            ));
        }
        // Line values compare as numbers when they are numbers ("0" = "0.0").
        let key = line_col
            .and_then(|i| cells.get(i))
            .map_or_else(String::new, |s| match s.parse::<f64>() {
                Ok(v) => v.to_string(),
                Err(_) => s.to_string(),
            });
        let sample = (
            v[0],
            DVec3::new(v[1], v[2], v[3]),
            crate::geometry::Attitude {
                roll_rad: v[4].to_radians(),
                pitch_rad: v[5].to_radians(),
                yaw_rad: v[6].to_radians(),
            },
        );
        match segments.last_mut() {
            Some((k, samples)) if *k == key => {
                if sample.0 <= samples[samples.len() - 1].0 {
                    return Err(format!(
                        "'{}' line {}: times must increase",
                        path.display(),
                        n + 1
                    ));
                }
                samples.push(sample);
            }
            Some((_, samples)) if sample.0 <= samples[samples.len() - 1].0 => {
                return Err(format!(
                    "'{}' line {}: line '{key}' starts before the previous line ends; \
                     lines must follow each other in time",
                    path.display(),
                    n + 1
                ));
            }
            _ => {
                if segments.iter().any(|(k, _)| *k == key) {
                    return Err(format!(
                        "'{}' line {}: line '{key}' appears again after other lines",
                        path.display(),
                        n + 1
                    ));
                }
                segments.push((key, vec![sample]));
            }
        }
    }
    let t0 = segments
        .first()
        .map(|s| s.1[0].0)
        .ok_or_else(|| format!("'{}' holds no trajectory rows", path.display()))?;
    segments
        .into_iter()
        .map(|(key, samples)| {
            let start = samples[0].0 - t0;
            Track::new(&samples, interpolation)
                .map(|t| (start, t))
                .ok_or_else(|| {
                    format!(
                        "'{}': line '{key}' needs at least two rows with increasing times",
                        path.display()
                    )
                })
        })
        .collect()
}
