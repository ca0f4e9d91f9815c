#!/usr/bin/env python3
"""Independent check of a lidarsim output directory with laspy.

Reads DIR/points.las with laspy (not our code) and checks it against the
LAS 1.4 R15 specification, against DIR/summary.json, against the text
output DIR/points.xyz and against the geometry of the built-in demo scene
(ground at z = 0, roofs above it, trees in the town and a forest stand east
of it at 150 < x < 270). Exits non-zero with a message on the
first failure; prints the figures it checked and a plain
"N passed, 0 failed" line at the end.
"""

import itertools
import json
import sys
from pathlib import Path

import laspy
import numpy as np

checks = 0


def check(cond, what):
    global checks
    if not cond:
        print(f"FAILED: {what}")
        print(f"{checks} passed, 1 failed")
        sys.exit(1)
    checks += 1


def main(out):
    out = Path(out)
    summary = json.loads((out / "summary.json").read_text())
    las = laspy.read(out / "points.las")
    h = las.header

    # Header (LAS 1.4 R15, Table 3).
    check(str(h.version) == "1.4", f"version 1.4, got {h.version}")
    check(h.point_format.id == 6, f"point format 6, got {h.point_format.id}")
    check(h.point_count == summary["points"] == len(las.points),
          f"point count {h.point_count} vs summary {summary['points']}")
    check(int(h.global_encoding.value) & 0x10, "WKT bit set for point format 6")
    check(np.allclose(h.scales, 0.001), f"scales {h.scales}")

    rn = np.asarray(las.return_number)
    nr = np.asarray(las.number_of_returns)
    by_return = [int(np.sum(rn == k)) for k in range(1, 16)]
    check(list(h.number_of_points_by_return[:15]) == by_return,
          f"points by return {list(h.number_of_points_by_return)} vs {by_return}")
    check(by_return[: len(summary["points_by_return"])] == summary["points_by_return"],
          "points by return match summary.json")
    check(np.all((rn >= 1) & (rn <= nr) & (nr <= 5)), "1 <= return <= returns <= 5")
    check(by_return[1] > 0.03 * by_return[0], f"second returns present: {by_return[:3]}")

    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    check(np.allclose(h.mins, [x.min(), y.min(), z.min()], atol=1e-9), "header minima")
    check(np.allclose(h.maxs, [x.max(), y.max(), z.max()], atol=1e-9), "header maxima")

    # Classes: ground 2, vegetation 3/4/5, building 6, noise 7, road 11.
    cls = np.asarray(las.classification)
    check(set(np.unique(cls)) <= {2, 3, 4, 5, 6, 7, 11}, f"classes {sorted(set(np.unique(cls)))}")
    ground = (cls == 2) | (cls == 11)
    # Ground at z = 0. In the town all but a few echoes lie within 2 cm (the
    # rest are mixed echoes where a footprint straddles a wall base or the
    # scene's edge); under the forest the ground echo is weakened by the
    # canopy and carries more range noise.
    in_forest = np.asarray(las.x) > 150
    dz_town = np.abs(z[ground & ~in_forest])
    dz_forest = np.abs(z[ground & in_forest])
    check(np.mean(dz_town < 0.02) > 0.999, f"town ground within 2 cm: {np.mean(dz_town < 0.02)}")
    check(np.mean(dz_forest < 0.05) > 0.95, f"forest ground within 5 cm: {np.mean(dz_forest < 0.05)}")
    # The discrete receiver (the default) is blind for 2.7 m after a
    # trigger, so a ground echo that a low branch or a wall base starts is
    # recorded as one mixed return up to that far above the ground: a few
    # in 10 000, never more than the dead zone.
    dz = np.concatenate([dz_town, dz_forest])
    check(np.mean(dz > 0.4) < 1e-4, f"ground beyond 40 cm: {np.mean(dz > 0.4):.2e} of ground")
    check(dz.max() < 2.7, f"all ground within the 2.7 m dead zone: {dz.max():.3f} m")
    # Building points: walls reach down to the ground, roofs are 5-12 m up.
    zb = z[cls == 6]
    check(np.all(zb > -0.25) and np.all(zb < 12.1), f"building points 0..12 m: {zb.min()}..{zb.max()}")
    check(np.mean(zb > 4.5) > 0.9, f"building points mostly on roofs: {np.mean(zb > 4.5)}")
    # Roofs cover 3 468 m² of the 126 000 m² scene (2.8 %), walls add some
    # and the town is flown twice, the forest once.
    check(0.025 < np.mean(cls == 6) < 0.06, f"building share {np.mean(cls == 6):.4f}")

    # Vegetation: the LAS user data byte says what returned an echo
    # (0 surface, 1 foliage, 2 trunk); foliage and trunks are vegetation.
    comp = np.asarray(las.user_data)
    check(set(np.unique(comp)) == {0, 1, 2}, f"components {set(np.unique(comp))}")
    check(np.all(np.isin(cls[comp > 0], [3, 4, 5])), "foliage and trunk echoes are vegetation")
    check(np.all(np.isin(cls[comp == 0], [2, 6, 7, 11])), "surface echoes are not vegetation")
    forest = (x > 152) & (x < 268)
    last = rn == nr
    ground_share = np.mean(cls[forest & last] == 2)
    check(0.3 < ground_share < 0.95, f"forest: ground share of last returns {ground_share:.3f}")
    check(np.mean(nr[forest & (rn == 1)] > 1) > 0.1, "forest: pulses with several returns")
    check(np.all(z[forest & (comp == 1)] < 24.5), "forest: foliage below the tallest tree top")

    # Scan angle (0.006 degree units): demo scans +-20 degrees, sway <= 0.6.
    sa = np.asarray(las.scan_angle) * 0.006
    check(np.all(np.abs(sa) <= 20.7), f"scan angles within +-20.7: {np.abs(sa).max()}")
    check(sa.max() > 19.5 and sa.min() < -19.5, f"scan angles {sa.min()}..{sa.max()}")

    # Flight lines, GPS time order, flags.
    src = np.asarray(las.point_source_id)
    check(set(np.unique(src)) == {1, 2, 3}, f"point source ids {set(np.unique(src))}")
    t = np.asarray(las.gps_time)
    for s in (1, 2, 3):
        ts = t[src == s]
        check(np.all(np.diff(ts) >= 0), f"GPS time non-decreasing in line {s}")
    edges = int(np.sum(np.asarray(las.edge_of_flight_line)))
    check(edges > 0, "edge-of-flight-line flags present")
    sd = np.asarray(las.scan_direction_flag)
    check(0.4 < sd.mean() < 0.6, f"both scan directions: {sd.mean()}")
    inten = np.asarray(las.intensity)
    check(inten.min() >= 0 and np.median(inten) > 1000, "intensities recorded")

    # Echo attributes as extra bytes, by name.
    names = list(las.point_format.extra_dimension_names)
    check(names == ["amplitude", "echo_width", "range", "incidence_angle", "object_id"],
          f"extra bytes {names}")
    inc = np.asarray(las.incidence_angle, dtype=np.float64)
    no_surface = (comp == 1) | (cls == 7)
    check(np.all(np.isnan(inc) == no_surface), "incidence angle NaN exactly for foliage and noise echoes")
    # Level ground: the incidence angle is the beam's angle from the
    # vertical, i.e. the scan angle up to the along-track sway (<= 0.6 deg).
    town_ground = ground & ~in_forest & (np.abs(z) < 0.02)
    d_inc = np.abs(inc[town_ground] - np.abs(sa[town_ground]))
    check(np.percentile(d_inc, 99) < 0.7, f"town ground incidence = |scan angle|: 99th percentile of difference {np.percentile(d_inc, 99):.3f} deg")
    rng = np.asarray(las["range"], dtype=np.float64)
    check(np.all((rng > 370) & (rng < 430)), f"ranges from 400 m altitude: {rng.min():.1f}..{rng.max():.1f} m")
    check(np.allclose(inten, np.clip(np.round(summary["intensity_gain"] * np.asarray(las.amplitude, dtype=np.float64)), 0, 65535), atol=1),
          "intensity = gain x amplitude extra byte")

    # The text output holds the same points (first 100 000).
    with open(out / "points.xyz") as f:
        head = f.readline().split()
        check(head[:4] == ["x", "y", "z", "intensity"], f"xyz header {head[:4]}")
        check(head[-1] == "component", f"xyz header ends with component: {head[-1]}")
        rows = np.loadtxt(itertools.islice(f, 100_000))
    n = len(rows)
    check(np.allclose(rows[:, 0], x[:n], atol=6e-4) and np.allclose(rows[:, 1], y[:n], atol=6e-4)
          and np.allclose(rows[:, 2], z[:n], atol=6e-4), "xyz coordinates match LAS")
    check(np.array_equal(rows[:, 3].astype(int), inten[:n]), "xyz intensities match LAS")
    check(np.array_equal(rows[:, -1].astype(int), comp[:n]), "xyz components match LAS user data")

    # The planned density: points per m2 over the central overlap of the two
    # lines, first returns, against twice the planned single-line density.
    first = rn == 1
    box = first & (np.abs(x) < 20) & (np.abs(y) < 100)
    measured = np.sum(box) / (40 * 200)
    planned = 2 * summary["point_density_per_m2"]
    print(f"central density {measured:.2f} /m2 (planned {planned:.2f} from two lines)")
    check(abs(measured / planned - 1) < 0.25, "density near the plan")

    print(f"points {len(las.points)}, first/second/third returns {by_return[:3]}, "
          f"classes {dict(zip(*np.unique(cls, return_counts=True)))}")
    print(f"{checks} passed, 0 failed")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "demo-out")
