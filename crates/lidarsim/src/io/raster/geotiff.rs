//! Single-band GeoTIFF DEMs: the pixel grid from `ModelPixelScaleTag` +
//! one `ModelTiepointTag`, or a `ModelTransformationTag` without rotation;
//! `GTRasterTypeGeoKey` for pixel-is-area or pixel-is-point; nodata from
//! `GDAL_NODATA` and NaN.

use std::io::BufReader;
use std::path::Path;

use super::{line_error, raster_grid};
use crate::scene::terrain::{HeightGrid, MAX_HEIGHT_M, MAX_NODES, TerrainError};

/// `GTRasterTypeGeoKey` (GeoTIFF 1.1 §7.4.2).
const GT_RASTER_TYPE_GEO_KEY: u16 = 1025;
/// `RasterPixelIsPoint`.
const RASTER_PIXEL_IS_POINT: u16 = 2;

/// Reads a single-band GeoTIFF DEM.
pub fn read_geotiff(path: &Path) -> Result<HeightGrid, TerrainError> {
    let read_err = |source| TerrainError::Read {
        path: path.to_path_buf(),
        source,
    };
    crate::io::input::check_input(path, crate::io::input::MAX_INPUT_BYTES).map_err(read_err)?;
    let file = std::fs::File::open(path).map_err(read_err)?;
    let file_len = file.metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    let mut tiff = GeoTiff::open(path, file)?;
    let (width, height) = tiff.dec.dimensions().map_err(|e| tiff.tiff_error(e))?;
    let (width, height) = (width as usize, height as usize);
    tiff.check_one_band()?;
    let tags = tiff.geo_tags()?;
    let pixel_to_model = tags.pixel_to_model(path)?;
    let c = if tags.pixel_is_point() { 0.0 } else { 0.5 };
    check_pixel_count(path, width, height)?;
    tiff.check_file_length(width, height, file_len)?;
    let image = tiff.read_image(width, height)?;
    let grid = raster_grid(width, height, pixel_to_model, c, tags.nodata, |k| {
        sample(&image, k)
    })
    .map_err(|(row, col, v)| {
        geotiff_error(
            path,
            format!(
                "the pixel at row {}, column {} of the file holds {v:e}, not a height within \
                 ±{MAX_HEIGHT_M} m; mark missing pixels with the GDAL_NODATA tag or NaN",
                row + 1,
                col + 1
            ),
        )
    })?;
    drop(image);
    grid.check_size(path)?;
    Ok(grid)
}

/// A format error of a GeoTIFF (of no line).
fn geotiff_error(path: &Path, reason: String) -> TerrainError {
    line_error(path, 0, reason)
}

/// A GeoTIFF being decoded.
struct GeoTiff<'a> {
    path: &'a Path,
    dec: tiff::decoder::Decoder<BufReader<std::fs::File>>,
}

/// The georeferencing tags of a GeoTIFF.
struct GeoTags {
    scale: Option<Vec<f64>>,
    tie: Option<Vec<f64>>,
    transform: Option<Vec<f64>>,
    /// The GeoKeyDirectory, empty when absent.
    keys: Vec<u16>,
    /// `GDAL_NODATA`.
    nodata: Option<f64>,
}

impl<'a> GeoTiff<'a> {
    /// The decoder, bounded so that sizes declared in a corrupt header
    /// fail as errors instead of allocations: the image itself up to
    /// MAX_NODES 64-bit samples, tag values (tie points, strip offsets) up
    /// to 16 MiB.
    fn open(path: &'a Path, file: std::fs::File) -> Result<Self, TerrainError> {
        use tiff::decoder::{Decoder, Limits};
        let dec = Decoder::new(BufReader::new(file))
            .map_err(|e| tiff_error(path, e))?
            .with_limits({
                let mut l = Limits::default();
                l.decoding_buffer_size = MAX_NODES * 8;
                l.intermediate_buffer_size = MAX_NODES * 8;
                l.ifd_value_size = 16 << 20;
                l
            });
        Ok(GeoTiff { path, dec })
    }

    /// A format error of this file.
    fn fail(&self, reason: String) -> TerrainError {
        geotiff_error(self.path, reason)
    }

    /// The decoder's error as a format error of this file.
    fn tiff_error(&self, e: tiff::TiffError) -> TerrainError {
        tiff_error(self.path, e)
    }

    /// A DEM has one sample per pixel.
    fn check_one_band(&mut self) -> Result<(), TerrainError> {
        let samples = self
            .dec
            .find_tag_unsigned::<u16>(tiff::tags::Tag::SamplesPerPixel)
            .map_err(|e| self.tiff_error(e))?
            .unwrap_or(1);
        if samples != 1 {
            return Err(self.fail(format!(
                "has {samples} samples per pixel; a DEM has one band"
            )));
        }
        Ok(())
    }

    /// A tag's values as numbers, if it is there.
    fn f64s(&mut self, tag: tiff::tags::Tag, name: &str) -> Result<Option<Vec<f64>>, TerrainError> {
        match self.dec.find_tag(tag).map_err(|e| self.tiff_error(e))? {
            None => Ok(None),
            Some(v) => v
                .into_f64_vec()
                .map(Some)
                .map_err(|e| self.fail(format!("{name} is malformed: {e}"))),
        }
    }

    /// The georeferencing tags, each checked to be of its type.
    fn geo_tags(&mut self) -> Result<GeoTags, TerrainError> {
        use tiff::tags::Tag;
        let scale = self.f64s(Tag::ModelPixelScaleTag, "ModelPixelScaleTag")?;
        let tie = self.f64s(Tag::ModelTiepointTag, "ModelTiepointTag")?;
        let transform = self.f64s(Tag::ModelTransformationTag, "ModelTransformationTag")?;
        let keys = match self
            .dec
            .find_tag(Tag::GeoKeyDirectoryTag)
            .map_err(|e| self.tiff_error(e))?
        {
            None => Vec::new(),
            Some(v) => v
                .into_u16_vec()
                .map_err(|e| self.fail(format!("GeoKeyDirectoryTag is malformed: {e}")))?,
        };
        let nodata = match self
            .dec
            .find_tag(Tag::GdalNodata)
            .map_err(|e| self.tiff_error(e))?
        {
            None => None,
            Some(v) => {
                let s = v
                    .into_string()
                    .map_err(|e| self.fail(format!("GDAL_NODATA is malformed: {e}")))?;
                let s = s.trim_matches(char::from(0)).trim();
                Some(
                    s.parse::<f64>()
                        .map_err(|_| self.fail(format!("GDAL_NODATA '{s}' is not a number")))?,
                )
            }
        };
        Ok(GeoTags {
            scale,
            tie,
            transform,
            keys,
            nodata,
        })
    }

    /// Uncompressed samples take their full size in the file: a header
    /// declaring more is corrupt (caught before allocating the image).
    fn check_file_length(
        &mut self,
        width: usize,
        height: usize,
        file_len: u64,
    ) -> Result<(), TerrainError> {
        use tiff::tags::Tag;
        let compression = self
            .dec
            .find_tag_unsigned::<u16>(Tag::Compression)
            .map_err(|e| self.tiff_error(e))?
            .unwrap_or(1);
        let bits = self
            .dec
            .find_tag_unsigned_vec::<u16>(Tag::BitsPerSample)
            .map_err(|e| self.tiff_error(e))?
            .and_then(|b| b.first().copied())
            .unwrap_or(1);
        let need = (width as u64)
            .saturating_mul(height as u64)
            .saturating_mul(u64::from(bits))
            / 8;
        if compression == 1 && need > file_len {
            return Err(self.fail(format!(
                "the header declares {width} × {height} uncompressed pixels of {bits} bits \
                 ({need} bytes), more than the file's {file_len} bytes: it is truncated or its \
                 header is wrong"
            )));
        }
        Ok(())
    }

    /// The image, at least `width × height` samples of it.
    fn read_image(
        &mut self,
        width: usize,
        height: usize,
    ) -> Result<tiff::decoder::DecodingResult, TerrainError> {
        let image = self.dec.read_image().map_err(|e| match e {
            tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
                self.fail("cannot decode the image: the file ends early (truncated?)".to_string())
            }
            e => self.fail(format!("cannot decode the image: {e}")),
        })?;
        let len = sample_count(&image);
        if len < width * height {
            return Err(self.fail(format!(
                "decoded {len} samples for {width} × {height} pixels"
            )));
        }
        Ok(image)
    }
}

/// The decoder's error as a format error.
fn tiff_error(path: &Path, e: tiff::TiffError) -> TerrainError {
    match e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            geotiff_error(
                path,
                "the file ends early: it is truncated or not a TIFF".to_string(),
            )
        }
        tiff::TiffError::LimitsExceeded => geotiff_error(
            path,
            "a tag declares more values than a GeoTIFF DEM can hold (the header is corrupt)"
                .to_string(),
        ),
        e => geotiff_error(path, format!("not a readable TIFF: {e}")),
    }
}

impl GeoTags {
    /// Whether `GTRasterTypeGeoKey` says the pixels are points. The
    /// GeoKeyDirectory: a 4-short header, then 4 shorts per key; a value
    /// in place when its TIFFTagLocation is 0.
    fn pixel_is_point(&self) -> bool {
        let mut pixel_is_point = false;
        if self.keys.len() >= 4 {
            for entry in self.keys[4..].chunks_exact(4) {
                if entry[0] == GT_RASTER_TYPE_GEO_KEY && entry[1] == 0 {
                    pixel_is_point = entry[3] == RASTER_PIXEL_IS_POINT;
                }
            }
        }
        pixel_is_point
    }

    /// Raster (I, J) → model (X, Y) as X = ax + bx·I, Y = ay + by·J:
    /// `(ax, bx, ay, by)`, from a pixel scale and one tie point, or from a
    /// transformation without rotation.
    fn pixel_to_model(&self, path: &Path) -> Result<(f64, f64, f64, f64), TerrainError> {
        let err = |reason: String| geotiff_error(path, reason);
        let (ax, bx, ay, by) = match (&self.scale, &self.tie, &self.transform) {
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
        Ok((ax, bx, ay, by))
    }
}

/// A terrain needs at least 2 × 2 cells and at most `MAX_NODES`.
fn check_pixel_count(path: &Path, width: usize, height: usize) -> Result<(), TerrainError> {
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
    Ok(())
}

/// The `k`-th sample of an image, as a number.
fn sample(image: &tiff::decoder::DecodingResult, k: usize) -> f64 {
    use tiff::decoder::DecodingResult;
    match image {
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
}

/// The number of samples of an image.
fn sample_count(image: &tiff::decoder::DecodingResult) -> usize {
    use tiff::decoder::DecodingResult;
    match image {
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
    }
}
