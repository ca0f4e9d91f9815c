#!/usr/bin/env python3
"""Memory stays flat in flight length: the same survey flown 8 times longer
must not need more memory (points are streamed to disk in pulse order), and
a flight of 100 million pulses runs within a 1 GiB address-space limit
(`ulimit -v`) with the peak resident memory of the 1-million-pulse flight.
Memory is also reused from block to block of pulses: with glibc told to
give freed memory back to the system at once (MALLOC_TRIM_THRESHOLD_=65536,
as Dask's nannies set it for their workers), the 8 times longer flight
takes at most 1.2 times the short one's page faults and 5 000 more
(buffers allocated anew for every block would be mapped and faulted in
again each time: some 80 faults a block here, 280 000 more for the long
flight).

The 100 M-pulse flight (one 24 km line at 250 kHz, one sub-ray) crosses a
1.2 km strip of ground, so 5 million of its pulses give points (150 MB of
LAS) and the rest miss the scene, which keeps it to about 40 s on 2 cores.

Usage: check_memory.py PATH/TO/lidarsim
Prints the peak resident set sizes and a plain "N passed, N failed" line.
"""

import json
import os
import subprocess
import sys
import time
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

LONG = """
# Bare point format 6 (no extra bytes): the file must be exactly the
# 375-byte LAS 1.4 header plus 30 bytes per point.
[output]
extra_bytes = false
[scanner]
prf_hz = 250000
scan_angle_deg = 20
subrays = 1
[[flight_line]]
start_m = [0.0, 0.0, 500.0]
end_m = [0.0, 24000.0, 500.0]
speed_mps = 60.0
[materials.ground]
reflectance = 0.3
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-400, 11400, 0], [400, 11400, 0], [400, 12600, 0], [-400, 12600, 0]]
"""

# Runs the command (argv[2:]) with an address-space limit of argv[1] bytes
# (0: none) and prints the child's peak resident set size, KiB, and its
# minor page faults.
MEASURE = (
    "import resource, subprocess, sys\n"
    "limit = int(sys.argv[1])\n"
    "def cap():\n"
    "    if limit:\n"
    "        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))\n"
    "subprocess.run(sys.argv[2:], check=True, stdout=subprocess.DEVNULL, preexec_fn=cap)\n"
    "use = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
    "print(use.ru_maxrss, use.ru_minflt)\n"
)


def run_measured(binary, survey, out, limit=0, env=None):
    """The run's peak resident set size (KiB), minor page faults and LAS
    file size."""
    r = subprocess.run(
        [sys.executable, "-c", MEASURE, str(limit), binary, "run", str(survey), "-o", str(out),
         "--threads", "2"],
        capture_output=True, text=True, env=env)
    if r.returncode != 0:
        print(r.stderr)
        raise SystemExit(f"lidarsim run {survey} failed")
    rss, faults = map(int, r.stdout.split())
    return rss, faults, (out / "points.las").stat().st_size


def flight(binary, length, tmp, env=None, name="out"):
    survey = Path(tmp) / f"s{length}.toml"
    survey.write_text(SURVEY.format(length=length, far=length + 100))
    return run_measured(binary, survey, Path(tmp) / f"{name}{length}", env=env)


def main(binary):
    with tempfile.TemporaryDirectory() as tmp:
        short, _, las_short = flight(binary, 300, tmp)    # 1 M pulses
        long, _, las_long = flight(binary, 2400, tmp)     # 8 M pulses
        trim = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")
        _, faults_short, _ = flight(binary, 300, tmp, env=trim, name="trim")
        _, faults_long, _ = flight(binary, 2400, tmp, env=trim, name="trim")
        survey = Path(tmp) / "long.toml"
        survey.write_text(LONG)
        t = time.monotonic()
        huge, _, las_huge = run_measured(binary, survey, Path(tmp) / "out100M", limit=1 << 30)
        seconds = time.monotonic() - t
        summary = json.loads((Path(tmp) / "out100M" / "summary.json").read_text())
    print(f"peak RSS: 1 M pulses {short / 1024:.1f} MiB (LAS {las_short / 1e6:.0f} MB), "
          f"8 M pulses {long / 1024:.1f} MiB (LAS {las_long / 1e6:.0f} MB)")
    print(f"peak RSS: {summary['pulses'] / 1e6:.0f} M pulses {huge / 1024:.1f} MiB under a 1 GiB "
          f"address-space limit, {summary['points'] / 1e6:.1f} M points "
          f"(LAS {las_huge / 1e6:.0f} MB), {seconds:.0f} s")
    print(f"minor page faults with MALLOC_TRIM_THRESHOLD_=65536: 1 M pulses {faults_short}, "
          f"8 M pulses {faults_long}")
    checks = [
        las_long > 7 * las_short and long < 1.2 * short + 10 * 1024,
        summary["pulses"] == 100_000_000 and summary["complete"]
        and las_huge == 375 + 30 * summary["points"] and huge < 1.2 * short + 16 * 1024,
        faults_long < 1.2 * faults_short + 5000,
    ]
    passed = sum(checks)
    print(f"{passed} passed, {len(checks) - passed} failed")
    sys.exit(0 if passed == len(checks) else 1)


if __name__ == "__main__":
    main(sys.argv[1])
