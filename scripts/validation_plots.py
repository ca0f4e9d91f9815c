#!/usr/bin/env python3
"""Pictures of the canopy-radiometry validation study.

Reads the JSON files `scripts/canopy_validation.py --json` wrote for two
builds ("before" and "after" a change) and draws one PNG per study into an
image directory (default docs/img/):

* validation-returns-vs-height.png: first-return canopy cover and the share
  of single-return pulses against flying height, both receivers;
* validation-ground-energy-vs-tau.png: ground echo energy relative to the
  bare ground against optical depth, with exp(-tau);
* validation-amplitude-vs-range.png: echo amplitude against range for the
  3 cm plate and the extended plane, log-log, with R^-2 and R^-4 guides.

    target/pyenv/bin/python scripts/validation_plots.py \\
        target/validation-before.json target/validation-cur.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402

HEIGHTS_S1 = (500, 1000, 2000)
TAUS = (0.5, 1, 2, 3)
HEIGHTS_S3 = (500, 707, 1000, 1414, 2000)
SIZE = (8.0, 5.0)  # inches, at DPI 100: 800 x 500 px
DPI = 100
COLOURS = {"before": "#c0392b", "after": "#1f5fa8"}

plt.rcParams.update({"font.size": 11, "axes.titlesize": 12, "legend.fontsize": 9.5})


def load(path: str) -> dict:
    with open(path) as f:
        doc = json.load(f)
    return doc.get("figures", doc)


def series(fig: dict, keys) -> list[float]:
    out = []
    for k in keys:
        v = fig.get(k)
        out.append(float("nan") if v is None else float(v))
    return out


def has(figs: dict, prefix: str) -> bool:
    return any(k.startswith(prefix) for f in figs.values() for k in f)


def plot_returns(figs: dict, labels: dict, path: str) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=SIZE, dpi=DPI)
    for name, f in figs.items():
        for rec, style, rlabel in (("noise", "-", "noise 0.005, 4σ"),
                                   ("low", "--", "no noise, min 1e-4")):
            cover = series(f, [f"s1.h{h}.{rec}.first_return_cover" for h in HEIGHTS_S1])
            single = series(f, [f"s1.h{h}.{rec}.pulses_with_returns_1" for h in HEIGHTS_S1])
            kw = dict(color=COLOURS[name], linestyle=style, marker="o" if rec == "noise" else "s",
                      label=f"{labels[name]}, {rlabel}")
            ax1.plot(HEIGHTS_S1, cover, **kw)
            ax2.plot(HEIGHTS_S1, single, **kw)
    for ax in (ax1, ax2):
        ax.set_xlabel("flying height above ground (m)")
        ax.set_xticks(HEIGHTS_S1)
        ax.set_ylim(0, 1.05)
        ax.grid(alpha=0.3)
    ax1.set_ylabel("share of first returns above 2 m")
    ax1.set_title("First-return canopy cover")
    ax2.set_ylabel("share of pulses with one return")
    ax2.set_title("Single-return pulses")
    cpc = next((f.get("s1.crown_projection_cover") for f in figs.values()
                if f.get("s1.crown_projection_cover") is not None), None)
    if cpc is not None:
        ax1.axhline(cpc, color="grey", linewidth=0.8, linestyle=":")
        ax1.text(HEIGHTS_S1[-1], cpc + 0.02, f"crown projection cover {cpc:.2f}",
                 ha="right", va="bottom", fontsize=9, color="grey")
    ax2.legend(loc="lower right")
    fig.suptitle("200 pines and spruces, 100 kHz, ±15°, 0.3 mrad, 19 sub-rays", fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_ground(figs: dict, labels: dict, path: str) -> None:
    fig, ax = plt.subplots(figsize=SIZE, dpi=DPI)
    t = [i * 0.05 for i in range(0, 71)]
    ax.plot(t, [math.exp(-x) for x in t], color="black", linewidth=1.2, label="exp(−τ)")
    ax.plot(t, [math.exp(-1.5 * x) for x in t], color="grey", linewidth=0.8, linestyle=":",
            label="exp(−1.5 τ)")
    notes = []
    for name, f in figs.items():
        ratio = series(f, [f"s2.tau{tau:g}.ground_ratio" for tau in TAUS])
        ax.plot(TAUS, ratio, color=COLOURS[name], marker="o", linestyle="none", markersize=8,
                label=f"{labels[name]} (ρ = 1, k = τ/L)")
        r01 = f.get("s2.tau3.rho0.1.ground_ratio")
        if r01 is not None:
            ax.plot([3], [r01], color=COLOURS[name], marker="x", markersize=11, linestyle="none",
                    label=f"{labels[name]} (ρ = 0.1, k = 10 τ/L)")
        fr = f.get("s2.tau3.foliage_ratio_rho1_over_rho0.1")
        if fr is not None:
            notes.append(f"{labels[name]}: {fr:.2f}")
    ax.set_yscale("log")
    ax.set_xlabel("optical depth τ = k·ρ·L of the vertical path through the crown")
    ax.set_ylabel("ground echo energy / without the tree")
    ax.set_title("Ground energy below one crown (uniform density, 100 m, 19 sub-rays)")
    ax.grid(alpha=0.3, which="both")
    if notes:
        ax.text(0.02, 0.04, "foliage energy at τ = 3, ρ = 1 over ρ = 0.1:\n" + "\n".join(notes),
                transform=ax.transAxes, fontsize=9.5, va="bottom",
                bbox=dict(facecolor="white", edgecolor="grey", alpha=0.9))
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def plot_amplitude(figs: dict, labels: dict, path: str) -> None:
    fig, ax = plt.subplots(figsize=SIZE, dpi=DPI)
    anchor = {}
    for i, (name, f) in enumerate(figs.items()):
        filled = i == len(figs) - 1
        for what, key, marker, text in (
                ("plane", "mean_amplitude", "s", "plane"),
                ("plate", "mean_amplitude_detected", "o", "plate, pulses that saw it"),
                ("plate", "mean_amplitude_window", "^", "plate, per pulse in footprint window")):
            r = series(f, [f"s3.{what}.h{h}.range_m" for h in HEIGHTS_S3])
            a = series(f, [f"s3.{what}.h{h}.{key}" for h in HEIGHTS_S3])
            if all(math.isnan(x) for x in a):
                continue
            anchor.setdefault(what, (r[0], a[0]))
            ax.plot(r, a, color=COLOURS[name], marker=marker, linestyle="-" if filled else "--",
                    markerfacecolor=COLOURS[name] if filled else "none", markersize=8 if filled else 10,
                    label=f"{labels[name]}: {text}")
    last = list(figs.values())[-1]
    r = series(last, [f"s3.plate.h{h}.range_m" for h in HEIGHTS_S3])
    e = series(last, [f"s3.plate.h{h}.mean_amplitude_window_expected" for h in HEIGHTS_S3])
    if not all(math.isnan(x) for x in e):
        ax.plot(r, e, color="black", linewidth=1.2, marker="^", markerfacecolor="white",
                markersize=6, label="plate, window: Gaussian beam, expected")
    rr = [450, 2200]
    guides = {"plane": ((2, ":"),), "plate": ((2, ":"), (4, "-."))}
    for what, (r0, a0) in anchor.items():
        for n, style in guides[what]:
            ax.plot(rr, [a0 * (x / r0) ** -n for x in rr], color="grey", linestyle=style, linewidth=1)
            ax.text(rr[1], a0 * (rr[1] / r0) ** -n, f" R⁻{'²' if n == 2 else '⁴'}", color="grey",
                    va="center", fontsize=9)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("range R (m)")
    ax.set_ylabel("echo amplitude (amplitude units)")
    ax.set_title("Amplitude against range: 3 cm plate (reflectance 0.5) and a plane (0.25)")
    ax.grid(alpha=0.3, which="both")
    ax.set_xlim(430, 2700)
    ax.set_xticks([500, 700, 1000, 1400, 2000])
    ax.set_xticks([], minor=True)
    ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%d"))
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo / 30, hi)
    ax.legend(loc="lower left", fontsize=8, ncol=2, handlelength=1.6, columnspacing=0.8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", help="JSON of the build before the change")
    ap.add_argument("after", help="JSON of the build after the change")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                                  "..", "docs", "img"),
                    help="image directory (default docs/img)")
    ap.add_argument("--labels", default="before,after", help="legend names of the two builds")
    args = ap.parse_args()
    names = args.labels.split(",")
    if len(names) != 2:
        print("error: --labels takes two names separated by a comma", file=sys.stderr)
        return 2
    figs = {"before": load(args.before), "after": load(args.after)}
    labels = {"before": names[0], "after": names[1]}
    os.makedirs(args.out, exist_ok=True)
    written = []
    for prefix, fname, fn in (("s1.", "validation-returns-vs-height.png", plot_returns),
                              ("s2.", "validation-ground-energy-vs-tau.png", plot_ground),
                              ("s3.", "validation-amplitude-vs-range.png", plot_amplitude)):
        if not has(figs, prefix):
            print(f"skipping {fname}: no {prefix} figures in the JSON files", file=sys.stderr)
            continue
        path = os.path.normpath(os.path.join(args.out, fname))
        fn(figs, labels, path)
        written.append(path)
    for p in written:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
