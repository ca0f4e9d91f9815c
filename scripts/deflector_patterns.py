#!/usr/bin/env python3
"""Ground patterns of the beam deflectors, for docs/survey.md.

Usage: scripts/deflector_patterns.py [LIDARSIM]   (default target/release/lidarsim)

For each `[scanner] deflector` kind it flies a short line north over flat
ground (one sub-ray, one return, `points.xyz` only), reads the points back
and draws a top view of the first fraction of a second, coloured by time,
as a standalone SVG: docs/img/pattern-<kind>.svg. Python 3 standard
library only. The settings are chosen to make each pattern legible at this
size (low height, slow scan), not to match an instrument.
"""
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IMAGES = os.path.join(ROOT, "docs", "img")
MAX_POINTS = 4000  # drawn per figure; keeps each SVG well under 300 kB

# kind, title, [scanner] keys, height m, speed m/s, seconds flown and drawn
PATTERNS = [
    ("oscillating", "Oscillating mirror (triangle)",
     'deflector = "oscillating"\nmirror = "triangle"\nprf_hz = 10000\n'
     'scan_frequency_hz = 15\nscan_angle_deg = 10', 60.0, 50.0, 0.2),
    ("polygon", "Rotating polygon",
     'deflector = "polygon"\nfacets = 12\nprf_hz = 30000\n'
     'scan_frequency_hz = 30\nscan_angle_deg = 10', 60.0, 50.0, 0.2),
    ("palmer", "Palmer (conic) scanner",
     'deflector = "palmer"\nprf_hz = 20000\nscan_frequency_hz = 10\n'
     'scan_angle_deg = 15', 60.0, 50.0, 0.2),
    ("risley", "Risley prisms (Livox Mid-70 rotors)",
     'deflector = "risley"\nprism_deviation_deg = [17.6, 17.6]\n'
     'rotor_frequency_hz = [-77.733333, 121.566667]\nprf_hz = 100000',
     60.0, 10.0, 0.1),
    ("fibre", "Fibre array",
     'deflector = "fibre"\nfibres = 32\nprf_hz = 1920\n'
     'scan_frequency_hz = 60\nscan_angle_deg = 10', 60.0, 50.0, 0.2),
]

SURVEY = """seed = 1
[scanner]
{keys}
divergence_mrad = 0.2
subrays = 1
max_returns = 1
[[flight_line]]
start_m = [0.0, 0.0, {h}]
end_m = [0.0, {y1}, {h}]
speed_mps = {v}
[output]
formats = ["xyz"]
gps_start_time_s = 0.0
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-500, -500, 0], [500, -500, 0], [500, 500, 0], [-500, 500, 0]]
"""


def simulate(binary, keys, h, v, seconds, tmp, kind):
    """Runs the survey; returns [(t, x, y)] of its points in time order."""
    survey = os.path.join(tmp, kind + ".toml")
    out = os.path.join(tmp, kind + "-out")
    with open(survey, "w") as f:
        f.write(SURVEY.format(keys=keys, h=h, v=v, y1=round(v * seconds, 6)))
    subprocess.run([binary, "run", survey, "-o", out, "--threads", "2"],
                   check=True, stdout=subprocess.DEVNULL)
    points = []
    with open(os.path.join(out, "points.xyz")) as f:
        col = {name: i for i, name in enumerate(f.readline().split())}
        ix, iy, it = col["x"], col["y"], col["gps_time"]
        for line in f:
            c = line.split()
            points.append((float(c[it]), float(c[ix]), float(c[iy])))
    points.sort()
    return points


def ramp(u):
    """Blue (u = 0) to red (u = 1)."""
    r, g, b = (int(round(a + (z - a) * u)) for a, z in ((30, 215), (60, 40), (220, 40)))
    return "#%02x%02x%02x" % (r, g, b)


def nice_step(span, ticks=6):
    """The smallest of 1, 2, 5 × 10^e giving at most about `ticks` ticks."""
    for e in range(-3, 5):
        for m in (1, 2, 5):
            if m * 10.0 ** e >= span / ticks:
                return m * 10.0 ** e
    return span / ticks


def wrap(text, width):
    """`text` in lines of at most about `width` characters, broken after commas."""
    lines, line = [], ""
    for part in text.split(", "):
        if line and len(line) + 2 + len(part) > width:
            lines.append(line + ",")
            line = part
        else:
            line = line + ", " + part if line else part
    return lines + [line]


def fmt(x):
    return ("%.2f" % x).rstrip("0").rstrip(".")


def svg(points, title, subtitles, seconds, track):
    t0 = points[0][0]
    points = [p for p in points if p[0] - t0 <= seconds + 1e-9]
    stride = max(1, -(-len(points) // MAX_POINTS))
    drawn = points[::stride]
    xs = [p[1] for p in points] + [0.0]
    ys = [p[2] for p in points] + list(track)
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    pad = 0.04 * max(x1 - x0, y1 - y0)
    x0, x1, y0, y1 = x0 - pad, x1 + pad, y0 - pad, y1 + pad
    # Equal scales on both axes: the figure keeps the pattern's shape.
    left, top, plot_w, max_h = 62, 48 + 14 * len(subtitles), 560, 560
    scale = min(plot_w / (x1 - x0), max_h / (y1 - y0))
    pw, ph = (x1 - x0) * scale, (y1 - y0) * scale
    width, height = left + pw + 110, top + ph + 52
    px = lambda x: left + (x - x0) * scale
    py = lambda y: top + (y1 - y) * scale
    o = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
         'viewBox="0 0 %d %d" font-family="sans-serif" font-size="12">'
         % (width, height, width, height),
         '<rect width="100%" height="100%" fill="white"/>',
         '<text x="%d" y="22" font-size="15" font-weight="bold">%s</text>' % (left, title),
         ] + ['<text x="%d" y="%d" font-size="11" fill="#333">%s</text>' % (left, 40 + 14 * i, s)
              for i, s in enumerate(subtitles)]
    # Grid and ticks.
    for lo, hi, horizontal in ((x0, x1, True), (y0, y1, False)):
        step = nice_step(hi - lo)
        k = int(lo // step) + 1
        while k * step <= hi:
            val = k * step
            if horizontal:
                p = px(val)
                o.append('<line x1="%.1f" y1="%.1f" x2="%.1f" y2="%.1f" stroke="#e4e4e4"/>'
                         % (p, top, p, top + ph))
                o.append('<text x="%.1f" y="%.1f" text-anchor="middle">%s</text>'
                         % (p, top + ph + 16, fmt(val)))
            else:
                p = py(val)
                o.append('<line x1="%.1f" y1="%.1f" x2="%.1f" y2="%.1f" stroke="#e4e4e4"/>'
                         % (left, p, left + pw, p))
                o.append('<text x="%.1f" y="%.1f" text-anchor="end">%s</text>'
                         % (left - 5, p + 4, fmt(val)))
            k += 1
    o.append('<rect x="%.1f" y="%.1f" width="%.1f" height="%.1f" fill="none" stroke="#555"/>'
             % (left, top, pw, ph))
    o.append('<text x="%.1f" y="%.1f" text-anchor="middle">x (east, across track), m</text>'
             % (left + pw / 2, top + ph + 36))
    o.append('<text transform="translate(16 %.1f) rotate(-90)" text-anchor="middle">'
             'y (north, along track), m</text>' % (top + ph / 2))
    # The aircraft's nadir track over the window, flying north.
    o.append('<line x1="%.1f" y1="%.1f" x2="%.1f" y2="%.1f" stroke="#888" '
             'stroke-dasharray="4 3"/>' % (px(0), py(track[0]), px(0), py(track[1])))
    ax, ay = px(0), py(track[1])
    o.append('<path d="M%.1f %.1fl-4 8h8z" fill="#888"/>' % (ax, ay - 2))
    # Points: one path of small squares per colour band.
    bands = 24
    span = max(seconds, 1e-12)
    groups = [[] for _ in range(bands)]
    size = 1.6 if len(drawn) > 1000 else 3.0  # marker side, px
    for t, x, y in drawn:
        b = min(bands - 1, int((t - t0) / span * bands))
        groups[b].append("M%.1f %.1fh%gv%gh-%gz" % (
            px(x) - size / 2, py(y) - size / 2, size, size, size))
    for b, g in enumerate(groups):
        if g:
            o.append('<path fill="%s" d="%s"/>' % (ramp((b + 0.5) / bands), "".join(g)))
    # Colour bar.
    cx, cw = left + pw + 28, 14
    for b in range(bands):
        yb = top + ph - (b + 1) * ph / bands
        o.append('<rect x="%.1f" y="%.1f" width="%d" height="%.2f" fill="%s"/>'
                 % (cx, yb, cw, ph / bands + 0.3, ramp((b + 0.5) / bands)))
    o.append('<rect x="%.1f" y="%d" width="%d" height="%.1f" fill="none" stroke="#555"/>'
             % (cx, top, cw, ph))
    o.append('<text x="%.1f" y="%.1f">0 s</text>' % (cx + cw + 4, top + ph))
    o.append('<text x="%.1f" y="%.1f">%s s</text>' % (cx + cw + 4, top + 10, fmt(seconds)))
    o.append('<text x="%.1f" y="%.1f" text-anchor="middle">time</text>' % (cx + cw / 2, top - 6))
    o.append('<text x="%.1f" y="%.1f" font-size="10" fill="#555">%d of %d points</text>'
             % (left + pw - 120, top + ph + 36, len(drawn), len(points)))
    o.append("</svg>\n")
    return "\n".join(o)


def main():
    binary = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target", "release", "lidarsim")
    if not (os.path.isfile(binary) or shutil.which(binary)):
        sys.exit("no lidarsim binary at %s (build it with cargo build --release)" % binary)
    os.makedirs(IMAGES, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="deflector-patterns-") as tmp:
        for kind, title, keys, h, v, seconds in PATTERNS:
            points = simulate(binary, keys, h, v, seconds, tmp, kind)
            if not points:
                sys.exit("%s: no points" % kind)
            shown = ", ".join(k.strip() for k in keys.split("\n"))
            subtitles = wrap("[scanner] " + shown, 90) + [
                "%g m above flat ground, flying north at %g m/s; the first %g s" % (h, v, seconds)]
            subtitles = [t.replace('"', "&quot;") for t in subtitles]
            path = os.path.join(IMAGES, "pattern-%s.svg" % kind)
            with open(path, "w") as f:
                f.write(svg(points, title, subtitles, seconds, (0.0, v * seconds)))
            print("wrote %s (%d points, %d bytes)" % (
                os.path.relpath(path, ROOT), len(points), os.path.getsize(path)))


if __name__ == "__main__":
    main()
