//! ESRI ASCII grids, streamed line by line: the header keys, then
//! `ncols × nrows` heights from the northern row down.

use std::io::BufReader;
use std::path::Path;

use super::line_error;
use crate::scene::terrain::{HeightGrid, MAX_HEIGHT_M, MAX_NODES, TerrainError};

/// Reads an ESRI ASCII grid.
pub fn read_ascii_grid(path: &Path) -> Result<HeightGrid, TerrainError> {
    use std::io::BufRead;
    let read_err = |source| TerrainError::Read {
        path: path.to_path_buf(),
        source,
    };
    crate::io::input::check_input(path, crate::io::input::MAX_INPUT_BYTES).map_err(read_err)?;
    let file = std::fs::File::open(path).map_err(read_err)?;
    // Streamed line by line: a 4000 × 4000 grid is ~350 MB of text.
    let mut lines = BufReader::new(file).split(b'\n').enumerate().map(|(n, l)| {
        let l = l.map_err(read_err)?;
        String::from_utf8(l).map(|l| (n, l)).map_err(|e| {
            line_error(
                path,
                n + 1,
                format!(
                    "not valid UTF-8 (byte {})",
                    e.utf8_error().valid_up_to() + 1
                ),
            )
        })
    });
    let (header, first_data) = read_ascii_header(path, &mut lines)?;
    let frame = header.frame(path)?;
    let heights = read_ascii_heights(path, &frame, first_data.map(Ok).into_iter().chain(lines))?;
    let grid = HeightGrid {
        cols: frame.ncols,
        rows: frame.nrows,
        origin_m: frame.origin_m,
        spacing_m: frame.spacing_m,
        z_offset_m: 0.0,
        heights,
    };
    grid.check_size(path)?;
    Ok(grid)
}

/// A line of a text file: its 0-based number and its text.
type NumberedLine = (usize, String);

/// The header keys of an ESRI ASCII grid, lowercase, as given.
struct AsciiHeader {
    keys: Vec<HeaderKey>,
}

/// A header key, its value and its 1-based line.
struct HeaderKey {
    key: String,
    value: f64,
    line: usize,
}

/// The header keys an ESRI ASCII grid may give (GDAL's `dx`, `dy`
/// included), lowercase.
const ASCII_HEADER_KEYS: [&str; 10] = [
    "ncols",
    "nrows",
    "xllcorner",
    "xllcenter",
    "yllcorner",
    "yllcenter",
    "cellsize",
    "dx",
    "dy",
    "nodata_value",
];

/// Reads the header lines up to the first line of data, which it returns
/// (none when the file has no data).
fn read_ascii_header(
    path: &Path,
    lines: &mut impl Iterator<Item = Result<NumberedLine, TerrainError>>,
) -> Result<(AsciiHeader, Option<NumberedLine>), TerrainError> {
    let err = |line: usize, reason: String| line_error(path, line, reason);
    let mut keys: Vec<HeaderKey> = Vec::new();
    for item in lines {
        let (n, line) = item?;
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else {
            continue;
        };
        // A number (`nan` and `inf` included) starts the data.
        if !key.starts_with(|c: char| c.is_ascii_alphabetic()) || key.parse::<f64>().is_ok() {
            return Ok((AsciiHeader { keys }, Some((n, line))));
        }
        let key = key.to_ascii_lowercase();
        let value = words
            .next()
            .ok_or_else(|| err(n + 1, format!("header key '{key}' has no value")))?;
        let value: f64 = value.parse().map_err(|_| {
            err(
                n + 1,
                format!("header key '{key}': '{value}' is not a number"),
            )
        })?;
        if !value.is_finite() {
            return Err(err(n + 1, format!("header key '{key}' must be finite")));
        }
        if keys.iter().any(|h| h.key == key) {
            return Err(err(n + 1, format!("header key '{key}' is given twice")));
        }
        if !ASCII_HEADER_KEYS.contains(&key.as_str()) {
            return Err(err(
                n + 1,
                format!(
                    "unknown header key '{key}'; expected ncols, nrows, xllcorner or xllcenter, \
                     yllcorner or yllcenter, cellsize (or dx and dy), NODATA_value"
                ),
            ));
        }
        keys.push(HeaderKey {
            key,
            value,
            line: n + 1,
        });
    }
    Ok((AsciiHeader { keys }, None))
}

/// What an ESRI ASCII header says of the grid.
struct AsciiFrame {
    ncols: usize,
    nrows: usize,
    /// The centre of the south-west cell.
    origin_m: [f64; 2],
    spacing_m: [f64; 2],
    nodata: Option<f64>,
}

impl AsciiHeader {
    /// A key's value and line.
    fn get(&self, k: &str) -> Option<(f64, usize)> {
        self.keys
            .iter()
            .find(|h| h.key == k)
            .map(|h| (h.value, h.line))
    }

    /// The grid the header describes, each key checked in turn.
    fn frame(&self, path: &Path) -> Result<AsciiFrame, TerrainError> {
        let ncols = self.count(path, "ncols")?;
        let nrows = self.count(path, "nrows")?;
        let (dx, dy) = self.cell_size(path)?;
        let x0 = self.centre(path, "xllcorner", "xllcenter", dx)?;
        let y0 = self.centre(path, "yllcorner", "yllcenter", dy)?;
        let nodata = self.get("nodata_value").map(|h| h.0);
        Ok(AsciiFrame {
            ncols,
            nrows,
            origin_m: [x0, y0],
            spacing_m: [dx, dy],
            nodata,
        })
    }

    /// A count of cells: a positive whole number up to 10⁹.
    fn count(&self, path: &Path, k: &str) -> Result<usize, TerrainError> {
        match self.get(k) {
            None => Err(line_error(path, 0, format!("the header has no '{k}'"))),
            Some((v, _)) if v >= 1.0 && v.fract() == 0.0 && v <= 1e9 => Ok(v as usize),
            Some((v, line)) => Err(line_error(
                path,
                line,
                format!("'{k}' must be a positive whole number, got {v}"),
            )),
        }
    }

    /// `cellsize`, or GDAL's `dx` and `dy` for rectangular cells.
    fn cell_size(&self, path: &Path) -> Result<(f64, f64), TerrainError> {
        let positive = |k: &str| -> Result<Option<f64>, TerrainError> {
            match self.get(k) {
                Some((v, line)) if v <= 0.0 => Err(line_error(
                    path,
                    line,
                    format!("'{k}' must be greater than 0, got {v}"),
                )),
                other => Ok(other.map(|h| h.0)),
            }
        };
        match (positive("cellsize")?, positive("dx")?, positive("dy")?) {
            (Some(s), None, None) => Ok((s, s)),
            (None, Some(dx), Some(dy)) => Ok((dx, dy)),
            (Some(_), _, _) => Err(line_error(
                path,
                0,
                "give either 'cellsize' or 'dx' and 'dy', not both".to_string(),
            )),
            _ => Err(line_error(
                path,
                0,
                "the header has no 'cellsize' (nor 'dx' and 'dy')".to_string(),
            )),
        }
    }

    /// The centre of the south-west cell along one axis, from its corner or
    /// its centre.
    fn centre(
        &self,
        path: &Path,
        corner: &str,
        center: &str,
        step: f64,
    ) -> Result<f64, TerrainError> {
        match (self.get(corner), self.get(center)) {
            (Some((v, _)), None) => Ok(v + step / 2.0),
            (None, Some((v, _))) => Ok(v),
            (Some(_), Some((_, line))) => Err(line_error(
                path,
                line,
                format!("give either '{corner}' or '{center}', not both"),
            )),
            (None, None) => Err(line_error(
                path,
                0,
                format!("the header has neither '{corner}' nor '{center}'"),
            )),
        }
    }
}

/// The heights of the data lines, exactly `ncols × nrows` of them, into
/// grid order (rows from the south).
fn read_ascii_heights(
    path: &Path,
    frame: &AsciiFrame,
    lines: impl Iterator<Item = Result<NumberedLine, TerrainError>>,
) -> Result<Vec<f32>, TerrainError> {
    let err = |line: usize, reason: String| line_error(path, line, reason);
    let AsciiFrame {
        ncols,
        nrows,
        nodata,
        ..
    } = *frame;
    let total = ncols
        .checked_mul(nrows)
        .filter(|n| *n <= MAX_NODES)
        .ok_or_else(|| TerrainError::Size {
            path: path.to_path_buf(),
            reason: format!("{ncols} × {nrows} cells exceed the limit of {MAX_NODES} cells"),
        })?;
    let mut heights = vec![f32::NAN; total];
    let mut k = 0usize;
    let mut last_line = 0;
    for item in lines {
        let (n, line) = item?;
        for word in line.split_whitespace() {
            if k >= total {
                return Err(err(
                    n + 1,
                    format!("more values than ncols × nrows = {ncols} × {nrows}"),
                ));
            }
            let v: f64 = word
                .parse()
                .map_err(|_| err(n + 1, format!("'{word}' is not a number")))?;
            // File row r (0 = north) is grid row nrows-1-r.
            let (r, c) = (k / ncols, k % ncols);
            if Some(v) != nodata && !v.is_nan() {
                if v.is_infinite() || v.abs() > MAX_HEIGHT_M {
                    return Err(err(
                        n + 1,
                        format!(
                            "height '{word}' (row {}, column {}) is not a height within \
                             ±{MAX_HEIGHT_M} m; mark missing cells with NODATA_value",
                            r + 1,
                            c + 1
                        ),
                    ));
                }
                heights[(nrows - 1 - r) * ncols + c] = v as f32;
            }
            k += 1;
            last_line = n + 1;
        }
    }
    if k < total {
        return Err(err(
            last_line,
            format!(
                "expected ncols × nrows = {ncols} × {nrows} = {total} values, found {k} \
                 (row {} of {nrows} is incomplete)",
                k / ncols + 1
            ),
        ));
    }
    Ok(heights)
}
