"""The points in memory against the LAS file, read by laspy (an independent
reader), and the files of `Survey.run_to` against `lidarsim run`'s."""

import csv
import os
import subprocess

import numpy as np
import pytest

import lidarsim
from conftest import EXAMPLES

laspy = pytest.importorskip("laspy")

# Dimensions of point format 6 that the structured array carries.
LAS_FIELDS = [
    "intensity", "return_number", "number_of_returns", "scan_direction_flag",
    "edge_of_flight_line", "scanner_channel", "classification", "user_data",
    "scan_angle", "point_source_id", "gps_time",
]
EXTRA = ["amplitude", "echo_width", "range", "incidence_angle", "object_id"]
ERRORS = ["error_x", "error_y", "error_z"]


def assert_same(points, las, extra):
    assert len(points) == len(las.points)
    for name in ["x", "y", "z"]:
        # laspy scales X with the header's scale and offset, as the array does.
        np.testing.assert_array_equal(points[name], np.asarray(las[name]), err_msg=name)
    for name in LAS_FIELDS + extra:
        np.testing.assert_array_equal(
            points[name], np.asarray(las[name]).astype(points.dtype[name]), err_msg=name
        )


@pytest.fixture(scope="module")
def uav_run(tmp_path_factory):
    """The drone example (navigation errors on, so the error extra bytes are
    in the file) in memory and in a directory."""
    survey = lidarsim.Survey.load(EXAMPLES / "uav-livox-mid70.toml")
    out = tmp_path_factory.mktemp("uav")
    summary = survey.run_to(out / "run", threads=2, progress=False)
    return survey.run(threads=2, progress=False), out / "run", summary


def test_points_equal_the_las_file_field_by_field(uav_run):
    result, out, summary = uav_run
    las = laspy.read(out / "points.las")
    assert_same(result.points, las, EXTRA + ERRORS)
    assert summary["complete"] is True
    assert summary["points"] == len(result.points) == result.summary["points"]
    # Errors are on: their fields are not all zero.
    assert np.abs(result.points["error_z"]).max() > 0


def test_to_laspy_writes_the_same_points(uav_run, tmp_path):
    result, out, _ = uav_run
    path = tmp_path / "again.las"
    result.to_laspy().write(path)
    again = laspy.read(path)
    assert_same(result.points, again, EXTRA + ERRORS)
    original = laspy.read(out / "points.las")
    np.testing.assert_array_equal(again.header.scales, original.header.scales)
    np.testing.assert_array_equal(again.header.offsets, original.header.offsets)


def test_trajectories_equal_the_csv_files(uav_run):
    result, out, _ = uav_run
    for name, which in [("trajectory_true.csv", "true"), ("trajectory_observed.csv", "observed")]:
        with open(out / name) as f:
            rows = list(csv.DictReader(f))
        t = result.trajectory[which]
        assert len(t) == len(rows)
        for field, column, decimals in [("gps_time", "gps_time_s", 6), ("x", "x_m", 4),
                                        ("z", "z_m", 4), ("roll", "roll_deg", 6)]:
            csv_values = np.array([float(r[column]) for r in rows])
            np.testing.assert_allclose(t[field], csv_values, atol=0.6 * 10.0**-decimals)
        assert set(t["line"].tolist()) == {1}
    # The observed path differs from the true one (the UAV navigation errors).
    assert np.abs(result.trajectory["observed"]["z"] - result.trajectory["true"]["z"]).max() > 0


def test_run_to_writes_the_bytes_of_the_command_line(lidarsim_bin, tmp_path):
    survey_path = EXAMPLES / "waveform-utm.toml"
    env = dict(os.environ, SOURCE_DATE_EPOCH="1790000000")
    subprocess.run([str(lidarsim_bin), "run", str(survey_path), "-o", str(tmp_path / "cli"),
                    "--threads", "2"], check=True, env=env, capture_output=True)
    os.environ["SOURCE_DATE_EPOCH"] = "1790000000"
    try:
        lidarsim.Survey.load(survey_path).run_to(tmp_path / "py", threads=2, progress=False)
    finally:
        del os.environ["SOURCE_DATE_EPOCH"]
    written = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert written == sorted(p.name for p in (tmp_path / "py").iterdir())
    for name in written:
        if name in ("summary.json", "report.html"):
            continue  # run times differ
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name
    # The CRS (EPSG:3067) and the points of the same survey in memory.
    result = lidarsim.Survey.load(survey_path).run(progress=False)
    assert "3067" in (result.las_header["crs_wkt"] or "") or "TM35FIN" in result.las_header["crs_wkt"]
    assert_same(result.points, laspy.read(tmp_path / "py" / "points.las"), EXTRA)
