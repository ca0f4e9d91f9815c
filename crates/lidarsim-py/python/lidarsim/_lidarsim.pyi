"""Type stubs of the compiled half of lidarsim (use the `lidarsim` API)."""

from typing import Any, Callable, Dict, List, Optional, Tuple

VERSION: str
POINT_FIELDS: List[Tuple[str, str]]
POINT_RECORD_BYTES: int
TRAJECTORY_FIELDS: List[Tuple[str, str]]

class SurveyError(ValueError):
    diagnostics: List[Dict[str, Any]]

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
