#!/usr/bin/env python3
"""Reads the error extra bytes of DIR/points.las with laspy (an independent
reader of the Extra Bytes VLR) and checks them against the GNSS bias of
scripts/fixtures/gnss-bias.toml: every point's error vector is the bias, and
the points sit on the biased ground. Prints "N passed, N failed"."""

import sys

import laspy
import numpy as np

las = laspy.read(sys.argv[1] + "/points.las")
names = list(las.point_format.extra_dimension_names)
ok = names == ["amplitude", "echo_width", "range", "incidence_angle", "object_id",
               "error_x", "error_y", "error_z"]
print(f"extra dimensions {names}")
if ok:
    e = np.stack([np.asarray(las[n]) for n in names[5:]], axis=1)
    ok = np.allclose(e, [0.25, -0.5, 0.125], atol=1e-6)
    ok = ok and np.allclose(np.asarray(las.z), 0.125, atol=0.011)
    print(f"{len(e)} points, error vector {e.mean(axis=0)}")
print("1 passed, 0 failed" if ok else "0 passed, 1 failed")
sys.exit(0 if ok else 1)
