"""PCD (the Point Cloud Library's format): a text header, then ASCII or binary rows.

The header names the fields (``FIELDS x y z rgb ...``) with their byte size, type
(``I``, ``U``, ``F``) and count, the cloud's ``WIDTH`` x ``HEIGHT`` and ``POINTS``, and
ends with ``DATA ascii`` or ``DATA binary`` (little-endian records, one per point);
``DATA binary_compressed`` (LZF) is refused with a message. An organized cloud (``HEIGHT``
> 1, a range camera's image) has one scan line per row: ``line_ids`` are the rows and
``grid`` the image, -1 where the camera saw nothing (NaN points, which are dropped).
Fields of count 1 besides x, y, z are kept as ``point_data`` in their own type; a packed
``rgb`` / ``rgba`` field becomes uint8 ``red``, ``green``, ``blue`` (``alpha``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh._progress import Stage
from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_declared, check_text, quote, read_bytes
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import parse_rows, skip_lines

#: Header keys in the order PCD files (version 0.7) write them.
KEYS: tuple[str, ...] = (
    "VERSION",
    "FIELDS",
    "SIZE",
    "TYPE",
    "COUNT",
    "WIDTH",
    "HEIGHT",
    "VIEWPOINT",
    "POINTS",
    "DATA",
)

#: Lines a header may take (comments included) before the file is judged not a PCD.
MAX_HEADER_LINES: int = 64


@dataclass
class _Header:
    fields: list[str]
    dtypes: list[np.dtype]  # one per field, little-endian
    counts: list[int]
    width: int
    height: int
    points: int
    data: str  # "ascii", "binary" or "binary_compressed"
    body: int  # offset of the first data byte
    lines: int  # header lines (the body starts on line lines + 1)


def _header(path: Path, data: bytes) -> _Header:
    """Parse the header up to and including its ``DATA`` line."""
    values: dict[str, list[str]] = {}
    pos = 0
    for no in range(1, MAX_HEADER_LINES + 1):
        end = data.find(b"\n", pos)
        if end < 0:
            raise FileFormatError(f"{path}: PCD header has no DATA line (truncated?)")
        raw = data[pos:end]
        pos = end + 1
        words = raw.split(b"#", 1)[0].decode("ascii", errors="replace").split()
        if not words:
            continue
        key = words[0].upper()
        if key not in KEYS:
            raise FileFormatError(f"{path}, line {no}: not a PCD header line: {quote(raw)}")
        values[key] = words[1:]
        if key == "DATA":
            return _checked(path, values, pos, no)
    raise FileFormatError(f"{path}: no PCD DATA line within {MAX_HEADER_LINES} lines")


def _checked(path: Path, values: dict[str, list[str]], body: int, lines: int) -> _Header:
    """The header's values checked against each other."""
    missing = [k for k in ("FIELDS", "SIZE", "TYPE", "WIDTH", "POINTS", "DATA") if k not in values]
    if missing:
        raise FileFormatError(f"{path}: PCD header lacks {', '.join(missing)}")
    fields = values["FIELDS"]
    try:
        sizes = [int(v) for v in values["SIZE"]]
        counts = [int(v) for v in values.get("COUNT", ["1"] * len(fields))]
        width, points = int(values["WIDTH"][0]), int(values["POINTS"][0])
        height = int(values.get("HEIGHT", ["1"])[0])
    except (ValueError, IndexError):
        raise FileFormatError(
            f"{path}: PCD header SIZE/COUNT/WIDTH/HEIGHT/POINTS not integers"
        ) from None
    types = values["TYPE"]
    if not (len(sizes) == len(types) == len(counts) == len(fields)) or not fields:
        raise FileFormatError(
            f"{path}: PCD header lists {len(fields)} FIELDS, {len(sizes)} SIZE,"
            f" {len(types)} TYPE and {len(counts)} COUNT values; they must match"
        )
    dtypes = []
    for name, size, kind, count in zip(fields, sizes, types, counts, strict=True):
        code = {"I": "i", "U": "u", "F": "f"}.get(kind.upper())
        if code is None or size not in (1, 2, 4, 8) or (code == "f" and size < 4) or count < 1:
            raise FileFormatError(
                f"{path}: PCD field {name!r} has TYPE {kind} SIZE {size} COUNT {count}"
            )
        dtypes.append(np.dtype(f"<{code}{size}"))
    missing = [c for c in "xyz" if c not in fields]
    if missing:
        raise FileFormatError(f"{path}: PCD FIELDS {fields} lack {'/'.join(missing)}")
    if width < 0 or height < 1 or points != width * height:
        raise FileFormatError(
            f"{path}: PCD POINTS {points} is not WIDTH x HEIGHT = {width} x {height}"
        )
    kind = values["DATA"][0].lower() if values["DATA"] else ""
    if kind == "binary_compressed":
        raise FileFormatError(
            f"{path}: PCD DATA binary_compressed (LZF) is not read; save the cloud as DATA"
            " binary or ascii (pcl_convert_pcd_ascii_binary, or Open3D's write_point_cloud)"
        )
    if kind not in ("ascii", "binary"):
        raise FileFormatError(f"{path}: PCD DATA must be ascii or binary, got {kind!r}")
    return _Header(fields, dtypes, counts, width, height, points, kind, body, lines)


def _table(path: Path, data: bytes, head: _Header, stage: Stage) -> dict[str, np.ndarray]:
    """Each field of count 1 as (POINTS,) values in its declared type."""
    n = head.points
    if head.data == "binary":
        record = np.dtype(
            [
                (f"f{k}", dt, (c,)) if c > 1 else (f"f{k}", dt)
                for k, (dt, c) in enumerate(zip(head.dtypes, head.counts, strict=True))
            ]
        )
        check_declared(path, n, record.itemsize, len(data) - head.body, "points")
        rows = np.frombuffer(data, dtype=record, count=n, offset=head.body)
        stage.update(head.body + n * record.itemsize)
        return {
            name: np.array(rows[f"f{k}"])
            for k, name in enumerate(head.fields)
            if head.counts[k] == 1
        }
    check_text(path, data, "a PCD ascii body", start=head.body)
    ncols = sum(head.counts)
    check_declared(path, n, 2 * ncols, len(data) - head.body, "points")
    stop = skip_lines(path, data, head.body, n, f"POINTS {n}")
    rows = parse_rows(
        path, data, head.body, stop, ncols, None, head.lines + 1, f"{ncols} values", stage
    )
    starts = np.cumsum([0, *head.counts])
    # text floats keep the digits written (float64); integers and packed colours their type
    return {
        name: rows.values[:, starts[k]].astype(
            head.dtypes[k] if head.dtypes[k].kind != "f" or name in ("rgb", "rgba") else "f8"
        )
        for k, name in enumerate(head.fields)
        if head.counts[k] == 1
    }


def _colors(packed: np.ndarray, alpha: bool) -> dict[str, np.ndarray]:
    """uint8 channels of a packed rgb(a) field (the 4 bytes as PCL stores them)."""
    bits = np.ascontiguousarray(packed).view(np.uint32) if packed.dtype.itemsize == 4 else packed
    bits = bits.astype(np.uint32)
    out = {
        "red": (bits >> 16 & 255).astype(np.uint8),
        "green": (bits >> 8 & 255).astype(np.uint8),
        "blue": (bits & 255).astype(np.uint8),
    }
    if alpha:
        out["alpha"] = (bits >> 24 & 255).astype(np.uint8)
    return out


def read_pcd(path: str | os.PathLike, *, context: Context = QUIET) -> ScanPoints:
    """Read a PCD point cloud (ASCII or binary; gzip-compressed too). O(file size).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64, points with a NaN or infinite coordinate dropped
        (``extra["dropped_invalid"]`` counts them); for an organized cloud (HEIGHT > 1)
        ``line_ids`` the row of each point and ``grid`` (HEIGHT, WIDTH) of point indices,
        -1 where a point was dropped; ``point_data`` the other fields of count 1
        (``extra["ignored_fields"]``: those of larger count, such as descriptors).
    """
    path = Path(path)
    data = read_bytes(path)
    if not data:
        raise FileFormatError(f"{path}: the file is empty; expected a PCD file")
    head = _header(path, data)
    with context.stage("read", len(data)) as stage:
        columns = _table(path, data, head, stage)
    xyz = np.column_stack([columns.pop(c).astype(np.float64) for c in "xyz"])
    valid = np.isfinite(xyz).all(axis=1)
    keep = np.flatnonzero(valid)
    if not len(keep):
        raise FileFormatError(f"{path}: the PCD file holds no point with finite x, y, z")
    point_data: dict[str, np.ndarray] = {}
    for name, values in columns.items():
        if name in ("rgb", "rgba"):
            point_data.update(_colors(values[keep], alpha=name == "rgba"))
        elif name != "_":  # PCL's padding
            point_data[name] = values[keep]
    line_ids, grid = None, None
    if head.height > 1:
        index = np.full(head.points, -1, dtype=np.int64)
        index[keep] = np.arange(len(keep))
        grid = index.reshape(head.height, head.width)
        line_ids = keep // head.width
    return ScanPoints(
        points=xyz[keep],
        line_ids=line_ids,
        source=path,
        extra={
            "format": "pcd",
            "encoding": head.data,
            "dropped_invalid": int(head.points - len(keep)),
            "ignored_fields": [f for f, c in zip(head.fields, head.counts, strict=True) if c > 1],
            "line_ids_from": "organized cloud rows" if head.height > 1 else None,
        },
        grid=grid,
        point_data=point_data,
    )
