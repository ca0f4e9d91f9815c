"""A survey split into parts run on a Dask cluster, merged into the files
one run writes, byte for byte.

::

    from distributed import Client, LocalCluster
    import lidarsim, lidarsim.distributed

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))
    survey = lidarsim.Survey.load("campaign.toml")
    summary = lidarsim.distributed.run(survey, client, out="campaign-out")

Any ``distributed.Client`` will do: a local cluster, dask-jobqueue's
``SLURMCluster`` or ``PBSCluster``, Kubernetes. Each part is one task (part
K of N simulates its stretch of the pulses, see ``lidarsim run --part``);
a part whose worker dies is run again elsewhere, and a part that fails is
retried. Parts write into a directory beside ``out`` that every worker
sees (``shared=True``, the usual HPC setup) or, with ``shared=False``, into
a worker's temporary directory whose files travel back to the client. The
client merges them into ``out`` as they arrive (a part's points are
joined as soon as the parts before it are), over the survey's world,
which it builds while the last parts run. While the run holds the
cluster, Dask's own monitoring of its servers is paused
(``pause_monitoring``).

The survey travels to the workers as its TOML text (file paths absolute:
meshes, rasters and point clouds must be readable there) with any scene
parts given as arrays.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

from . import Survey, _lidarsim, _threads, merge

__all__ = ["run", "merge"]

PathLike = Union[str, "os.PathLike[str]"]


def _part_name(k: int, n: int) -> str:
    return f"part-{k:04d}-of-{n:04d}"


#: Parts of a run for each part a cluster runs at once, by default. With
#: one each, a worker slowed down (a busy host, a slower node) holds up the
#: whole run; parts are cheap (a worker builds the survey's world once, and
#: the client joins each part's points as it arrives), so a run is cut
#: finer, into parts that workers take as they become free.
PARTS_PER_SLOT = 16

#: Periodic callbacks of a Dask cluster's servers that a run pauses while
#: it holds the cluster, unless asked not to (``pause_monitoring``): each
#: worker's statistical profiler, which wakes every 10 ms
#: (``distributed.worker.profile.interval``) to sample its threads' Python
#: stacks, and the event-loop tick of the workers, their nannies and the
#: scheduler, which wakes every 20 ms (``distributed.admin.tick.interval``)
#: to measure how late the loop is. A part runs in Rust with the
#: interpreter released, where the samples see one frame and no loop is
#: held up; on a host with a core per worker, each wake-up takes the core
#: from a part.
_MONITORING = ("profile", "profile-cycle", "tick")

#: The last survey a worker process built, by the TOML text it came from:
#: a worker that runs several parts of one survey reads and indexes its
#: scene once.
_BUILT: Dict[str, Survey] = {}


def _survey(spec: Tuple[str, tuple]) -> Survey:
    """The survey of ``spec``, built once per worker process."""
    text, data = spec
    digest = hashlib.sha256(text.encode())
    for method, args in data:
        digest.update(method.encode())
        for a in args:
            digest.update(a.tobytes() if hasattr(a, "tobytes") else repr(a).encode())
    key = digest.hexdigest()
    survey = _BUILT.get(key)
    if survey is None:
        survey = Survey.from_toml(text)._with_data(data)
        _BUILT.clear()
        _BUILT[key] = survey
    return survey


def _run_part(
    spec: Tuple[str, tuple], k: int, n: int, shared: Optional[str], threads: int
) -> Dict[str, Any]:
    """A worker's task: part ``k`` of ``n`` of the survey ``spec`` (TOML
    text and array parts), into ``shared/part-K-of-N`` or, without a shared
    directory, into a temporary one whose files are returned."""
    survey = _survey(spec)
    if shared is not None:
        out = Path(shared) / _part_name(k, n)
        record = survey._core.run_part(os.fspath(out), k, n, threads, True)
        return {"part": k, "record": record, "dir": os.fspath(out)}
    with tempfile.TemporaryDirectory(prefix="lidarsim-part-") as tmp:
        out = Path(tmp) / _part_name(k, n)
        record = survey._core.run_part(os.fspath(out), k, n, threads, True)
        files = {
            os.fspath(p.relative_to(out)): p.read_bytes() for p in out.rglob("*") if p.is_file()
        }
    return {"part": k, "record": record, "files": files}


def run(
    survey: Survey,
    client: Any,
    out: PathLike,
    parts: Optional[int] = None,
    threads_per_part: int = 1,
    shared: bool = True,
    parts_dir: Optional[PathLike] = None,
    keep_parts: bool = False,
    retries: int = 2,
    overwrite: bool = False,
    progress: Any = True,
    pause_monitoring: bool = True,
) -> Dict[str, Any]:
    """Runs ``survey`` split into ``parts`` parts (by default
    ``PARTS_PER_SLOT`` for each part the cluster runs at once, so that the
    scheduler hands the last parts to the workers that are free first) as
    tasks on ``client``, and
    merges them into ``out``: the files of ``survey.run_to(out)``, byte for
    byte (``summary.json``'s timings apart). Returns the merged run's
    summary.

    ``threads_per_part``: threads each part simulates on (match the
    workers' threads). ``shared``: parts write into ``parts_dir`` (default
    ``OUT.parts`` beside ``out``), which every worker must see; False:
    each part's files come back to the client. ``keep_parts``: keep the
    parts' directories after merging. ``retries``: runs of a part that
    failed with an error before giving up (a part whose worker died is run
    again by the scheduler in any case). ``progress``: True for a line of
    parts done and pulses per second, False for none, or a callable
    ``f(parts_done, parts_total, pulses_per_second)``.
    ``pause_monitoring``: pause Dask's monitoring of its servers until the
    run ends (the workers' statistical profiler, which samples their
    Python stacks every 10 ms and shows nothing of a part, and every
    server's event-loop tick, every 20 ms); their wake-ups take time from
    the parts. False leaves them running."""
    out = Path(out)
    threads = sum(client.nthreads().values()) or 1
    if parts is None:
        parts = PARTS_PER_SLOT * max(1, threads // max(1, threads_per_part))
    if parts < 1:
        raise ValueError(f"parts must be at least 1, got {parts}")
    where = Path(parts_dir) if parts_dir is not None else out.with_name(out.name + ".parts")
    where = where.resolve()
    where.mkdir(parents=True, exist_ok=True)
    # The merge claims the output at once (before any part runs), and joins
    # the parts' points as they arrive.
    merging = _lidarsim.PartMerge(os.fspath(out), overwrite, not keep_parts)
    paused = _pause_monitoring(client) if pause_monitoring else []
    try:
        return _run(survey, client, out, parts, threads, threads_per_part, shared, where,
                    keep_parts, retries, progress, merging)
    finally:
        _resume_monitoring(client, paused)


def _run(
    survey: Survey,
    client: Any,
    out: Path,
    parts: int,
    threads: int,
    threads_per_part: int,
    shared: bool,
    where: Path,
    keep_parts: bool,
    retries: int,
    progress: Any,
    merging: Any,
) -> Dict[str, Any]:
    """``run`` once the output is claimed: submits the parts, merges them
    as they arrive and finishes the merge."""
    from distributed import as_completed

    spec = (survey.to_toml(), survey._data)
    token = f"{os.getpid()}-{time.monotonic_ns()}"
    futures = [
        client.submit(
            _run_part,
            spec,
            k,
            parts,
            os.fspath(where) if shared else None,
            threads_per_part,
            key=f"lidarsim-{_part_name(k, parts)}-{token}",
            retries=retries,
            pure=False,
        )
        for k in range(1, parts + 1)
    ]
    report = _Report(progress, parts)
    # The survey's world, for the merge: the client builds it while the
    # last parts run, once a worker thread has no part left to take.
    world = _WorldBuilder(survey)
    if parts * threads_per_part < threads:
        world.start()
    started = time.monotonic()
    slots = 0
    dirs: Dict[int, Path] = {}
    try:
        for done, future in enumerate(as_completed(futures), start=1):
            result = future.result()
            k = result["part"]
            if "files" in result:
                target = where / _part_name(k, parts)
                if target.exists():
                    shutil.rmtree(target)
                for name, data in result["files"].items():
                    path = target / name
                    path.parent.mkdir(parents=True, exist_ok=True)
                    path.write_bytes(data)
                dirs[k] = target
            else:
                dirs[k] = Path(result["dir"])
            # The part is done with: the scheduler need not run it again
            # if the worker that holds its result dies.
            futures.remove(future)
            slots += result["record"]["pulse_slots"]
            report(done, slots / max(time.monotonic() - started, 1e-9))
            if (parts - done) * threads_per_part < threads:
                world.start()
            merging.add(os.fspath(dirs[k]))
    except BaseException:
        for f in futures:
            f.cancel()
        raise
    finally:
        report.close()
    # Parts not kept are taken by the merge: the first one's LAS file is
    # moved rather than copied, and every part's directory removed.
    summary = merging.finish(_threads(None), survey._core if world.built() else None)
    if not keep_parts:
        try:
            where.rmdir()
        except OSError:
            pass
    return summary


def _stop_monitoring(dask_worker: Any = None, dask_scheduler: Any = None) -> Tuple[str, ...]:
    """On a worker or nanny (``Client.run``) or the scheduler
    (``Client.run_on_scheduler``), on its event loop: stops the callbacks
    of ``_MONITORING`` that run, and names them."""
    server = dask_worker if dask_worker is not None else dask_scheduler
    stopped = []
    for name in _MONITORING:
        callback = getattr(server, "periodic_callbacks", {}).get(name)
        if callback is not None and callback.is_running():
            callback.stop()
            stopped.append(name)
    return tuple(stopped)


def _start_monitoring(
    names: Tuple[str, ...], dask_worker: Any = None, dask_scheduler: Any = None
) -> None:
    """On a server: starts again the callbacks ``_stop_monitoring`` stopped."""
    server = dask_worker if dask_worker is not None else dask_scheduler
    for name in names:
        callback = getattr(server, "periodic_callbacks", {}).get(name)
        if callback is not None and not callback.is_running():
            callback.start()


#: Where callbacks were paused: ("worker" or "nanny", the worker's
#: address, the callbacks) or ("scheduler", None, the callbacks).
_Paused = List[Tuple[str, Optional[str], Tuple[str, ...]]]


def _pause_monitoring(client: Any) -> _Paused:
    """Stops the ``_MONITORING`` callbacks of every worker, nanny and the
    scheduler of ``client``; what was stopped, where. A server that cannot
    be reached keeps its callbacks (the run goes on)."""
    paused = []
    for kind in ("worker", "nanny"):
        try:
            stopped = client.run(_stop_monitoring, nanny=kind == "nanny", on_error="ignore")
        except Exception:  # noqa: BLE001 - monitoring is not the run's business
            continue
        paused += [(kind, w, names) for w, names in stopped.items()
                   if isinstance(names, tuple) and names]
    try:
        names = client.run_on_scheduler(_stop_monitoring)
        if names:
            paused.append(("scheduler", None, tuple(names)))
    except Exception:  # noqa: BLE001
        pass
    return paused


def _resume_monitoring(client: Any, paused: _Paused) -> None:
    """Starts again the callbacks ``_pause_monitoring`` stopped, on the
    servers still there. Nannies are reached by their worker's address:
    a nanny whose worker was restarted during the run has a new one, so
    every nanny starts again the callbacks stopped on any."""
    nannies = tuple(sorted({n for kind, _, names in paused if kind == "nanny" for n in names}))
    calls = [((names,), {"workers": [worker], "on_error": "ignore"})
             for kind, worker, names in paused if kind == "worker"]
    if nannies:
        calls.append(((nannies,), {"nanny": True, "on_error": "ignore"}))
    for args, kwargs in calls:
        try:
            client.run(_start_monitoring, *args, **kwargs)
        except Exception:  # noqa: BLE001 - a server gone has nothing to start
            pass
    for kind, _, names in paused:
        if kind == "scheduler":
            try:
                client.run_on_scheduler(_start_monitoring, names)
            except Exception:  # noqa: BLE001
                pass


class _WorldBuilder:
    """Builds a survey's world on a thread of the client (the scene read
    and indexed with the GIL released), for the merge to use."""

    def __init__(self, survey: Survey) -> None:
        self.survey = survey
        self.thread: Optional[threading.Thread] = None
        self.ok = False

    def start(self) -> None:
        if self.thread is None:
            self.thread = threading.Thread(target=self._build, daemon=True)
            self.thread.start()

    def _build(self) -> None:
        try:
            self.survey.build()
            self.ok = True
        except Exception:  # noqa: BLE001 - the merge then builds the world itself
            self.ok = False

    def built(self) -> bool:
        """Whether the world is built, once the thread is done."""
        if self.thread is None:
            return False
        self.thread.join()
        return self.ok


class _Report:
    """Progress of a distributed run: a callable, or a line on stderr."""

    def __init__(self, progress: Any, total: int) -> None:
        self.total = total
        self.callback = progress if callable(progress) else None
        self.line = progress is True
        self.shown = False

    def __call__(self, done: int, rate: float) -> None:
        if self.callback is not None:
            self.callback(done, self.total, rate)
        elif self.line:
            sys.stderr.write(f"\rparts {done}/{self.total} done, {rate:,.0f} pulses/s")
            sys.stderr.flush()
            self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\n")

