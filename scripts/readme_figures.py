#!/usr/bin/env python3
"""The README's figures of the demo, from a demo run's own files (issue 49:
the README quoted counts and sizes of an older build).

    readme_figures.py DEMO_DIR            print the block
    readme_figures.py DEMO_DIR --write    put it into README.md
    readme_figures.py DEMO_DIR --check    exit 1 when README.md's block differs

The block stands in README.md between the markers below; everything in it
comes from DEMO_DIR/summary.json and the sizes of the files there. Times are
left out: they depend on the machine and on how busy it is.
"""

import json
import os
import sys

BEGIN = "<!-- demo figures: scripts/readme_figures.py writes them from a demo run -->"
END = "<!-- end of demo figures -->"
README = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "README.md")


def grouped(n):
    """1 536 076: digits in groups of three, as the README writes them."""
    return f"{n:,}".replace(",", "\u202f")


def megabytes(path):
    return f"{os.path.getsize(path) / 1e6:.1f} MB"


def block(demo_dir):
    s = json.load(open(os.path.join(demo_dir, "summary.json")))
    lines = len(s["plan"]["lines"])
    returns = s["points_by_return"]
    # points_by_return[k]: points that are return k + 1 of their pulse, so
    # the second entry counts the pulses with two returns or more.
    multi = returns[1] if len(returns) > 1 else 0
    rows = [
        ("flight lines", f"{lines}, {s['swath_width_m']:.0f} m swath each"),
        ("pulses", grouped(s["pulses"])),
        ("pulses with an echo", grouped(s["pulses_with_echo"])),
        ("points", f"{grouped(s['points'])} "
                   f"({s['points'] / max(s['pulses'], 1):.2f} per pulse; "
                   f"{grouped(s['pulses_with_echo'] - multi)} pulses with one return, "
                   f"{grouped(multi)} with more)"),
        ("planned density", f"{s['point_density_per_m2']:.2f} points/m² per line"),
        ("scene", f"{grouped(s['scene_primitives'])} primitives, "
                  f"{grouped(sum(s.get('forest_trees', [])))} generated trees"),
    ]
    for name in ("points.las", "points.xyz"):
        path = os.path.join(demo_dir, name)
        if os.path.exists(path):
            rows.append((f"`{name}`", megabytes(path)))
    out = [BEGIN, "", "| the demo | |", "|---|---|"]
    out += [f"| {k} | {v} |" for k, v in rows]
    out += ["", END]
    return "\n".join(out)


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    demo_dir, mode = sys.argv[1], (sys.argv[2] if len(sys.argv) > 2 else "")
    new = block(demo_dir)
    if mode == "":
        print(new)
        return 0
    text = open(README, encoding="utf-8").read()
    if BEGIN not in text or END not in text:
        print("README.md has no demo figures block", file=sys.stderr)
        return 1
    a, b = text.index(BEGIN), text.index(END) + len(END)
    old = text[a:b]
    if mode == "--write":
        open(README, "w", encoding="utf-8").write(text[:a] + new + text[b:])
        return 0
    if mode == "--check":
        if old != new:
            print("README.md's demo figures differ from the demo's "
                  "(scripts/readme_figures.py DEMO_DIR --write updates them):",
                  file=sys.stderr)
            old_rows, new_rows = old.splitlines(), new.splitlines()
            for o, n in zip(old_rows, new_rows):
                if o != n:
                    print(f"  README: {o}\n  demo:   {n}", file=sys.stderr)
            return 1
        print("README.md's demo figures match the demo")
        return 0
    print(f"unknown mode {mode}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
