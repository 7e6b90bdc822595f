"""Type stubs of the native module ``scanmesh._core`` (Rust, PyO3).

Checked against the built module by ``python -m mypy.stubtest scanmesh._core`` in CI.
"""

from collections.abc import Mapping, Sequence
from typing import final

import numpy as np
import numpy.typing as npt

__all__ = [
    "ScanmeshError",
    "DegenerateInputError",
    "ParameterError",
    "InvalidMeshError",
    "MemoryLimitError",
    "SLIVER_ANGLE_DEG",
    "DEFAULT_BRIDGE_FACTOR",
    "DEFAULT_HOLE_FACTOR",
    "DEFAULT_JUMP_FACTOR",
    "DEFAULT_MAX_EDGE_FACTOR",
    "DEFAULT_GRID_TURN_DEG",
    "DEFAULT_GRID_EDGE_FACTOR",
    "BEHIND_VOXELS",
    "MAX_MARGIN",
    "MAX_TILES",
    "project",
    "delaunay",
    "delaunay_trimmed",
    "grid_triangulate",
    "median_spacing",
    "trim_long_edges",
    "validate",
    "mesh_quality",
    "tac_norm",
    "steep_count",
    "DEFAULT_GAP_FACTOR",
    "DEFAULT_BAND",
    "detect_lines",
    "scan_segments",
    "strip_mesh",
    "StripParams",
    "ScanContext",
    "ScanSegments",
    "set_strip_filter",
    "strip_filter_counts",
    "empty_triangles",
    "triangulations",
    "cheapest_fans",
    "lop",
    "parse_text_table",
    "stl_records",
    "simplify",
    "AnnealParams",
    "Annealer",
    "StripResult",
    "AnnealOutcome",
    "TrimmedDelaunay",
    "GridTriangles",
    "CheapestFans",
    "TextTable",
    "TextProblem",
    "JUMP_STEPS",
    "DepthView",
    "FusionVolume",
    "ProgressCounter",
]

class ScanmeshError(ValueError): ...
class DegenerateInputError(ScanmeshError): ...
class ParameterError(ScanmeshError): ...
class InvalidMeshError(ScanmeshError): ...
class MemoryLimitError(ScanmeshError, MemoryError): ...

SLIVER_ANGLE_DEG: float
DEFAULT_BRIDGE_FACTOR: float
DEFAULT_HOLE_FACTOR: float
DEFAULT_JUMP_FACTOR: float
DEFAULT_GRID_TURN_DEG: float
DEFAULT_GRID_EDGE_FACTOR: float
DEFAULT_MAX_EDGE_FACTOR: float
JUMP_STEPS: float
BEHIND_VOXELS: float
MAX_MARGIN: int
MAX_TILES: int

def project(
    points: npt.NDArray[np.float64],
    plane: str | None,
    normal: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def delaunay(
    uv: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
def delaunay_trimmed(
    uv: npt.NDArray[np.float64],
    points: npt.NDArray[np.float64],
    max_edge: float | None = None,
    jump_factor: float = ...,
    progress: ProgressCounter | None = None,
) -> TrimmedDelaunay: ...
def grid_triangulate(
    grid: npt.NDArray[np.int64],
    uv: npt.NDArray[np.float64],
    points: npt.NDArray[np.float64],
    sight: npt.NDArray[np.float64],
    max_turn_deg: float = ...,
    edge_factor: float = ...,
) -> GridTriangles: ...
def median_spacing(uv: npt.NDArray[np.float64], faces_: npt.NDArray[np.int64]) -> float: ...
def trim_long_edges(
    uv: npt.NDArray[np.float64],
    faces_: npt.NDArray[np.int64],
    max_edge: float,
    points: npt.NDArray[np.float64] | None = None,
    jump_factor: float = ...,
) -> npt.NDArray[np.int64]: ...
def validate(uv: npt.NDArray[np.float64], faces_: npt.NDArray[np.int64]) -> None: ...
def mesh_quality(
    points: npt.NDArray[np.float64], faces_: npt.NDArray[np.int64]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def tac_norm(values: npt.NDArray[np.float64], p: float) -> float: ...
def steep_count(
    points: npt.NDArray[np.float64],
    faces_: npt.NDArray[np.int64],
    normal: npt.NDArray[np.float64],
    max_tilt: float,
) -> int: ...
def empty_triangles(uv: npt.NDArray[np.float64]) -> npt.NDArray[np.int64]: ...
def triangulations(
    uv: npt.NDArray[np.float64], faces_: npt.NDArray[np.int64], max_count: int
) -> npt.NDArray[np.int64]: ...
def cheapest_fans(
    uv: npt.NDArray[np.float64],
    triangles: npt.NDArray[np.int64],
    d: npt.NDArray[np.float64],
    c: npt.NDArray[np.float64],
    vertices: npt.NDArray[np.int64],
    w: npt.NDArray[np.float64],
) -> CheapestFans: ...
def lop(
    points: npt.NDArray[np.float64],
    uv: npt.NDArray[np.float64],
    faces_: npt.NDArray[np.int64],
    criterion: str,
    *,
    p: float = ...,
    sliver_guard: bool = ...,
    tie_tolerance: float = ...,
    sight: npt.NDArray[np.float64] | None = None,
    curtain_angle: float = ...,
    fixed: npt.NDArray[np.int64] | None = None,
) -> tuple[npt.NDArray[np.int64], int]: ...

@final
class DepthView:
    """One range view: a depth image along the scanner's -z and its scanner-to-world pose."""

    def __new__(
        cls,
        pose: npt.NDArray[np.float64],
        origin: tuple[float, float],
        step: float,
        depth: npt.NDArray[np.float64],
        cos: npt.NDArray[np.float64],
        weight: npt.NDArray[np.float64] | None = None,
        margin: int = 0,
    ) -> DepthView: ...

@final
class ProgressCounter:
    """Items done of items planned by the long native call it is passed to."""

    def __new__(cls) -> ProgressCounter: ...
    @property
    def done(self) -> int: ...
    @property
    def total(self) -> int: ...

@final
class FusionVolume:
    """The voxel grid range views are integrated and carved into."""

    def __new__(
        cls,
        origin: tuple[float, float, float],
        voxel: float,
        dims: tuple[int, int, int],
        truncation: float,
        max_voxels: int,
    ) -> FusionVolume: ...
    @property
    def allocated(self) -> tuple[int, int]: ...
    def integrate(self, view: DepthView) -> None: ...
    def carve(self, view: DepthView) -> None: ...
    def evidence(self) -> npt.NDArray[np.uint8]: ...
    def extract(
        self,
        samples: npt.NDArray[np.float64],
        normals: npt.NDArray[np.float64],
        views: list[DepthView],
        progress: ProgressCounter | None = None,
    ) -> tuple[
        npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.uint8], int, dict[str, int]
    ]: ...

@final
class AnnealParams:
    """The core's annealing parameters: its defaults with the given keywords replaced."""

    def __new__(cls, **params: int | float | bool) -> AnnealParams: ...
    def auto_sweeps(self, n_points: int, interior_edges: int) -> int: ...
    def as_dict(self) -> dict[str, int | float | bool]: ...

@final
class Annealer:
    def __new__(
        cls,
        points: npt.NDArray[np.float64],
        uv: npt.NDArray[np.float64],
        faces: npt.NDArray[np.int64],
        params: AnnealParams,
        sight: npt.NDArray[np.float64] | None = None,
        fixed: npt.NDArray[np.int64] | None = None,
        progress: ProgressCounter | None = None,
    ) -> Annealer: ...
    def advance(self, max_proposals: int, max_seconds: float) -> int: ...
    def replan(self, sweeps: int) -> None: ...
    @property
    def done(self) -> bool: ...
    @property
    def chains(self) -> int: ...
    @property
    def sweep_len(self) -> int: ...
    @property
    def sweeps_done(self) -> int: ...
    @property
    def energy(self) -> float: ...
    def finish(self, progress: ProgressCounter | None = None) -> AnnealOutcome: ...

@final
class AnnealOutcome:
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def trace(self) -> npt.NDArray[np.float64]: ...
    @property
    def initial_energy(self) -> float: ...
    @property
    def energy(self) -> float: ...
    @property
    def initial_temperature(self) -> float: ...
    @property
    def polish_flips(self) -> int: ...
    @property
    def proposals(self) -> int: ...
    @property
    def stopped(self) -> str: ...
    @property
    def chains(self) -> int: ...
    @property
    def best_chain(self) -> int: ...
    @property
    def chain_energies(self) -> list[float]: ...

DEFAULT_GAP_FACTOR: float
DEFAULT_BAND: int

def detect_lines(uv: npt.NDArray[np.float64], gap_factor: float) -> npt.NDArray[np.int64]: ...
def scan_segments(
    uv: npt.NDArray[np.float64], line_ids: npt.NDArray[np.int64], gap_factor: float
) -> ScanSegments: ...

@final
class ScanSegments:
    """Scan lines split at gaps: segments of point indices per line, the median step, the
    gap length and the duplicates."""

    @property
    def lines(self) -> list[list[npt.NDArray[np.int64]]]: ...
    @property
    def median_step(self) -> float: ...
    @property
    def gap(self) -> float: ...
    @property
    def duplicates(self) -> npt.NDArray[np.int64]: ...

def set_strip_filter(on: bool) -> None: ...
def strip_filter_counts(reset: bool = False) -> tuple[int, int]: ...
@final
class StripParams:
    """The strip method's options; an option its method or solver does not use is refused."""

    def __new__(
        cls,
        method: str,
        *,
        weight: Mapping[str, float],
        alpha: int | None = None,
        solver: str | None = None,
        band: int | None = None,
        check: bool = True,
        jump_factor: float = ...,
    ) -> StripParams: ...

@final
class ScanContext:
    """What a run over some consecutive lines shares with the whole scan."""

    def __new__(
        cls,
        *,
        lo: Sequence[float],
        hi: Sequence[float],
        largest_planar: float,
        median_step: float,
        first_turned: bool,
        own_rows: tuple[int, int] | None = None,
    ) -> ScanContext: ...

def strip_mesh(
    points: npt.NDArray[np.float64],
    uv: npt.NDArray[np.float64],
    line_ids: npt.NDArray[np.int64],
    params: StripParams,
    gap_factor: float,
    context: ScanContext | None = None,
    progress: ProgressCounter | None = None,
) -> StripResult: ...

@final
class StripResult:
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def unused(self) -> npt.NDArray[np.int64]: ...
    @property
    def duplicates(self) -> npt.NDArray[np.int64]: ...
    @property
    def n_strips(self) -> int: ...
    @property
    def cost(self) -> float: ...
    @property
    def planar_error(self) -> str | None: ...
    @property
    def dropped_jumps(self) -> int: ...
    @property
    def dropped_overlaps(self) -> int: ...
    @property
    def trimmed(self) -> npt.NDArray[np.int64]: ...
    @property
    def signed_area(self) -> float: ...

def parse_text_table(
    data: bytes, start: int, stop: int, ncols: int, delimiter: str | None = None
) -> TextTable: ...

@final
class TextTable:
    @property
    def values(self) -> npt.NDArray[np.float64]: ...
    @property
    def row_lines(self) -> npt.NDArray[np.int64]: ...
    @property
    def blank_lines(self) -> npt.NDArray[np.int64]: ...
    @property
    def n_lines(self) -> int: ...
    @property
    def problem(self) -> TextProblem | None: ...

@final
class TextProblem:
    """The first bad line of a refused text range: its index, a byte offset, its kind."""

    @property
    def line(self) -> int: ...
    @property
    def offset(self) -> int: ...
    @property
    def kind(self) -> str: ...

def stl_records(
    points: npt.NDArray[np.float64], faces_: npt.NDArray[np.int64]
) -> npt.NDArray[np.uint8]: ...
def simplify(
    vertices: npt.NDArray[np.float64],
    faces_: npt.NDArray[np.int64],
    labels: npt.NDArray[np.uint8],
    tolerance: float,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.uint8]]: ...

@final
class TrimmedDelaunay:
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def duplicate_of(self) -> npt.NDArray[np.int64]: ...
    @property
    def trimmed(self) -> npt.NDArray[np.int64]: ...
    @property
    def max_edge(self) -> float: ...
    @property
    def seconds(self) -> tuple[float, float]: ...

@final
class GridTriangles:
    @property
    def faces(self) -> npt.NDArray[np.int64]: ...
    @property
    def candidates(self) -> int: ...
    @property
    def turned(self) -> int: ...
    @property
    def long(self) -> int: ...
    @property
    def folded(self) -> int: ...
    @property
    def peeled(self) -> int: ...
    @property
    def unused(self) -> npt.NDArray[np.int64]: ...
    @property
    def spacing(self) -> float: ...

@final
class CheapestFans:
    @property
    def lower_bounds(self) -> npt.NDArray[np.float64]: ...
    @property
    def owner(self) -> npt.NDArray[np.int64]: ...
    @property
    def values(self) -> npt.NDArray[np.float64]: ...
    @property
    def fans(self) -> npt.NDArray[np.int64]: ...
    @property
    def offsets(self) -> npt.NDArray[np.int64]: ...
