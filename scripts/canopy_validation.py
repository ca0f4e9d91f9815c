#!/usr/bin/env python3
"""Canopy-radiometry validation study for a lidarsim binary.

A study script, not a test: it writes survey files, runs one lidarsim binary
on each (one subprocess per run, with a timeout), reads `points.ply` with
numpy and prints the figures as `key value` lines (optionally also to a JSON
file), so that two builds of the simulator can be compared figure by figure.

Studies (select with --studies, default all):

1. Return statistics against flying height. 200 explicit `[[tree]]` entries
   (Scots pine and Norway spruce, half each, 15-25 m, crown base 50 % of the
   height, dbh 0.25 m, explicit crown radii scaled to a crown projection
   cover of 0.76) placed by a seeded generator in a 100 m x 100 m square
   with at least 3 m between stems, over a `ground` polygon (+-150 m,
   reflectance 0.25). One line along y from -60 to 60 m at 60 m/s, flown at
   500, 1000 and 2000 m above ground with one scanner (100 kHz, 50 Hz,
   +-15 deg, 0.3 mrad, 19 sub-rays, 5 returns), with a realistic receiver
   (noise 0.005, 4 sigma) and a low-threshold one (no noise, min amplitude
   1e-4); plus PRF 25 kHz and 400 kHz at 500 m (noise on) for the
   tree-height bias against point density.
2. Ground energy against optical depth. One pine with `uniform_density`,
   beam 0.2 m from the stem inside the flat crown top, so a vertical path
   crosses the whole crown (L = height - crown base); extinction chosen for
   tau = k rho L = 0.5, 1, 2, 3; ground energy per pulse relative to a run
   without the tree, against exp(-tau); at tau = 3, foliage energy per pulse
   for (rho = 1, k = tau/L) and (rho = 0.1, k = 10 tau/L).
3. Echo amplitude against range for a 3 cm x 3 cm plate 10 m above ground
   and for an extended plane, profiler at 500, 707, 1000, 1414, 2000 m;
   fitted exponent n of amplitude ~ R^-n for the plane, for the plate's
   echoes (mean over the pulses that saw it) and for the plate's energy per
   pulse over the pulses whose axis passes within a footprint diameter
   (`plate_window`, R^-4 for a Gaussian beam: `plate_window_expected`).

Keys: `s1.h<height>.<noise|low>.*`, `s1.density.prf<prf>.*`, `s2.tau<tau>.*`
(`.rho0.1` for the second split), `s3.<plate|plane>.h<height>.*`; every run
also gives `<key>.time_s`, its wall-clock time, and each study `s<n>.time_s`.

Only numpy is needed. Example:

    target/pyenv/bin/python scripts/canopy_validation.py \\
        --bin /tmp/lidarsim-cur --json target/validation-cur.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

# ---------------------------------------------------------------------------
# Constants of the study

STAND_HALF = 50.0  # the stand is the square [-50, 50] m x [-50, 50] m
STAND_SHRINK = 5.0  # statistics over the square shrunk by this much
N_TREES = 200
MIN_STEM_SPACING = 3.0
TARGET_COVER = 0.76
HEIGHTS_S1 = (500, 1000, 2000)
DENSITY_PRFS = (25_000, 400_000)  # extra PRFs at 500 m, noise on
TAUS = (0.5, 1.0, 2.0, 3.0)
HEIGHTS_S3 = (500, 707, 1000, 1414, 2000)
PLATE_SIDE = 0.03
PLATE_Z = 10.0
PLATE_REFLECTANCE = 0.5
DIVERGENCE_MRAD = 0.3

ASPRS_GROUND = 2
ASPRS_BUILDING = 6
ASPRS_NOISE = 7
COMPONENT_FOLIAGE = 1
COMPONENT_TRUNK = 2


class StudyError(RuntimeError):
    """A run failed or its output could not be read."""


# ---------------------------------------------------------------------------
# Output: key value lines, collected for the JSON


class Figures:
    def __init__(self) -> None:
        self.values: dict[str, object] = {}

    def put(self, key: str, value) -> None:
        if isinstance(value, (np.floating, float)):
            value = float(value)
            text = "nan" if math.isnan(value) else f"{value:.6g}"
            self.values[key] = None if math.isnan(value) else value
        elif isinstance(value, (np.integer, int)):
            value = int(value)
            text = str(value)
            self.values[key] = value
        else:
            text = str(value)
            self.values[key] = value
        print(f"{key} {text}", flush=True)


# ---------------------------------------------------------------------------
# PLY reader (binary little-endian, any property order the header declares)

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "<i2", "int16": "<i2", "ushort": "<u2", "uint16": "<u2",
    "int": "<i4", "int32": "<i4", "uint": "<u4", "uint32": "<u4",
    "float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8",
}
PLY_NEEDED = ("x", "y", "z", "gps_time", "return_number", "number_of_returns",
              "classification", "component", "amplitude", "range", "object_id")


def read_ply(path: str) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise StudyError(f"{path}: not a PLY file (no 'ply' magic or no end_header)")
    header = data[:end].decode("ascii", "replace").splitlines()
    offset = end + len(b"end_header\n")
    count = None
    fields = []
    in_vertex = False
    for line in header:
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "format" and parts[1] != "binary_little_endian":
            raise StudyError(f"{path}: format {parts[1]}, expected binary_little_endian")
        if parts[0] == "element":
            in_vertex = parts[1] == "vertex"
            if in_vertex:
                count = int(parts[2])
        elif parts[0] == "property" and in_vertex:
            if parts[1] == "list":
                raise StudyError(f"{path}: list properties are not supported")
            fields.append((parts[2], PLY_TYPES[parts[1]]))
    if count is None:
        raise StudyError(f"{path}: no 'element vertex N' line")
    dtype = np.dtype(fields)
    missing = [n for n in PLY_NEEDED if n not in dtype.names]
    if missing:
        raise StudyError(f"{path}: missing properties {missing}")
    if len(data) - offset < count * dtype.itemsize:
        raise StudyError(f"{path}: {count} vertices of {dtype.itemsize} bytes declared, "
                         f"only {len(data) - offset} bytes of data")
    return np.frombuffer(data, dtype=dtype, count=count, offset=offset).copy()


# ---------------------------------------------------------------------------
# Running the binary


class Runner:
    def __init__(self, binary: str, work: str, timeout: float, threads: int | None,
                 keep: bool) -> None:
        self.binary = binary
        self.work = work
        self.timeout = timeout
        self.threads = threads
        self.keep = keep
        self.timings: dict[str, float] = {}

    def run(self, name: str, survey: str) -> dict:
        """Write SURVEY as WORK/NAME/survey.toml, run it into a fresh
        WORK/NAME/out, read points.ply and summary.json; return both and the
        wall-clock time."""
        rdir = os.path.join(self.work, name)
        if os.path.exists(rdir):
            shutil.rmtree(rdir)
        os.makedirs(rdir)
        spath = os.path.join(rdir, "survey.toml")
        with open(spath, "w") as f:
            f.write(survey)
        out = os.path.join(rdir, "out")
        cmd = [self.binary, "run", spath, "-o", out]
        if self.threads:
            cmd += ["--threads", str(self.threads)]
        t0 = time.monotonic()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=self.timeout)
        except subprocess.TimeoutExpired as e:
            err = e.stderr.decode("utf-8", "replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
            raise StudyError(f"run {name}: timed out after {self.timeout:g} s: {' '.join(cmd)}\n"
                             f"--- stderr ---\n{err}") from None
        except OSError as e:
            raise StudyError(f"run {name}: cannot start {self.binary}: {e}") from None
        wall = time.monotonic() - t0
        if proc.returncode != 0:
            raise StudyError(f"run {name}: exit status {proc.returncode}: {' '.join(cmd)}\n"
                             f"--- stderr ---\n{proc.stderr}\n--- stdout ---\n{proc.stdout[-2000:]}")
        try:
            with open(os.path.join(out, "summary.json")) as f:
                summary = json.load(f)
            points = read_ply(os.path.join(out, "points.ply"))
        except (OSError, ValueError) as e:
            raise StudyError(f"run {name}: cannot read its output in {out}: {e}") from None
        if not summary.get("complete", False):
            raise StudyError(f"run {name}: summary.json says the run is not complete")
        if len(points) != summary.get("points", len(points)):
            raise StudyError(f"run {name}: points.ply holds {len(points)} points, "
                             f"summary.json says {summary.get('points')}")
        if not self.keep:
            shutil.rmtree(out, ignore_errors=True)
        self.timings[name] = wall
        print(f"# run {name}: {summary.get('pulses')} pulses, {len(points)} points, "
              f"{wall:.1f} s", file=sys.stderr, flush=True)
        return {"points": points, "summary": summary, "wall_s": wall}


# ---------------------------------------------------------------------------
# Survey text


def fmt(v: float) -> str:
    return repr(float(v))


def vec(v) -> str:
    return "[" + ", ".join(fmt(x) for x in v) + "]"


def square_polygon(material: str, cls: str, half: float, z: float, cx=0.0, cy=0.0) -> str:
    corners = [[cx - half, cy - half, z], [cx + half, cy - half, z],
               [cx + half, cy + half, z], [cx - half, cy + half, z]]
    return (f'[[polygon]]\nmaterial = "{material}"\nclass = "{cls}"\n'
            f"vertices_m = [{', '.join(vec(c) for c in corners)}]\n")


def survey_text(*, scanner: dict, receiver: dict, line: tuple, speed: float,
                scene: str, seed: int = 1) -> str:
    s = [f"seed = {seed}\n", "[scanner]\n"]
    s += [f"{k} = {v}\n" for k, v in scanner.items()]
    s += ["\n[receiver]\n"]
    s += [f"{k} = {v}\n" for k, v in receiver.items()]
    s += ['\n[output]\nformats = ["ply"]\ntrajectory_interval_s = 0.01\n',
          f"\n[[flight_line]]\nstart_m = {vec(line[0])}\nend_m = {vec(line[1])}\n"
          f"speed_mps = {fmt(speed)}\n\n", scene]
    return "".join(s)


RECEIVER_NOISE = {"noise": 0.005, "threshold_sigma": 4}
RECEIVER_LOW = {"noise": 0, "min_amplitude": 1e-4}


# ---------------------------------------------------------------------------
# Study 1: return statistics against flying height


def make_stand(seed: int = 2023) -> dict:
    rng = np.random.default_rng(seed)
    pos: list[tuple[float, float]] = []
    draws = 0
    while len(pos) < N_TREES:
        draws += 1
        if draws > 1_000_000:
            raise StudyError("could not place the stand")
        x, y = rng.uniform(-STAND_HALF, STAND_HALF, 2)
        if all((x - a) ** 2 + (y - b) ** 2 >= MIN_STEM_SPACING ** 2 for a, b in pos):
            pos.append((round(float(x), 3), round(float(y), 3)))
    xy = np.array(pos)
    species = np.array(["pine"] * (N_TREES // 2) + ["spruce"] * (N_TREES - N_TREES // 2))
    rng.shuffle(species)
    height = np.round(rng.uniform(15.0, 25.0, N_TREES), 2)
    base = np.round(0.5 * height, 2)
    # Radii drawn in 1.8-3.2 m, then scaled together so that the crown
    # projection cover sum(pi r^2) / area is TARGET_COVER (1.8-3.2 m alone
    # gives about 0.40 for 200 trees on a hectare).
    r = rng.uniform(1.8, 3.2, N_TREES)
    area = (2 * STAND_HALF) ** 2
    r *= math.sqrt(TARGET_COVER * area / (math.pi * np.sum(r ** 2)))
    r = np.round(r, 3)
    return {"xy": xy, "species": species, "height": height, "base": base, "radius": r,
            "dbh": np.full(N_TREES, 0.25), "area": area}


def stand_scene(stand: dict) -> str:
    s = ["[materials.ground]\nreflectance = 0.25\n\n",
         square_polygon("ground", "ground", 150.0, 0.0), "\n"]
    for i in range(N_TREES):
        x, y = stand["xy"][i]
        s.append(f'[[tree]]\nposition_m = {vec([x, y, 0.0])}\nspecies = "{stand["species"][i]}"\n'
                 f"dbh_m = {fmt(stand['dbh'][i])}\nheight_m = {fmt(stand['height'][i])}\n"
                 f"crown_base_m = {fmt(stand['base'][i])}\ncrown_radius_m = {fmt(stand['radius'][i])}\n\n")
    return "".join(s)


def s1_survey(stand_scene_text: str, height: float, prf: float, receiver: dict) -> str:
    scanner = {"prf_hz": prf, "scan_frequency_hz": 50, "scan_angle_deg": 15,
               "divergence_mrad": DIVERGENCE_MRAD, "subrays": 19, "max_returns": 5}
    return survey_text(scanner=scanner, receiver=receiver,
                       line=([0.0, -60.0, height], [0.0, 60.0, height]), speed=60.0,
                       scene=stand_scene_text)


def object_id_check(p: np.ndarray, stand: dict, n_polygons: int) -> float:
    """Share of vegetation points whose object id - n_polygons names a tree
    whose crown (radius + 1 m) holds the point horizontally."""
    veg = (p["component"] == COMPONENT_FOLIAGE) | (p["component"] == COMPONENT_TRUNK)
    if not np.any(veg):
        return float("nan")
    idx = p["object_id"][veg].astype(np.int64) - n_polygons
    ok = (idx >= 0) & (idx < N_TREES)
    good = np.zeros(len(idx), bool)
    ii = idx[ok]
    d = np.hypot(p["x"][veg][ok] - stand["xy"][ii, 0], p["y"][veg][ok] - stand["xy"][ii, 1])
    good[ok] = d <= stand["radius"][ii] + 1.0
    return float(np.mean(good))


def s1_analyse(fig: Figures, key: str, run: dict, stand: dict, full: bool) -> dict:
    p = run["points"]
    pulses = run["summary"]["pulses"]
    lim = STAND_HALF - STAND_SHRINK
    inside = (np.abs(p["x"]) <= lim) & (np.abs(p["y"]) <= lim)
    inner_area = (2 * lim) ** 2
    first = p["return_number"] == 1
    fi = first & inside
    res = {}
    n_first = int(np.sum(fi))
    fig.put(f"{key}.pulses", pulses)
    fig.put(f"{key}.points", len(p))
    fig.put(f"{key}.first_returns_in_stand", n_first)
    density = n_first / inner_area
    fig.put(f"{key}.first_return_density_per_m2", density)
    res["density"] = density
    if full:
        cover = np.sum(p["z"][fi] > 2.0) / max(n_first, 1)
        fig.put(f"{key}.first_return_cover", cover)
        nr = p["number_of_returns"][fi]
        for lab, m in (("1", nr == 1), ("2", nr == 2), ("3", nr == 3), ("4plus", nr >= 4)):
            fig.put(f"{key}.pulses_with_returns_{lab}", np.sum(m) / max(n_first, 1))
        fig.put(f"{key}.mean_returns_per_pulse", float(np.mean(nr)) if n_first else float("nan"))
        fig.put(f"{key}.noise_points_in_stand", int(np.sum(inside & (p["classification"] == ASPRS_NOISE))))
        # Trees that give a point: geometric rule, and object ids.
        veg = (p["component"] == COMPONENT_FOLIAGE) | (p["component"] == COMPONENT_TRUNK)
        vx, vy = p["x"][veg], p["y"][veg]
        hit = np.zeros(N_TREES, bool)
        for i in range(N_TREES):
            tx, ty = stand["xy"][i]
            r = stand["radius"][i]
            near = (np.abs(vx - tx) <= r) & (np.abs(vy - ty) <= r)
            if np.any(near):
                hit[i] = np.any(np.hypot(vx[near] - tx, vy[near] - ty) <= r)
        fig.put(f"{key}.trees_detected_share", float(np.mean(hit)))
        ids = np.unique(p["object_id"][veg].astype(np.int64)) - 1  # polygon 0 is the ground
        ids = ids[(ids >= 0) & (ids < N_TREES)]
        fig.put(f"{key}.trees_detected_share_by_object_id", len(ids) / N_TREES)
        fig.put(f"{key}.object_id_consistency", object_id_check(p, stand, 1))
        fig.put(f"{key}.ground_class_above_0p5m",
                int(np.sum(inside & (p["classification"] == ASPRS_GROUND) & (p["z"] > 0.5))))
    # Tree height bias: highest non-noise point within 1 m of the stem.
    ok = p["classification"] != ASPRS_NOISE
    px, py, pz = p["x"][ok], p["y"][ok], p["z"][ok]
    bias = []
    for i in range(N_TREES):
        tx, ty = stand["xy"][i]
        near = (np.abs(px - tx) <= 1.0) & (np.abs(py - ty) <= 1.0)
        if not np.any(near):
            continue
        nz = pz[near][np.hypot(px[near] - tx, py[near] - ty) <= 1.0]
        if len(nz):
            bias.append(float(np.max(nz)) - stand["height"][i])
    b = np.array(bias)
    fig.put(f"{key}.height_bias_mean_m", float(np.mean(b)) if len(b) else float("nan"))
    fig.put(f"{key}.height_bias_median_m", float(np.median(b)) if len(b) else float("nan"))
    fig.put(f"{key}.height_bias_trees", len(b))
    fig.put(f"{key}.time_s", run["wall_s"])
    res["bias"] = float(np.mean(b)) if len(b) else float("nan")
    return res


def study1(fig: Figures, runner: Runner) -> None:
    stand = make_stand()
    cover = float(np.sum(math.pi * stand["radius"] ** 2) / stand["area"])
    fig.put("s1.trees", N_TREES)
    fig.put("s1.trees_pine", int(np.sum(stand["species"] == "pine")))
    fig.put("s1.crown_projection_cover", cover)
    fig.put("s1.crown_radius_min_m", float(stand["radius"].min()))
    fig.put("s1.crown_radius_max_m", float(stand["radius"].max()))
    d = np.hypot(*(stand["xy"][:, None, :] - stand["xy"][None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    fig.put("s1.min_stem_distance_m", float(d.min()))
    scene = stand_scene(stand)
    t0 = time.monotonic()
    for h in HEIGHTS_S1:
        for rname, rec in (("noise", RECEIVER_NOISE), ("low", RECEIVER_LOW)):
            key = f"s1.h{h}.{rname}"
            run = runner.run(f"s1-h{h}-{rname}", s1_survey(scene, h, 100_000, rec))
            s1_analyse(fig, key, run, stand, full=True)
    for prf in DENSITY_PRFS:
        key = f"s1.density.prf{prf}"
        run = runner.run(f"s1-prf{prf}", s1_survey(scene, 500, prf, RECEIVER_NOISE))
        s1_analyse(fig, key, run, stand, full=False)
    fig.put("s1.time_s", time.monotonic() - t0)


# ---------------------------------------------------------------------------
# Study 2: ground energy against optical depth

S2_HEIGHT = 20.0
S2_BASE = 10.0
S2_RADIUS = 4.0
S2_FLAT_TOP = 0.10  # pine: a = 0.1 (a + b), docs/trees.md
S2_OFFSET = 0.2  # beam this far from the stem axis (< a = 0.4 m)
S2_ALT = 100.0
S2_PRF = 20_000
S2_SPEED = 0.1  # a 0.1 m line flown in 1 s: S2_PRF pulses
S2_MAX_RETURNS = 15  # so that a crown of echoes never pushes the ground echo out
S2_FOLIAGE_REFLECTANCE = 0.42  # pine preset


def s2_survey(tree: dict | None) -> str:
    scanner = {"prf_hz": S2_PRF, "scan_frequency_hz": 50, "scan_angle_deg": 0,
               "divergence_mrad": DIVERGENCE_MRAD, "subrays": 19,
               "max_returns": S2_MAX_RETURNS}
    receiver = {"noise": 0, "min_amplitude": 1e-5}
    scene = ["[materials.ground]\nreflectance = 0.25\n\n",
             square_polygon("ground", "ground", 30.0, 0.0), "\n"]
    if tree is not None:
        scene.append(f'[[tree]]\nposition_m = [0.0, 0.0, 0.0]\nspecies = "pine"\ndbh_m = 0.02\n'
                     f"height_m = {fmt(S2_HEIGHT)}\ncrown_base_m = {fmt(S2_BASE)}\n"
                     f"crown_radius_m = {fmt(S2_RADIUS)}\n"
                     f"uniform_density = {fmt(tree['rho'])}\n"
                     f"extinction_per_m = {fmt(tree['k'])}\n")
    half = S2_SPEED * 1.0 / 2  # a line flown in 1 s: S2_PRF pulses
    return survey_text(scanner=scanner, receiver=receiver,
                       line=([S2_OFFSET, -half, S2_ALT], [S2_OFFSET, half, S2_ALT]),
                       speed=S2_SPEED, scene="".join(scene))


def s2_expected_foliage(rho: float, k: float, beta: float, model: str) -> float:
    """Foliage energy per pulse a continuous Beer-Lambert crown would give
    on the vertical path (range S2_ALT - S2_HEIGHT at the top): the
    interception density k rho exp(-k rho s) times what an intercepted
    sub-ray returns there, (Rn/R)^2 refl x 2/3 ("physical") or
    (Rn/R)^2 refl rho exp(-beta k rho s) ("specification", beta the partial
    blocking)."""
    L = S2_HEIGHT - S2_BASE
    s = np.linspace(0.0, L, 20001)
    R = S2_ALT - S2_HEIGHT + s
    mu = k * rho
    dens = mu * np.exp(-mu * s) * (1000.0 / R) ** 2 * S2_FOLIAGE_REFLECTANCE
    if model == "physical":
        f = dens * 2.0 / 3.0
    else:
        f = dens * rho * np.exp(-beta * mu * s)
    return float(np.sum((f[1:] + f[:-1]) / 2 * np.diff(s)))


def s2_energies(run: dict) -> dict:
    p = run["points"]
    pulses = run["summary"]["pulses"]
    first = p["return_number"] == 1
    return {
        "ground": float(np.sum(p["amplitude"][p["classification"] == ASPRS_GROUND]) / pulses),
        "foliage": float(np.sum(p["amplitude"][p["component"] == COMPONENT_FOLIAGE]) / pulses),
        "trunk_points": int(np.sum(p["component"] == COMPONENT_TRUNK)),
        "ground_pulses": len(np.unique(p["gps_time"][p["classification"] == ASPRS_GROUND])) / pulses,
        "capped": float(np.mean(p["number_of_returns"][first] >= S2_MAX_RETURNS)) if np.any(first) else 0.0,
        "pulses": pulses,
    }


def study2(fig: Figures, runner: Runner) -> None:
    t0 = time.monotonic()
    L = S2_HEIGHT - S2_BASE
    fig.put("s2.crown_length_m", L)
    fig.put("s2.flat_top_radius_m", S2_FLAT_TOP * S2_RADIUS)
    fig.put("s2.beam_offset_m", S2_OFFSET)
    ref = runner.run("s2-notree", s2_survey(None))
    e0 = s2_energies(ref)
    fig.put("s2.notree.pulses", e0["pulses"])
    fig.put("s2.notree.ground_energy", e0["ground"])
    fig.put("s2.notree.time_s", ref["wall_s"])
    cases = [(tau, 1.0, tau / L) for tau in TAUS] + [(3.0, 0.1, 10 * 3.0 / L)]
    foliage = {}
    for tau, rho, k in cases:
        key = f"s2.tau{tau:g}" + ("" if rho == 1.0 else f".rho{rho:g}")
        run = runner.run(f"s2-tau{tau:g}-rho{rho:g}", s2_survey({"rho": rho, "k": k}))
        e = s2_energies(run)
        fig.put(f"{key}.rho", rho)
        fig.put(f"{key}.k_per_m", k)
        fig.put(f"{key}.ground_energy", e["ground"])
        fig.put(f"{key}.ground_ratio", e["ground"] / e0["ground"])
        fig.put(f"{key}.exp_minus_tau", math.exp(-tau))
        fig.put(f"{key}.share_of_pulses_with_ground_echo", e["ground_pulses"])
        fig.put(f"{key}.foliage_energy", e["foliage"])
        fig.put(f"{key}.foliage_energy_expected_physical",
                s2_expected_foliage(rho, k, 0.0, "physical"))
        fig.put(f"{key}.foliage_energy_expected_specification",
                s2_expected_foliage(rho, k, 0.5, "specification"))
        fig.put(f"{key}.exp_minus_1p5tau", math.exp(-1.5 * tau))
        fig.put(f"{key}.pulses_at_max_returns", e["capped"])
        fig.put(f"{key}.trunk_points", e["trunk_points"])
        fig.put(f"{key}.time_s", run["wall_s"])
        if tau == 3.0:
            foliage[rho] = e["foliage"]
    fig.put("s2.tau3.foliage_energy_rho1", foliage[1.0])
    fig.put("s2.tau3.foliage_energy_rho0.1", foliage[0.1])
    fig.put("s2.tau3.foliage_ratio_rho1_over_rho0.1",
            foliage[1.0] / foliage[0.1] if foliage[0.1] > 0 else float("nan"))
    fig.put("s2.time_s", time.monotonic() - t0)


# ---------------------------------------------------------------------------
# Study 3: echo amplitude against range

S3_PRF = 20_000
S3_SPEED = 1.0
S3_HALF_LINE = 1.0  # a 2 m line centred on the plate: 40 000 pulses


def s3_survey(height: float, plate: bool) -> str:
    scanner = {"prf_hz": S3_PRF, "scan_frequency_hz": 50, "scan_angle_deg": 0,
               "divergence_mrad": DIVERGENCE_MRAD, "subrays": 19, "max_returns": 5}
    receiver = {"noise": 0, "min_amplitude": 1e-6}
    scene = ["[materials.ground]\nreflectance = 0.25\n\n"]
    if plate:
        scene.append(f"[materials.plate]\nreflectance = {PLATE_REFLECTANCE}\n\n")
        scene.append(square_polygon("plate", "building", PLATE_SIDE / 2, PLATE_Z) + "\n")
    scene.append(square_polygon("ground", "ground", 20.0, 0.0))
    return survey_text(scanner=scanner, receiver=receiver,
                       line=([0.0, -S3_HALF_LINE, height], [0.0, S3_HALF_LINE, height]),
                       speed=S3_SPEED, scene="".join(scene))


def fit_exponent(r, a) -> float:
    r, a = np.asarray(r, float), np.asarray(a, float)
    ok = (r > 0) & (a > 0) & np.isfinite(a)
    if np.sum(ok) < 2:
        return float("nan")
    slope = np.polyfit(np.log(r[ok]), np.log(a[ok]), 1)[0]
    return float(-slope)


def study3(fig: Figures, runner: Runner) -> None:
    t0 = time.monotonic()
    res = {"plate": {}, "plate_window": {}, "plate_window_expected": {}, "plane": {}}
    for h in HEIGHTS_S3:
        # Plate.
        run = runner.run(f"s3-plate-h{h}", s3_survey(h, True))
        p = run["points"]
        pulses = run["summary"]["pulses"]
        m = p["classification"] == ASPRS_BUILDING
        key = f"s3.plate.h{h}"
        times = p["gps_time"][m]
        detected = len(np.unique(times))
        per_pulse = np.sum(p["amplitude"][m]) / detected if detected else float("nan")
        rng_m = float(np.mean(p["range"][m])) if detected else h - PLATE_Z
        # Mean over the pulses whose beam axis passes within one footprint
        # diameter (2 w, w the 1/e^2 radius) of the plate centre: for a small
        # target the physics gives R^-4 for this mean.
        window_half = (h - PLATE_Z) * DIVERGENCE_MRAD * 1e-3
        k = np.arange(pulses)
        y_axis = -S3_HALF_LINE + k / S3_PRF * S3_SPEED
        n_window = int(np.sum(np.abs(y_axis) <= window_half))
        window_mean = np.sum(p["amplitude"][m]) / n_window
        # What a Gaussian beam (1/e^2 radius w = R div / 2) puts on the
        # plate, summed over the pass: (prf / v) A sqrt(2/pi) / w of the
        # pulse energy, times refl (Rn/R)^2; over the window's pulses.
        w = (h - PLATE_Z) * DIVERGENCE_MRAD * 1e-3 / 2
        total_phys = (S3_PRF / S3_SPEED) * PLATE_SIDE ** 2 * math.sqrt(2 / math.pi) / w \
            * PLATE_REFLECTANCE * (1000.0 / (h - PLATE_Z)) ** 2
        fig.put(f"{key}.range_m", rng_m)
        fig.put(f"{key}.pulses_detected", detected)
        fig.put(f"{key}.echoes", int(np.sum(m)))
        fig.put(f"{key}.mean_amplitude_detected", per_pulse)
        fig.put(f"{key}.max_amplitude", float(np.max(p["amplitude"][m])) if detected else float("nan"))
        fig.put(f"{key}.window_pulses", n_window)
        fig.put(f"{key}.mean_amplitude_window", window_mean)
        fig.put(f"{key}.mean_amplitude_window_expected", total_phys / n_window)
        fig.put(f"{key}.energy_over_pass", float(np.sum(p["amplitude"][m])))
        fig.put(f"{key}.energy_over_pass_expected", total_phys)
        fig.put(f"{key}.time_s", run["wall_s"])
        res["plate"][h] = (rng_m, per_pulse)
        res["plate_window"][h] = (rng_m, window_mean)
        res["plate_window_expected"][h] = (h - PLATE_Z, total_phys / n_window)
        # Plane.
        run = runner.run(f"s3-plane-h{h}", s3_survey(h, False))
        p = run["points"]
        g = p["classification"] == ASPRS_GROUND
        key = f"s3.plane.h{h}"
        amp = float(np.mean(p["amplitude"][g])) if np.any(g) else float("nan")
        rng_m = float(np.mean(p["range"][g])) if np.any(g) else float(h)
        fig.put(f"{key}.range_m", rng_m)
        fig.put(f"{key}.mean_amplitude", amp)
        fig.put(f"{key}.expected_amplitude", 0.25 * (1000.0 / h) ** 2)
        fig.put(f"{key}.time_s", run["wall_s"])
        res["plane"][h] = (rng_m, amp)
    for name, data in res.items():
        near = [data[h] for h in HEIGHTS_S3 if h <= 1000]
        alls = [data[h] for h in HEIGHTS_S3]
        fig.put(f"s3.{name}.n_500_1000", fit_exponent(*zip(*near)))
        fig.put(f"s3.{name}.n_all", fit_exponent(*zip(*alls)))
    fig.put("s3.time_s", time.monotonic() - t0)


# ---------------------------------------------------------------------------


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", required=True, help="lidarsim binary to study")
    ap.add_argument("--work", help="work directory (default: a new temporary directory, removed after)")
    ap.add_argument("--json", help="also write the figures to this JSON file")
    ap.add_argument("--studies", default="1,2,3", help="which studies to run (default 1,2,3)")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds allowed per run (default 600)")
    ap.add_argument("--threads", type=int, help="--threads for each run (default: the binary's, all cores)")
    ap.add_argument("--keep", action="store_true", help="keep every run's output directory")
    args = ap.parse_args()

    binary = os.path.abspath(args.bin)
    if not (os.path.isfile(binary) and os.access(binary, os.X_OK)):
        print(f"error: {args.bin} is not an executable file", file=sys.stderr)
        return 2
    studies = {s.strip() for s in args.studies.split(",") if s.strip()}
    if not studies <= {"1", "2", "3"}:
        print(f"error: --studies takes 1, 2 and 3, got {args.studies}", file=sys.stderr)
        return 2
    temp = args.work is None
    work = tempfile.mkdtemp(prefix="canopy-validation-") if temp else os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    runner = Runner(binary, work, args.timeout, args.threads, args.keep)
    fig = Figures()
    fig.put("binary", binary)
    try:
        version = subprocess.run([binary, "--version"], capture_output=True, text=True,
                                 timeout=30).stdout.strip().splitlines()[0]
    except (OSError, subprocess.TimeoutExpired, IndexError):
        version = "unknown"
    fig.put("version", version)
    t0 = time.monotonic()
    status = 0
    try:
        if "1" in studies:
            study1(fig, runner)
        if "2" in studies:
            study2(fig, runner)
        if "3" in studies:
            study3(fig, runner)
    except StudyError as e:
        print(f"error: {e}", file=sys.stderr)
        status = 1
    fig.put("total_time_s", time.monotonic() - t0)
    if args.json:
        doc = {"figures": fig.values,
               "run_wall_s": {k: round(v, 3) for k, v in runner.timings.items()},
               "complete": status == 0}
        with open(args.json, "w") as f:
            json.dump(doc, f, indent=1, sort_keys=False)
            f.write("\n")
    if temp and not args.keep and status == 0:
        shutil.rmtree(work, ignore_errors=True)
    elif status != 0:
        print(f"work directory kept for inspection: {work}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
