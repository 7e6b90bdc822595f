"""OFF meshes (NOFF with vertex normals): counts, vertex rows, ``3 a b c`` face rows."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from scanmesh._progress import Stage
from scanmesh.formats.obj import ROWS_PER_BLOCK, text_rows


def off_chunks(
    vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray | None, stage: Stage
) -> Iterator[bytes]:
    """OFF text, coordinates with 17 significant digits (read back exactly)."""
    head = "NOFF" if normals is not None else "OFF"
    yield f"{head}\n{len(vertices)} {len(faces)} 0\n".encode("ascii")
    if normals is None:
        yield from text_rows(vertices, "%.17g %.17g %.17g\n")
    else:
        yield from text_rows(
            np.hstack([vertices, normals]), "%.17g %.17g %.17g %.17g %.17g %.17g\n"
        )
    done = 0
    for text in text_rows(faces.astype(np.int64), "3 %d %d %d\n"):
        yield text
        done = min(done + ROWS_PER_BLOCK, len(faces))
        stage.update(done)
