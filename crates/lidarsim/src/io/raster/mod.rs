//! Terrain rasters read into height grids: GeoTIFF (the pixel grid from
//! `ModelPixelScaleTag` + one `ModelTiepointTag`, or a
//! `ModelTransformationTag` without rotation; `GTRasterTypeGeoKey` for
//! pixel-is-area or pixel-is-point; nodata from `GDAL_NODATA` and NaN) and
//! ESRI ASCII grids (streamed line by line), each refusing heights beyond
//! ±[`MAX_HEIGHT_M`]. `geotiff.rs` and `ascii.rs` read the two formats;
//! [`raster_grid`] makes the samples of any north-up raster a height grid.

mod ascii;
mod geotiff;

use rayon::prelude::*;
use std::path::Path;

use crate::scene::terrain::{HeightGrid, MAX_HEIGHT_M, TerrainError};

pub use ascii::read_ascii_grid;
pub use geotiff::read_geotiff;

/// Reads a GeoTIFF (`.tif`, `.tiff`) or ESRI ASCII grid (`.asc`) by its
/// extension.
pub fn read_raster(path: &Path) -> Result<HeightGrid, TerrainError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("tif") | Some("tiff") => read_geotiff(path),
        Some("asc") => read_ascii_grid(path),
        _ => Err(TerrainError::UnknownFormat {
            path: path.to_path_buf(),
        }),
    }
}

/// A format error of `path` at 1-based `line` (0: of no line).
fn line_error(path: &Path, line: usize, reason: String) -> TerrainError {
    TerrainError::Format {
        path: path.to_path_buf(),
        line,
        reason,
    }
}

/// The nodes of a north-up raster of `width` × `height` samples as a
/// height grid: `value(k)` is the raster's `k`-th sample (rows of `width`
/// in the raster's order), raster `(I, J)` lies at model
/// `X = ax + bx·I`, `Y = ay + by·J`, and the nodes at `(I + c, J + c)`
/// (`c` = 0.5 for pixel centres, 0 when the pixels are points); NaN and
/// `nodata` samples are nodata. The grid's nodes run east and north
/// whatever the raster's order. `Err((row, column, value))` (of the
/// raster, from 0) names a sample that is not a height within
/// ±[`MAX_HEIGHT_M`].
pub fn raster_grid(
    width: usize,
    height: usize,
    (ax, bx, ay, by): (f64, f64, f64, f64),
    c: f64,
    nodata: Option<f64>,
    value: impl Fn(usize) -> f64 + Sync,
) -> Result<HeightGrid, (usize, usize, f64)> {
    // Pixel centre of column i / row j.
    let x_of = |i: usize| ax + bx * (i as f64 + c);
    let y_of = |j: usize| ay + by * (j as f64 + c);
    // Grid node (col, row) runs east and north: flip the raster's order
    // where its axes run west or south.
    let src_col = |col: usize| if bx > 0.0 { col } else { width - 1 - col };
    let src_row = |row: usize| if by > 0.0 { row } else { height - 1 - row };
    let mut heights = vec![f32::NAN; width * height];
    heights
        .par_chunks_mut(width)
        .enumerate()
        .for_each(|(row, out)| {
            let base = src_row(row) * width;
            for (col, h) in out.iter_mut().enumerate() {
                let v = value(base + src_col(col));
                if !v.is_nan() && Some(v) != nodata {
                    // Implausible heights stay as they are, to be reported.
                    *h = if v.abs() <= MAX_HEIGHT_M {
                        v as f32
                    } else {
                        f32::INFINITY
                    };
                }
            }
        });
    if heights.iter().any(|h| h.is_infinite()) {
        // The first in the raster's own order.
        let bad = |v: f64| !v.is_nan() && Some(v) != nodata && v.abs() > MAX_HEIGHT_M;
        if let Some(k) = (0..width * height).find(|&k| bad(value(k))) {
            return Err((k / width, k % width, value(k)));
        }
    }
    Ok(HeightGrid {
        cols: width,
        rows: height,
        origin_m: [x_of(src_col(0)), y_of(src_row(0))],
        spacing_m: [bx.abs(), by.abs()],
        z_offset_m: 0.0,
        heights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp(name: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("lidarsim-raster-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn ascii_grid_origin_cell_size_rows_and_nodata() {
        // 3 columns, 2 rows; the first row written is the northern one.
        let p = temp(
            "a.asc",
            "ncols 3\nnrows 2\nxllcorner 1000\nyllcorner 2000\ncellsize 10\n\
             NODATA_value -9999\n1 2 3\n4 -9999 6\n",
        );
        let g = read_ascii_grid(&p).unwrap();
        assert_eq!((g.cols, g.rows), (3, 2));
        // Lower-left corner 1000, 2000 → centre of the south-west cell.
        assert_eq!(g.origin_m, [1005.0, 2005.0]);
        assert_eq!(g.spacing_m, [10.0, 10.0]);
        // South row (grid row 0) is the file's last row.
        assert_eq!(g.height(0, 0), Some(4.0));
        assert_eq!(g.height(1, 0), None);
        assert_eq!(g.height(2, 0), Some(6.0));
        assert_eq!(g.height(0, 1), Some(1.0));
        assert_eq!(g.height(2, 1), Some(3.0));
        // Only the NE triangle of the eastern cell avoids the hole:
        // cell (1,0) corners (1,0)=hole → lower triangle out; upper (a,c,d)
        // has a = (1,0) too → out. Cell (0,0): lower has b = hole → out;
        // upper (0,0),(1,1),(0,1) valid.
        assert_eq!(g.triangle_count(), 1);

        let p = temp(
            "c.asc",
            "NCOLS 2\nNROWS 2\nXLLCENTER 0.5\nYLLCENTER -3\nCELLSIZE 2\n7 8\n9\n10\n",
        );
        let g = read_ascii_grid(&p).unwrap();
        assert_eq!(g.origin_m, [0.5, -3.0]);
        // GDAL's rectangular cells: dx, dy instead of cellsize.
        let q = temp(
            "d.asc",
            "ncols 2\nnrows 2\nxllcorner 10\nyllcorner 20\ndx 4\ndy 3\n1 2\n3 4\n",
        );
        let r = read_ascii_grid(&q).unwrap();
        assert_eq!((r.origin_m, r.spacing_m), ([12.0, 21.5], [4.0, 3.0]));
        assert_eq!(g.heights, vec![9.0, 10.0, 7.0, 8.0]);
        // Interpolation on the lower triangle (0,0),(1,0),(1,1).
        let z = g.elevation_at(0.5 + 1.5, -3.0 + 0.5).unwrap();
        // fu = 0.75, fv = 0.25: a + fu (b - a) + fv (c - b) = 9 + 0.75 + 0.25·(8-10)
        assert!((z - (9.0 + 0.75 - 0.5)).abs() < 1e-12, "{z}");
    }

    #[test]
    fn ascii_grid_errors_name_the_line() {
        let cases = [
            (
                "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 x\n",
                "line 7",
                "'x' is not a number",
            ),
            (
                "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3\n",
                "line 7",
                "found 3",
            ),
            (
                "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4 5\n",
                "line 7",
                "more values",
            ),
            (
                "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize -1\n1 2\n3 4\n",
                "line 5",
                "cellsize",
            ),
            (
                "ncols 2\nnrows 2\nxllcorner 0\ncellsize 1\n1 2\n3 4\n",
                "",
                "yllcorner",
            ),
            (
                "ncols 2\nnrows 2.5\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n",
                "line 2",
                "whole number",
            ),
            (
                "ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncelsize 1\n1 2\n3 4\n",
                "line 5",
                "unknown header key 'celsize'",
            ),
        ];
        for (i, (text, line, what)) in cases.iter().enumerate() {
            let p = temp(&format!("bad{i}.asc"), text);
            let e = read_ascii_grid(&p).unwrap_err().to_string();
            assert!(e.contains(what) && e.contains(line), "case {i}: {e}");
        }
    }
}
