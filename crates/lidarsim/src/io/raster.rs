//! Terrain rasters read into height grids: GeoTIFF (the pixel grid from
//! `ModelPixelScaleTag` + one `ModelTiepointTag`, or a
//! `ModelTransformationTag` without rotation; `GTRasterTypeGeoKey` for
//! pixel-is-area or pixel-is-point; nodata from `GDAL_NODATA` and NaN) and
//! ESRI ASCII grids (streamed line by line), each refusing heights beyond
//! ±[`MAX_HEIGHT_M`].

use std::io::BufReader;

use rayon::prelude::*;
use std::path::Path;

use crate::scene::terrain::{HeightGrid, MAX_HEIGHT_M, MAX_NODES, TerrainError};

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

/// Reads an ESRI ASCII grid.
pub fn read_ascii_grid(path: &Path) -> Result<HeightGrid, TerrainError> {
    use std::io::BufRead;
    let read_err = |source| TerrainError::Read {
        path: path.to_path_buf(),
        source,
    };
    super::input::check_input(path, super::input::MAX_INPUT_BYTES).map_err(read_err)?;
    let file = std::fs::File::open(path).map_err(read_err)?;
    let err = |line: usize, reason: String| TerrainError::Format {
        path: path.to_path_buf(),
        line,
        reason,
    };
    // Streamed line by line: a 4000 × 4000 grid is ~350 MB of text.
    let mut lines = BufReader::new(file).split(b'\n').enumerate().map(|(n, l)| {
        let l = l.map_err(read_err)?;
        String::from_utf8(l).map(|l| (n, l)).map_err(|e| {
            err(
                n + 1,
                format!(
                    "not valid UTF-8 (byte {})",
                    e.utf8_error().valid_up_to() + 1
                ),
            )
        })
    });
    let mut header: Vec<(String, f64, usize)> = Vec::new();
    let mut first_data: Option<(usize, String)> = None;
    for item in lines.by_ref() {
        let (n, line) = item?;
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else {
            continue;
        };
        // A number (`nan` and `inf` included) starts the data.
        if !key.starts_with(|c: char| c.is_ascii_alphabetic()) || key.parse::<f64>().is_ok() {
            first_data = Some((n, line));
            break;
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
        if header.iter().any(|(k, _, _)| *k == key) {
            return Err(err(n + 1, format!("header key '{key}' is given twice")));
        }
        const KNOWN: [&str; 10] = [
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
        if !KNOWN.contains(&key.as_str()) {
            return Err(err(
                n + 1,
                format!(
                    "unknown header key '{key}'; expected ncols, nrows, xllcorner or xllcenter, \
                     yllcorner or yllcenter, cellsize (or dx and dy), NODATA_value"
                ),
            ));
        }
        header.push((key, value, n + 1));
    }
    let get = |k: &str| {
        header
            .iter()
            .find(|(key, _, _)| key == k)
            .map(|h| (h.1, h.2))
    };
    let count = |k: &str| -> Result<usize, TerrainError> {
        match get(k) {
            None => Err(err(0, format!("the header has no '{k}'"))),
            Some((v, line)) if v >= 1.0 && v.fract() == 0.0 && v <= 1e9 => {
                let _ = line;
                Ok(v as usize)
            }
            Some((v, line)) => Err(err(
                line,
                format!("'{k}' must be a positive whole number, got {v}"),
            )),
        }
    };
    let ncols = count("ncols")?;
    let nrows = count("nrows")?;
    // `cellsize`, or GDAL's `dx` and `dy` for rectangular cells.
    let positive = |k: &str| -> Result<Option<f64>, TerrainError> {
        match get(k) {
            Some((v, line)) if v <= 0.0 => {
                Err(err(line, format!("'{k}' must be greater than 0, got {v}")))
            }
            other => Ok(other.map(|h| h.0)),
        }
    };
    let (dx, dy) = match (positive("cellsize")?, positive("dx")?, positive("dy")?) {
        (Some(s), None, None) => (s, s),
        (None, Some(dx), Some(dy)) => (dx, dy),
        (Some(_), _, _) => {
            return Err(err(
                0,
                "give either 'cellsize' or 'dx' and 'dy', not both".to_string(),
            ));
        }
        _ => {
            return Err(err(
                0,
                "the header has no 'cellsize' (nor 'dx' and 'dy')".to_string(),
            ));
        }
    };
    let centre = |corner: &str, center: &str, step: f64| -> Result<f64, TerrainError> {
        match (get(corner), get(center)) {
            (Some((v, _)), None) => Ok(v + step / 2.0),
            (None, Some((v, _))) => Ok(v),
            (Some(_), Some((_, line))) => Err(err(
                line,
                format!("give either '{corner}' or '{center}', not both"),
            )),
            (None, None) => Err(err(
                0,
                format!("the header has neither '{corner}' nor '{center}'"),
            )),
        }
    };
    let x0 = centre("xllcorner", "xllcenter", dx)?;
    let y0 = centre("yllcorner", "yllcenter", dy)?;
    let nodata = get("nodata_value").map(|h| h.0);
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
    for item in first_data.map(Ok).into_iter().chain(lines) {
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
    let grid = HeightGrid {
        cols: ncols,
        rows: nrows,
        origin_m: [x0, y0],
        spacing_m: [dx, dy],
        z_offset_m: 0.0,
        heights,
    };
    grid.check_size(path)?;
    Ok(grid)
}

/// `GTRasterTypeGeoKey` (GeoTIFF 1.1 §7.4.2).
const GT_RASTER_TYPE_GEO_KEY: u16 = 1025;
/// `RasterPixelIsPoint`.
const RASTER_PIXEL_IS_POINT: u16 = 2;

/// Reads a single-band GeoTIFF DEM.
pub fn read_geotiff(path: &Path) -> Result<HeightGrid, TerrainError> {
    use tiff::decoder::{Decoder, DecodingResult, Limits};
    use tiff::tags::Tag;

    let read_err = |source| TerrainError::Read {
        path: path.to_path_buf(),
        source,
    };
    super::input::check_input(path, super::input::MAX_INPUT_BYTES).map_err(read_err)?;
    let file = std::fs::File::open(path).map_err(read_err)?;
    let err = |reason: String| TerrainError::Format {
        path: path.to_path_buf(),
        line: 0,
        reason,
    };
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    let tiff_err = |e: tiff::TiffError| match e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            err("the file ends early: it is truncated or not a TIFF".to_string())
        }
        tiff::TiffError::LimitsExceeded => err(
            "a tag declares more values than a GeoTIFF DEM can hold (the header is corrupt)"
                .to_string(),
        ),
        e => err(format!("not a readable TIFF: {e}")),
    };
    // Bounded, so that sizes declared in a corrupt header fail as errors
    // instead of allocations: the image itself up to MAX_NODES 64-bit
    // samples, tag values (tie points, strip offsets) up to 16 MiB.
    let mut dec = Decoder::new(BufReader::new(file))
        .map_err(tiff_err)?
        .with_limits({
            let mut l = Limits::default();
            l.decoding_buffer_size = MAX_NODES * 8;
            l.intermediate_buffer_size = MAX_NODES * 8;
            l.ifd_value_size = 16 << 20;
            l
        });
    let (width, height) = dec.dimensions().map_err(tiff_err)?;
    let (width, height) = (width as usize, height as usize);
    let samples = dec
        .find_tag_unsigned::<u16>(Tag::SamplesPerPixel)
        .map_err(tiff_err)?
        .unwrap_or(1);
    if samples != 1 {
        return Err(err(format!(
            "has {samples} samples per pixel; a DEM has one band"
        )));
    }
    let f64s =
        |dec: &mut Decoder<_>, tag: Tag, name: &str| -> Result<Option<Vec<f64>>, TerrainError> {
            match dec.find_tag(tag).map_err(tiff_err)? {
                None => Ok(None),
                Some(v) => v
                    .into_f64_vec()
                    .map(Some)
                    .map_err(|e| err(format!("{name} is malformed: {e}"))),
            }
        };
    let scale = f64s(&mut dec, Tag::ModelPixelScaleTag, "ModelPixelScaleTag")?;
    let tie = f64s(&mut dec, Tag::ModelTiepointTag, "ModelTiepointTag")?;
    let transform = f64s(
        &mut dec,
        Tag::ModelTransformationTag,
        "ModelTransformationTag",
    )?;
    let keys = match dec.find_tag(Tag::GeoKeyDirectoryTag).map_err(tiff_err)? {
        None => Vec::new(),
        Some(v) => v
            .into_u16_vec()
            .map_err(|e| err(format!("GeoKeyDirectoryTag is malformed: {e}")))?,
    };
    let nodata = match dec.find_tag(Tag::GdalNodata).map_err(tiff_err)? {
        None => None,
        Some(v) => {
            let s = v
                .into_string()
                .map_err(|e| err(format!("GDAL_NODATA is malformed: {e}")))?;
            let s = s.trim_matches(char::from(0)).trim();
            Some(
                s.parse::<f64>()
                    .map_err(|_| err(format!("GDAL_NODATA '{s}' is not a number")))?,
            )
        }
    };
    // GeoKeyDirectory: a 4-short header, then 4 shorts per key; a value in
    // place when its TIFFTagLocation is 0.
    let mut pixel_is_point = false;
    if keys.len() >= 4 {
        for entry in keys[4..].chunks_exact(4) {
            if entry[0] == GT_RASTER_TYPE_GEO_KEY && entry[1] == 0 {
                pixel_is_point = entry[3] == RASTER_PIXEL_IS_POINT;
            }
        }
    }
    // Raster (I, J) → model (X, Y) as X = ax + bx·I, Y = ay + by·J.
    let (ax, bx, ay, by) = match (&scale, &tie, &transform) {
        (Some(s), Some(t), None) => {
            if s.len() < 2 {
                return Err(err(format!(
                    "ModelPixelScaleTag has {} values, expected 3",
                    s.len()
                )));
            }
            if t.len() != 6 {
                return Err(err(format!(
                    "ModelTiepointTag holds {} tie points; only one tie point with a pixel \
                     scale is supported (ground control points need a warp, e.g. gdalwarp)",
                    t.len() / 6
                )));
            }
            (t[3] - t[0] * s[0], s[0], t[4] + t[1] * s[1], -s[1])
        }
        (None, _, Some(m)) | (Some(_), _, Some(m)) => {
            if m.len() != 16 {
                return Err(err(format!(
                    "ModelTransformationTag has {} values, expected 16",
                    m.len()
                )));
            }
            if m[1] != 0.0 || m[4] != 0.0 {
                return Err(err(
                    "ModelTransformationTag rotates or shears the pixel grid; only north-up \
                     grids are supported (resample it, e.g. with gdalwarp)"
                        .to_string(),
                ));
            }
            (m[3], m[0], m[7], m[5])
        }
        _ => {
            return Err(err(
                "is not georeferenced: it has neither ModelPixelScaleTag + ModelTiepointTag \
                 nor ModelTransformationTag"
                    .to_string(),
            ));
        }
    };
    if !(bx != 0.0 && by != 0.0 && [ax, bx, ay, by].iter().all(|v| v.is_finite())) {
        return Err(err(format!("the pixel size ({bx}, {by}) is not usable")));
    }
    let c = if pixel_is_point { 0.0 } else { 0.5 };
    if width < 2 || height < 2 {
        return Err(TerrainError::Size {
            path: path.to_path_buf(),
            reason: format!("a terrain needs at least 2 × 2 cells, got {width} × {height}"),
        });
    }
    if width.saturating_mul(height) > MAX_NODES {
        return Err(TerrainError::Size {
            path: path.to_path_buf(),
            reason: format!("{width} × {height} cells exceed the limit of {MAX_NODES} cells"),
        });
    }
    // Uncompressed samples take their full size in the file: a header
    // declaring more is corrupt (caught before allocating the image).
    let compression = dec
        .find_tag_unsigned::<u16>(Tag::Compression)
        .map_err(tiff_err)?
        .unwrap_or(1);
    let bits = dec
        .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
        .map_err(tiff_err)?
        .and_then(|b| b.first().copied())
        .unwrap_or(1);
    let need = (width as u64)
        .saturating_mul(height as u64)
        .saturating_mul(u64::from(bits))
        / 8;
    if compression == 1 && need > file_len {
        return Err(err(format!(
            "the header declares {width} × {height} uncompressed pixels of {bits} bits \
             ({need} bytes), more than the file's {file_len} bytes: it is truncated or its \
             header is wrong"
        )));
    }
    let image = dec.read_image().map_err(|e| match e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            err("cannot decode the image: the file ends early (truncated?)".to_string())
        }
        e => err(format!("cannot decode the image: {e}")),
    })?;
    let value = |k: usize| -> f64 {
        match &image {
            DecodingResult::U8(v) => v[k] as f64,
            DecodingResult::U16(v) => v[k] as f64,
            DecodingResult::U32(v) => v[k] as f64,
            DecodingResult::U64(v) => v[k] as f64,
            DecodingResult::I8(v) => v[k] as f64,
            DecodingResult::I16(v) => v[k] as f64,
            DecodingResult::I32(v) => v[k] as f64,
            DecodingResult::I64(v) => v[k] as f64,
            DecodingResult::F16(v) => f64::from(v[k]),
            DecodingResult::F32(v) => v[k] as f64,
            DecodingResult::F64(v) => v[k],
        }
    };
    let len = match &image {
        DecodingResult::U8(v) => v.len(),
        DecodingResult::U16(v) => v.len(),
        DecodingResult::U32(v) => v.len(),
        DecodingResult::U64(v) => v.len(),
        DecodingResult::I8(v) => v.len(),
        DecodingResult::I16(v) => v.len(),
        DecodingResult::I32(v) => v.len(),
        DecodingResult::I64(v) => v.len(),
        DecodingResult::F16(v) => v.len(),
        DecodingResult::F32(v) => v.len(),
        DecodingResult::F64(v) => v.len(),
    };
    if len < width * height {
        return Err(err(format!(
            "decoded {len} samples for {width} × {height} pixels"
        )));
    }
    let grid = raster_grid(width, height, (ax, bx, ay, by), c, nodata, value).map_err(
        |(row, col, v)| {
            err(format!(
                "the pixel at row {}, column {} of the file holds {v:e}, not a height within \
                 ±{MAX_HEIGHT_M} m; mark missing pixels with the GDAL_NODATA tag or NaN",
                row + 1,
                col + 1
            ))
        },
    )?;
    drop(image);
    grid.check_size(path)?;
    Ok(grid)
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
