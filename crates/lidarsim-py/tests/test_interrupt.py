"""Ctrl-C during a run raises KeyboardInterrupt within a block and leaves
the interpreter usable; the GIL is released while simulating."""

import json
import signal
import subprocess
import sys
import textwrap
import threading
import time

import lidarsim

# A flat field flown for 2000 s at 100 kHz: 200 M pulses, minutes of work,
# so the interrupt always comes mid-run.
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
    started = time.monotonic()
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
        print(f"interrupted after {time.monotonic() - started:.2f} s", flush=True)
    # The interpreter goes on: a small run works.
    small = survey.replace({"flight_line": [{"start_m": [0.0, 0.0, 500.0],
                                             "end_m": [0.0, 60.0, 500.0], "speed_mps": 60.0}]})
    print("after", len(small.run(progress=False).points), flush=True)
    """
)


def interrupt(mode, out_dir=""):
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, LONG, mode, str(out_dir)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert child.stdout.readline().strip() == "running"
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=120)
    waited = time.monotonic() - sent
    lines = out.splitlines()
    assert child.returncode == 0, out
    assert any(line.startswith("interrupted") for line in lines), out
    assert "finished" not in lines
    after = [line for line in lines if line.startswith("after ")]
    assert after and int(after[0].split()[1]) > 1000, out
    # The run stopped long before its end (minutes of pulses).
    assert waited < 60, waited


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


def test_the_gil_is_released_while_simulating():
    survey = lidarsim.Survey.from_toml(
        LONG.replace("60000.0, 500.0]", "300.0, 500.0]").replace("-60000.0", "-300.0")
    )
    survey.build()
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        result = survey.run(threads=1, progress=False)
    finally:
        stop.set()
        t.join()
    assert len(result.points) > 100_000
    # A thread that never got the GIL back would not have counted.
    assert len(ticks) > 10
