"""Scenes from arrays: a mesh, a height grid, trees and points given as
NumPy arrays give the points the same geometry gives from the files a
survey names (OBJ, a GeoTIFF written by GDAL, [[tree]] tables, a LAS file
written by laspy); a run writes them as files its survey.toml names; bad
arrays raise SurveyError naming the key."""

import subprocess

import laspy
import numpy as np
import pytest

import lidarsim

# One 120 m line at 40 kHz over a 200 m square of grass: 240 000 pulses.
HEAD = """
seed = 21
[scanner]
prf_hz = 40000
scan_frequency_hz = 50
scan_angle_deg = 15
subrays = 7
[receiver]
noise = 0.01
[[flight_line]]
start_m = [0.0, -60.0, 300.0]
end_m = [0.0, 60.0, 300.0]
speed_mps = 60.0
[output]
formats = ["las"]
[materials.grass]
reflectance = 0.3
[materials.roof]
reflectance = 0.45
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-100, -100, -1], [100, -100, -1], [100, 100, -1], [-100, 100, -1]]
"""


def points(survey):
    return survey.run(threads=2, progress=False).points


def same(a, b):
    assert len(a) > 10_000
    assert a.tobytes() == b.tobytes()


def house():
    """A box with a gable roof: 10 vertices, 16 triangles, awkward
    coordinates (no short decimal form)."""
    w, d, h, r = 12.3456789, 8.7654321, 6.1, 9.0 + 1.0 / 3.0
    v = np.array(
        [
            [0, 0, 0], [w, 0, 0], [w, d, 0], [0, d, 0],
            [0, 0, h], [w, 0, h], [w, d, h], [0, d, h],
            [0, d / 2, r], [w, d / 2, r],
        ],
        dtype=float,
    ) + np.array([-6.1, -4.2, 0.0])
    f = np.array(
        [
            [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6],
            [3, 0, 4], [3, 4, 7], [4, 5, 9], [4, 9, 8], [7, 6, 9], [7, 9, 8],
            [4, 8, 7], [5, 6, 9], [0, 2, 1], [0, 3, 2],
        ]
    )
    return v, f


def write_obj(path, v, f):
    with open(path, "w") as out:
        for x, y, z in v:
            out.write(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n")
        for a, b, c in f:
            out.write(f"f {a + 1} {b + 1} {c + 1}\n")


def test_a_mesh_from_arrays_gives_the_points_of_its_obj_file(tmp_path):
    v, f = house()
    write_obj(tmp_path / "house.obj", v, f)
    placed = 'offset_m = [3.5, -2.25, 0.0]\nscale = 1.5\nrotation_z_deg = 30.0\n'
    from_file = lidarsim.Survey.from_toml(
        HEAD + f'[[mesh]]\nfile = "house.obj"\nmaterial = "roof"\nclass = "roof"\n{placed}',
        base_dir=tmp_path,
    )
    from_arrays = lidarsim.Survey.from_toml(HEAD).with_mesh(
        v, f, material="roof", class_="roof", offset_m=[3.5, -2.25, 0.0], scale=1.5,
        rotation_z_deg=30.0,
    )
    a, b = points(from_file), points(from_arrays)
    same(a, b)
    assert (a["classification"] == 6).sum() > 1000


def test_a_height_grid_from_an_array_gives_the_points_of_its_geotiff(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import from_origin

    rows, cols = 60, 80
    yy, xx = np.mgrid[0:rows, 0:cols]
    heights = (3.0 * np.sin(xx / 7.0) + 2.0 * np.cos(yy / 5.0)).astype(np.float32)
    heights[10, 20] = np.nan
    transform = from_origin(-101.3, 98.7, 2.5, 3.25)
    with rasterio.open(
        tmp_path / "dem.tif", "w", driver="GTiff", height=rows, width=cols, count=1,
        dtype="float32", transform=transform, nodata=np.nan,
    ) as dst:
        dst.write(heights, 1)
    from_file = lidarsim.Survey.from_toml(
        HEAD + '[[terrain]]\nfile = "dem.tif"\nmaterial = "grass"\nclass = "ground"\n',
        base_dir=tmp_path,
    )
    from_array = lidarsim.Survey.from_toml(HEAD).with_terrain(
        heights, transform, material="grass", class_="ground"
    )
    a, b = points(from_file), points(from_array)
    same(a, b)
    # The points lie on the terrain, not on the polygon 1 m under it.
    assert np.median(a["z"]) > 0.0


def test_trees_from_a_table_give_the_points_of_tree_tables():
    rng = np.random.default_rng(4)
    n = 40
    table = {
        "x": rng.uniform(-40, 40, n),
        "y": rng.uniform(-50, 50, n),
        "z": np.full(n, -1.0),
        "species": rng.choice(["pine", "spruce", "birch"], n),
        "dbh_m": rng.uniform(0.15, 0.4, n),
        "height_m": rng.uniform(14, 24, n),
        "crown_base_m": rng.uniform(5, 9, n),
        "seed": np.arange(n) + 100,
    }
    text = HEAD
    for i in range(n):
        text += (
            "[[tree]]\n"
            f"position_m = [{float(table['x'][i])!r}, {float(table['y'][i])!r}, -1.0]\n"
            f'species = "{table["species"][i]}"\n'
            f"dbh_m = {float(table['dbh_m'][i])!r}\n"
            f"height_m = {float(table['height_m'][i])!r}\n"
            f"crown_base_m = {float(table['crown_base_m'][i])!r}\n"
            f"seed = {table['seed'][i]}\n"
        )
    a = points(lidarsim.Survey.from_toml(text))
    b = points(lidarsim.Survey.from_toml(HEAD).with_trees(table))
    same(a, b)
    assert (a["user_data"] == 1).sum() > 1000  # foliage returns
    # A structured array is a table too.
    rec = np.rec.fromarrays(list(table.values()), names=list(table))
    same(a, points(lidarsim.Survey.from_toml(HEAD).with_trees(rec)))


def test_points_from_arrays_give_the_voxels_of_their_las_file(tmp_path):
    rng = np.random.default_rng(9)
    n = 30_000
    # Millimetre integers: the LAS file holds them exactly, and its
    # reader's x = X · 0.001 + 0 is the array's value to the bit.
    ints = np.column_stack(
        [rng.integers(-20_000, 20_000, n), rng.integers(-30_000, 30_000, n),
         rng.integers(0, 8_000, n)]
    )
    xyz = ints.astype(np.float64) * 0.001 + 0.0
    codes = rng.choice(np.array([2, 5, 6], dtype=np.uint8), n)
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.zeros(3)
    las = laspy.LasData(header)
    las.X, las.Y, las.Z = ints[:, 0], ints[:, 1], ints[:, 2]
    las.classification = codes
    las.write(tmp_path / "cloud.las")
    from_file = lidarsim.Survey.from_toml(
        HEAD + '[[point_cloud]]\nfile = "cloud.las"\nvoxel_m = 0.5\nmaterial = "roof"\n',
        base_dir=tmp_path,
    )
    from_arrays = lidarsim.Survey.from_toml(HEAD).with_point_cloud(
        xyz, voxel_m=0.5, material="roof", classes=codes
    )
    same(points(from_file), points(from_arrays))


def test_a_run_writes_array_scenes_as_files_its_survey_names(tmp_path, lidarsim_bin):
    v, f = house()
    survey = (
        lidarsim.Survey.from_toml(HEAD)
        .with_mesh(v, f, material="roof", class_="roof", rotation_z_deg=12.0)
        .with_point_cloud(np.array([[20.0, 20.0, 3.0], [20.2, 20.1, 3.3]]), 1.0, "grass", "roof")
    )
    out = tmp_path / "out"
    summary = survey.run_to(out, threads=2, progress=False)
    assert "scene/mesh-0.obj" in summary["files"]
    assert "scene/point_cloud-0.xyz" in summary["files"]
    text = (out / "survey.toml").read_text()
    assert 'file = "scene/mesh-0.obj"' in text and 'file = "scene/point_cloud-0.xyz"' in text
    # The command line runs the directory's survey to the same points.
    again = tmp_path / "again"
    subprocess.run(
        [str(lidarsim_bin), "run", str(out / "survey.toml"), "-o", str(again)],
        check=True, capture_output=True,
    )
    a, b = laspy.read(out / "points.las"), laspy.read(again / "points.las")
    assert len(a.points) > 10_000
    for dim in ["X", "Y", "Z", "intensity", "classification", "gps_time"]:
        assert np.array_equal(a[dim], b[dim]), dim
    # A second run into the same directory replaces the scene files.
    survey.run_to(out, threads=1, progress=False)
    assert sorted(p.name for p in (out / "scene").iterdir()) == [
        "mesh-0.obj",
        "point_cloud-0.xyz",
    ]


def test_replace_keeps_the_scene_parts_given_as_arrays(tmp_path):
    v, f = house()
    write_obj(tmp_path / "house.obj", v, f)
    from_file = lidarsim.Survey.from_toml(
        HEAD + '[[mesh]]\nfile = "house.obj"\nmaterial = "roof"\nclass = "roof"\n',
        base_dir=tmp_path,
    )
    from_arrays = lidarsim.Survey.from_toml(HEAD).with_mesh(v, f, "roof", "roof")
    change = {"scanner": {"scan_angle_deg": 10}}
    same(points(from_file.replace(change, seed=3)), points(from_arrays.replace(change, seed=3)))
    same(points(from_file), points(from_arrays.with_trees({
        "x": [], "y": [], "species": [], "dbh_m": [], "height_m": [], "crown_base_m": [],
    })))


def test_bad_arrays_name_their_keys():
    base = lidarsim.Survey.from_toml(HEAD)
    v, f = house()
    cases = [
        (lambda: base.with_mesh(v, [[0, 1, 99]], "roof", "roof"), "mesh.faces[0]"),
        (lambda: base.with_mesh(v, f, "slate", "roof"), "mesh.material"),
        (lambda: base.with_mesh(v[:, :2], f, "roof", "roof"), "mesh.vertices"),
        (lambda: base.with_mesh(v, f, "roof", "roofs"), "mesh.class"),
        (lambda: base.with_mesh(v, [[0, 0, 1]], "roof", "roof"), "mesh.faces"),
        (lambda: base.with_terrain(np.zeros((4, 4)), (1, 0.5, 0, 0, -1, 0), "grass"),
         "terrain.transform"),
        (lambda: base.with_terrain(np.zeros(16), (1, 0, 0, 0, -1, 0), "grass"),
         "terrain.heights"),
        (lambda: base.with_terrain(np.full((3, 3), 2e6), (1, 0, 0, 0, -1, 0), "grass"),
         "terrain.heights[0, 0]"),
        (lambda: base.with_point_cloud([[0, 0, np.inf]], 1.0, "grass"), "point_cloud.points[0]"),
        (lambda: base.with_point_cloud([[0, 0, 0]], 0.0, "grass"), "point_cloud.voxel_m"),
        (lambda: base.with_point_cloud([[0, 0, 0]], 1.0, "grass", classes=[2, 3]),
         "point_cloud.classes"),
        (lambda: base.with_trees({"x": [1.0], "y": [2.0], "species": ["pine"]}),
         "tree.dbh_m"),
        (lambda: base.with_trees({"x": [1.0], "y": [2.0], "species": ["fir"], "dbh_m": [0.2],
                                  "height_m": [15.0], "crown_base_m": [5.0]}),
         "tree[0].species"),
    ]
    for make, key in cases:
        with pytest.raises(lidarsim.SurveyError) as e:
            make()
        assert f"`{key}`" in str(e.value), (key, str(e.value))
