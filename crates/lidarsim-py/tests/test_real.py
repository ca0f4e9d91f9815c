"""lidarsim.compare against an independent computation (NumPy over laspy's
reading of the LAS file), a cloud against itself and against a copy thinned
by pulse; lidarsim.twin of a simulated stand, flown again."""

import numpy as np
import pytest

import lidarsim

laspy = pytest.importorskip("laspy")

# A small stand on flat ground (z = 0): a line at 300 m over 50 pines and
# spruces, noise and speckle off, so that the ground is exactly z = 0.
STAND = """
seed = 5
[scanner]
prf_hz = 60000
scan_frequency_hz = 50
scan_angle_deg = 15
subrays = 7
[[flight_line]]
start_m = [0.0, -80.0, 300.0]
end_m = [0.0, 80.0, 300.0]
speed_mps = 50.0
[output]
formats = ["las"]
[materials.ground]
reflectance = 0.25
[[polygon]]
material = "ground"
class = "ground"
vertices_m = [[-200, -200, 0], [200, -200, 0], [200, 200, 0], [-200, 200, 0]]
[[forest]]
rectangle_m = [-60, -60, 60, 60]
stems_per_ha = 350
species = { pine = 0.5, spruce = 0.5 }
height_m = [10, 24]
min_spacing_m = 3
seed = 4
"""

# The rectangle compared: inside the swath and the flight, on whole cells.
AREA = (-40.0, -50.0, 40.0, 50.0)


@pytest.fixture(scope="module")
def stand(tmp_path_factory):
    """The stand's points in memory and in a LAS file."""
    d = tmp_path_factory.mktemp("stand")
    survey = lidarsim.Survey.from_toml(STAND)
    survey.run_to(d / "run", threads=2, progress=False)
    return survey.run(threads=2, progress=False), d / "run" / "points.las", d


def independent(las, area):
    """The metrics of a cloud over `area`, from laspy's reading with NumPy
    alone: heights are z (the ground is the plane z = 0)."""
    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    keep = (x >= area[0]) & (x < area[2]) & (y >= area[1]) & (y < area[3])
    rn = np.asarray(las.return_number)[keep]
    nr = np.asarray(las.number_of_returns)[keep]
    cls = np.asarray(las.classification)[keep]
    t = np.asarray(las.gps_time)[keep]
    inten = np.asarray(las.intensity)[keep].astype(float)
    h = z[keep]
    first = rn == 1
    last = rn == nr
    ground = cls == 2
    size = (area[2] - area[0]) * (area[3] - area[1])
    canopy = first & (h >= 2.0)

    def pct(v, q):
        return np.percentile(v, q, method="inverted_cdf") if len(v) >= 10 else None

    # The last return of each pulse, by GPS time, wherever it fell (a
    # slanted pulse's last return may lie outside the area).
    all_t, all_rn = np.asarray(las.gps_time), np.asarray(las.return_number)
    all_last = all_rn == np.asarray(las.number_of_returns)
    all_ground = np.asarray(las.classification) == 2
    last_ground = dict(zip(all_t[all_last], all_ground[all_last]))
    reach = [last_ground[tt] for tt in t[canopy] if tt in last_ground]
    m = {
        "pulse_density_per_m2": first.sum() / size,
        "return_density_per_m2": len(rn) / size,
        "returns_per_pulse": nr[first].mean(),
        "single_return_share": np.mean(nr[first] == 1),
        "ground_share": ground.mean(),
        "first_ground_share": ground[first].mean(),
        "last_ground_share": ground[last].mean(),
        "canopy_cover": canopy.sum() / first.sum(),
        "canopy_single_share": np.mean(nr[canopy] == 1),
        "canopy_ground_reach": np.mean(reach),
        "intensity_vegetation": inten[canopy].mean(),
        "intensity_ground": inten[first & ground].mean(),
    }
    m["intensity_ratio"] = m["intensity_vegetation"] / m["intensity_ground"]
    for q in (10, 25, 50, 75, 90, 95, 99):
        m[f"first_p{q}"] = pct(h[first & (h >= 2.0)], q)
        m[f"all_p{q}"] = pct(h[h >= 2.0], q)
    shares = {
        "return_number": np.bincount(np.clip(rn, 1, 5) - 1, minlength=5) / len(rn),
        "number_of_returns": np.bincount(np.clip(nr[first], 1, 5) - 1, minlength=5) / first.sum(),
    }
    return m, shares


def test_compare_metrics_equal_an_independent_computation(stand):
    result, path, _ = stand
    las = laspy.read(path)
    c = lidarsim.compare(path, las, area=AREA, cell_m=20)
    # The area compared is the rectangle: every cell of it holds returns.
    assert c["area_m2"] == pytest.approx(80 * 100)
    want, shares = independent(las, AREA)
    got = c["a"]["metrics"]
    assert set(want) <= set(got)
    for key, value in want.items():
        assert value is not None, key
        assert got[key] == pytest.approx(float(value), rel=1e-9, abs=1e-9), key
    for key, value in shares.items():
        np.testing.assert_allclose(c["a"]["distributions"][key], value, rtol=1e-12, err_msg=key)
    # The stand has canopy, several returns and ground: the metrics mean
    # something.
    assert 0.2 < got["canopy_cover"] < 0.9 and got["returns_per_pulse"] > 1.2


def test_a_cloud_against_itself_differs_in_nothing(stand, tmp_path):
    result, path, _ = stand
    c = lidarsim.compare(result, path, out_dir=tmp_path / "cmp", cell_m=20)
    known = {k: v for k, v in c["difference"].items() if v is not None}
    assert len(known) == len(c["difference"])
    assert all(v == 0.0 for v in known.values()), known
    for m in c["cells"]["metrics"]:
        np.testing.assert_array_equal(m["a"], m["b"], err_msg=m["key"])
        assert m["mean_difference"] in (0.0, None), m["key"]
    assert (tmp_path / "cmp" / "compare.html").read_text().startswith("<!doctype html>")
    assert "pulses (first returns) per m²" in c["table"]


def thinned_copy(las, keep_share, path, seed=3):
    """`las` with each pulse (its GPS time) kept with probability
    `keep_share`, all its returns together, written to `path`."""
    t = np.asarray(las.gps_time)
    pulses = np.unique(t)
    rng = np.random.default_rng(seed)
    kept = pulses[rng.random(len(pulses)) < keep_share]
    mask = np.isin(t, kept)
    out = laspy.LasData(las.header)
    out.points = las.points[mask]
    out.write(path)
    return mask


def test_a_thinned_copy_has_the_density_and_keeps_the_pulses_metrics(stand, tmp_path):
    _, path, _ = stand
    las = laspy.read(path)
    mask = thinned_copy(las, 0.4, tmp_path / "thin.las")
    c = lidarsim.compare(path, tmp_path / "thin.las", area=AREA, cell_m=20)
    a, b = c["a"]["metrics"], c["b"]["metrics"]
    want_b, _ = independent(laspy.read(tmp_path / "thin.las"), AREA)
    assert b["pulse_density_per_m2"] == pytest.approx(want_b["pulse_density_per_m2"], rel=1e-9)
    assert b["pulse_density_per_m2"] / a["pulse_density_per_m2"] == pytest.approx(0.4, abs=0.02)
    # Per pulse nothing changed: within a few standard errors of the cells.
    for key in ("returns_per_pulse", "single_return_share", "canopy_cover", "first_p95"):
        m = next(m for m in c["cells"]["metrics"] if m["key"] == key)
        assert abs(m["z"]) < 4, (key, m["z"])
    # Matched: the full cloud thinned to the copy's pulse density.
    d = lidarsim.compare(path, tmp_path / "thin.las", area=AREA, match_density=True)
    ratio = d["a"]["metrics"]["pulse_density_per_m2"] / d["b"]["metrics"]["pulse_density_per_m2"]
    assert ratio == pytest.approx(1.0, abs=0.03)
    assert d["a"]["kept_share"] == pytest.approx(0.4, abs=0.02) and d["b"]["kept_share"] == 1.0
    assert any("thinned by pulse" in n for n in d["notes"])


def test_twin_of_a_stand_runs_and_compares(stand, tmp_path):
    _, path, _ = stand
    survey = lidarsim.twin(path, tmp_path / "twin", verbose=False)
    report = survey.twin_report
    assert report["trees"]["trees"] > 20
    strip = report["acquisition"]["strips"][0]["track"]
    assert strip["height_m"] == pytest.approx(300, rel=0.03)
    assert strip["speed_mps"] == pytest.approx(50, rel=0.03)
    flown = survey.run(threads=2, progress=False)
    c = lidarsim.compare(path, flown, area=AREA)
    assert c["b"]["metrics"]["pulse_density_per_m2"] == pytest.approx(
        c["a"]["metrics"]["pulse_density_per_m2"], rel=0.1
    )
    with pytest.raises(ValueError, match="altitude"):
        lidarsim.twin(path, tmp_path / "bad", altitude_m=-1, verbose=False)
    with pytest.raises(TypeError, match="unexpected keyword"):
        lidarsim.twin(path, tmp_path / "bad", altitude=300, verbose=False)
