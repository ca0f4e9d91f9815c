"""Point density and canopy penetration against flying height, over a
100 m x 100 m stand of 600 stems/ha: one flight line per height, the same
scanner (100 kHz, +-20 deg, 0.5 mrad), figures taken from the points over
the stand's central 60 m x 60 m.

    python examples/python/height_sweep.py

prints the table that docs/python.md shows (the package's tests run
`sweep()` and compare).
"""

import numpy as np

import lidarsim

SURVEY = {
    "seed": 7,
    "scanner": {
        "prf_hz": 100_000,
        "scan_frequency_hz": 100,
        "scan_angle_deg": 20,
        "divergence_mrad": 0.5,
        "subrays": 19,
        "max_returns": 5,
    },
    "receiver": {"noise": 0.005, "threshold_sigma": 4.0},
    "materials": {"ground": {"reflectance": 0.25}},
    "polygon": [
        {
            "material": "ground",
            "class": "ground",
            "vertices_m": [[-150, -150, 0], [150, -150, 0], [150, 150, 0], [-150, 150, 0]],
        }
    ],
    "forest": [
        {
            "rectangle_m": [-50.0, -50.0, 50.0, 50.0],
            "stems_per_ha": 600,
            "species": {"pine": 0.5, "spruce": 0.3, "birch": 0.2},
            "height_m": [12.0, 26.0],
            "min_spacing_m": 2.0,
            "seed": 3,
        }
    ],
}

HEIGHTS_M = [300, 600, 900, 1200]

#: LAS class of ground points (LAS 1.4 R15, Table 17).
GROUND = 2


def figures(points: np.ndarray) -> dict:
    """Point and pulse densities over the central 60 m x 60 m and the share
    of pulses whose first return is vegetation that also reach the ground
    (canopy penetration)."""
    inside = (np.abs(points["x"]) <= 30.0) & (np.abs(points["y"]) <= 30.0)
    p = points[inside]
    area = 60.0 * 60.0
    first = p["return_number"] == 1
    # A pulse is its line's pulse index (one line per run).
    pulses = p["pulse_index"]
    canopy = np.unique(pulses[first & (p["classification"] != GROUND)])
    grounded = np.unique(pulses[p["classification"] == GROUND])
    return {
        "points_per_m2": len(p) / area,
        "pulses_per_m2": int(first.sum()) / area,
        "penetration": len(np.intersect1d(canopy, grounded)) / max(len(canopy), 1),
    }


def line_at(height_m: float) -> dict:
    """A 100 m line along y over the stand's centre at 50 m/s."""
    return {
        "start_m": [0.0, -50.0, float(height_m)],
        "end_m": [0.0, 50.0, float(height_m)],
        "speed_mps": 50.0,
    }


def sweep(threads=None) -> list:
    """The figures at each flying height."""
    base = lidarsim.Survey.from_dict({**SURVEY, "flight_line": [line_at(HEIGHTS_M[0])]})
    rows = []
    for h in HEIGHTS_M:
        survey = base.replace({"flight_line": [line_at(h)]})
        points = survey.run(threads=threads, progress=False).points
        rows.append({"height_m": h, **figures(points)})
    return rows


def table(rows: list) -> str:
    """The rows as the Markdown table of docs/python.md."""
    lines = [
        "| flying height | points/m² | pulses/m² | penetration |",
        "|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['height_m']} m | {r['points_per_m2']:.2f} | {r['pulses_per_m2']:.2f} "
            f"| {100 * r['penetration']:.1f} % |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(sweep()))
