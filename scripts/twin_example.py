#!/usr/bin/env python3
"""The worked example of docs/validation.md, "A real scan twinned": twin a
real scan with the built `lidarsim`, fly the twin, compare the two clouds,
and write the figures (PNG, matplotlib) and the tables (Markdown) the page
shows, so that no number there is copied by hand.

Usage:
  target/pyenv/bin/python scripts/twin_example.py \
      --scan ../shared/data/real/MixedConifer.laz --bin target/release/lidarsim \
      [--work target/twin-example] [--img docs/img]

Writes WORK/twin (the twin), WORK/run (its flight), WORK/compare
(compare.json, compare.html), WORK/figures.md (the tables) and
IMG/twin-*.png. Needs numpy and matplotlib (scripts/check_python.sh puts
them into target/pyenv). It also flies the twin with the physics of
before issue 46 and with the pine and spruce presets (VARIANTS) and
tabulates what the physics decides.
"""

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np


def run(cmd):
    print("$", " ".join(str(c) for c in cmd), file=sys.stderr)
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def table(rows, header):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def acquisition_table(twin):
    a = twin["acquisition"]
    rows = []
    for s in a["strips"]:
        t = s["track"] or {}
        m = s["mirror"] or {}
        rows.append([
            s["strip"],
            s["first_returns"],
            f"{s['scan_angle_deg'][0]:.0f} … {s['scan_angle_deg'][1]:.0f}",
            f"{t.get('heading_deg', float('nan')):.0f}",
            f"{t.get('speed_mps', float('nan')):.1f}",
            f"{t.get('height_m', float('nan')):.0f} ± {t.get('height_se_m', float('nan')):.0f}",
            f"{t.get('scan_line_skew_deg', float('nan')):.0f}",
            f"{m.get('frequency_hz', float('nan')):.2f}" if m else "–",
            f"{s['pulse_density_per_m2']:.2f}",
        ])
    return table(rows, ["strip", "first returns", "scan angles, deg", "heading, deg",
                        "speed, m/s", "height above ground, m", "scan-line skew, deg",
                        "mirror, Hz", "first returns per m²"])


def scanner_lines(twin):
    a = twin["acquisition"]
    s = a["scanner"]
    est = lambda e, d: f"{e['value']:.{d}f} ({e['source']})"
    lines = [
        f"- deflector: {s['deflector']}, {est(s['scan_frequency_hz'], 2)} Hz, "
        f"±{est(s['scan_angle_deg'], 1)} degrees, up to {s['max_returns']} returns",
        f"- PRF {est(s['prf_hz'], 0)} Hz; the time steps between pulses show "
        f"{a['timing_prf_hz']:.0f} Hz" if a["timing_prf_hz"] else f"- PRF {est(s['prf_hz'], 0)} Hz",
        f"- flying height {est(a['flying_height_m'], 0)} m, speed {est(a['speed_mps'], 1)} m/s, "
        f"{a['pulse_density_per_m2']:.2f} first returns per m²",
    ]
    t = twin["trees"]
    lines.append(
        f"- {t['trees']} trees ({t['trees_per_ha']:.0f} per ha), heights "
        f"{t['height_m'][0]:.1f} / {t['height_m'][1]:.1f} / {t['height_m'][2]:.1f} m "
        f"(5th, 50th, 95th percentile), crown radii {t['crown_radius_m'][1]:.1f} m (median); "
        f"{100 * t['canopy_share']:.0f} % of the area above 2 m, {100 * t['crowns_cover_of_canopy']:.0f} % "
        f"of it under the crowns ({100 * t['equal_area_cover_of_canopy']:.0f} % with discs of each "
        f"crown's area)"
    )
    lines.append(f"- ground: {twin['terrain']['description']}")
    lines += [f"- note: {n}" for n in a["notes"]]
    return "\n".join(lines)


KEYS = [
    "pulse_density_per_m2", "returns_per_pulse", "single_return_share", "first_ground_share",
    "canopy_cover", "canopy_single_share", "first_p25", "first_p50", "first_p95", "first_p99",
    "intensity_ratio",
]


def metrics_table(c):
    rows = []
    for key in KEYS:
        m = next(m for m in c["cells"]["metrics"] if m["key"] == key)
        a, b = c["a"]["metrics"][key], c["b"]["metrics"][key]
        share = key.endswith("share") or key in ("canopy_cover",)
        f = (lambda v: f"{100 * v:.1f} %") if share else (lambda v: f"{v:.2f}")
        d = (lambda v: f"{100 * v:+.1f} pt") if share else (lambda v: f"{v:+.2f}")
        z = "–" if m["z"] is None else f"{m['z']:+.1f}"
        sd = "–" if m["sd_a"] is None else d(m["sd_a"]).lstrip("+")
        rows.append([key, f(a), f(b), d(b - a), z, sd])
    return table(rows, ["metric", "real", "twin", "twin − real", "z of the cells' mean difference",
                        "sd of the real cells"])


def figures(c, img):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, b = c["a"], c["b"]
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    x = np.arange(5)
    ax[0].bar(x - 0.2, a["distributions"]["number_of_returns"], 0.4, label="real")
    ax[0].bar(x + 0.2, b["distributions"]["number_of_returns"], 0.4, label="twin")
    ax[0].set_xticks(x, ["1", "2", "3", "4", "≥5"])
    ax[0].set_xlabel("returns of the pulse")
    ax[0].set_ylabel("share of pulses")
    ax[0].legend()
    for side, name in ((a, "real"), (b, "twin")):
        p = np.array(side["distributions"]["profile_first"])
        ax[1].plot(p, np.arange(len(p)) + 0.5, label=name)
    ax[1].set_xlabel("share of first returns per metre")
    ax[1].set_ylabel("height above ground, m")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(img / "twin-returns-profile.png", dpi=90)
    g = c["cells"]
    m = next(m for m in g["metrics"] if m["key"] == "canopy_cover")
    grids = []
    for side in ("a", "b"):
        full = np.full(g["cols"] * g["rows"], np.nan)
        full[np.array(g["used"])] = [np.nan if v is None else v for v in m[side]]
        grids.append(full.reshape(g["rows"], g["cols"]))
    fig, ax = plt.subplots(1, 3, figsize=(11, 3.4))
    for k, (grid, title) in enumerate(zip(grids + [grids[1] - grids[0]], ["real", "twin", "twin − real"])):
        cmap, lim = ("RdBu_r", 0.3) if k == 2 else ("viridis", None)
        im = ax[k].imshow(grid, origin="lower", cmap=cmap, vmin=-lim if lim else 0, vmax=lim if lim else 1)
        ax[k].set_title(f"canopy cover, {title}")
        ax[k].set_xticks([])
        ax[k].set_yticks([])
        fig.colorbar(im, ax=ax[k], fraction=0.046)
    fig.tight_layout()
    fig.savefig(img / "twin-cover-maps.png", dpi=90)


# The physics a variant flies with: the twin's survey with these keys.
VARIANTS = [
    ("specification's crowns, waveform receiver (before issue 46)", "pine",
     {"vegetation": 'foliage = "specification"', "scanner": 'echo_detection = "waveform"'}),
    ("physical crowns, discrete receiver (the defaults), pine", "pine", {}),
    ("physical crowns, discrete receiver (the defaults), spruce", "spruce", {}),
]

# What the physics decides, compared across the variants.
PHYSICS = ["returns_per_pulse", "single_return_share", "canopy_single_share", "canopy_cover",
           "first_p50", "first_p95", "intensity_ratio"]


def with_keys(text, keys):
    """The survey `text` with `keys` added at the top of their tables."""
    for table_name, lines in keys.items():
        head = f"[{table_name}]\n"
        text = text.replace(head, head + lines + "\n", 1) if head in text else text + "\n" + head + lines + "\n"
    return text


def variants(args):
    """Each variant twinned, flown and compared; a table of what the
    physics decides, real against each."""
    rows, real = [], None
    for name, species, keys in VARIANTS:
        work = args.work / ("variant-" + species + ("-before" if keys else ""))
        run([args.bin, "twin", args.scan, "-o", work / "twin", "--species", species])
        survey = work / "twin" / "survey.toml"
        survey.write_text(with_keys(survey.read_text(), keys))
        run([args.bin, "run", survey, "-o", work / "run"])
        run([args.bin, "compare", args.scan, work / "run", "-o", work / "compare",
             "--cell-m", args.cell_m, "--labels", "real,twin"])
        c = json.loads((work / "compare" / "compare.json").read_text())
        real = c["a"]["metrics"]
        rows.append([name] + [fmt(k, c["b"]["metrics"][k]) for k in PHYSICS])
    rows.insert(0, ["the real scan"] + [fmt(k, real[k]) for k in PHYSICS])
    return table(rows, ["flown with"] + PHYSICS)


def fmt(key, v):
    if v is None:
        return "–"
    share = key.endswith("share") or key in ("canopy_cover",)
    return f"{100 * v:.1f} %" if share else f"{v:.2f}"


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scan", required=True, type=Path)
    p.add_argument("--bin", default="target/release/lidarsim", type=Path)
    p.add_argument("--work", default="target/twin-example", type=Path)
    p.add_argument("--img", default="docs/img", type=Path)
    p.add_argument("--cell-m", default="15")
    args = p.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    args.work.mkdir(parents=True)
    print(run([args.bin, "twin", args.scan, "-o", args.work / "twin"]))
    run([args.bin, "run", args.work / "twin" / "survey.toml", "-o", args.work / "run"])
    print(run([args.bin, "compare", args.scan, args.work / "run", "-o", args.work / "compare",
               "--cell-m", args.cell_m, "--labels", "real,twin"]))
    twin = json.loads((args.work / "twin" / "twin.json").read_text())
    c = json.loads((args.work / "compare" / "compare.json").read_text())
    args.img.mkdir(parents=True, exist_ok=True)
    figures(c, args.img)
    text = "\n\n".join([acquisition_table(twin), scanner_lines(twin), metrics_table(c),
                          variants(args)])
    (args.work / "figures.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
