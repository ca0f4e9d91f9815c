"""A survey split over a Dask cluster of worker processes and merged
writes the files of one run byte for byte — with the parts in a shared
directory or sent back to the client, and when a worker is killed in the
middle of a part; parts and merges from Python refuse what is not one
run."""

import os
import signal
import time

import pytest

import lidarsim

distributed = pytest.importorskip("distributed")
import lidarsim.distributed  # noqa: E402

# Four lines over a plane and a roof, full waveforms and LAZ: four parts
# of whole lines, 0.6 s at 25 kHz each.
SURVEY = """
seed = 29
[scanner]
prf_hz = 25000
scan_frequency_hz = 40
scan_angle_deg = 15
subrays = 7
[receiver]
noise = 0.01
[output]
formats = ["las-waveform", "laz", "xyz"]
[materials.grass]
reflectance = 0.3
[materials.roof]
reflectance = 0.2
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
[[polygon]]
material = "roof"
class = "roof"
vertices_m = [[-12, -8, 6], [10, -8, 6], [10, 8, 9], [-12, 8, 9]]
"""

LINES = "".join(
    f"[[flight_line]]\nstart_m = [{x}, -15.0, 200.0]\nend_m = [{x}, 15.0, 200.0]\nspeed_mps = 50.0\n"
    for x in (-40.0, -10.0, 20.0, 50.0)
)

SAME = [
    "points.las",
    "points.wdp",
    "points.laz",
    "points.xyz",
    "survey.toml",
    "trajectory.csv",
    "trajectory_true.csv",
    "trajectory_observed.csv",
]


@pytest.fixture(scope="module")
def client():
    # The workers are processes started after this: they inherit the date
    # every LAS header carries.
    os.environ["SOURCE_DATE_EPOCH"] = "1700000000"
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def survey(extra=""):
    return lidarsim.Survey.from_toml(SURVEY + LINES + extra)


def assert_same_run(a, b):
    for name in SAME:
        if not (a / name).exists():
            assert not (b / name).exists(), name
            continue
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    import json

    def summary(d):
        s = json.loads((d / "summary.json").read_text())
        for k in ["wall_time_s", "index_time_s", "pulses_per_second", "threads"]:
            s.pop(k)
        return s

    assert summary(a) == summary(b)


@pytest.mark.parametrize("shared", [True, False])
def test_a_run_on_a_local_cluster_is_the_unsplit_run(client, tmp_path, shared):
    s = survey()
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    seen = []
    summary = lidarsim.distributed.run(
        s, client, tmp_path / "merged", parts=4, shared=shared,
        progress=lambda done, total, rate: seen.append((done, total, rate)),
    )
    assert summary["points"] > 50_000
    assert_same_run(tmp_path / "whole", tmp_path / "merged")
    assert [d for d, _, _ in seen] == [1, 2, 3, 4] and all(t == 4 for _, t, _ in seen)
    assert all(rate > 0 for _, _, rate in seen)
    # The parts' directory is gone after the merge.
    assert not (tmp_path / "merged.parts").exists()


def test_a_worker_killed_mid_part_still_gives_the_unsplit_run(client, tmp_path):
    # Longer parts (600 000 pulses each, about a second), so that a part is
    # running when its worker is killed; the scheduler runs it again on a
    # new worker.
    long_lines = LINES.replace("-15.0", "-150.0").replace(" 15.0", " 150.0")
    s = lidarsim.Survey.from_toml(
        SURVEY.replace("prf_hz = 25000", "prf_hz = 100000").replace(
            '"las-waveform", "laz", "xyz"', '"las"'
        )
        + long_lines
    )
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    pids = client.run(os.getpid)

    def kill_a_busy_worker():
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            busy = [w for w, tasks in client.processing().items() if tasks]
            if busy:
                os.kill(pids[busy[0]], signal.SIGKILL)
                return pids[busy[0]]
            time.sleep(0.02)
        return None

    import threading

    killed = []
    t = threading.Thread(target=lambda: killed.append(kill_a_busy_worker()))
    t.start()
    lidarsim.distributed.run(s, client, tmp_path / "merged", parts=4, progress=False)
    t.join()
    assert killed and killed[0] is not None
    assert killed[0] not in client.run(os.getpid).values()
    assert_same_run(tmp_path / "whole", tmp_path / "merged")


def test_parts_from_python_merge_and_bad_merges_are_refused(tmp_path):
    s = survey()
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    dirs = [tmp_path / f"p{k}" for k in (1, 2, 3)]
    for k, d in zip((2, 3, 1), (dirs[1], dirs[2], dirs[0])):
        record = s.run_part(d, k, 3, threads=1)
        assert record["complete"] and record["part"] == k and record["parts"] == 3
    with pytest.raises(OSError, match="part 2/3 is missing"):
        lidarsim.merge([dirs[0], dirs[2]], tmp_path / "bad")
    with pytest.raises(OSError, match="given twice"):
        lidarsim.merge([dirs[0], dirs[1], dirs[1], dirs[2]], tmp_path / "bad2")
    lidarsim.merge([dirs[2], dirs[0], dirs[1]], tmp_path / "merged")
    assert_same_run(tmp_path / "whole", tmp_path / "merged")
    with pytest.raises(ValueError, match="K must be from 1 to N"):
        s.run_part(tmp_path / "p4", 4, 3)
