"""PLY: reading the vertices (and a Stanford range grid's scan lines), writing meshes.

Reading: ASCII or binary, every element walked so that a file cut short anywhere is
reported, every declared element count checked against the bytes left before anything is
allocated. A ``range_grid`` element (``obj_info num_cols`` / ``num_rows``, one list of 0
or 1 vertex index per cell, row by row) gives the scan lines and is kept as
``ScanPoints.grid``. Which grid direction is a scan line: a digitizer records one frame
(one laser stripe) at a time, and a scan line is a frame. In Cyberware data (headers with
``obj_info is_cyberware_data 1`` or ``echo_*`` fields, as in the Stanford range scans) x
steps by ``echo_lgincr`` along a row and is constant down a column: a frame is a column.
Other range grids are taken row by row, the PLY convention; ``lines="rows"`` or
``"columns"`` says so explicitly. A range grid is a range image in its scanner's frame: the
rays run along z and the scanner looks down from +z (the Stanford scans: a scan's points
hidden from its neighbour's scanner lie below that neighbour's samples in z, 4 to 38 times
as many as above, docs/benchmarks/curtains.md), so its ``up`` is +z unless a ``comment
scanmesh up`` line says otherwise. That is the line of sight the grid triangulation and
the curtain rules judge faces against; without it they judged against the projection
plane's normal, up to 71 degrees off the rays on the Stanford scans, and kept curtains.

Writing: binary little-endian PLY, double coordinates (exact), optional vertex normals,
per-vertex values and header comments (a georeference, read back as ``ScanPoints.georef``),
in blocks so that memory stays bounded and Ctrl-C is honoured between blocks.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._context import QUIET, Context
from scanmesh._progress import Stage
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import (
    check_declared,
    check_finite,
    check_text,
    line_at,
    quote,
    read_bytes,
)
from scanmesh.formats.georef import from_comments
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.table import parse_free, parse_rows, skip_lines, tokens_per_line
from scanmesh.formats.xyz import parse_up

_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}

#: Faces per block when writing (bounds memory and the time between Ctrl-C checks).
FACES_PER_BLOCK: int = 1 << 17


@dataclass
class _PlyElement:
    name: str
    count: int
    # (name, dtype) for scalars; (name, count dtype, item dtype) for lists
    props: list[tuple[str, ...]]
    line: int  # header line of the element

    @property
    def scalar_only(self) -> bool:
        return all(len(p) == 2 for p in self.props)


@dataclass
class _Header:
    fmt: str
    elements: list[_PlyElement]
    info: dict[str, str]
    comments: list[str]
    body: int  # offset of the body


def _ply_header(path: Path, data: bytes) -> _Header:
    """Parse a PLY header line by line, up to the line that is exactly ``end_header``."""
    if not data.startswith(b"ply"):
        raise FileFormatError(f"{path}, line 1: not a PLY file (it must start with 'ply')")
    fmt, elements, info, comments = None, [], {}, []
    pos, no = data.find(b"\n") + 1, 2
    if pos == 0:
        raise FileFormatError(f"{path}: PLY header has no 'end_header' line (truncated?)")
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise FileFormatError(f"{path}: PLY header has no 'end_header' line (truncated?)")
        raw_bytes = data[pos:end]
        pos = end + 1
        try:
            raw = raw_bytes.decode("ascii")
        except UnicodeDecodeError:
            raise FileFormatError(f"{path}, line {no}: PLY header holds non-ASCII bytes") from None
        words = raw.split()
        if words == ["end_header"]:
            break
        if words and words[0] == "comment":
            comments.append(raw.strip()[len("comment") :].strip())
        elif words:
            _header_line(path, no, raw, words, elements, info)
            if words[0] == "format":
                fmt = words[1]
        no += 1
    if fmt is None:
        raise FileFormatError(f"{path}: PLY header has no 'format' line")
    return _Header(fmt, elements, info, comments, pos)


def _header_line(
    path: Path, no: int, raw: str, words: list[str], elements: list, info: dict
) -> None:
    """Apply one non-comment header line."""
    key = words[0]
    try:
        if key == "format":
            if words[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise ValueError(f"unknown format {words[1]!r}")
        elif key == "obj_info":
            if len(words) >= 3:
                info[words[1]] = words[2]
        elif key == "element":
            elements.append(_PlyElement(words[1], int(words[2]), [], no))
            if elements[-1].count < 0:
                raise ValueError("negative count")
        elif key == "property":
            if not elements:
                raise ValueError("property before any element")
            if words[1] == "list":
                elements[-1].props.append((words[4], _PLY_TYPES[words[2]], _PLY_TYPES[words[3]]))
            else:
                elements[-1].props.append((words[2], _PLY_TYPES[words[1]]))
        else:
            raise ValueError(f"unknown keyword {key!r}")
    except (IndexError, KeyError, ValueError) as exc:
        raise FileFormatError(
            f"{path}, line {no}: bad PLY header line ({exc}): {quote(raw)}"
        ) from None


def _min_item_bytes(el: _PlyElement, binary: bool) -> int:
    """The fewest bytes one item of ``el`` can take (binary: its fixed part; text: 2 per
    value, a digit and a separator)."""
    if binary:
        return sum(np.dtype(p[1]).itemsize for p in el.props)
    return 2 * len(el.props)


def _ply_binary_element(
    path: Path, data: bytes, pos: int, el: _PlyElement, order: str
) -> tuple[np.ndarray | list[np.ndarray], int]:
    """Read one binary element at ``pos``: a structured array, or for a single-list element a
    list of (k,) arrays. Returns it and the offset after it."""

    def short(need: int, have: int) -> FileFormatError:
        return FileFormatError(
            f"{path}: truncated PLY: element {el.name!r} ({el.count} items) needs {need} bytes"
            f" at offset {pos}, only {have} remain"
        )

    if el.scalar_only:
        dtype = np.dtype([(name, order + t) for name, t in el.props])
        need = dtype.itemsize * el.count
        if len(data) - pos < need:
            raise short(need, len(data) - pos)
        return np.frombuffer(data, dtype=dtype, count=el.count, offset=pos), pos + need
    if len(el.props) != 1:
        return _mixed_element(path, data, pos, el, order, short)
    _, ctype, itype = el.props[0]
    cdt, idt = np.dtype(order + ctype), np.dtype(order + itype)
    if el.count == 0:
        return [], pos
    if len(data) - pos < cdt.itemsize:
        raise short(cdt.itemsize, len(data) - pos)
    k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
    # fast path: every item has the same length k (triangle faces)
    fixed = np.dtype([("n", cdt), ("v", idt, (k,))]) if 0 < k < 1 << 16 else None
    if fixed is not None and len(data) - pos >= fixed.itemsize * el.count:
        block = np.frombuffer(data, dtype=fixed, count=el.count, offset=pos)
        if np.all(block["n"] == k):
            return list(block["v"]), pos + fixed.itemsize * el.count
    items = []
    for _ in range(el.count):  # variable-length lists (range grids): one step per item
        if len(data) - pos < cdt.itemsize:
            raise short(cdt.itemsize, len(data) - pos)
        k = int(np.frombuffer(data, dtype=cdt, count=1, offset=pos)[0])
        pos += cdt.itemsize
        if k < 0 or len(data) - pos < k * idt.itemsize:
            raise short(k * idt.itemsize, len(data) - pos)
        items.append(np.frombuffer(data, dtype=idt, count=k, offset=pos))
        pos += k * idt.itemsize
    return items, pos


def _mixed_element(
    path: Path, data: bytes, pos: int, el: _PlyElement, order: str, short: Any
) -> tuple[np.ndarray, int]:
    """A binary element mixing lists and scalars (faces with a colour or trimesh's ``stl``
    attribute): one structured array when every item's lists have the first item's
    lengths (triangles), as is the rule in practice; FileFormatError otherwise."""
    if el.count == 0:
        return np.empty(0), pos
    fields: list[tuple[Any, ...]] = []
    lengths: dict[str, int] = {}  # count field -> the first item's list length
    at = pos
    for k, prop in enumerate(el.props):
        if len(prop) == 2:
            fields.append((prop[0], order + prop[1]))
            at += np.dtype(prop[1]).itemsize
            continue
        cdt, idt = np.dtype(order + prop[1]), np.dtype(order + prop[2])
        if len(data) - at < cdt.itemsize:
            raise short(at - pos + cdt.itemsize, len(data) - pos)
        n = int(np.frombuffer(data, dtype=cdt, count=1, offset=at)[0])
        fields += [(f"_count_{k}", cdt), (prop[0], idt, (n,))]
        lengths[f"_count_{k}"] = n
        at += cdt.itemsize + n * idt.itemsize
    record = np.dtype(fields)
    need = record.itemsize * el.count
    if len(data) - pos < need:
        raise short(need, len(data) - pos)
    items = np.frombuffer(data, dtype=record, count=el.count, offset=pos)
    for name, length in lengths.items():
        if not (items[name] == length).all():
            raise FileFormatError(
                f"{path}, line {el.line}: PLY element {el.name!r} mixes scalar properties"
                " with lists of varying length; only lists of one length are supported there"
            )
    return items, pos + need


def _ascii_lists(path: Path, data: bytes, a: int, b: int, el: _PlyElement) -> list[np.ndarray]:
    """An ASCII single-list element (one ``count i0 i1 ...`` line per item) as arrays."""
    if len(el.props) != 1 or len(el.props[0]) != 3:
        raise FileFormatError(
            f"{path}, line {el.line}: PLY element {el.name!r} must hold one list property"
        )
    if el.count == 0:
        return []
    counts = tokens_per_line(data, a, b)
    flat = parse_free(path, data, a, b, f" in PLY element {el.name!r}")
    first = np.cumsum(counts) - counts
    declared = np.where(counts > 0, flat[np.minimum(first, max(len(flat) - 1, 0))], -1)
    bad = np.flatnonzero((counts == 0) | (declared != counts - 1))
    if len(bad):
        line, _ = line_at(data, a)
        text = data[a:b].split(b"\n")[int(bad[0])]
        raise FileFormatError(
            f"{path}, line {line + int(bad[0])}: a {el.name!r} list must start with its"
            f" length: {quote(text)}"
        )
    rest = np.delete(flat, first).astype(np.int64)
    return np.split(rest, np.cumsum(counts - 1)[:-1])


#: (3,) direction towards the scanner of a range grid without a ``scanmesh up`` comment:
#: +z of the range image's frame (the module doc).
RANGE_IMAGE_UP = np.array([0.0, 0.0, 1.0])


def _is_cyberware(info: dict[str, str]) -> bool:
    """True for a Cyberware range image (frames are grid columns)."""
    return info.get("is_cyberware_data") == "1" or any(k.startswith("echo_") for k in info)


def read_ply(
    path: str | os.PathLike, *, lines: str = "auto", context: Context = QUIET
) -> ScanPoints:
    """Read the vertices of a PLY file (ASCII, binary little- or big-endian).

    Parameters
    ----------
    path : str or PathLike
        The file.
    lines : {"auto", "rows", "columns"}
        Which direction of a range grid is a scan line (see the module doc); "auto": columns
        for Cyberware data, rows otherwise.
    context : Context
        The call's progress, as in :func:`scanmesh.read` (bytes of an ASCII vertex list,
        chunk by chunk).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 from the vertex ``x``, ``y``, ``z`` properties;
        ``line_ids`` (N,) int64 frame index and ``grid`` (frames, positions) for a range
        grid, else None; ``up`` from a ``comment scanmesh up x y z`` header line, else
        (0, 0, 1) for a range grid (the module doc), else None;
        ``extra["faces_ignored"]`` the file's face count (faces are not read here).
    """
    if lines not in ("auto", "rows", "columns"):
        raise ParameterError(f"lines must be 'auto', 'rows' or 'columns', got {lines!r}")
    path = Path(path)
    data = read_bytes(path)
    if not data:
        raise FileFormatError(f"{path}: the file is empty; expected a PLY file")
    head = _ply_header(path, data)
    names = [el.name for el in head.elements]
    if "vertex" not in names:
        raise FileFormatError(f"{path}: PLY file has no 'vertex' element")
    vertex_el = head.elements[names.index("vertex")]
    if vertex_el.count == 0:
        raise FileFormatError(f"{path}, line {vertex_el.line}: the PLY file holds no vertices")
    prop_names = [p[0] for p in vertex_el.props]
    missing = [c for c in "xyz" if c not in prop_names]
    if missing:
        raise FileFormatError(
            f"{path}, line {vertex_el.line}: PLY vertex element has no {'/'.join(missing)}"
            f" property (has {', '.join(prop_names)})"
        )
    binary = head.fmt != "ascii"
    pos = head.body
    left = len(data) - pos
    for el in head.elements:  # the one bound: declared counts against the bytes left
        need = _min_item_bytes(el, binary)
        check_declared(path, el.count, need, left, f"{el.name!r} items", f", line {el.line}")
        left -= el.count * need
    grid = None
    if not binary:
        check_text(path, data, "an ASCII PLY body", start=pos)
        for el in head.elements:
            end = skip_lines(path, data, pos, el.count, f"PLY element {el.name!r}")
            if el.name == "vertex":
                if not el.scalar_only:
                    raise FileFormatError(
                        f"{path}, line {el.line}: list properties in the vertex element are not"
                        " supported"
                    )
                vertices = _ascii_vertices(path, data, pos, end, el, context)
            elif el.name == "range_grid":
                grid = _ascii_lists(path, data, pos, end, el)
            pos = end
        cols = [prop_names.index(c) for c in "xyz"]
        points = np.ascontiguousarray(vertices[:, cols])
        data_of = {p[0]: vertices[:, k].astype(p[1]) for k, p in enumerate(vertex_el.props)}
    else:
        order = "<" if head.fmt == "binary_little_endian" else ">"
        with context.stage("read", len(data), blocking=True):
            for el in head.elements:
                got, pos = _ply_binary_element(path, data, pos, el, order)
                if el.name == "vertex":
                    vertices = got
                elif el.name == "range_grid":
                    grid = got
        points = np.column_stack([vertices[c].astype(np.float64) for c in "xyz"])
        data_of = {p[0]: vertices[p[0]].astype(p[1]) for p in vertex_el.props}
    check_finite(path, points, "vertex")
    faces = sum(el.count for el in head.elements if el.name == "face")
    extra: dict[str, Any] = {
        "format": "ply",
        "encoding": head.fmt,
        "obj_info": head.info,
        "faces_ignored": faces,
    }
    line_ids, cells = None, None
    up = parse_up(path, head.comments)
    if grid is not None:
        if up is None:
            up = RANGE_IMAGE_UP
        by_columns = lines == "columns" or (lines == "auto" and _is_cyberware(head.info))
        line_ids, cells = _range_grid_lines(path, grid, head.info, len(points), by_columns)
        extra["line_ids_from"] = (
            "range_grid columns (Cyberware frames)" if by_columns else "range_grid rows"
        )
    else:
        extra["line_ids_from"] = None
    return ScanPoints(
        points=points,
        line_ids=line_ids,
        source=path,
        extra=extra,
        grid=cells,
        up=up,
        georef=from_comments(head.comments),
        point_data={k: v for k, v in data_of.items() if k not in ("x", "y", "z")},
    )


def _ascii_vertices(
    path: Path, data: bytes, a: int, b: int, el: _PlyElement, context: Context
) -> np.ndarray:
    """The (count, nprops) values of an ASCII vertex element in ``data[a:b]``."""
    nprops = len(el.props)
    line_no, _ = line_at(data, a)
    with context.stage("read", b) as stage:
        rows = parse_rows(
            path,
            data,
            a,
            b,
            nprops,
            None,
            line_no,
            f"{nprops} vertex values",
            stage,
            " in a PLY vertex",
        )
    if len(rows.values) != el.count:
        bad = rows.first_blank if rows.first_blank is not None else line_no + el.count - 1
        raise FileFormatError(
            f"{path}, line {bad}: expected {nprops} vertex values, found 0 (element 'vertex'"
            f" declares {el.count} lines)"
        )
    return rows.values


def _range_grid_lines(
    path: Path, grid: list[np.ndarray], info: dict[str, str], n: int, by_columns: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Line id of each vertex and the (lines, positions) grid of vertex indices."""
    try:
        cols, rows = int(info["num_cols"]), int(info["num_rows"])
    except (KeyError, ValueError):
        raise FileFormatError(
            f"{path}: PLY range_grid needs 'obj_info num_cols' and 'obj_info num_rows'"
            f" in the header (found {info})"
        ) from None
    if rows < 1 or cols < 1:
        raise FileFormatError(
            f"{path}: PLY range_grid declares num_rows {rows} and num_cols {cols}; both must be"
            " at least 1"
        )
    if len(grid) != rows * cols:
        raise FileFormatError(
            f"{path}: PLY range_grid has {len(grid)} entries, not num_rows x num_cols ="
            f" {rows} x {cols} = {rows * cols}"
        )
    sizes = np.fromiter((len(g) for g in grid), dtype=np.int64, count=len(grid))
    if sizes.size and sizes.max() > 1:
        cell = int(np.argmax(sizes > 1))
        raise FileFormatError(
            f"{path}: PLY range_grid cell {cell} lists {sizes[cell]} vertices; at most 1 allowed"
        )
    cells = np.flatnonzero(sizes == 1)
    index = np.concatenate([grid[c] for c in cells]).astype(np.int64) if len(cells) else cells
    out_of_range = np.flatnonzero((index < 0) | (index >= n))
    if len(out_of_range):
        c = int(cells[out_of_range[0]])
        raise FileFormatError(
            f"{path}: PLY range_grid cell {c} points to vertex {index[out_of_range[0]]},"
            f" outside 0..{n - 1}"
        )
    seen = np.bincount(index, minlength=n)
    if (seen != 1).any():
        v = int(np.flatnonzero(seen != 1)[0])
        raise FileFormatError(
            f"{path}: PLY range_grid names vertex {v} {int(seen[v])} times (every vertex must"
            f" appear exactly once; {int((seen == 0).sum())} vertices are missing)"
        )
    table = np.full(rows * cols, -1, dtype=np.int64)
    table[cells] = index
    table = table.reshape(rows, cols)
    line_ids = np.full(n, -1, dtype=np.int64)
    line_ids[index] = cells % cols if by_columns else cells // cols
    return line_ids, np.ascontiguousarray(table.T if by_columns else table)


#: A face record of the binary PLY written here: the count 3, then three int32 indices.
PLY_FACE = np.dtype([("n", "u1"), ("v", "<i4", (3,))])


#: numpy kind and size -> the PLY type written for a point_data column.
PLY_TYPE_NAMES = {
    "u1": "uchar",
    "i1": "char",
    "u2": "ushort",
    "i2": "short",
    "u4": "uint",
    "i4": "int",
    "f4": "float",
    "f8": "double",
}


def ply_column(values: np.ndarray) -> np.ndarray:
    """``values`` in a type PLY has: 64-bit integers as int/uint when they fit, else double
    (PLY has no 64-bit integer); other types as they are, little-endian."""
    code = f"{values.dtype.kind}{values.dtype.itemsize}"
    if code not in PLY_TYPE_NAMES:
        small = "u4" if values.dtype.kind == "u" else "i4"
        info = np.iinfo(small)
        fits = values.dtype.kind in "iu" and (
            not values.size or (values.min() >= info.min and values.max() <= info.max)
        )
        values = values.astype(small if fits else "f8")
    return values.astype(values.dtype.newbyteorder("<"), copy=False)


def ply_header(
    n_vertices: int,
    n_faces: int,
    normals: bool = False,
    point_data: dict[str, np.ndarray] | None = None,
    comments: Sequence[str] = (),
    face_data: dict[str, np.ndarray] | None = None,
) -> bytes:
    """The header of the binary PLY written here: ``comment`` lines (``comments``: one-line
    ASCII texts), double x, y, z (and nx, ny, nz) per vertex, then each ``point_data``
    column (already :func:`ply_column`), then triangles as uchar-counted int lists followed
    by each ``face_data`` column (the same way)."""
    head = ["ply", "format binary_little_endian 1.0", "comment written by scanmesh"]
    head += [f"comment {c}" for c in comments]
    head += [f"element vertex {n_vertices}"]
    head += [f"property double {c}" for c in ("x", "y", "z")]
    if normals:
        head += [f"property double {c}" for c in ("nx", "ny", "nz")]
    for name, values in (point_data or {}).items():
        code = f"{values.dtype.kind}{values.dtype.itemsize}"
        head.append(f"property {PLY_TYPE_NAMES[code]} {name}")
    head += [f"element face {n_faces}", "property list uchar int vertex_indices"]
    for name, values in (face_data or {}).items():
        code = f"{values.dtype.kind}{values.dtype.itemsize}"
        head.append(f"property {PLY_TYPE_NAMES[code]} {name}")
    head.append("end_header")
    return ("\n".join(head) + "\n").encode("ascii")


def vertex_records(coords: np.ndarray, columns: dict[str, np.ndarray]) -> np.ndarray:
    """The binary vertex records :func:`ply_header` declares for (n, 3) coordinates or (n,
    6) coordinates and normals, and the (n,) ``columns`` (already :func:`ply_column`), as
    one structured array. O(n)."""
    names = ["x", "y", "z", "nx", "ny", "nz"][: coords.shape[1]]
    record = np.dtype([(n, "<f8") for n in names] + [(k, v.dtype) for k, v in columns.items()])
    out = np.empty(len(coords), dtype=record)
    for k, name in enumerate(names):
        out[name] = coords[:, k]
    for name, values in columns.items():
        out[name] = values
    return out


def ply_chunks(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None,
    stage: Stage,
    point_data: dict[str, np.ndarray] | None = None,
    comments: Sequence[str] = (),
    face_data: dict[str, np.ndarray] | None = None,
) -> Iterator[bytes | memoryview]:
    """Binary little-endian PLY of a triangle mesh, block by block, with vertex normals,
    per-vertex ``point_data`` columns (each (N,)), per-face ``face_data`` columns (each
    (M,)), in PLY types by :func:`ply_column`, and header ``comments`` when given."""
    columns = {k: ply_column(np.asarray(v)) for k, v in (point_data or {}).items()}
    face_columns = {k: ply_column(np.asarray(v)) for k, v in (face_data or {}).items()}
    yield ply_header(
        len(vertices), len(faces), normals is not None, columns, comments, face_columns
    )
    coords = vertices if normals is None else np.hstack([vertices, normals])
    if not columns:
        yield memoryview(np.ascontiguousarray(coords, dtype="<f8")).cast("B")
    else:
        for start in range(0, len(vertices), FACES_PER_BLOCK):
            stop = min(start + FACES_PER_BLOCK, len(vertices))
            part = {k: v[start:stop] for k, v in columns.items()}
            yield memoryview(vertex_records(coords[start:stop], part)).cast("B")
    face_record = np.dtype(PLY_FACE.descr + [(k, v.dtype) for k, v in face_columns.items()])
    for start in range(0, len(faces), FACES_PER_BLOCK):
        block = faces[start : start + FACES_PER_BLOCK]
        out = np.empty(len(block), dtype=face_record)
        out["n"] = 3
        out["v"] = block
        for name, values in face_columns.items():
            out[name] = values[start : start + len(block)]
        yield memoryview(out).cast("B")
        stage.update(start + len(block))
