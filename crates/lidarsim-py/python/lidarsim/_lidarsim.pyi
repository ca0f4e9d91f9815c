"""Type stubs of the compiled half of lidarsim (use the `lidarsim` API)."""

from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

import numpy as np

VERSION: str
POINT_FIELDS: List[Tuple[str, str]]
POINT_RECORD_BYTES: int
TRAJECTORY_FIELDS: List[Tuple[str, str]]

class SurveyError(ValueError):
    diagnostics: List[Dict[str, Any]]

class InputError(OSError):
    path: str

class OutputError(OSError):
    path: str

class PartError(OSError):
    path: str

class ResumeError(OSError):
    path: str

class BudgetError(OSError):
    path: str

def merge(
    part_dirs: List[str],
    out_dir: str,
    threads: int,
    overwrite: bool = False,
    take_parts: bool = False,
    survey: Optional["SurveyCore"] = None,
) -> Dict[str, Any]: ...

def twin(
    path: str,
    out_dir: str,
    overwrite: bool = False,
    species: str = "pine",
    instrument: Optional[str] = None,
    acquisition: Optional[Dict[str, float]] = None,
    window: Optional[Tuple[float, float, float]] = None,
    chm_cell_m: Optional[float] = None,
) -> Dict[str, Any]: ...
def compare(
    a: Any,
    b: Any,
    out_dir: Optional[str] = None,
    overwrite: bool = False,
    cell_m: float = 20.0,
    area: Optional[Tuple[float, float, float, float]] = None,
    match_density: bool = False,
    seed: int = 1,
    labels: Tuple[str, str] = ("A", "B"),
) -> Dict[str, Any]: ...

class PartMerge:
    def __init__(self, out_dir: str, overwrite: bool = False, take_parts: bool = False) -> None: ...
    def add(self, part_dir: str) -> None: ...
    def finish(self, threads: int, survey: Optional["SurveyCore"] = None) -> Dict[str, Any]: ...

class PointStream(Iterator["np.ndarray"]):
    pulses_done: int
    pulses_total: int
    def __iter__(self) -> "PointStream": ...
    def __next__(self) -> "np.ndarray": ...
    def close(self) -> None: ...

class SurveyCore:
    @staticmethod
    def load(path: str, seed: Optional[int] = None) -> "SurveyCore": ...
    @staticmethod
    def from_toml(text: str, base_dir: Optional[str] = None, seed: Optional[int] = None) -> "SurveyCore": ...
    @staticmethod
    def from_dict(d: Dict[str, Any], base_dir: Optional[str] = None, seed: Optional[int] = None) -> "SurveyCore": ...
    @staticmethod
    def demo(seed: Optional[int] = None) -> "SurveyCore": ...
    @property
    def seed(self) -> int: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_toml(self) -> str: ...
    def warnings(self) -> List[str]: ...
    def build(self) -> None: ...
    def run(
        self, threads: int, progress: Optional[Callable[[int, int], Any]] = None
    ) -> Dict[str, Any]: ...
    def run_to(
        self,
        out_dir: str,
        threads: int,
        progress: Optional[Callable[[int, int], Any]] = None,
        overwrite: bool = False,
        resume: bool = False,
        no_space_check: bool = False,
    ) -> Dict[str, Any]: ...
    def stream(self, threads: int, min_points: int) -> PointStream: ...
    def waveform(self, line: int, pulse: int) -> Dict[str, Any]: ...
    def with_mesh(
        self,
        vertices: "np.ndarray",
        faces: "np.ndarray",
        material: str,
        class_name: str,
        offset_m: List[float],
        scale: float,
        rotation_z_deg: float,
    ) -> "SurveyCore": ...
    def with_terrain(
        self,
        heights: "np.ndarray",
        transform: List[float],
        material: str,
        class_name: str,
        nodata: Optional[float],
    ) -> "SurveyCore": ...
    def with_point_cloud(
        self,
        points: "np.ndarray",
        voxel_m: float,
        material: str,
        class_name: Optional[str],
        classes: Optional["np.ndarray"],
    ) -> "SurveyCore": ...
    def run_part(
        self, out_dir: str, k: int, n: int, threads: int, overwrite: bool = False
    ) -> Dict[str, Any]: ...
