#!/usr/bin/env python3
"""The demo's report as a browser shows it (issue 49): headless Chromium
renders report.html, and every panel (each picture of the page, an inline
SVG) must show something: a share of the pixels of its inner part (15 %
in from each edge, where axes, ticks, legends and titles do not reach)
in the screenshot differ from the panel's background colour. A panel of
only axes and labels, or of data squeezed into a sliver, fails.

Usage: check_report_browser.py REPORT.html OUT_DIR [--min-share 0.003]

Writes OUT_DIR/report.png (the whole page), OUT_DIR/panel-NN.png (each
panel cut from it) and OUT_DIR/panels.json (each panel's box, share of
non-background pixels and verdict). Exits 1 when a panel is blank, 2 when
Chromium cannot run. Only the standard library: the PNG reading and
writing are below.

Chromium comes from Debian's package (scripts/install_chromium.sh).
"""

import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

# Appended to a copy of the page: after the layout, the boxes of the
# panels written into the document, for --dump-dom to print. It stands
# after every panel, so it moves none of them.
PROBE = """<pre id="lidarsim-panels"></pre><script>
window.addEventListener('load', function () {
  var out = [];
  document.querySelectorAll('svg, img').forEach(function (e) {
    var r = e.getBoundingClientRect();
    out.push({label: e.getAttribute('aria-label') || e.getAttribute('alt') || e.tagName,
              x: r.left + window.scrollX, y: r.top + window.scrollY,
              w: r.width, h: r.height});
  });
  document.getElementById('lidarsim-panels').textContent =
    'PANELS' + JSON.stringify(out) + 'END';
});
</script>"""

WIDTH = 1400


def chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def run_chromium(exe, args):
    base = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
            "--force-device-scale-factor=1", "--virtual-time-budget=5000"]
    return subprocess.run(base + args, capture_output=True, text=True, timeout=300)


def read_png(path):
    """(width, height, rows of RGB tuples) of an 8-bit RGB or RGBA PNG."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, color = struct.unpack(">IIBB", body[:10])
            assert depth == 8 and color in (2, 6), f"PNG depth {depth} colour {color}"
            bpp = 3 if color == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append(bytes(line) if bpp == 3 else bytes(
            v for k in range(w) for v in line[4 * k:4 * k + 3]))
        prev = line
    return w, h, rows


def write_png(path, w, rows):
    raw = b"".join(b"\x00" + r for r in rows)
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(
            ">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, len(rows), 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)))
        f.write(chunk(b"IEND", b""))


def ink_share(rows, x0, y0, x1, y1):
    """Share of the box's pixels that differ from its most common colour
    (the panel's background) by more than a trace of anti-aliasing."""
    counts = {}
    for y in range(y0, y1):
        r = rows[y]
        for x in range(x0, x1):
            px = r[3 * x:3 * x + 3]
            counts[px] = counts.get(px, 0) + 1
    total = sum(counts.values())
    if total == 0:
        return 0.0
    bg = max(counts, key=counts.get)
    far = sum(n for px, n in counts.items()
              if max(abs(px[i] - bg[i]) for i in range(3)) > 24)
    return far / total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("report")
    ap.add_argument("out_dir")
    ap.add_argument("--min-share", type=float, default=0.003)
    a = ap.parse_args()
    exe = chromium()
    if exe is None:
        print("no Chromium: run scripts/install_chromium.sh", file=sys.stderr)
        return 2
    os.makedirs(a.out_dir, exist_ok=True)
    page = open(a.report, encoding="utf-8").read()
    page = page.replace("</body>", PROBE + "</body>") if "</body>" in page else page + PROBE
    with tempfile.TemporaryDirectory() as tmp:
        probed = os.path.join(tmp, "report.html")
        open(probed, "w", encoding="utf-8").write(page)
        url = "file://" + probed
        dom = run_chromium(exe, [f"--window-size={WIDTH},1000", "--dump-dom", url])
        text = dom.stdout
        if "PANELS" not in text:
            print("Chromium printed no panel boxes:\n" + dom.stderr[-2000:], file=sys.stderr)
            return 2
        panels = json.loads(text[text.index("PANELS") + 6:text.index("END", text.index("PANELS"))])
        height = int(max(p["y"] + p["h"] for p in panels)) + 40 if panels else 1000
        shot = os.path.join(a.out_dir, "report.png")
        r = run_chromium(exe, [f"--window-size={WIDTH},{height}", f"--screenshot={shot}", url])
        if not os.path.exists(shot):
            print("Chromium wrote no screenshot:\n" + r.stderr[-2000:], file=sys.stderr)
            return 2
    w, h, rows = read_png(shot)
    blank = []
    for k, p in enumerate(panels):
        x0, y0 = max(0, int(p["x"])), max(0, int(p["y"]))
        x1, y1 = min(w, int(p["x"] + p["w"])), min(h, int(p["y"] + p["h"]))
        ix, iy = int(0.15 * (x1 - x0)), int(0.15 * (y1 - y0))
        share = (ink_share(rows, x0 + ix, y0 + iy, x1 - ix, y1 - iy)
                 if x1 - x0 > 2 * ix and y1 - y0 > 2 * iy else 0.0)
        p["share"] = round(share, 4)
        p["blank"] = share < a.min_share
        if x1 > x0 and y1 > y0:
            write_png(os.path.join(a.out_dir, f"panel-{k:02}.png"), x1 - x0,
                      [r[3 * x0:3 * x1] for r in rows[y0:y1]])
        print(f"panel {k:2} {p['label'][:40]:40} {x1 - x0:4}x{y1 - y0:<4} "
              f"{100 * share:5.1f} % ink{'  BLANK' if p['blank'] else ''}")
        if p["blank"]:
            blank.append(p["label"])
    json.dump(panels, open(os.path.join(a.out_dir, "panels.json"), "w"), indent=1)
    if not panels:
        print("the page has no panel", file=sys.stderr)
        return 1
    if blank:
        print(f"blank panels: {blank}", file=sys.stderr)
        return 1
    print(f"{len(panels)} panels, none blank; screenshot {shot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
