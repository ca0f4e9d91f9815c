#!/usr/bin/env python3
"""End-to-end check of terrain rasters against GDAL, through rasterio.

Usage: check_terrain.py LIDARSIM OUTDIR

Writes a tilted-plane DEM in projected (UTM-like) coordinates twice with
rasterio — as a GeoTIFF (float64, PixelIsArea, strips) and as an ESRI ASCII
grid (GDAL's AAIGrid driver) — with a nodata block, flies a survey over
each with `lidarsim run` (offset_m brings the raster near the origin), and
reads the points with laspy. Expectations come from rasterio alone: the
pixel centres from the affine transform GDAL reports, the plane from the
formula written into the raster. On the plane the TIN through the pixel
centres is the plane itself, so every point must lie on it; a misread
origin, pixel size or row order would shift heights by metres. Prints
"N passed, N failed".
"""

import subprocess
import sys
from pathlib import Path

import laspy
import numpy as np
import rasterio
from rasterio.transform import from_origin

lidarsim, out = sys.argv[1], Path(sys.argv[2])
out.mkdir(parents=True, exist_ok=True)
passed = failed = 0


def check(cond, what):
    global passed, failed
    if cond:
        passed += 1
    else:
        failed += 1
        print(f"FAILED: {what}")


E0, N0 = 350_000.0, 5_600_000.0
cols, rows, dx, dy = 70, 50, 4.0, 3.0
west, north = E0 + 2.0, N0 + 160.0
transform = from_origin(west, north, dx, dy)


def plane(x, y):
    return 200.0 + 0.15 * (x - E0) - 0.1 * (y - N0)


# Pixel centres as GDAL defines them (row 0 north).
r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
xs, ys = rasterio.transform.xy(transform, r.ravel(), c.ravel(), offset="center")
xs = np.asarray(xs).reshape(rows, cols)
ys = np.asarray(ys).reshape(rows, cols)
z = plane(xs, ys)
NODATA = -9999.0
z[20:24, 30:35] = NODATA  # a hole: rows 20-23, columns 30-34
hole_x = (xs[0, 30], xs[0, 34])
hole_y = (ys[23, 0], ys[20, 0])

profile = dict(width=cols, height=rows, count=1, crs="EPSG:32632", transform=transform, nodata=NODATA)
with rasterio.open(out / "dem.tif", "w", driver="GTiff", dtype="float64", **profile) as dst:
    dst.write(z, 1)
with rasterio.open(out / "dem.asc", "w", driver="AAIGrid", dtype="float32",
                   **profile, FORCE_CELLSIZE=False) as dst:
    dst.write(z.astype("float32"), 1)

for name in ["dem.tif", "dem.asc"]:
    with rasterio.open(out / name) as src:
        check(src.transform.almost_equals(transform), f"{name}: GDAL reads back its transform")
    run = out / f"run-{name.replace('.', '-')}"
    survey = out / f"survey-{name.replace('.', '-')}.toml"
    cx = (west + dx * cols / 2) - E0
    survey.write_text(f"""
seed = 5
[scanner]
prf_hz = 30000
scan_frequency_hz = 40
scan_angle_deg = 20
subrays = 1
[[flight_line]]
start_m = [{cx}, -20, 700]
end_m = [{cx}, 190, 700]
speed_mps = 60
[materials.soil]
reflectance = 0.3
[[terrain]]
file = "{name}"
material = "soil"
offset_m = [{-E0}, {-N0}, 0]
""")
    subprocess.run([lidarsim, "run", str(survey), "-o", str(run)], check=True, stdout=subprocess.DEVNULL)
    las = laspy.read(run / "points.las")
    x = np.asarray(las.x) + E0
    y = np.asarray(las.y) + N0
    zz = np.asarray(las.z)
    n = len(x)
    check(n > 5000, f"{name}: {n} points")
    err = np.abs(zz - plane(x, y))
    print(f"{name}: {n} points, height error max {err.max():.4f} m, mean {err.mean():.5f} m")
    check(err.max() < 0.01, f"{name}: points on the plane (max error {err.max()} m)")
    # Inside the pixel-centre extent (the TIN spans centre to centre).
    check(x.min() >= xs.min() - 1e-3 and x.max() <= xs.max() + 1e-3, f"{name}: x within pixel centres")
    check(y.min() >= ys.min() - 1e-3 and y.max() <= ys.max() + 1e-3, f"{name}: y within pixel centres")
    # And reaching them (the swath is wider than the raster).
    print(f"{name}: points span x {x.min() - E0:.2f}..{x.max() - E0:.2f}, y {y.min() - N0:.2f}..{y.max() - N0:.2f}; "
          f"pixel centres x {xs.min() - E0}..{xs.max() - E0}, y {ys.min() - N0}..{ys.max() - N0}")
    check(x.min() < xs.min() + 3 and x.max() > xs.max() - 3, f"{name}: x reaches the raster's edges")
    check(y.min() < ys.min() + 3 and y.max() > ys.max() - 3, f"{name}: y reaches the raster's edges")
    inside = (x > hole_x[0] + 0.5) & (x < hole_x[1] - 0.5) & (y > hole_y[0] + 0.5) & (y < hole_y[1] - 0.5)
    check(inside.sum() == 0, f"{name}: {inside.sum()} points in the nodata hole")
    check(np.all(np.asarray(las.classification) == 2), f"{name}: terrain class ground (2)")

print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
