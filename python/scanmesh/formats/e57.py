"""E57 (ASTM E2807, terrestrial and mobile laser scans) through pye57, an optional extra.

pye57 (``pip install "scanmesh[e57]"``) wraps libE57Format. Every scan (station) of the
file is read in global coordinates (its pose applied; points the file marks invalid
dropped) and the scans are concatenated in file order. A structured scan's
``columnIndex`` is its scan line (a terrestrial scanner sweeps one vertical column per
mirror turn): ``line_ids`` number the columns on from one scan to the next. Intensity and
colours come as ``point_data``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh._extras import require
from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_finite, check_regular
from scanmesh.formats.points import ScanPoints

#: The first bytes of an E57 file (its physical header's signature).
E57_MAGIC: bytes = b"ASTM-E57"

#: pye57's field names -> the point_data names (PLY's for colours).
FIELDS: dict[str, str] = {
    "intensity": "intensity",
    "colorRed": "red",
    "colorGreen": "green",
    "colorBlue": "blue",
}


def read_e57(path: str | os.PathLike, *, context: Context = QUIET) -> ScanPoints:
    """Read every scan of an E57 file. O(points); needs pye57.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 in the file's global frame; ``line_ids`` the column of
        each point, numbered on across scans, when every scan is structured (else None:
        detected); ``point_data`` ``intensity`` and uint8 ``red``, ``green``, ``blue``
        where every scan has them; ``extra["scan_starts"]``: each scan's first point.
    """
    path = Path(path)
    size = check_regular(path)
    pye57 = require("pye57", "e57", f"{path}: reading E57 files")
    with open(path, "rb") as handle:
        if handle.read(len(E57_MAGIC)) != E57_MAGIC:
            raise FileFormatError(f"{path}: not an E57 file (no {E57_MAGIC.decode()} signature)")
    scans: list[dict[str, np.ndarray]] = []
    with context.stage("read", size, blocking=True):
        try:
            e57 = pye57.E57(str(path))
            for index in range(e57.scan_count):
                scans.append(
                    e57.read_scan(
                        index,
                        intensity=True,
                        colors=True,
                        row_column=True,
                        ignore_missing_fields=True,
                    )
                )
        except Exception as exc:  # libE57Format reports corrupt files in its own types
            raise FileFormatError(f"{path}: not a readable E57 file: {exc}") from None
    if not scans or not sum(len(s["cartesianX"]) for s in scans):
        raise FileFormatError(f"{path}: the E57 file holds no points")
    points = np.concatenate(
        [np.column_stack([s[f"cartesian{c}"] for c in "XYZ"]) for s in scans]
    ).astype(np.float64)
    check_finite(path, points)
    point_data = {
        name: np.concatenate([s[field] for s in scans])
        for field, name in FIELDS.items()
        if all(field in s for s in scans)
    }
    for name in ("red", "green", "blue"):
        if name in point_data:
            point_data[name] = np.clip(point_data[name], 0, 255).astype(np.uint8)
    line_ids = None
    if all("columnIndex" in s for s in scans):
        parts, offset = [], 0
        for s in scans:
            column = np.asarray(s["columnIndex"], dtype=np.int64)
            parts.append(column + offset)
            offset += int(column.max(initial=-1)) + 1
        line_ids = np.concatenate(parts)
    starts = np.cumsum([0] + [len(s["cartesianX"]) for s in scans[:-1]]).tolist()
    return ScanPoints(
        points=points,
        line_ids=line_ids,
        source=path,
        extra={
            "format": "e57",
            "scan_starts": starts,
            "line_ids_from": "columnIndex" if line_ids is not None else None,
        },
        point_data=point_data,
    )
