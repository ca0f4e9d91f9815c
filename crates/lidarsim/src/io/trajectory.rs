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
    let columns = Columns::of_header(path, header)?;
    let mut segments: Vec<Segment> = Vec::new();
    for (n, row) in rows {
        let (key, sample) = columns.row(path, n, row)?;
        add_sample(path, &mut segments, n, key, sample)?;
    }
    let t0 = segments
        .first()
        .map(|s| s.samples[0].0)
        .ok_or_else(|| format!("'{}' holds no trajectory rows", path.display()))?;
    segments
        .into_iter()
        .map(|Segment { key, samples }| {
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

/// The columns a trajectory needs, as messages name them.
const WANTED: [&str; 7] = [
    "time_s",
    "x_m",
    "y_m",
    "z_m",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
];

/// The names each of `WANTED` may have in a header.
const NAMES: [&[&str]; 7] = [
    &["time_s", "gps_time_s", "time"],
    &["x_m", "x"],
    &["y_m", "y"],
    &["z_m", "z"],
    &["roll_deg", "roll"],
    &["pitch_deg", "pitch"],
    &["yaw_deg", "yaw"],
];

/// Where a file's header puts each column.
struct Columns<'a> {
    /// The header's names, in order.
    names: Vec<&'a str>,
    /// The column of each of `WANTED`.
    wanted: [usize; 7],
    /// The column of `line`, if any.
    line: Option<usize>,
}

/// Consecutive rows of one `line` value.
struct Segment {
    key: String,
    samples: Vec<TrackSample>,
}

impl<'a> Columns<'a> {
    /// The header's columns: each named once, every wanted one there.
    fn of_header(path: &Path, header: &'a str) -> Result<Self, String> {
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
        let mut found = [None; 7];
        for (k, want) in NAMES.iter().enumerate() {
            found[k] = column(path, &names, want)?;
        }
        let mut wanted = [0usize; 7];
        for (k, c) in found.iter().enumerate() {
            match c {
                Some(i) => wanted[k] = *i,
                None => {
                    return Err(format!(
                        "'{}' line 1: no column `{}` (the header must name: {})",
                        path.display(),
                        WANTED[k],
                        WANTED.join(", ")
                    ));
                }
            }
        }
        let line = column(path, &names, &["line"])?;
        Ok(Columns {
            names,
            wanted,
            line,
        })
    }

    /// Row `n` (0-based) as its line value and sample.
    fn row(&self, path: &Path, n: usize, row: &str) -> Result<(String, TrackSample), String> {
        let cells: Vec<&str> = row.split(',').map(str::trim).collect();
        if cells.len() != self.names.len() {
            return Err(format!(
                "'{}' line {}: {} values for the header's {} columns ({}); every row needs one \
                 value per column",
                path.display(),
                n + 1,
                cells.len(),
                self.names.len(),
                self.names.join(", ")
            ));
        }
        let value = |k: usize| -> Result<f64, String> {
            let cell = cells.get(self.wanted[k]).copied().unwrap_or("");
            cell.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    format!(
                        "'{}' line {}: `{}` is '{cell}', not a number",
                        path.display(),
                        n + 1,
                        WANTED[k]
                    )
                })
        };
        let v: Vec<f64> = (0..7).map(value).collect::<Result<_, _>>()?;
        if let Some(k) = (1..4).find(|&k| v[k].abs() > MAX_COORDINATE_M) {
            return Err(format!(
                "'{}' line {}: `{}` is {}, beyond ±{} m",
                path.display(),
                n + 1,
                WANTED[k],
                num(v[k]),
                num(MAX_COORDINATE_M)
            ));
        }
        if let Some(k) = (4..7).find(|&k| v[k].abs() > 360.0) {
            return Err(format!(
                "'{}' line {}: `{}` is {}°, beyond ±360°",
                path.display(),
                n + 1,
                WANTED[k],
                num(v[k])
            ));
        }
        // Line values compare as numbers when they are numbers ("0" = "0.0").
        let key = self
            .line
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
        Ok((key, sample))
    }
}

/// The one column named by any of `want`. Columns of one meaning under
/// two of its names are just as ambiguous as one name twice.
fn column(path: &Path, names: &[&str], want: &[&str]) -> Result<Option<usize>, String> {
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
}

/// Adds the sample of row `n` to its line's segment: the last one, if of
/// its line, or a new one; times increase within and across lines.
fn add_sample(
    path: &Path,
    segments: &mut Vec<Segment>,
    n: usize,
    key: String,
    sample: TrackSample,
) -> Result<(), String> {
    match segments.last_mut() {
        Some(last) if last.key == key => {
            if sample.0 <= last.samples[last.samples.len() - 1].0 {
                return Err(format!(
                    "'{}' line {}: times must increase",
                    path.display(),
                    n + 1
                ));
            }
            last.samples.push(sample);
        }
        Some(last) if sample.0 <= last.samples[last.samples.len() - 1].0 => {
            return Err(format!(
                "'{}' line {}: line '{key}' starts before the previous line ends; \
                 lines must follow each other in time",
                path.display(),
                n + 1
            ));
        }
        _ => {
            if segments.iter().any(|s| s.key == key) {
                return Err(format!(
                    "'{}' line {}: line '{key}' appears again after other lines",
                    path.display(),
                    n + 1
                ));
            }
            segments.push(Segment {
                key,
                samples: vec![sample],
            });
        }
    }
    Ok(())
}
