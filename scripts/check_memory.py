#!/usr/bin/env python3
"""Memory stays flat in flight length: the same survey flown 8 times longer
must not need more memory (points are streamed to disk in pulse order).

Usage: check_memory.py PATH/TO/lidarsim
Prints the peak resident set sizes and a plain "N passed, N failed" line.
"""

import subprocess
import sys
import tempfile
from pathlib import Path

SURVEY = """
[scanner]
prf_hz = 200000
scan_angle_deg = 20
subrays = 1
[[flight_line]]
start_m = [0.0, 0.0, 500.0]
end_m = [0.0, {length}, 500.0]
speed_mps = 60.0
[materials.ground]
reflectance = 0.3
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-400, -100, 0], [400, -100, 0], [400, {far}, 0], [-400, {far}, 0]]
"""

MEASURE = (
    "import resource, subprocess, sys\n"
    "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
)


def peak_rss_kib(binary, length, tmp):
    survey = Path(tmp) / f"s{length}.toml"
    survey.write_text(SURVEY.format(length=length, far=length + 100))
    out = Path(tmp) / f"out{length}"
    r = subprocess.run(
        [sys.executable, "-c", MEASURE, binary, "run", str(survey), "-o", str(out), "--threads", "2"],
        capture_output=True, text=True, check=True)
    las = (out / "points.las").stat().st_size
    return int(r.stdout.strip()), las


def main(binary):
    with tempfile.TemporaryDirectory() as tmp:
        short, las_short = peak_rss_kib(binary, 300, tmp)    # 1 M pulses
        long, las_long = peak_rss_kib(binary, 2400, tmp)     # 8 M pulses
    print(f"peak RSS: 1 M pulses {short / 1024:.1f} MiB (LAS {las_short / 1e6:.0f} MB), "
          f"8 M pulses {long / 1024:.1f} MiB (LAS {las_long / 1e6:.0f} MB)")
    ok = las_long > 7 * las_short and long < 1.2 * short + 10 * 1024
    print("1 passed, 0 failed" if ok else "0 passed, 1 failed")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main(sys.argv[1])
