"""Wavefront OBJ meshes: ``v`` (and ``vn``) lines, then 1-based ``f`` lines, in blocks."""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from scanmesh._progress import Stage

#: Rows (vertices or faces) formatted per block: about 0.05 s of text each, so Ctrl-C
#: and progress answer between blocks and the strings' memory stays bounded.
ROWS_PER_BLOCK: int = 1 << 16


def text_rows(values: np.ndarray, row: str) -> Iterator[bytes]:
    """``row % values[i]`` for every row of (R, k) ``values``, in blocks of text."""
    for start in range(0, len(values), ROWS_PER_BLOCK):
        block = values[start : start + ROWS_PER_BLOCK]
        yield ((row * len(block)) % tuple(block.ravel().tolist())).encode("ascii")


def obj_chunks(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray | None,
    stage: Stage,
    comments: Sequence[str] = (),
) -> Iterator[bytes]:
    """OBJ text: ``#`` comment lines (``comments``: one-line ASCII texts), then
    coordinates with 17 significant digits (read back exactly)."""
    yield "".join(f"# {c}\n" for c in ("written by scanmesh", *comments)).encode("ascii")
    yield from text_rows(vertices, "v %.17g %.17g %.17g\n")
    if normals is not None:
        yield from text_rows(normals, "vn %.17g %.17g %.17g\n")
    row = "f %d//%d %d//%d %d//%d\n" if normals is not None else "f %d %d %d\n"
    one_based = faces.astype(np.int64) + 1
    if normals is not None:
        one_based = np.repeat(one_based, 2, axis=1)
    done = 0
    for text in text_rows(one_based, row):
        yield text
        done = min(done + ROWS_PER_BLOCK, len(faces))
        stage.update(done)
