#!/usr/bin/env bash
# Runs the built-in demo and validates its LAS file with laspy (an
# independent reader), then every output format (LAS with full waveform,
# LAZ, PLY, XYZ, CRS) on scripts/fixtures/two-planes.toml, installing laspy,
# lazrs and pyproj into target/pyenv.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/pyenv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c "import laspy, lazrs, numpy, pyproj, rasterio" 2>/dev/null; then
  # rasterio's wheels bundle GDAL: the independent writer of terrain rasters.
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    "laspy>=2.5" "lazrs>=0.6" numpy "pyproj>=3.6" "rasterio>=1.3"
fi

out=target/demo-check
rm -rf "$out"
cargo run --release --quiet -- demo -o "$out"
"$venv/bin/python" scripts/check_las.py "$out"

# The error vector as LAS extra bytes, read by laspy.
rm -rf target/extra-bytes-check
cargo run --release --quiet -- run scripts/fixtures/gnss-bias.toml -o target/extra-bytes-check > /dev/null
"$venv/bin/python" scripts/check_extra_bytes.py target/extra-bytes-check

# Every point format, read by laspy, laspy+lazrs, pyproj and numpy.
rm -rf target/outputs-check
cargo run --release --quiet -- run scripts/fixtures/two-planes.toml -o target/outputs-check > /dev/null
"$venv/bin/python" scripts/check_outputs.py target/outputs-check

# Terrain rasters written by GDAL (rasterio), flown, points read by laspy.
rm -rf target/terrain-check
"$venv/bin/python" scripts/check_terrain.py target/release/lidarsim target/terrain-check

# The example survey of each beam deflector, read by laspy: scan angles,
# scan direction flags and scanner channels.
"$venv/bin/python" scripts/check_deflector_examples.py target/release/lidarsim target/deflector-examples
