#!/usr/bin/env python3
"""Runs the example survey of each beam deflector and reads its LAS file
with laspy (an independent reader): the scan angle within the instrument's
field of view, the scan direction flag as the deflector sets it (one way for
a polygon and a fibre array, both looks for a Palmer scanner) and the scanner
channel field (two channels for the VQ-1560i, one otherwise).

Usage: check_deflector_examples.py LIDARSIM OUTDIR
"""

import shutil
import subprocess
import sys
from pathlib import Path

import laspy
import numpy as np

# example: (largest |scan angle| in degrees, scan direction flags, channels)
EXPECT = {
    # Polygon: +-30 deg, left to right only.
    "polygon-vq780i": (30.0, {1}, {0}),
    # Palmer: a 20 deg cone (across-track angle up to 20), forward (1) and
    # backward (0) looks.
    "palmer-vq880g": (20.0, {0, 1}, {0}),
    # Risley: a 70.4 deg rosette, on a multicopter that rolls up to 1.9 deg.
    "uav-livox-mid70": (37.1, {1}, {0}),
    # Fibre array: +-7 deg, left to right only.
    "fibre-array": (7.0, {1}, {0}),
    # Two channels through one polygon, tilted 14 deg along the track: the
    # across-track angle reaches atan(tan 30 deg / cos 14 deg) = 30.75 deg.
    "two-channel-vq1560i": (30.75, {1}, {0, 1}),
}


def main() -> None:
    lidarsim, out = Path(sys.argv[1]), Path(sys.argv[2])
    root = Path(__file__).resolve().parent.parent
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for name, (max_angle, flags, channels) in EXPECT.items():
        dest = out / name
        subprocess.run(
            [str(lidarsim), "run", str(root / "examples" / f"{name}.toml"), "-o", str(dest)],
            check=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        las = laspy.read(dest / "points.las")
        n = len(las.points)
        assert n > 1000, f"{name}: {n} points"
        # LAS 1.4 point format 6: scan angle in 0.006 degree steps.
        angle = np.abs(np.asarray(las.scan_angle, dtype=float) * 0.006)
        # The beam's footprint and the ground's tilt add a little.
        assert angle.max() <= max_angle + 0.5, f"{name}: scan angle {angle.max():.2f}"
        assert angle.max() >= 0.8 * max_angle, f"{name}: scan angle {angle.max():.2f}"
        got_flags = set(np.unique(np.asarray(las.scan_direction_flag)).tolist())
        assert got_flags == flags, f"{name}: scan direction flags {got_flags}"
        got_channels = set(np.unique(np.asarray(las.scanner_channel)).tolist())
        assert got_channels == channels, f"{name}: channels {got_channels}"
        if len(channels) > 1:
            counts = np.bincount(np.asarray(las.scanner_channel))
            assert abs(counts[0] - counts[1]) < 0.02 * n, f"{name}: {counts}"
        print(
            f"{name}: {n} points, |scan angle| <= {angle.max():.2f} deg, "
            f"flags {sorted(got_flags)}, channels {sorted(got_channels)}"
        )


if __name__ == "__main__":
    main()
