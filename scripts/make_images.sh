#!/usr/bin/env bash
# Regenerates the pictures in docs/img/ from the built-in demo:
# a top view by class, a top view by height and a cross-section through the
# forest stand.
set -euo pipefail
cd "$(dirname "$0")/.."
out=target/demo-images
cargo run --release --quiet -- demo -o "$out" > /dev/null
mkdir -p docs/img
cargo run --release --quiet -- render "$out/points.las" -o docs/img/demo-top-class.png --color class --resolution 0.6
cargo run --release --quiet -- render "$out/points.las" -o docs/img/demo-top-height.png --color height --resolution 0.6
cargo run --release --quiet -- render "$out/points.las" -o docs/img/demo-profile.png --color class \
  --profile 150,0,270,0,2 --resolution 0.1
# The waveform of a pulse with four echoes through a crown: the first point
# of the demo whose pulse has four or more returns.
t=$(awk 'NR>1 && $6>=4 && $5==1 {print $8; exit}' "$out/points.xyz")
cargo run --release --quiet -- waveform "$out" --gps-time "$t" -o docs/img/demo-waveform.png
