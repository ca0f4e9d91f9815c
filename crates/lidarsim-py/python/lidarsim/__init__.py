"""lidarsim: airborne LiDAR simulation from Python.

Build a survey from a file, TOML text or a dict (the keys of the survey
file, described in ``docs/survey.md``), run it, and get the points as a
NumPy structured array with the fields of the LAS file::

    import lidarsim
    survey = lidarsim.Survey.load("examples/forest.toml")
    result = survey.run()
    result.points["z"], result.points["classification"]
    las = result.to_laspy()            # needs laspy
    survey.run_to("out")               # the files of `lidarsim run`
    for block in survey.stream():      # a flight of any length, in blocks
        ...
    survey = survey.with_mesh(vertices, faces, material="roof", class_="roof")
    survey = survey.with_trees({"x": xs, "y": ys, "species": sp, ...})
    w = survey.waveform(line=0, pulse=1000)   # one pulse's full waveform
    twin = lidarsim.twin("scan.laz", "twin")  # a survey that re-flies a real scan
    c = lidarsim.compare("scan.laz", twin.run())  # the field's metrics, side by side

A survey with problems raises :class:`SurveyError` (a ``ValueError``),
whose message names every key at fault. A file that cannot be read,
written, joined or continued raises the ``OSError`` of its kind, with the
file in ``e.path``: :class:`InputError` (a file a run reads),
:class:`OutputError` (a file or directory it writes), :class:`PartError`
(a part of a split run refused), :class:`ResumeError` (an interrupted run
that cannot be continued) and :class:`BudgetError` (a run that would not
fit the disk or memory, refused before it starts). The simulation runs with the GIL released on every
core; Ctrl-C raises ``KeyboardInterrupt`` within a block of pulses.
"""

from __future__ import annotations

import copy
import os
import sys
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, Mapping, Optional, Union

import numpy as np

from . import _lidarsim
from ._lidarsim import (
    BudgetError,
    InputError,
    OutputError,
    PartError,
    ResumeError,
    SurveyError,
)

__all__ = [
    "BudgetError",
    "InputError",
    "OutputError",
    "PartError",
    "POINT_DTYPE",
    "compare",
    "merge",
    "TRAJECTORY_DTYPE",
    "Result",
    "ResumeError",
    "Survey",
    "SurveyError",
    "Waveform",
    "__version__",
    "twin",
]

__version__: str = _lidarsim.VERSION

#: The fields of a point: laspy's dimension names where laspy has one,
#: the LAS file's extra-byte names otherwise, and ``pulse_index`` (the
#: pulse within its flight line, not in the LAS file).
POINT_DTYPE = np.dtype(list(_lidarsim.POINT_FIELDS))
assert POINT_DTYPE.itemsize == _lidarsim.POINT_RECORD_BYTES

#: The fields of a trajectory row: GPS time (s), position (m), roll, pitch
#: and yaw (degrees), flight line (1 for the first).
TRAJECTORY_DTYPE = np.dtype(list(_lidarsim.TRAJECTORY_FIELDS))

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[bool, Callable[[int, int], Any], None]


def _threads(threads: Optional[int]) -> int:
    if threads is None:
        return os.cpu_count() or 1
    if threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    return int(threads)


class _Bar:
    """A progress display: tqdm (terminal or notebook) when it is installed,
    else one line on stderr rewritten in place."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.bar = None
        self.shown = False

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            try:
                from tqdm.auto import tqdm

                self.bar = tqdm(total=total, unit=" pulses", unit_scale=True, desc=self.label)
            except ImportError:
                self.bar = False
        if self.bar:
            self.bar.update(done - self.bar.n)
        else:
            pct = 100.0 * done / total if total else 100.0
            sys.stderr.write(f"\r{self.label}: {done}/{total} pulses ({pct:.0f} %)")
            sys.stderr.flush()
            self.shown = True

    def close(self) -> None:
        if self.bar:
            self.bar.close()
        elif self.shown:
            sys.stderr.write("\n")


def _progress(progress: Progress, label: str):
    """The callback for ``progress`` and the display to close afterwards."""
    if progress is True:
        bar = _Bar(label)
        return bar, bar
    if progress in (False, None):
        return None, None
    if callable(progress):
        return progress, None
    raise TypeError("progress must be True, False or a callable(done, total)")


def _merge(base: Dict[str, Any], changes: Mapping[str, Any]) -> Dict[str, Any]:
    """``base`` with ``changes`` merged in: tables key by key, other values
    replaced; a value of None removes the key."""
    out = copy.deepcopy(base)
    for key, value in changes.items():
        if value is None:
            out.pop(key, None)
        elif isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _rows(key: str, values: Any, dtype: Any) -> np.ndarray:
    """``values`` as a contiguous (n, 3) array of ``dtype``, or a
    :class:`SurveyError` naming ``key``."""
    try:
        a = np.ascontiguousarray(values, dtype=dtype)
    except (TypeError, ValueError) as e:
        raise SurveyError(f"key `{key}`: not an array of numbers: {e}") from None
    if a.size == 0:
        a = a.reshape(0, 3)
    if a.ndim != 2 or a.shape[1] != 3:
        raise SurveyError(f"key `{key}`: an array of shape (n, 3) is needed, got {a.shape}")
    return a


def _columns(table: Any) -> Dict[str, np.ndarray]:
    """The columns of a table: a dict of arrays, a pandas or GeoPandas
    DataFrame (a point ``geometry`` gives ``x`` and ``y``) or a structured
    NumPy array."""
    names = getattr(getattr(table, "dtype", None), "names", None)
    if names:
        return {n: np.asarray(table[n]) for n in names}
    if hasattr(table, "columns"):
        cols = {str(c): np.asarray(table[c]) for c in table.columns if str(c) != "geometry"}
        if "geometry" in table.columns and "x" not in cols:
            geometry = table["geometry"]
            cols["x"], cols["y"] = np.asarray(geometry.x), np.asarray(geometry.y)
        return cols
    return {str(k): np.asarray(v) for k, v in dict(table).items()}


#: The ``[[tree]]`` keys a tree table may have besides ``x``, ``y``, ``z``.
TREE_COLUMNS = (
    "species",
    "dbh_m",
    "height_m",
    "crown_base_m",
    "foliage_reflectance",
    "bark_reflectance",
    "crown_radius_m",
    "extinction_per_m",
    "uniform_density",
    "seed",
)


def _tree_entries(table: Any) -> list:
    """``[[tree]]`` dicts, one per row of ``table``."""
    cols = _columns(table)
    for needed in ("x", "y", "species", "dbh_m", "height_m", "crown_base_m"):
        if needed not in cols:
            raise SurveyError(f"key `tree.{needed}`: the tree table has no column `{needed}`")
    unknown = sorted(set(cols) - {"x", "y", "z", *TREE_COLUMNS})
    if unknown:
        raise SurveyError(
            f"key `tree.{unknown[0]}`: unknown column `{unknown[0]}`; a tree table has x, y, "
            f"z and {', '.join(TREE_COLUMNS)}"
        )
    n = len(cols["x"])
    for name, values in cols.items():
        if len(values) != n:
            raise SurveyError(f"key `tree.{name}`: {len(values)} values for {n} trees")
    z = cols.get("z", np.zeros(n))
    entries = []
    for i in range(n):
        entry = {"position_m": [float(cols["x"][i]), float(cols["y"][i]), float(z[i])]}
        for key in TREE_COLUMNS:
            if key not in cols:
                continue
            value = cols[key][i]
            if key == "species":
                entry[key] = str(value)
            elif key == "seed":
                entry[key] = int(value)
            elif not (isinstance(value, float) and np.isnan(value)):
                entry[key] = float(value)
        entries.append(entry)
    return entries


class Survey:
    """A checked survey: scanner, platform, flight lines, scene and outputs.

    Make one with :meth:`load`, :meth:`from_toml`, :meth:`from_dict` or
    :meth:`demo`; change settings with :meth:`replace` (a new, re-checked
    survey); add scene parts from arrays with :meth:`with_mesh`,
    :meth:`with_terrain`, :meth:`with_trees` and :meth:`with_point_cloud`.
    The scene is built and indexed once, on the first run.
    """

    def __init__(self, core: "_lidarsim.SurveyCore", data: tuple = ()) -> None:
        self._core = core
        # The scene parts given as arrays, as (method, arguments) to apply
        # again to a survey rebuilt from the dict (replace, seed).
        self._data = data

    @classmethod
    def load(cls, path: PathLike, seed: Optional[int] = None) -> "Survey":
        """Reads and checks the survey file at ``path``. ``seed`` replaces
        the file's seed (every random stream follows it)."""
        return cls(_lidarsim.SurveyCore.load(os.fspath(path), seed))

    @classmethod
    def from_toml(
        cls, text: str, base_dir: Optional[PathLike] = None, seed: Optional[int] = None
    ) -> "Survey":
        """Checks a survey given as TOML text. Relative file names in it are
        found from ``base_dir`` (the working directory by default)."""
        base = None if base_dir is None else os.fspath(base_dir)
        return cls(_lidarsim.SurveyCore.from_toml(text, base, seed))

    @classmethod
    def from_dict(
        cls,
        d: Mapping[str, Any],
        base_dir: Optional[PathLike] = None,
        seed: Optional[int] = None,
    ) -> "Survey":
        """Checks a survey given as a dict with the survey file's keys
        (tables as dicts, arrays of tables as lists of dicts; NumPy arrays
        and scalars are accepted as values). Problems name their keys."""
        base = None if base_dir is None else os.fspath(base_dir)
        return cls(_lidarsim.SurveyCore.from_dict(dict(d), base, seed))

    @classmethod
    def demo(cls, seed: Optional[int] = None) -> "Survey":
        """The built-in demo: a small town with streets, buildings and trees."""
        return cls(_lidarsim.SurveyCore.demo(seed))

    @property
    def seed(self) -> int:
        """The seed of every random stream."""
        return self._core.seed

    def to_dict(self) -> Dict[str, Any]:
        """The survey's keys as a dict (seed fixed, file paths absolute):
        ``Survey.from_dict(s.to_dict())`` is the same survey, but for the
        scene parts given as arrays (meshes, terrains and point clouds of
        the ``with_`` methods), which have no keys: :meth:`replace` keeps
        them, and :meth:`run_to` writes them as files that its
        ``survey.toml`` names."""
        return self._core.to_dict()

    def to_toml(self) -> str:
        """The survey as TOML text (what a run's ``survey.toml`` holds)."""
        return self._core.to_toml()

    def replace(self, changes: Mapping[str, Any], seed: Optional[int] = None) -> "Survey":
        """A new survey with ``changes`` merged into this one's keys, for a
        parameter sweep::

            higher = survey.replace({"plan": {"altitude_m": 800}})

        Tables merge key by key; other values (arrays of tables such as
        ``flight_line`` included) are replaced; None removes a key."""
        return Survey.from_dict(_merge(self.to_dict(), changes), seed=seed)._with_data(self._data)

    def _with_data(self, data: tuple) -> "Survey":
        """This survey with the scene parts ``data`` added."""
        core = self._core
        for method, args in data:
            core = getattr(core, method)(*args)
        return Survey(core, self._data + data)

    def with_mesh(
        self,
        vertices: Any,
        faces: Any,
        material: str,
        class_: str = "unclassified",
        offset_m: Any = (0.0, 0.0, 0.0),
        scale: float = 1.0,
        rotation_z_deg: float = 0.0,
    ) -> "Survey":
        """A new survey with a triangle mesh added as the next ``[[mesh]]``:
        ``vertices`` an (n, 3) array of x, y, z in metres, ``faces`` an
        (m, 3) array of vertex indices from 0, ``material`` a name in
        ``[materials]``, ``class_`` a class name of the survey file
        (``"roof"``, ``"ground"``, …). Placed as a ``[[mesh]]`` file is:
        scaled, turned by ``rotation_z_deg`` about the vertical, moved by
        ``offset_m``. The same triangles from an OBJ file give the same
        points."""
        args = (
            _rows("mesh.vertices", vertices, np.float64),
            _rows("mesh.faces", faces, np.int64),
            str(material),
            str(class_),
            [float(v) for v in offset_m],
            float(scale),
            float(rotation_z_deg),
        )
        return self._with_data((("with_mesh", args),))

    def with_terrain(
        self,
        heights: Any,
        transform: Any,
        material: str,
        class_: str = "ground",
        nodata: Optional[float] = None,
    ) -> "Survey":
        """A new survey with a height grid added as the next
        ``[[terrain]]``: ``heights`` a 2-D array of a north-up raster in its
        own row order, ``transform`` its affine transform as rasterio gives
        it (``(a, b, c, d, e, f)``: ``x = a·col + c``, ``y = e·row + f`` at a
        pixel's corner; an ``affine.Affine`` works), the nodes at the pixel
        centres as for a GeoTIFF; NaN or ``nodata`` for missing nodes. The
        same raster in a GeoTIFF gives the same points."""
        t = tuple(float(v) for v in tuple(transform)[:6])
        h = np.ascontiguousarray(heights, dtype=np.float64)
        if h.ndim != 2:
            raise SurveyError(f"key `terrain.heights`: a 2-D array is needed, got {h.ndim} dimensions")
        args = (h, list(t), str(material), str(class_), None if nodata is None else float(nodata))
        return self._with_data((("with_terrain", args),))

    def with_point_cloud(
        self,
        points: Any,
        voxel_m: float,
        material: str,
        class_: Optional[str] = None,
        classes: Any = None,
    ) -> "Survey":
        """A new survey with points added as the next ``[[point_cloud]]``,
        as voxels of ``voxel_m``: ``points`` an (n, 3) array of x, y, z;
        each voxel of class ``class_`` or, without it, of the class most of
        its points have (``classes``: an ASPRS code per point, as a LAS
        file's classification). The same points in a LAS file give the
        same points."""
        args = (
            _rows("point_cloud.points", points, np.float64),
            float(voxel_m),
            str(material),
            None if class_ is None else str(class_),
            None if classes is None else np.ascontiguousarray(classes, dtype=np.uint8).ravel(),
        )
        return self._with_data((("with_point_cloud", args),))

    def with_trees(self, table: Any) -> "Survey":
        """A new survey with a tree for each row of ``table`` added as
        ``[[tree]]`` entries: a dict of arrays, a pandas or GeoPandas
        DataFrame or a structured array with columns ``x``, ``y``
        (``geometry`` points will do), ``z`` (the stem base's height, 0 if
        absent), ``species``, ``dbh_m``, ``height_m``, ``crown_base_m`` and
        optionally the other ``[[tree]]`` keys (a NaN leaves a key at its
        default). The same trees written as ``[[tree]]`` tables give the
        same points."""
        trees = list(self.to_dict().get("tree", [])) + _tree_entries(table)
        return self.replace({"tree": trees})

    def warnings(self) -> list:
        """Settings that are allowed but probably not meant, each naming its
        key (builds the scene if it was not built)."""
        return self._core.warnings()

    def build(self) -> None:
        """Builds the scene and its index now rather than on the first run."""
        self._core.build()

    def _with_seed(self, seed: Optional[int]) -> "Survey":
        return self if seed is None or seed == self.seed else self.replace({}, seed=seed)

    def run(
        self, threads: Optional[int] = None, seed: Optional[int] = None, progress: Progress = True
    ) -> "Result":
        """Simulates every pulse and returns the points in memory.

        ``threads``: cores to use (all by default). ``seed``: run with this
        seed instead. ``progress``: True for a progress bar, False for none,
        or a callable ``f(done, total)`` (in pulses)."""
        survey = self._with_seed(seed)
        callback, bar = _progress(progress, "simulating")
        try:
            raw = survey._core.run(_threads(threads), callback)
        finally:
            if bar is not None:
                bar.close()
        return Result(
            points=raw["points"].view(POINT_DTYPE),
            trajectory={
                "true": raw["trajectory_true"].view(TRAJECTORY_DTYPE),
                "observed": raw["trajectory_observed"].view(TRAJECTORY_DTYPE),
            },
            summary=raw["summary"],
            las_header=raw["las"],
        )

    def run_part(
        self,
        out_dir: PathLike,
        part: int,
        parts: int,
        threads: Optional[int] = None,
        overwrite: bool = False,
    ) -> Dict[str, Any]:
        """Simulates part ``part`` of ``parts`` (from 1) of the survey into
        ``out_dir``, as ``lidarsim run SURVEY --part K/N`` does, and returns
        the part's record (``part.json``). :func:`merge` joins the parts
        into the files one run writes; :mod:`lidarsim.distributed` runs
        them on a Dask cluster."""
        return self._core.run_part(
            os.fspath(out_dir), int(part), int(parts), _threads(threads), overwrite
        )

    def stream(
        self,
        block_points: int = 1_000_000,
        threads: Optional[int] = None,
        seed: Optional[int] = None,
        progress: Progress = True,
    ) -> Iterator[np.ndarray]:
        """Simulates every pulse and yields the points in blocks of at least
        ``block_points`` (the last may hold fewer), in the order of
        :meth:`run`'s ``points``: memory stays that of a few blocks however
        long the flight. The simulation runs ahead of the loop by at most
        two blocks. Leaving the loop early stops it; Ctrl-C raises
        ``KeyboardInterrupt``."""
        if block_points < 1:
            raise ValueError(f"block_points must be at least 1, got {block_points}")
        survey = self._with_seed(seed)
        callback, bar = _progress(progress, "simulating")
        stream = survey._core.stream(_threads(threads), int(block_points))
        try:
            for block in stream:
                if callback is not None:
                    callback(stream.pulses_done, stream.pulses_total)
                yield block.view(POINT_DTYPE)
            if callback is not None:
                callback(stream.pulses_total, stream.pulses_total)
        finally:
            stream.close()
            if bar is not None:
                bar.close()

    def waveform(self, line: int, pulse: int) -> "Waveform":
        """The full waveform of pulse ``pulse`` of flight line ``line``
        (both from 0), simulated on its own: the same pulse, to the bit, as
        in a run (every random number is keyed by the pulse)."""
        if line < 0 or pulse < 0:
            raise IndexError(f"line and pulse are numbered from 0, got {line}, {pulse}")
        return Waveform(self._core.waveform(int(line), int(pulse)))

    def run_to(
        self,
        out_dir: PathLike,
        threads: Optional[int] = None,
        seed: Optional[int] = None,
        progress: Progress = True,
        overwrite: bool = False,
        resume: bool = False,
        no_space_check: bool = False,
    ) -> Dict[str, Any]:
        """Writes the files of ``lidarsim run`` (points, trajectories,
        report, summary) into ``out_dir`` and returns the summary. Options
        as the command line's ``--overwrite``, ``--resume`` and
        ``--no-space-check``. Interrupted by Ctrl-C, the files are kept
        under ``.partial`` names with a record to resume, and
        ``KeyboardInterrupt`` is raised."""
        survey = self._with_seed(seed)
        callback, bar = _progress(progress, "simulating")
        try:
            return survey._core.run_to(
                os.fspath(out_dir), _threads(threads), callback, overwrite, resume, no_space_check
            )
        finally:
            if bar is not None:
                bar.close()


class Waveform:
    """One pulse's full waveform (:meth:`Survey.waveform`).

    ``time_ns``: two-way travel time of each sample; ``range_m``: the same
    as range; ``samples``: the received signal (amplitude units: sub-ray
    returns convolved with the emitted pulse, plus atmosphere and noise);
    ``background``: the atmosphere's expected part of it; ``threshold``:
    the detection threshold above the background. ``returns_range_m`` and
    ``returns_power``: the sub-ray returns the signal is made of (Eq. 2 per
    sub-ray). ``echo_range_m``, ``echo_amplitude`` (energy amplitude, the
    LAS intensity's), ``echo_peak_amplitude`` and ``echo_width_ns``: the
    echoes detected. ``points``: the points they give
    (:data:`POINT_DTYPE`). ``emitted``: False for a pulse slot in which a
    polygon scanner fires nothing.
    """

    def __init__(self, raw: Dict[str, Any]) -> None:
        self.emitted: bool = raw["emitted"]
        self.time_ns: np.ndarray = raw["time_ns"]
        self.range_m: np.ndarray = raw["range_m"]
        self.samples: np.ndarray = raw["samples"]
        self.background: np.ndarray = raw["background"]
        self.threshold: float = raw["threshold"]
        self.returns_range_m: np.ndarray = raw["returns_range_m"]
        self.returns_power: np.ndarray = raw["returns_power"]
        self.echo_range_m: np.ndarray = raw["echo_range_m"]
        self.echo_amplitude: np.ndarray = raw["echo_amplitude"]
        self.echo_peak_amplitude: np.ndarray = raw["echo_peak_amplitude"]
        self.echo_width_ns: np.ndarray = raw["echo_width_ns"]
        self.points: np.ndarray = raw["points"].view(POINT_DTYPE)

    def __repr__(self) -> str:
        return (
            f"<lidarsim.Waveform: {len(self.samples)} samples, "
            f"{len(self.returns_power)} sub-ray returns, {len(self.echo_range_m)} echoes>"
        )


class Result:
    """The outcome of :meth:`Survey.run`.

    ``points``: structured array of :data:`POINT_DTYPE`, in pulse order and
    return order within a pulse. ``trajectory``: ``{"true": ...,
    "observed": ...}`` arrays of :data:`TRAJECTORY_DTYPE` (the path flown
    and the one the GNSS/IMU measured). ``summary``: the run's
    ``summary.json`` as a dict. ``las_header``: the LAS file's scale,
    offset, CRS and which extra bytes it has.
    """

    def __init__(
        self,
        points: np.ndarray,
        trajectory: Dict[str, np.ndarray],
        summary: Dict[str, Any],
        las_header: Dict[str, Any],
    ) -> None:
        self.points = points
        self.trajectory = trajectory
        self.summary = summary
        self.las_header = las_header

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return f"<lidarsim.Result: {len(self.points)} points, {self.summary['pulses']} pulses>"

    @property
    def scan_angle_deg(self) -> np.ndarray:
        """The scan angle in degrees (``points["scan_angle"]`` is in the LAS
        field's units of 0.006°)."""
        return self.points["scan_angle"] * 0.006

    def to_laspy(self):
        """The points as a ``laspy.LasData`` (point format 6, LAS 1.4) with
        the LAS file's scale, offset and extra bytes: writing it gives the
        points of ``points.las``. Needs laspy; the CRS needs pyproj."""
        import laspy

        p = self.points
        h = self.las_header
        header = laspy.LasHeader(point_format=6, version="1.4")
        header.scales = np.array([h["scale"]] * 3)
        header.offsets = np.array(h["offset"])
        extra = []
        if h["extra_bytes"]:
            extra += [
                ("amplitude", np.float32),
                ("echo_width", np.float32),
                ("range", np.float32),
                ("incidence_angle", np.float32),
                ("object_id", np.uint32),
            ]
        if h["error_extra_bytes"]:
            extra += [("error_x", np.float32), ("error_y", np.float32), ("error_z", np.float32)]
        if extra:
            header.add_extra_dims([laspy.ExtraBytesParams(name=n, type=t) for n, t in extra])
        if h["crs_wkt"]:
            try:
                import pyproj

                header.add_crs(pyproj.CRS.from_wkt(h["crs_wkt"]))
            except ImportError:
                pass
        las = laspy.LasData(header)
        for axis, name in enumerate("XYZ"):
            stored = np.round((p[name.lower()] - h["offset"][axis]) / h["scale"])
            setattr(las, name, stored.astype(np.int32))
        for name in [
            "intensity",
            "return_number",
            "number_of_returns",
            "scan_direction_flag",
            "edge_of_flight_line",
            "scanner_channel",
            "classification",
            "user_data",
            "scan_angle",
            "point_source_id",
            "gps_time",
        ]:
            las[name] = p[name]
        for name, _ in extra:
            las[name] = p[name]
        return las


def merge(
    part_dirs: "list",
    out_dir: PathLike,
    threads: Optional[int] = None,
    overwrite: bool = False,
    take_parts: bool = False,
    survey: Optional[Survey] = None,
) -> Dict[str, Any]:
    """Merges the directories of the parts of one split run (in any order)
    into ``out_dir``: the files the unsplit run writes, byte for byte
    (``summary.json``'s timings apart); returns the summary. Refuses, with
    a :class:`PartError` naming it, a part missing, given twice, unfinished,
    changed, or of another survey, seed or number of parts. ``take_parts``:
    move the first part's LAS file into ``out_dir`` rather than copy it,
    and remove the parts' directories once merged. ``survey``: the survey
    the parts ran; when its world is built (``Survey.build``, or a run of
    it), the merge uses that world instead of reading and indexing the
    scene again. A survey other than the parts' is not used."""
    return _lidarsim.merge(
        [os.fspath(p) for p in part_dirs],
        os.fspath(out_dir),
        _threads(threads),
        overwrite,
        take_parts,
        survey._core if survey is not None else None,
    )


#: The options of :func:`twin` that replace what is read of the acquisition.
TWIN_ACQUISITION = (
    "altitude_m",
    "speed_mps",
    "prf_hz",
    "scan_frequency_hz",
    "scan_angle_deg",
    "heading_deg",
    "line_spacing_m",
)


def twin(
    path: PathLike,
    out_dir: PathLike,
    *,
    species: str = "pine",
    instrument: Optional[str] = None,
    window: Optional[tuple] = None,
    chm_cell_m: Optional[float] = None,
    overwrite: bool = False,
    verbose: bool = True,
    **acquisition: float,
) -> Survey:
    """The twin of the real airborne scan at ``path`` (LAS or LAZ), as
    ``lidarsim twin`` makes it: its ground, trees and acquisition read from
    the points, written into ``out_dir`` as ``survey.toml`` with the files it
    names (``trees.csv``, ``dtm.tif``) and ``twin.json``; returns the survey,
    with ``twin.json`` as its ``twin_report`` dict.

    ``species``: of every tree; ``instrument``: a scanner preset;
    ``window``: the tree tops' window diameter ``(a, b, c)`` as
    ``a + b·h + c·h²`` m; ``chm_cell_m``: the canopy height model's cell;
    the keyword arguments ``altitude_m``, ``speed_mps``, ``prf_hz``,
    ``scan_frequency_hz``, ``scan_angle_deg``, ``heading_deg`` and
    ``line_spacing_m`` replace what is read (``docs/validation.md``). A scan
    that cannot be twinned raises ``ValueError`` saying what is missing and
    which argument supplies it; ``verbose`` prints what was read."""
    unknown = sorted(set(acquisition) - set(TWIN_ACQUISITION))
    if unknown:
        raise TypeError(
            f"twin() got an unexpected keyword argument {unknown[0]!r}; "
            f"the acquisition's are {', '.join(TWIN_ACQUISITION)}"
        )
    raw = _lidarsim.twin(
        os.fspath(path),
        os.fspath(out_dir),
        overwrite,
        species,
        instrument,
        {k: float(v) for k, v in acquisition.items()},
        None if window is None else tuple(float(v) for v in window),
        None if chm_cell_m is None else float(chm_cell_m),
    )
    if verbose:
        for line in raw["summary"]:
            print(line)
    survey = Survey.load(raw["survey"])
    survey.twin_report = raw["report"]
    return survey


def _cloud(c: Any, name: str) -> Any:
    """A cloud for :func:`compare`: a path as it is, else a dict of the
    columns of a :class:`Result`, a structured array of
    :data:`POINT_DTYPE` or a ``laspy.LasData``."""
    if isinstance(c, (str, os.PathLike)):
        return os.fspath(c)
    if isinstance(c, Result):
        c = c.points
    if isinstance(c, np.ndarray) and c.dtype.names:
        angle = c["scan_angle"].astype(np.float32) * np.float32(0.006)
    elif hasattr(c, "points") and hasattr(c, "header"):  # laspy.LasData
        if hasattr(c, "scan_angle"):
            raw_angle = np.asarray(c.scan_angle, dtype=np.float32)
            extended = c.header.point_format.id >= 6
            angle = raw_angle * np.float32(0.006) if extended else raw_angle
        else:
            angle = np.asarray(c.scan_angle_rank, dtype=np.float32)
    else:
        raise TypeError(
            f"compare: {name} must be a path, a Result, a structured array of POINT_DTYPE or a "
            f"laspy.LasData, not {type(c).__name__}"
        )

    def col(field: str, dtype: Any) -> np.ndarray:
        values = c[field] if isinstance(c, np.ndarray) else getattr(c, field)
        return np.ascontiguousarray(np.asarray(values), dtype=dtype)

    return {
        "name": name,
        "x": col("x", np.float64),
        "y": col("y", np.float64),
        "z": col("z", np.float64),
        "intensity": col("intensity", np.uint16),
        "return_number": col("return_number", np.uint8),
        "number_of_returns": col("number_of_returns", np.uint8),
        "classification": col("classification", np.uint8),
        "gps_time": col("gps_time", np.float64),
        "scan_angle_deg": np.ascontiguousarray(angle, dtype=np.float32),
        "point_source_id": col("point_source_id", np.uint16),
    }


def compare(
    a: Any,
    b: Any,
    out_dir: Optional[PathLike] = None,
    *,
    cell_m: float = 20.0,
    area: Optional[tuple] = None,
    match_density: bool = False,
    seed: int = 1,
    labels: tuple = ("A", "B"),
    overwrite: bool = False,
) -> Dict[str, Any]:
    """The field's metrics of clouds ``a`` and ``b`` over their common area,
    as ``lidarsim compare`` gives them: ``a`` and ``b`` each a LAS/LAZ path,
    a :class:`Result` of :meth:`Survey.run`, a structured array of
    :data:`POINT_DTYPE` or a ``laspy.LasData``. Returns ``compare.json`` as
    a dict (``a`` and ``b`` with their ``metrics`` and ``distributions``,
    ``difference`` = b − a, ``cells`` with each metric's values per cell as
    NumPy arrays, NaN where a cell has none, and their paired statistics)
    plus ``table``, the text table; with ``out_dir`` it also writes
    ``compare.json`` and ``compare.html`` there. ``area``: ``(xmin, ymin,
    xmax, ymax)``; ``match_density``: thin the cloud of more pulses per m²
    to the other's first, by pulse."""
    out = _lidarsim.compare(
        _cloud(a, labels[0]),
        _cloud(b, labels[1]),
        None if out_dir is None else os.fspath(out_dir),
        overwrite,
        float(cell_m),
        None if area is None else tuple(float(v) for v in area),
        bool(match_density),
        int(seed),
        (str(labels[0]), str(labels[1])),
    )
    for m in out["cells"]["metrics"]:
        for side in ("a", "b"):
            m[side] = np.array([np.nan if v is None else v for v in m[side]], dtype=np.float64)
    return out
