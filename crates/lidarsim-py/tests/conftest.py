"""Shared fixtures of the Python package's tests: the repository's paths,
the command-line binary (LIDARSIM_BIN, else target/release/lidarsim) and a
small survey with a mesh file beside it."""

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples"

# One 200 m line at 100 kHz over a field with the example house (OBJ,
# found relative to the survey): 333 334 pulses.
SMALL = """
seed = 11
[scanner]
prf_hz = 100000
scan_frequency_hz = 50
scan_angle_deg = 20
[receiver]
noise = 0.01
[[flight_line]]
start_m = [0.0, -100.0, 400.0]
end_m = [0.0, 100.0, 400.0]
speed_mps = 60.0
[output]
formats = ["las"]
[materials.grass]
reflectance = 0.3
[[polygon]]
material = "grass"
class = "ground"
vertices_m = [[-300, -300, 0], [300, -300, 0], [300, 300, 0], [-300, 300, 0]]
[[mesh]]
file = "house.obj"
class = "building"
"""


@pytest.fixture
def small_dir(tmp_path: Path) -> Path:
    """A directory holding `small.toml` and the house it names."""
    for name in ["house.obj", "house.mtl"]:
        shutil.copy(EXAMPLES / name, tmp_path / name)
    (tmp_path / "small.toml").write_text(SMALL)
    return tmp_path


@pytest.fixture
def lidarsim_bin() -> Path:
    path = Path(os.environ.get("LIDARSIM_BIN", ROOT / "target" / "release" / "lidarsim"))
    if not path.exists():
        pytest.fail(f"the lidarsim binary is not at {path}: build it (cargo build --release)")
    return path
