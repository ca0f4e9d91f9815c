#!/usr/bin/env bash
# Makes the pictures of docs/img/ from the built-in demo: top views by
# class and height, a cross-section through the forest stand, the waveform
# of a pulse through a crown, and the demo's report as headless Chromium
# shows it (whole and panel by panel, each panel checked not blank).
# With a directory argument the pictures go there instead (the test suite
# does so, to run this script without touching docs/img/).
set -euo pipefail
cd "$(dirname "$0")/.."
dest=${1:-docs/img}
out=target/demo-images
cargo run --release --quiet -- demo -o "$out" --overwrite > /dev/null
mkdir -p "$dest"
# The pictures this script makes, made anew (render and waveform write
# only over pictures lidarsim wrote itself).
rm -f "$dest"/demo-top-class.png "$dest"/demo-top-height.png "$dest"/demo-profile.png \
  "$dest"/demo-waveform.png "$dest"/demo-report.png
cargo run --release --quiet -- render "$out/points.las" -o "$dest/demo-top-class.png" --color class --resolution 0.6 > /dev/null
cargo run --release --quiet -- render "$out/points.las" -o "$dest/demo-top-height.png" --color height --resolution 0.6 > /dev/null
cargo run --release --quiet -- render "$out/points.las" -o "$dest/demo-profile.png" --color class \
  --profile 150,0,270,0,2 --resolution 0.1 > /dev/null
# The waveform of a pulse with four echoes through a crown: the first point
# of the demo whose pulse has four or more returns.
t=$(awk 'NR>1 && $6>=4 && $5==1 {print $8; exit}' "$out/points.xyz")
cargo run --release --quiet -- waveform "$out" --gps-time "$t" -o "$dest/demo-waveform.png" > /dev/null
# The report in a browser: the page and each panel.
scripts/install_chromium.sh
rm -rf "$dest/report"
python3 scripts/check_report_browser.py "$out/report.html" "$dest/report"
mv "$dest/report/report.png" "$dest/demo-report.png"
rm -f "$dest/report/panels.json"
echo "pictures in $dest"
