"""LAS / LAZ LiDAR points through laspy (``pip install scanmesh[las]``).

Before laspy reads anything, the public header block is checked against the file size
(the one bound of :mod:`scanmesh.formats._source`): the VLRs must fit between the header
and the points, the EVLRs after them, and the declared points in what is left (for LAZ,
at most ``LAZ_RATIO`` times it, far beyond what LAZ compression reaches on real data).
"""

from __future__ import annotations

import os
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._extras import require
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import check_declared, check_finite, check_regular
from scanmesh.formats.georef import EPSG_UNITS, Georef, wkt_name, wkt_unit
from scanmesh.formats.points import ScanPoints

#: How many times its compressed size a LAZ point block may declare.
LAZ_RATIO: int = 256

#: ``returns=`` names: which returns of each pulse to keep.
RETURNS = ("first", "last", "all")

#: Per-point LAS dimensions kept as ``point_data`` (when the point format has them).
KEPT_DIMENSIONS: tuple[str, ...] = ("intensity", "classification", "red", "green", "blue")

# GeoTIFF keys of a LAS GeoKeyDirectory (GeoTIFF 1.0, section 6.2)
_GEOGRAPHIC, _GEOG_UNITS, _PROJECTED, _CITATION, _PCS_CITATION = 2048, 2054, 3072, 1026, 3073
_LINEAR_UNITS, _VERTICAL_UNITS = 3076, 4099
_USER_DEFINED = 32767


def _georef(header: Any) -> Georef | None:
    """The coordinate reference system and units a LAS header records: EPSG code, unit
    codes and citation from its GeoKeyDirectory, name and unit from its OGC WKT; None when
    it records neither."""
    keys: dict[int, Any] = {}
    text, wkt = "", None
    for vlr in [*header.vlrs, *(header.evlrs or [])]:
        if hasattr(vlr, "geo_keys"):
            keys = {int(k.id): k for k in vlr.geo_keys}
        elif hasattr(vlr, "strings"):
            text = "\0".join(vlr.strings)  # GeoAsciiParams: keys index into the raw text
        elif hasattr(vlr, "string") and wkt is None:
            wkt = str(vlr.string).strip("\0 ") or None
    if not keys and wkt is None:
        return None

    def code(key: int) -> int | None:
        entry = keys.get(key)
        if entry is None or entry.tiff_tag_location != 0:
            return None
        value = int(entry.value_offset)
        return value if 0 < value < _USER_DEFINED else None

    def citation(key: int) -> str | None:
        entry = keys.get(key)
        if entry is None or entry.tiff_tag_location != 34737:
            return None
        start = int(entry.value_offset)
        return text[start : start + int(entry.count)].strip("|\0 ") or None

    epsg = code(_PROJECTED) or code(_GEOGRAPHIC)
    crs = f"EPSG:{epsg}" if epsg else None
    crs = crs or (wkt_name(wkt) if wkt else None)
    crs = crs or citation(_PCS_CITATION) or citation(_CITATION)
    linear = code(_LINEAR_UNITS) if _PROJECTED in keys else code(_GEOG_UNITS)
    horizontal = EPSG_UNITS.get(linear) if linear else None
    vertical = code(_VERTICAL_UNITS)
    return Georef(
        crs=crs,
        wkt=wkt,
        horizontal_units=horizontal or (wkt_unit(wkt) if wkt else None),
        vertical_units=EPSG_UNITS.get(vertical) if vertical else None,
    )


def _check_header(path: Path, size: int) -> None:
    """Check the declared counts of a LAS public header block against ``size`` bytes."""
    with open(path, "rb") as handle:
        head = handle.read(375)
    if len(head) < 227 or not head.startswith(b"LASF"):
        raise FileFormatError(
            f"{path}: not a LAS/LAZ file (it must start with 'LASF' and a 227-byte header)"
        )
    minor = head[25]
    header_size, offset, n_vlrs = struct.unpack_from("<HII", head, 94)
    point_format, record = struct.unpack_from("<BH", head, 104)
    (count,) = struct.unpack_from("<I", head, 107)
    if minor >= 4 and len(head) >= 255:
        (count64,) = struct.unpack_from("<Q", head, 247)
        count = count64 or count
    if not header_size <= offset <= size:
        raise FileFormatError(
            f"{path}: the LAS header puts the points at byte {offset}, outside"
            f" {header_size}..{size} (truncated or corrupt?)"
        )
    check_declared(path, n_vlrs, 54, offset - header_size, "variable-length records")
    available = size - offset
    compressed = bool(point_format & 0xC0)
    check_declared(path, count, record, available * (LAZ_RATIO if compressed else 1), "points")
    if minor >= 4 and len(head) >= 247:
        evlr_start, n_evlrs = struct.unpack_from("<QI", head, 235)
        if n_evlrs:
            check_declared(
                path, n_evlrs, 60, max(size - evlr_start, 0), "extended variable-length records"
            )


def _ints(value: int | str | Sequence[int], name: str) -> np.ndarray:
    """An int, a comma-separated string or a sequence of ints as an int64 array."""
    try:
        if isinstance(value, str):
            items = [int(v) for v in value.replace(",", " ").split()]
        elif isinstance(value, int | np.integer) and not isinstance(value, bool):
            items = [int(value)]
        else:
            items = [int(v) for v in value if not isinstance(v, bool) and int(v) == v]
            if len(items) != len(value):
                raise ValueError
    except (TypeError, ValueError):
        items = []
    if not items:
        raise ParameterError(f"{name} must be integers (e.g. 2 or '2,9'), got {value!r}")
    return np.array(items, dtype=np.int64)


def read_las(
    path: str | os.PathLike,
    *,
    returns: str | int | Sequence[int] = "first",
    classes: int | str | Sequence[int] | None = None,
) -> ScanPoints:
    """Read LAS or LAZ LiDAR points through laspy (``pip install scanmesh[las]``).

    Parameters
    ----------
    path : str or PathLike
        A ``.las`` or ``.laz`` file.
    returns : "first", "last", "all", or return numbers
        ``"first"`` (default): first returns, the top surface; ``"last"``: last returns
        (``return_number == number_of_returns``); ``"all"``; or return numbers such as 2.
    classes : int, "2,9" or sequence of ints, optional
        ASPRS classes to keep (2 = ground); every class when None.

    Scan lines are the scanner's sweeps: a new sweep starts wherever
    ``scan_direction_flag`` changes between consecutive points of the whole file. Sweeps are
    numbered before selecting, so a sweep keeps its id whatever is selected. When the flag
    never changes the file gives no lines (``line_ids`` None).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 scaled coordinates; ``line_ids`` (N,) int64 sweep index;
        ``point_data``: ``intensity``, ``classification`` and, in point formats with
        colours, ``red``, ``green``, ``blue`` (uint16, as stored); ``georef``: the EPSG
        code (or WKT name, or GeoTIFF citation) and the units the header records.
    """
    path = Path(path)
    named = isinstance(returns, str) and returns in RETURNS
    if isinstance(returns, str) and not named and not returns.replace(",", "").isdigit():
        raise ParameterError(
            f"returns must be 'first', 'last', 'all' or return numbers, got {returns!r}"
        )
    wanted_returns = None if named else _ints(returns, "returns")
    wanted_classes = None if classes is None else _ints(classes, "classes")
    laspy = require("laspy", "las", f"{path}: reading LAS/LAZ files")
    _check_header(path, check_regular(path))
    try:
        las = laspy.read(path)
        xyz = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
        flag = np.asarray(las.scan_direction_flag).astype(np.int8)
        number = np.asarray(las.return_number)
        of = np.asarray(las.number_of_returns)
        klass = np.asarray(las.classification)
        header = las.header
        declared = int(header.point_count)
        names = set(las.point_format.dimension_names)
        kept = {d: np.asarray(las[d]) for d in KEPT_DIMENSIONS if d in names}
        georef = _georef(header)
    except Exception as exc:  # laspy, lazrs and numpy all raise their own kinds
        hint = ""
        if "LazBackend" in type(exc).__name__ or "laz" in str(exc).lower():
            hint = " (LAZ needs a backend: `pip install scanmesh[las]` installs lazrs)"
        raise FileFormatError(
            f"{path}: not a readable LAS/LAZ file: {type(exc).__name__}: {exc}{hint}"
        ) from None
    if len(xyz) != declared:
        raise FileFormatError(
            f"{path}: truncated LAS: the header declares {declared} points, {len(xyz)} were read"
        )
    sweeps = np.concatenate(([0], np.cumsum(flag[1:] != flag[:-1]))).astype(np.int64)
    if wanted_returns is not None:
        keep = np.isin(number, wanted_returns)
    else:
        keep = {"first": number == 1, "last": number == of, "all": np.ones(len(xyz), bool)}[
            returns  # type: ignore[index]
        ]
    if wanted_classes is not None:
        keep &= np.isin(klass, wanted_classes)
    points = xyz[keep]
    chosen = f"returns={returns!r}" + (f", classes={classes!r}" if classes is not None else "")
    if not len(points):
        raise FileFormatError(
            f"{path}: no points selected by {chosen} ({len(xyz)} points in the file, classes"
            f" {sorted(set(np.unique(klass).tolist()))})"
        )
    check_finite(path, points)
    has_sweeps = bool(len(flag)) and sweeps[-1] > 0
    extra = {
        "format": "laz" if path.suffix.lower() == ".laz" else "las",
        "version": str(header.version),
        "point_format": int(header.point_format.id),
        "returns": returns,
        "classes": classes,
        "points_in_file": len(xyz),
        "sweeps_in_file": int(sweeps[-1]) + 1 if len(sweeps) else 0,
        "scale": tuple(float(s) for s in header.scales),
        "line_ids_from": "scan_direction_flag changes" if has_sweeps else None,
    }
    return ScanPoints(
        points=points,
        line_ids=sweeps[keep] if has_sweeps else None,
        source=path,
        extra=extra,
        point_data={d: values[keep] for d, values in kept.items()},
        georef=georef,
    )
