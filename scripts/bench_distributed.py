#!/usr/bin/env python3
"""The terrain benchmark scene flown as several lines, run three ways:
one process on 1 thread, one process on 2 threads, and split into parts on
a 2-worker Dask LocalCluster (1 thread each) and merged. Prints the wall
times (scene loading included), the cluster's speed-up over 1 thread and
its overhead over the 2-thread run, and checks that the merged points.las
is the unsplit one's bytes. Not part of the test suite (it measures time).
With --rounds R the three runs are repeated R times, in turn, each split
on a fresh cluster, and the ratios of each round and their medians are
printed: on a shared host whose speed drifts, runs side by side in time
compare fairer than one run of each. Every run starts with the runs
before it written out and removed (os.sync), so that none pays for
another's disk writes; each round prints when the split's last two parts
ended, how long the merge took after them, and the CPU time of the
2-thread run, the split's client and its workers (getrusage, the workers'
through client.run), so that the split's extra CPU time is seen apart
from the host's speed.

    target/pyenv/bin/python scripts/bench_distributed.py [--lines 4] [--pulses-per-line 10000000] [--rounds 1] [--parts N]

With --monitoring-pairs P it measures instead what Dask's monitoring of
its servers (the workers' statistical profiler, every server's event-loop
tick) costs a split: P pairs of splits on one 2-worker cluster, one with
the monitoring paused (lidarsim.distributed.run's default) and one with
it running (pause_monitoring=False), in turn, the order alternating from
pair to pair; it prints each split's wall and CPU time (the client's and
the workers') and the medians of each kind.

Needs the lidarsim package and distributed (scripts/check_python.sh
installs both into target/pyenv) and target/release/lidarsim.
"""

import argparse
import hashlib
import os
import re
import resource
import statistics
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import lidarsim
import lidarsim.distributed
from distributed import Client, LocalCluster

ROOT = Path(__file__).resolve().parents[1]


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def cpu_seconds():
    """CPU time of this process so far (all its threads), s."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=4)
    ap.add_argument("--pulses-per-line", type=int, default=10_000_000)
    ap.add_argument("--rounds", type=int, default=1, help="repeat the three runs, in turn")
    ap.add_argument("--keep", action="store_true", help="keep the working directory")
    ap.add_argument("--parts", type=int, default=None,
                    help="parts of the split (default: lidarsim.distributed.run's)")
    ap.add_argument("--monitoring-pairs", type=int, default=0,
                    help="measure Dask's monitoring instead: this many pairs of splits")
    a = ap.parse_args()
    os.environ.setdefault("SOURCE_DATE_EPOCH", "1700000000")
    work = Path(tempfile.mkdtemp(prefix="lidarsim-bench-dist-"))
    binary = ROOT / "target" / "release" / "lidarsim"
    subprocess.run(
        [str(binary), "bench", "--export", str(work), "--scene", "terrain"],
        check=True, capture_output=True,
    )
    text = (work / "terrain.toml").read_text()
    # Parallel lines 360 m long across the 400 m scene, alternating in
    # direction, each flown slowly enough to fire pulses-per-line pulses at
    # the benchmark's 100 kHz over the scene.
    length = 360.0
    speed = length / (a.pulses_per_line / 100_000)
    lines = ""
    for i in range(a.lines):
        x = -150.0 + 300.0 * i / max(a.lines - 1, 1)
        y0, y1 = (-length / 2, length / 2) if i % 2 == 0 else (length / 2, -length / 2)
        lines += (
            f"[[flight_line]]\nstart_m = [{x}, {y0}, 500.0]\nend_m = [{x}, {y1}, 500.0]\n"
            f"speed_mps = {speed}\n\n"
        )
    text = re.sub(r"\[\[flight_line\]\].*?speed_mps = 60.0\n", lines, text, flags=re.S)
    (work / "lines.toml").write_text(text)
    survey = lidarsim.Survey.load(work / "lines.toml")
    pulses = a.lines * a.pulses_per_line
    print(f"terrain scene, {a.lines} lines, {pulses} pulses")

    if a.monitoring_pairs:
        monitoring_pairs(work, survey, a.parts, a.monitoring_pairs)
        if not a.keep:
            shutil.rmtree(work, ignore_errors=True)
        return
    rounds = []
    for r in range(a.rounds):
        one, two, split, same = one_round(work, a.parts)
        if a.rounds > 1:
            print(f"round {r + 1}: {one:.2f} / {two:.2f} / {split:.2f} s, speed-up "
                  f"{one / split:.2f}, overhead {100 * (split / two - 1):+.1f} %", flush=True)
        rounds.append((one, two, split, same))
    one, two, split, _ = rounds[-1]
    if a.rounds == 1:
        print(f"1 process, 1 thread:      {one:7.2f} s  ({pulses / one:,.0f} pulses/s)")
        print(f"1 process, 2 threads:     {two:7.2f} s  ({pulses / two:,.0f} pulses/s)")
        print(f"2 workers x 1 thread:     {split:7.2f} s  ({pulses / split:,.0f} pulses/s), "
              "parts and merge")
    speedup = statistics.median(o / s for o, _, s, _ in rounds)
    overhead = statistics.median(s / t - 1 for _, t, s, _ in rounds)
    what = "median " if a.rounds > 1 else ""
    print(f"{what}speed-up over 1 thread:   {speedup:.2f}")
    print(f"{what}overhead over 2 threads:  {100 * overhead:+.1f} %")
    print(f"merged points.las is the unsplit run's: {all(r[3] for r in rounds)}")
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)


def monitoring_pairs(work, survey, parts, pairs):
    """Splits on one cluster (its workers hold the scene after the first),
    with Dask's monitoring paused and running, in turn: wall and CPU time
    of each, and the medians of each kind."""
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    client.run(lambda: __import__("lidarsim"))
    survey.build()
    seen = {False: [], True: []}
    for p in range(pairs):
        for monitored in (True, False) if p % 2 == 0 else (False, True):
            shutil.rmtree(work / "split", ignore_errors=True)
            os.sync()
            workers_before = client.run(cpu_seconds)
            cpu_client = cpu_seconds()
            wall, _ = timed(lambda: lidarsim.distributed.run(
                survey, client, work / "split", parts=parts, threads_per_part=1,
                progress=False, pause_monitoring=not monitored))
            workers = client.run(cpu_seconds)
            cpu = cpu_seconds() - cpu_client + sum(
                workers[w] - workers_before.get(w, 0.0) for w in workers)
            seen[monitored].append((wall, cpu))
            print(f"  monitoring {'running' if monitored else 'paused '}: {wall:.2f} s, "
                  f"CPU time {cpu:.2f} s", flush=True)
    client.close()
    cluster.close()
    shutil.rmtree(work / "split", ignore_errors=True)
    for monitored in (False, True):
        walls = [w for w, _ in seen[monitored]]
        cpus = [c for _, c in seen[monitored]]
        print(f"monitoring {'running' if monitored else 'paused '}: median {statistics.median(walls):.2f} s "
              f"({min(walls):.2f}-{max(walls):.2f}), CPU time {statistics.median(cpus):.2f} s")


def digest_and_remove(out):
    """The SHA-256 of out/points.las. Then out is removed (its pages still
    to be written are dropped with it) and os.sync() writes whatever else is
    pending, so that the next timed run does not share the disk with this
    one's write-back (1.6 GB at the default size)."""
    h = hashlib.sha256()
    with open(out / "points.las", "rb") as f:
        for chunk in iter(lambda: f.read(1 << 24), b""):
            h.update(chunk)
    shutil.rmtree(out)
    os.sync()
    return h.hexdigest()


def one_round(work, parts):
    """The three runs once: wall times of 1 thread, 2 threads and the split
    (a fresh 2-worker cluster, so that no worker holds the scene already),
    and whether the split's points.las is the unsplit one's. Each run starts
    with no other run's output waiting to be written."""
    for d in ("one", "two", "split", "split.parts"):
        shutil.rmtree(work / d, ignore_errors=True)
    os.sync()
    one, _ = timed(lambda: lidarsim.Survey.load(work / "lines.toml").run_to(
        work / "one", threads=1, progress=False))
    digest = digest_and_remove(work / "one")
    cpu_two = cpu_seconds()
    two, _ = timed(lambda: lidarsim.Survey.load(work / "lines.toml").run_to(
        work / "two", threads=2, progress=False))
    cpu_two = cpu_seconds() - cpu_two
    digest_and_remove(work / "two")
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    client.run(lambda: __import__("lidarsim"))
    workers_before = client.run(cpu_seconds)
    cpu_client = cpu_seconds()
    started = time.perf_counter()
    parts_done = []
    # A survey loaded afresh, as for the other two runs: one whose world a
    # split built already would spare the next split's client its build.
    split, _ = timed(lambda: lidarsim.distributed.run(
        lidarsim.Survey.load(work / "lines.toml"), client, work / "split", parts=parts,
        threads_per_part=1,
        progress=lambda *_: parts_done.append(time.perf_counter() - started)))
    cpu_client = cpu_seconds() - cpu_client
    workers = client.run(cpu_seconds)
    cpu_workers = sum(workers[w] - workers_before.get(w, 0.0) for w in workers)
    client.close()
    cluster.close()
    print(f"  split: {len(parts_done)} parts, the last two done at "
          + ", ".join(f"{t:.2f}" for t in parts_done[-2:])
          + f" s, merged {split - parts_done[-1]:.2f} s later", flush=True)
    print(f"  CPU time: 2 threads {cpu_two:.2f} s; split {cpu_client + cpu_workers:.2f} s "
          f"(client {cpu_client:.2f}, workers {cpu_workers:.2f})", flush=True)
    same = digest_and_remove(work / "split") == digest
    return one, two, split, same


if __name__ == "__main__":
    main()
