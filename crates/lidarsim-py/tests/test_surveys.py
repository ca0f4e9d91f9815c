"""Surveys from a file, text and a dict; changes for a sweep; bad input."""

import sys

import numpy as np
import pytest

import lidarsim
from conftest import SMALL

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.9 and 3.10
    tomllib = None


def test_a_survey_built_three_ways_gives_the_same_points(small_dir):
    from_file = lidarsim.Survey.load(small_dir / "small.toml")
    from_text = lidarsim.Survey.from_toml(SMALL, base_dir=small_dir)
    if tomllib is not None:
        d = tomllib.loads(SMALL)
    else:
        d = from_file.to_dict()
    from_dict = lidarsim.Survey.from_dict(d, base_dir=small_dir)
    runs = [s.run(threads=2, progress=False) for s in (from_file, from_text, from_dict)]
    assert len(runs[0].points) > 300_000
    # The house is in the scene: some points are classed building (6).
    assert np.count_nonzero(runs[0].points["classification"] == 6) > 100
    for other in runs[1:]:
        assert runs[0].points.tobytes() == other.points.tobytes()


def test_the_thread_count_does_not_change_the_points(small_dir):
    s = lidarsim.Survey.load(small_dir / "small.toml")
    one = s.run(threads=1, progress=False).points
    two = s.run(threads=2, progress=False).points
    assert one.tobytes() == two.tobytes()


def test_to_dict_round_trips_and_replace_changes_one_setting(small_dir):
    s = lidarsim.Survey.load(small_dir / "small.toml")
    again = lidarsim.Survey.from_dict(s.to_dict())
    assert again.to_dict() == s.to_dict()
    # A sweep step: twice the flying height doubles the swath (2 H tan 20°).
    low = s.replace({"flight_line": [{"start_m": [0.0, -30.0, 300.0],
                                      "end_m": [0.0, 30.0, 300.0], "speed_mps": 60.0}]})
    high = low.replace({"flight_line": [{"start_m": [0.0, -30.0, 600.0],
                                         "end_m": [0.0, 30.0, 600.0], "speed_mps": 60.0}]})
    assert high.to_dict()["scanner"] == s.to_dict()["scanner"]
    widths = []
    for survey, h in [(low, 300.0), (high, 600.0)]:
        r = survey.run(progress=False)
        assert r.summary["swath_width_m"] == pytest.approx(2 * h * np.tan(np.radians(20)), rel=1e-6)
        ground = r.points[r.points["classification"] == 2]
        widths.append(ground["x"].max() - ground["x"].min())
    assert widths[1] / widths[0] == pytest.approx(2.0, rel=0.02)


def test_a_seed_replaces_the_files_seed():
    s = lidarsim.Survey.demo()
    assert s.replace({}, seed=99).seed == 99
    assert lidarsim.Survey.demo(seed=5).seed == 5


def test_bad_values_raise_survey_error_naming_each_key():
    bad = {
        "scanner": {"prf_hz": -5, "scan_angel_deg": 10},
        "receiver": {"noise": "loud"},
        "flight_line": [{"start_m": [0, 0, 100], "end_m": [0, 10, 100], "speed_mps": 5}],
    }
    with pytest.raises(lidarsim.SurveyError) as caught:
        lidarsim.Survey.from_dict(bad)
    e = caught.value
    assert isinstance(e, ValueError)
    keys = {d["key"] for d in e.diagnostics}
    assert {"scanner.prf_hz", "scanner.scan_angel_deg", "receiver.noise"} <= keys
    text = str(e)
    for key in ["scanner.prf_hz", "scanner.scan_angel_deg", "receiver.noise"]:
        assert f"`{key}`" in text
    assert "scan_angle_deg" in text  # the near key is suggested


def test_text_and_file_errors_give_line_and_key(tmp_path):
    text = "[scanner]\nprf_hz = 0\n[[flight_line]]\nstart_m = [0, 0, 100]\nend_m = [0, 5, 100]\nspeed_mps = 5\n"
    with pytest.raises(lidarsim.SurveyError) as caught:
        lidarsim.Survey.from_toml(text)
    [d] = [d for d in caught.value.diagnostics if d["key"] == "scanner.prf_hz"]
    assert d["line"] == 2
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(lidarsim.SurveyError) as caught:
        lidarsim.Survey.load(path)
    assert "bad.toml:2" in str(caught.value) and "scanner.prf_hz" in str(caught.value)


def test_a_missing_file_is_reported_at_its_key_when_the_scene_is_built(small_dir):
    s = lidarsim.Survey.from_toml(SMALL.replace("house.obj", "no-such-house.obj"), base_dir=small_dir)
    with pytest.raises(lidarsim.SurveyError) as caught:
        s.run(progress=False)
    assert "mesh[0].file" in str(caught.value)
    with pytest.raises(ValueError):
        s.run(threads=0, progress=False)


def test_values_that_are_not_survey_values_are_refused():
    with pytest.raises(TypeError, match="scanner.prf_hz"):
        lidarsim.Survey.from_dict({"scanner": {"prf_hz": object()}})


# A few pulses over a plane: enough for a run into a folder.
TINY = """
[scanner]
prf_hz = 10000
scan_angle_deg = 10
subrays = 1
[[flight_line]]
start_m = [0.0, -5.0, 200.0]
end_m = [0.0, 5.0, 200.0]
speed_mps = 50.0
[materials.grass]
reflectance = 0.4
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]]
"""


def test_a_run_into_a_foreign_folder_names_the_keyword_that_allows_it(tmp_path):
    # Issue 49: the message said "pass --overwrite" to a Python user.
    (tmp_path / "notes.txt").write_text("mine")
    s = lidarsim.Survey.from_toml(TINY)
    with pytest.raises(OSError) as e:
        s.run_to(tmp_path, progress=False)
    assert "overwrite=True" in str(e.value) and "--overwrite" not in str(e.value)
    s.run_to(tmp_path, progress=False, overwrite=True)
    assert (tmp_path / "notes.txt").read_text() == "mine"


def test_to_laspy_without_laspy_says_how_to_install_it(monkeypatch):
    # Issue 49: a bare ModuleNotFoundError. A None in sys.modules makes the
    # import fail as it does where laspy is not installed.
    result = lidarsim.Survey.from_toml(TINY).run(progress=False)
    monkeypatch.setitem(sys.modules, "laspy", None)
    with pytest.raises(ModuleNotFoundError, match="pip install laspy"):
        result.to_laspy()
