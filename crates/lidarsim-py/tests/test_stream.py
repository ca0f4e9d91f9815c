"""Streamed runs and single waveforms: a stream yields exactly the points
of a run, in blocks, with memory that does not grow with the flight; a
pulse's waveform is the pulse of the run and obeys Eq. 2."""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import lidarsim

# A nadir-looking scanner over flat Lambertian ground 500 m below: every
# sub-ray meets the ground at R = 500 m / cos(small angle).
FLAT = """
seed = 3
[scanner]
prf_hz = {prf}
scan_frequency_hz = 100
scan_angle_deg = {angle}
subrays = {subrays}
[receiver]
noise = {noise}
[[flight_line]]
start_m = [0.0, 0.0, 500.0]
end_m = [0.0, {length}, 500.0]
speed_mps = 50.0
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-2000, -2000, 0], [2000, -2000, 0], [2000, 200000, 0], [-2000, 200000, 0]]
"""


def flat(prf=20000, angle=10, subrays=7, noise=0.01, length=100.0):
    text = FLAT.format(prf=prf, angle=angle, subrays=subrays, noise=noise, length=length)
    return lidarsim.Survey.from_toml(text)


def test_a_stream_yields_the_points_of_a_run_in_blocks(small_dir):
    survey = lidarsim.Survey.load(small_dir / "small.toml")
    whole = survey.run(threads=2, progress=False).points
    blocks = list(survey.stream(block_points=50_000, threads=2, progress=False))
    assert len(blocks) > 3
    assert all(b.dtype == lidarsim.POINT_DTYPE for b in blocks)
    # Every block but the last holds at least the asked-for points.
    assert all(len(b) >= 50_000 for b in blocks[:-1])
    streamed = np.concatenate(blocks)
    assert streamed.tobytes() == whole.tobytes()


def test_leaving_a_stream_early_stops_it():
    survey = flat(length=2000.0)
    stream = survey.stream(block_points=1000, threads=2, progress=False)
    first = next(stream)
    assert len(first) >= 1000
    stream.close()
    # The interpreter and the survey go on as before.
    again = next(iter(survey.stream(block_points=1000, threads=1, progress=False)))
    assert again.tobytes()[: first.nbytes] == first.tobytes()[: again.nbytes]


def test_stream_progress_reaches_the_total():
    survey = flat(length=100.0)
    seen = []
    for _ in survey.stream(block_points=2000, progress=lambda d, t: seen.append((d, t))):
        pass
    total = 40_000
    assert seen[-1] == (total, total)
    assert all(t == total and 0 <= d <= total for d, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


MEMORY = """
import resource, sys
import lidarsim
sys.path.insert(0, {tests!r})
from test_stream import flat
survey = flat(prf=200000, angle=20, subrays=1, noise=0.0, length={length})
survey.build()
points = 0
for block in survey.stream(block_points=100_000, threads=2, progress=False):
    points += len(block)
print(points, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def peak_rss_kib(length: float, tests: str):
    code = textwrap.dedent(MEMORY.format(length=length, tests=tests))
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True
    ).stdout.split()
    return int(out[0]), int(out[1])


def test_a_streamed_flight_runs_in_the_memory_of_a_few_blocks():
    # 40 times the flight, 40 times the points, the same peak memory: the
    # long flight's 4.8 M points take 410 MB as one array, and its peak
    # stays within 64 MiB of the short flight's.
    tests = str(__import__("pathlib").Path(__file__).parent)
    short_points, short_peak = peak_rss_kib(25.0, tests)
    long_points, long_peak = peak_rss_kib(1000.0, tests)
    assert short_points == 100_000
    assert long_points == 4_000_000
    assert long_points * lidarsim.POINT_DTYPE.itemsize > 300e6
    assert long_peak - short_peak < 64 * 1024, (short_peak, long_peak)


def test_a_waveform_is_the_pulse_of_the_run():
    survey = flat(noise=0.01)
    points = survey.run(threads=2, progress=False).points
    for pulse in [0, 777, 39_999]:
        w = survey.waveform(line=0, pulse=pulse)
        want = points[points["pulse_index"] == pulse]
        assert w.emitted
        assert w.points.tobytes() == want.tobytes()
        assert len(w.echo_range_m) == len(want) == 1
        # The samples' time axis and ranges agree: R = c t / 2.
        assert np.allclose(w.range_m, 299_792_458.0 * w.time_ns * 1e-9 / 2.0)
        # The signal peaks at the echo, above the threshold.
        peak = np.argmax(w.samples)
        assert abs(w.range_m[peak] - w.echo_range_m[0]) < 0.1
        assert w.samples[peak] > w.threshold == pytest.approx(4.0 * 0.01)
    with pytest.raises(IndexError, match="line 1"):
        survey.waveform(line=1, pulse=0)
    with pytest.raises(IndexError, match="40000 pulses"):
        survey.waveform(line=0, pulse=40_000)


def test_a_waveform_returns_the_power_of_equation_2():
    # Eq. 2 for each sub-ray of a level Lambertian plane: share · ρ ·
    # (Rn / R)² · cos α with R = H / cos α: summed over the beam, for a
    # beam a fraction of a milliradian wide, ρ (Rn / H)² to 1e-6.
    survey = flat(angle=0, subrays=19, noise=0.0)
    w = survey.waveform(line=0, pulse=100)
    rn = 1000.0
    assert len(w.returns_power) == 19
    assert w.returns_power.sum() == pytest.approx(0.3 * (rn / 500.0) ** 2, rel=1e-6)
    assert np.all(np.abs(w.returns_range_m - 500.0) < 1e-3)
    # One echo at the ground, whose energy amplitude is that power.
    assert w.echo_range_m == pytest.approx([500.0], abs=0.01)
    assert w.echo_amplitude == pytest.approx([0.3 * 4.0], rel=0.01)
