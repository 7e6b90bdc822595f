"""Input checks shared by every public function: shapes, dtypes, finite values, options."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from scanmesh.errors import DegenerateInputError, InvalidMeshError, ParameterError, ScanmeshError


def _shown(value: object) -> str:
    """``repr`` of a value for a message, numpy scalars as the Python numbers they hold
    (``nan``, not ``np.float64(nan)``)."""
    return repr(value.item() if isinstance(value, np.generic) else value)


def as_points(points: ArrayLike, name: str = "points") -> np.ndarray:
    """Return ``points`` as a C-contiguous (N, 3) float64 array, or raise naming the problem.

    Accepts any real dtype (integers, float32, ...) and any memory layout.
    """
    try:
        arr = np.asarray(points)
    except (ValueError, TypeError) as exc:
        raise ScanmeshError(f"{name} cannot be read as an array: {exc}") from None
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.number) or np.issubdtype(arr.dtype, np.bool_)
    ):
        raise ScanmeshError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if np.issubdtype(arr.dtype, np.complexfloating):
        raise ScanmeshError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ScanmeshError(f"{name} must have shape (N, 3), got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise DegenerateInputError(
            f"{name}[{row}] has a non-finite coordinate {'xyz'[col]}={float(arr[row, col])!r}"
            f" ({int(bad.any(axis=1).sum())} such point(s) in all)"
        )
    if len(arr) < 3:
        raise DegenerateInputError(f"need at least 3 points to triangulate, got {len(arr)}")
    return arr


def as_faces(faces: ArrayLike, n_vertices: int, name: str = "faces") -> np.ndarray:
    """Return ``faces`` as a C-contiguous (M, 3) int64 array of valid vertex indices.

    The one check of faces given by a caller; every problem is an ``InvalidMeshError``.
    """
    try:
        arr = np.asarray(faces)
    except (TypeError, ValueError) as exc:
        raise InvalidMeshError(f"{name} cannot be read as an array: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InvalidMeshError(f"{name} must have shape (M, 3), got {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        if not np.issubdtype(arr.dtype, np.floating) or not np.all(arr == np.round(arr)):
            raise InvalidMeshError(
                f"{name} must hold integer vertex indices, got dtype {arr.dtype}"
            )
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    if arr.size and (arr.min() < 0 or arr.max() >= n_vertices):
        row = int(np.argwhere((arr < 0) | (arr >= n_vertices))[0, 0])
        raise InvalidMeshError(
            f"{name}: face {row} {arr[row].tolist()} refers to a vertex outside 0..{n_vertices - 1}"
        )
    return arr


def power_of_two_unit(arr: np.ndarray) -> tuple[np.ndarray, int]:
    """(``arr`` x 2**-e, e): scaled by a power of two to at most 1 in magnitude.

    The scaling is exact (no rounding, so orientations, collinearity and ratios are those
    of ``arr``), and it keeps products of coordinates from overflowing at 1e300 or
    underflowing to zero at 1e-300 (README: every method takes 1e-300..1e300). O(N).
    """
    exponent = power_of_two_exponent(arr)
    return np.ldexp(arr, -exponent), exponent


def power_of_two_exponent(arr: np.ndarray) -> int:
    """The e of :func:`power_of_two_unit`: 2**-e scales ``arr`` to at most 1 in magnitude
    (0 for an empty or all-zero array). O(N), no copy of ``arr``."""
    big = float(max(abs(arr.max()), abs(arr.min()))) if arr.size else 0.0
    return math.frexp(big)[1] if big > 0.0 else 0


#: Float line ids are accepted up to this magnitude, where every integer is still a float
#: (2**53); beyond it neighbouring ids would merge.
MAX_FLOAT_ID: float = 2.0**53


def as_line_ids(line_ids: ArrayLike, n_points: int) -> np.ndarray:
    """Return ``line_ids`` as a C-contiguous (N,) int64 array, or raise naming the problem.

    Integers that fit int64 and whole floats up to ``MAX_FLOAT_ID`` in magnitude are
    accepted; NaN, infinities, fractions, larger floats, unsigned ids of 2**63 and more,
    booleans and other shapes are refused: a cast would merge or reorder lines silently.
    """
    try:
        arr = np.asarray(line_ids)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ScanmeshError(f"lines cannot be read as an array: {exc}") from None
    if arr.shape != (n_points,):
        raise ScanmeshError(f"lines must be one id per point, shape ({n_points},), got {arr.shape}")
    if arr.dtype.kind == "u" and arr.size and int(arr.max()) > np.iinfo(np.int64).max:
        row = int(np.argmax(arr))
        raise ScanmeshError(f"lines[{row}] = {arr[row]} does not fit a signed 64-bit line id")
    if arr.dtype.kind == "f":
        bad = ~np.isfinite(arr) | (arr != np.round(arr)) | (np.abs(arr) > MAX_FLOAT_ID)
        if bad.any():
            row = int(np.argmax(bad))
            raise ScanmeshError(
                f"lines[{row}] = {arr[row].item()!r}: line ids must be integers (floats: whole, at"
                " most 2**53 in magnitude); a non-integral, non-finite or larger id would"
                " merge or reorder lines"
            )
    elif arr.dtype.kind not in "iu":
        raise ScanmeshError(f"lines must hold integer line ids, got dtype {arr.dtype}")
    return np.ascontiguousarray(arr, dtype=np.int64)


def _is_real(value: Any) -> bool:
    """A real number: int, float or a numpy real scalar, but not a bool."""
    return not isinstance(value, (bool, np.bool_)) and isinstance(
        value, (int, float, np.integer, np.floating)
    )


@dataclass(frozen=True)
class Option:
    """One option of a method: its type, range, default and a one-line doc.

    :meth:`check` is the one validation every option goes through (the API and the
    command alike), so a bad value always ends in a ``ParameterError`` naming the option
    and the value, never in a ``TypeError`` or ``OverflowError`` further down.
    """

    #: keyword name (the command's flag is ``--`` + name with dashes)
    name: str
    #: "int", "float", "bool", "choice" (one of ``choices``) or "any" (``convert`` decides)
    kind: str
    #: value used when the option is not given
    default: Any
    #: one line for help texts
    doc: str
    #: smallest and largest accepted value ("int", "float"); None: unbounded
    low: float | None = None
    high: float | None = None
    #: "float": True when ``low`` (``high``) itself is refused (an open interval)
    low_open: bool = False
    high_open: bool = False
    #: "choice": the accepted values; "float": the only accepted values when not empty
    choices: tuple[Any, ...] = ()
    #: "float": False when math.inf is accepted
    finite: bool = True
    #: "any": turns a value into the checked one or raises ParameterError
    convert: Callable[[Any], Any] | None = None
    #: True when None is a value of its own ("work it out from the data"), kept as None
    automatic: bool = False

    @property
    def flag(self) -> str:
        """The command-line flag of this option."""
        return "--" + self.name.replace("_", "-")

    def check(self, value: Any, label: str | None = None) -> Any:
        """``value`` as the type the method takes, or ParameterError naming ``label``
        (default: the option's name) and the value."""
        name = label or self.name
        if value is None and self.automatic:
            return None
        if self.kind == "any":
            assert self.convert is not None
            return self.convert(value)
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise ParameterError(f"{name} must be True or False, got {_shown(value)}")
            return bool(value)
        if self.kind == "choice":
            if not any(type(value) is type(c) and value == c for c in self.choices):
                shown = ", ".join(repr(c) for c in self.choices)
                raise ParameterError(f"{name} must be one of {shown}, got {_shown(value)}")
            return value
        if self.kind == "int":
            if not _is_real(value) or not isinstance(value, (int, np.integer)):
                raise ParameterError(
                    f"{name} must be a whole number{self._range()}, got {_shown(value)}"
                )
            number: Any = int(value)
        else:
            try:
                number = float(value) if _is_real(value) else math.nan
            except OverflowError:  # an int beyond the float range
                number = math.nan
            if math.isnan(number) or (self.finite and math.isinf(number)):
                what = "a finite number" if self.finite else "a number"
                raise ParameterError(f"{name} must be {what}{self._range()}, got {_shown(value)}")
            if self.choices and number not in self.choices:
                shown = " or ".join(f"{c:g}" for c in self.choices)
                raise ParameterError(f"{name} must be {shown}, got {_shown(value)}")
        low_ok = self.low is None or (number > self.low if self.low_open else number >= self.low)
        high_ok = self.high is None or (
            number < self.high if self.high_open else number <= self.high
        )
        if not (low_ok and high_ok):
            what = "a whole number" if self.kind == "int" else "a number"
            raise ParameterError(f"{name} must be {what}{self._range()}, got {_shown(value)}")
        return number

    def _range(self) -> str:
        if self.low is None and self.high is None:
            return ""
        if self.high is None:
            return f" {'>' if self.low_open else '>='} {self.low:g}"
        if self.low is None:
            return f" {'<' if self.high_open else '<='} {self.high:g}"
        if self.kind == "int":
            return f" from {int(self.low)} to {int(self.high)}"
        opening = "(" if self.low_open else "["
        closing = ")" if self.high_open else "]"
        return f" in {opening}{self.low:g}, {self.high:g}{closing}"


#: A positive finite number (a spacing, a voxel size, an angle, a truncation): the one
#: check of such keywords outside the method options; ``POSITIVE.check(value, name)``.
POSITIVE = Option("value", "float", None, "a positive finite number", low=0.0, low_open=True)


def check_options(known: Iterable[Option], given: Mapping[str, Any], where: str) -> dict[str, Any]:
    """Every option of ``known`` checked, defaults for those not ``given``.

    Raises ParameterError for a keyword not in ``known`` (``where`` says whose options
    they are, e.g. "method 'anneal'") and for the first bad value.
    """
    table = {option.name: option for option in known}
    unknown = sorted(set(given) - set(table))
    if unknown:
        raise ParameterError(
            f"unknown option(s) {unknown} for {where}; its options:"
            f" {', '.join(sorted(table)) or 'none'}"
        )
    return {
        name: option.check(given[name]) if name in given else option.default
        for name, option in table.items()
    }
