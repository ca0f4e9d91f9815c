"""Ctrl-C during a run raises KeyboardInterrupt within a block and leaves
the interpreter usable; the GIL is released while simulating.

No test waits a guessed time: the run is held at a known pulse by the
test hook (``LIDARSIM_TEST_HOLD_AT_PULSE``, see ``src/hold.rs``), which
says "holding after N pulses" on standard error, and is interrupted or
released there."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import threading

import lidarsim

# A flat field flown for 2000 s at 100 kHz: 200 M pulses, minutes of work;
# the run is held after HOLD_AT pulses until the interrupt comes.
LONG = """
[scanner]
prf_hz = 100000
[[flight_line]]
start_m = [0.0, -60000.0, 500.0]
end_m = [0.0, 60000.0, 500.0]
speed_mps = 60.0
[output]
formats = ["las"]
[materials.g]
reflectance = 0.3
[[polygon]]
material = "g"
class = "ground"
vertices_m = [[-1000, -61000, 0], [1000, -61000, 0], [1000, 61000, 0], [-1000, 61000, 0]]
"""

CHILD = textwrap.dedent(
    """
    import signal, sys, time
    # Ctrl-C as in an interactive interpreter, also when the test runs in
    # the background of a shell, whose children start with SIGINT ignored
    # (Python then leaves it ignored and never raises KeyboardInterrupt).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import lidarsim
    survey = lidarsim.Survey.from_toml(sys.argv[1])
    survey.build()
    def progress(done, total):
        print("running", flush=True)
    try:
        if sys.argv[2] == "memory":
            survey.run(threads=2, progress=progress)
        elif sys.argv[2] == "stream":
            for block in survey.stream(block_points=100_000, threads=2, progress=progress):
                pass
        else:
            survey.run_to(sys.argv[3], threads=2, progress=progress, no_space_check=True)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
    # The interpreter goes on: a small run works (without the hold).
    import os
    os.environ.pop("LIDARSIM_TEST_HOLD_AT_PULSE")
    small = survey.replace({"flight_line": [{"start_m": [0.0, 0.0, 500.0],
                                             "end_m": [0.0, 60.0, 500.0], "speed_mps": 60.0}]})
    print("after", len(small.run(progress=False).points), flush=True)
    """
)


HOLD_AT = 50_000


def interrupt(mode, out_dir=""):
    env = dict(os.environ, LIDARSIM_TEST_HOLD_AT_PULSE=str(HOLD_AT))
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, LONG, mode, str(out_dir)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    # The run is held (it cannot end by itself) until the interrupt.
    for line in child.stderr:
        if line.startswith("holding after"):
            break
    else:
        raise AssertionError(f"the run never reached its hold: {child.communicate()}")
    child.send_signal(signal.SIGINT)
    out, err = child.communicate(timeout=120)
    lines = out.splitlines()
    assert child.returncode == 0, (out, err)
    assert "interrupted" in lines, (out, err)
    assert "finished" not in lines
    after = [line for line in lines if line.startswith("after ")]
    assert after and int(after[0].split()[1]) > 1000, out


def test_ctrl_c_interrupts_a_run_in_memory():
    interrupt("memory")


def test_ctrl_c_interrupts_a_stream():
    interrupt("stream")


def test_ctrl_c_interrupts_a_run_to_a_directory_and_keeps_partial_files(tmp_path):
    out = tmp_path / "run"
    interrupt("dir", out)
    assert (out / "points.las.partial").exists()
    assert not (out / "points.las").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["complete"] is False and summary["next_pulse"]["pulse"] > 0
    # It stopped within a block or two of the hold, not at its end.
    assert HOLD_AT <= summary["pulses"] < 10 * HOLD_AT, summary["pulses"]


def test_the_gil_is_released_while_simulating(tmp_path, monkeypatch):
    # The run is held after HOLD_AT pulses, on the thread that simulates,
    # until another Python thread creates the release file. That thread
    # runs only if the run lets the GIL go; if it did not, the hold would
    # last its longest and the run would fail with an error saying so.
    release = tmp_path / "release"
    monkeypatch.setenv("LIDARSIM_TEST_HOLD_AT_PULSE", str(HOLD_AT))
    monkeypatch.setenv("LIDARSIM_TEST_HOLD_UNTIL", str(release))
    monkeypatch.setenv("LIDARSIM_TEST_HOLD_SECONDS", "60")
    survey = lidarsim.Survey.from_toml(
        LONG.replace("60000.0, 500.0]", "3000.0, 500.0]").replace("-60000.0", "-3000.0")
    )
    survey.build()
    reached = threading.Event()

    def progress(done, total):
        if done >= HOLD_AT:
            reached.set()

    def release_it():
        # Reached on the run's thread (the progress callback comes just
        # before the hold); this thread gets the GIL only while the run
        # is held with the GIL released.
        reached.wait(timeout=120)
        release.write_text("go")

    t = threading.Thread(target=release_it)
    t.start()
    try:
        result = survey.run(threads=1, progress=progress)
    finally:
        reached.set()
        t.join()
    assert release.exists()
    assert len(result.points) > HOLD_AT
