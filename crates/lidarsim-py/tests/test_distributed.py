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


def monitoring(client):
    """Whether Dask's monitoring callbacks run, as a set over each worker's
    profiler and tick, each nanny's tick and the scheduler's tick: {True}
    when all run, {False} when none."""
    def running(names, dask_worker=None, dask_scheduler=None):
        server = dask_worker if dask_worker is not None else dask_scheduler
        return [server.periodic_callbacks[n].is_running() for n in names]

    states = list(client.run(running, ["profile", "profile-cycle", "tick"]).values())
    states += list(client.run(running, ["tick"], nanny=True).values())
    states.append(client.run_on_scheduler(running, ["tick"]))
    assert len(states) == 5
    return {r for server in states for r in server}


@pytest.mark.parametrize("shared", [True, False])
def test_a_run_on_a_local_cluster_is_the_unsplit_run(client, tmp_path, shared):
    s = survey()
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    seen = []

    assert monitoring(client) == {True}
    summary = lidarsim.distributed.run(
        s, client, tmp_path / "merged", parts=4, shared=shared,
        progress=lambda done, total, rate: seen.append((done, total, rate, monitoring(client))),
    )
    assert summary["points"] > 50_000
    assert_same_run(tmp_path / "whole", tmp_path / "merged")
    assert [d for d, _, _, _ in seen] == [1, 2, 3, 4] and all(t == 4 for _, t, _, _ in seen)
    assert all(rate > 0 for _, _, rate, _ in seen)
    # Dask's monitoring was paused while the run held the cluster, and
    # runs again after it; asked to, the run leaves it running.
    assert all(m == {False} for _, _, _, m in seen)
    assert monitoring(client) == {True}
    if shared:
        during = []
        lidarsim.distributed.run(
            s, client, tmp_path / "monitored", parts=2, pause_monitoring=False,
            progress=lambda *_: during.append(monitoring(client)),
        )
        assert during == [{True}, {True}]
    # The parts' directory is gone after the merge.
    assert not (tmp_path / "merged.parts").exists()


def set_env(values, dask_worker=None, dask_nanny=None):
    """Sets (a value) or removes (None) environment variables."""
    for k, v in values.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def test_a_worker_killed_mid_part_still_gives_the_unsplit_run(client, tmp_path):
    # Every part is held after 1000 pulses (the test hook of src/hold.rs)
    # until the release file appears, so that a worker with a part is
    # killed while the part is certainly running, not after a guessed
    # time; the scheduler runs the part again on the worker its nanny
    # starts (which inherits the nanny's environment, hold included).
    s = lidarsim.Survey.from_toml(SURVEY.replace('"las-waveform", "laz", "xyz"', '"las"') + LINES)
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    release = tmp_path / "release"
    hold = {"LIDARSIM_TEST_HOLD_AT_PULSE": "1000", "LIDARSIM_TEST_HOLD_UNTIL": str(release)}
    client.run(set_env, hold)
    client.run(set_env, hold, nanny=True)
    pids = client.run(os.getpid)

    def kill_a_busy_worker():
        # A part is held from its first thousand pulses until the release:
        # a worker seen with a part is killed mid-part.
        try:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                busy = [w for w, tasks in client.processing().items() if tasks]
                if busy:
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    return pids[busy[0]]
                time.sleep(0.02)
            return None
        finally:
            release.write_text("go")

    import threading

    killed = []
    t = threading.Thread(target=lambda: killed.append(kill_a_busy_worker()))
    t.start()
    try:
        lidarsim.distributed.run(s, client, tmp_path / "merged", parts=4, progress=False)
    finally:
        t.join()
        unset = {k: None for k in hold}
        client.run(set_env, unset)
        client.run(set_env, unset, nanny=True)
    assert killed and killed[0] is not None
    assert killed[0] not in client.run(os.getpid).values()
    assert_same_run(tmp_path / "whole", tmp_path / "merged")
    # The killed worker's nanny, which started a new worker, monitors
    # again too.
    assert monitoring(client) == {True}


def test_parts_from_python_merge_and_bad_merges_are_refused(tmp_path):
    s = survey()
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    dirs = [tmp_path / f"p{k}" for k in (1, 2, 3)]
    for k, d in zip((2, 3, 1), (dirs[1], dirs[2], dirs[0])):
        record = s.run_part(d, k, 3, threads=1)
        assert record["complete"] and record["part"] == k and record["parts"] == 3
    with pytest.raises(lidarsim.PartError, match="part 2/3 is missing"):
        lidarsim.merge([dirs[0], dirs[2]], tmp_path / "bad")
    with pytest.raises(lidarsim.PartError, match="given twice") as e:
        lidarsim.merge([dirs[0], dirs[1], dirs[1], dirs[2]], tmp_path / "bad2")
    assert e.value.path == str(dirs[1])
    lidarsim.merge([dirs[2], dirs[0], dirs[1]], tmp_path / "merged")
    assert_same_run(tmp_path / "whole", tmp_path / "merged")
    with pytest.raises(ValueError, match="K must be from 1 to N"):
        s.run_part(tmp_path / "p4", 4, 3)


def shed_survey(shed, seed=29):
    """The survey with a shed read from the mesh file ``shed``."""
    shed.write_text("v 15 -5 4\nv 25 -5 4\nv 25 5 4\nv 15 5 4\nf 1 2 3\nf 1 3 4\n")
    mesh = f'[[mesh]]\nfile = "{shed}"\nmaterial = "roof"\nclass = "roof"\n'
    return lidarsim.Survey.from_toml(
        (SURVEY + LINES + mesh).replace("seed = 29", f"seed = {seed}")
    )


def test_a_merge_uses_the_built_world_of_the_parts_survey_and_no_other(tmp_path):
    shed = tmp_path / "shed.obj"
    s = shed_survey(shed)
    not_built = shed_survey(shed)
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    dirs = [tmp_path / f"p{k}" for k in (1, 2)]
    for k, d in enumerate(dirs, start=1):
        s.run_part(d, k, 2, threads=1)
    other_seed = shed_survey(tmp_path / "other.obj", seed=30)
    other_seed.build()
    # With the scene's file gone, a merge that reads the scene again fails
    # as building the parts' survey fails (its key, file and line): one
    # given no survey, a survey of another seed, or the parts' survey with
    # no world built.
    shed.unlink()
    for i, given in enumerate([None, other_seed, not_built]):
        with pytest.raises(lidarsim.SurveyError, match="shed.obj"):
            lidarsim.merge(dirs, tmp_path / f"bad{i}", survey=given)
    lidarsim.merge(dirs, tmp_path / "merged", survey=s)
    assert_same_run(tmp_path / "whole", tmp_path / "merged")


def test_a_distributed_run_merges_over_the_clients_world(client, tmp_path):
    # The client's survey was built (by its unsplit run); the scene's file
    # is removed once every part is done, so the merge reads no scene.
    shed = tmp_path / "shed.obj"
    s = shed_survey(shed)
    s.run_to(tmp_path / "whole", threads=2, progress=False)

    def progress(done, total, rate):
        if done == total:
            shed.unlink()

    lidarsim.distributed.run(s, client, tmp_path / "merged", parts=3, progress=progress)
    assert not shed.exists()
    assert_same_run(tmp_path / "whole", tmp_path / "merged")


def points_offset(las):
    """The LAS header's offset to the point records (LAS 1.4, byte 96)."""
    return int.from_bytes(las.read_bytes()[96:100], "little")


def test_a_merge_joins_each_part_as_soon_as_the_parts_before_it(tmp_path):
    # Plain LAS: the parts' own LAS files are joined.
    s = lidarsim.Survey.from_toml(
        SURVEY.replace('"las-waveform", "laz", "xyz"', '"las"') + LINES
    )
    s.run_to(tmp_path / "whole", threads=2, progress=False)
    dirs = [tmp_path / f"p{k}" for k in (1, 2, 3)]
    for k, d in enumerate(dirs, start=1):
        s.run_part(d, k, 3, threads=1)
    las = [d / "points.las" for d in dirs]
    sizes = [p.stat().st_size for p in las]
    records = [size - points_offset(p) for size, p in zip(sizes, las)]
    out = tmp_path / "merged"
    joined = out / "points.las.partial"
    m = lidarsim._lidarsim.PartMerge(str(out))
    # Part 3 waits for parts 1 and 2; part 1 then joins whole, and part 2
    # with it: its point records after part 1's file.
    m.add(str(dirs[2]))
    assert not joined.exists()
    m.add(str(dirs[0]))
    assert joined.stat().st_size == sizes[0]
    with pytest.raises(OSError, match="given twice"):
        m.add(str(dirs[0]))
    m.add(str(dirs[1]))
    assert joined.stat().st_size == sizes[0] + records[1] + records[2]
    m.finish(2)
    assert not joined.exists()
    assert_same_run(tmp_path / "whole", out)
    with pytest.raises(ValueError, match="finished"):
        m.finish(2)


def test_a_merge_of_arriving_parts_refuses_a_foreign_or_missing_part(tmp_path):
    s = survey()
    other = survey().replace({}, seed=30)
    for k in (1, 2):
        s.run_part(tmp_path / f"p{k}", k, 3, threads=1)
    other.run_part(tmp_path / "q3", 3, 3, threads=1)
    m = lidarsim._lidarsim.PartMerge(str(tmp_path / "merged"))
    m.add(str(tmp_path / "p1"))
    with pytest.raises(OSError, match="q3.*is not of the run of .*p1"):
        m.add(str(tmp_path / "q3"))
    m.add(str(tmp_path / "p2"))
    with pytest.raises(OSError, match="part 3/3 is missing"):
        m.finish(2)
