#!/usr/bin/env python3
"""Figures of examples/forest.toml: point densities, return types, ground
share under canopy. Usage: forest_example_figures.py OUT/points.xyz (after
`lidarsim run examples/forest.toml -o OUT`). The stand outlines below are
those of the example."""
# Figures of examples/forest.toml from points.xyz (plain python 3).
# Columns: x y z intensity return_number number_of_returns classification
# gps_time scan_angle_deg point_source_id amplitude echo_width_ns range_m component
import sys
from collections import Counter

path = sys.argv[1] if len(sys.argv) > 1 else "/tmp/forest-out/points.xyz"

# The two [[forest]] outlines of examples/forest.toml.
STANDS = [
    [(-90.0, -90.0), (-5.0, -90.0), (-5.0, 90.0), (-90.0, 90.0)],
    [(5.0, -90.0), (90.0, -90.0), (90.0, 50.0), (50.0, 90.0), (5.0, 90.0)],
]

def area(poly):
    n = len(poly)
    return abs(sum(poly[i][0] * poly[(i + 1) % n][1] - poly[(i + 1) % n][0] * poly[i][1]
                   for i in range(n))) / 2

def inside(poly, x, y):  # even-odd rule, as crates/lidarsim/src/scene/forest.rs
    c, j = False, len(poly) - 1
    for i in range(len(poly)):
        (xi, yi), (xj, yj) = poly[i], poly[j]
        if (yi > y) != (yj > y) and x < xi + (y - yi) * (xj - xi) / (yj - yi):
            c = not c
        j = i
    return c

def in_stands(x, y):
    return any(inside(p, x, y) for p in STANDS)

stand_area = sum(area(p) for p in STANDS)

kinds = ("single", "first", "intermediate", "last")
def kind(rn, nr):
    if nr == 1:
        return "single"
    if rn == 1:
        return "first"
    if rn == nr:
        return "last"
    return "intermediate"

n_all = n_in = first_in = 0
kind_all, kind_in = Counter(), Counter()
last_in = last_in_ground = 0            # return_number == number_of_returns (singles included)
lastmany_in = lastmany_in_ground = 0    # last of several returns only
cls_in, comp_in = Counter(), Counter()
pulses = {}                             # (line, gps_time) -> [number_of_returns, first return in stand]

with open(path) as f:
    header = f.readline().split()
    col = {name: i for i, name in enumerate(header)}
    for line in f:
        v = line.split()
        x, y = float(v[col["x"]]), float(v[col["y"]])
        rn, nr = int(v[col["return_number"]]), int(v[col["number_of_returns"]])
        cls, comp = int(v[col["classification"]]), int(v[col["component"]])
        k = kind(rn, nr)
        n_all += 1
        kind_all[k] += 1
        inn = in_stands(x, y)
        key = (v[col["point_source_id"]], v[col["gps_time"]])
        if rn == 1:
            pulses[key] = [nr, inn]
        if not inn:
            continue
        n_in += 1
        kind_in[k] += 1
        cls_in[cls] += 1
        comp_in[comp] += 1
        if rn == 1:
            first_in += 1
        if rn == nr:
            last_in += 1
            last_in_ground += cls == 2
            if nr > 1:
                lastmany_in += 1
                lastmany_in_ground += cls == 2

stand_pulses = [nr for nr, inn in pulses.values() if inn]
print(f"stand area                 {stand_area:.0f} m²")
print(f"points in stands           {n_in} of {n_all}")
print(f"density, all returns       {n_in / stand_area:.2f} /m²")
print(f"density, first returns     {first_in / stand_area:.2f} /m²")
for label, c, n in (("in stands", kind_in, n_in), ("all points", kind_all, n_all)):
    print(f"return types ({label}): " + ", ".join(f"{k} {100 * c[k] / n:.1f} %" for k in kinds))
print(f"ground (class 2) among last returns in stands (singles included): "
      f"{100 * last_in_ground / last_in:.1f} % ({last_in_ground}/{last_in})")
print(f"ground (class 2) among last-of-several returns in stands: "
      f"{100 * lastmany_in_ground / lastmany_in:.1f} % ({lastmany_in_ground}/{lastmany_in})")
print(f"mean returns per pulse in stands (pulses with an echo, by first return): "
      f"{sum(stand_pulses) / len(stand_pulses):.3f} over {len(stand_pulses)} pulses")
print("classes in stands:    " + ", ".join(f"{c}: {100 * n / n_in:.1f} %" for c, n in sorted(cls_in.items())))
print("components in stands: " + ", ".join(f"{c}: {100 * n / n_in:.1f} %" for c, n in sorted(comp_in.items())))
