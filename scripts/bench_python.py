#!/usr/bin/env python3
"""The overhead of running from Python: the same survey run by
`lidarsim run`, by `Survey.run_to` (the same files) and by `Survey.run`
(points in memory), each timed a few times on the same threads; prints the
median times and the ratios to the command line's.

Usage: target/pyenv/bin/python scripts/bench_python.py [SURVEY] [--threads N] [--repeat K]
(the wheel installed by scripts/check_python.sh; default survey
examples/uav-livox-mid70.toml).
"""

import argparse
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import lidarsim

ROOT = Path(__file__).resolve().parent.parent


def timed(f):
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("survey", nargs="?", default=str(ROOT / "examples" / "uav-livox-mid70.toml"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "lidarsim"))
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    times = {"lidarsim run": [], "Survey.run_to": [], "Survey.run": []}
    try:
        for k in range(a.repeat):
            cli, py = tmp / f"cli{k}", tmp / f"py{k}"
            times["lidarsim run"].append(timed(lambda: subprocess.run(
                [a.bin, "run", a.survey, "-o", str(cli), "--threads", str(a.threads)],
                check=True, capture_output=True)))
            # Loading and building the scene count, as they do for the CLI.
            times["Survey.run_to"].append(timed(lambda: lidarsim.Survey.load(a.survey).run_to(
                py, threads=a.threads, progress=False)))
            times["Survey.run"].append(timed(lambda: lidarsim.Survey.load(a.survey).run(
                threads=a.threads, progress=False)))
            shutil.rmtree(cli)
            shutil.rmtree(py)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    base = statistics.median(times["lidarsim run"])
    print(f"survey {a.survey}, {a.threads} threads, median of {a.repeat}")
    for name, ts in times.items():
        m = statistics.median(ts)
        print(f"{name:14s} {m:7.3f} s  {m / base:6.3f} x lidarsim run")


if __name__ == "__main__":
    main()
