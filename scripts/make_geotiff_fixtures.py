#!/usr/bin/env python3
"""Writes small GeoTIFF DEMs with rasterio (GDAL), an independent writer.

Usage: make_geotiff_fixtures.py OUTDIR

The files are committed as crates/lidarsim/tests/data/*.tif (run this
script with that folder to regenerate them); tests/integration/terrain.rs states the
same parameters and checks what lidarsim reads from them.

- dem_area.tif: float32, 40 x 24 pixels of 10 m x 5 m, upper-left corner
  (500000, 4200120), PixelIsArea (GDAL's default), tiled 16 x 16, DEFLATE
  with the floating-point predictor, GDAL_NODATA -9999 on pixel
  (col 7, row 3). Height of pixel (col, row) = 100 + 0.5 col - 0.25 row
  + 0.01 col row (rows counted from the north).
- dem_point.tif: int16, 12 x 9 pixels of 2 m, upper-left corner (-30, 50),
  AREA_OR_POINT=Point (GTRasterTypeGeoKey = RasterPixelIsPoint), strips,
  LZW. Height = 7 col - 3 row + 20.
"""

import sys
from pathlib import Path

import numpy as np
import rasterio
from rasterio.transform import from_origin

out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)

cols, rows = 40, 24
c, r = np.meshgrid(np.arange(cols), np.arange(rows))
z = (100 + 0.5 * c - 0.25 * r + 0.01 * c * r).astype("float32")
z[3, 7] = -9999
with rasterio.open(
    out / "dem_area.tif", "w", driver="GTiff", width=cols, height=rows, count=1,
    dtype="float32", crs="EPSG:32633", transform=from_origin(500000, 4200120, 10, 5),
    nodata=-9999, tiled=True, blockxsize=16, blockysize=16, compress="deflate",
    predictor=3,
) as dst:
    dst.write(z, 1)

cols, rows = 12, 9
c, r = np.meshgrid(np.arange(cols), np.arange(rows))
z = (7 * c - 3 * r + 20).astype("int16")
with rasterio.open(
    out / "dem_point.tif", "w", driver="GTiff", width=cols, height=rows, count=1,
    dtype="int16", crs="EPSG:32633", transform=from_origin(-30, 50, 2, 2),
    compress="lzw",
) as dst:
    dst.update_tags(AREA_OR_POINT="Point")
    dst.write(z, 1)

with rasterio.open(out / "dem_point.tif") as src:
    assert src.tags().get("AREA_OR_POINT") == "Point", src.tags()
    # GDAL reports the corner-based transform either way.
    assert src.transform == from_origin(-30, 50, 2, 2), src.transform
print(f"wrote {out}/dem_area.tif and {out}/dem_point.tif")
