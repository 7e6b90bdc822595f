"""Meshes written by the workers, block by block, into one file renamed into place at the end.

Every method hands its faces over as futures of :class:`FaceBlock` (faces over its own
vertices and their global point indices, additive quality sums). Each block is written by
the worker that holds it into its own file in a hidden folder beside the output; once all
are written and their sizes known, workers copy them into a hidden temporary at their
offsets (binary STL: the 84-byte header with the total count, then 50-byte records block
after block; PLY: the header, the vertices part by part with the scan's per-point values,
then the faces block after block, over global indices; the same bytes as
:func:`scanmesh.formats.write.save_mesh` writes for the same vertices, faces and
``point_data``, but without the normals and measures :meth:`scanmesh.Surface.save` adds,
which need every face of a vertex together; copied in the kernel where it can,
``os.copy_file_range``) and the temporary is renamed onto the output. Nothing is ever
assembled in one process, and a failure or Ctrl-C anywhere removes the folder and the
temporary: the output is either the whole new mesh or untouched.

The output must be on a filesystem every worker mounts at the same path (NFS, Lustre,
CephFS, a local disk for a LocalCluster). Object stores reached through fsspec (``s3://``,
``gs://``, ``abfs://``) are refused: placing blocks needs writes at an offset into one
file, which an object does not take (it is written whole, or in a multipart upload), and a
rename there is a copy then a delete, so readers could see a half-copied mesh. An atomic
store write would be a multipart upload whose parts the workers send and whose completion
the client commits (S3 ``CompleteMultipartUpload``); fsspec has no portable API for it
(and S3 parts must be at least 5 MiB), so it is not done: write to a shared filesystem and
copy the finished file to the store.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import struct
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.errors import ParameterError
from scanmesh.formats.ply import PLY_FACE, ply_header, vertex_records
from scanmesh.formats.stl import STL_HEADER
from scanmesh.formats.write import create_temporary, remove_stale_temporaries

from ._source import Part, load_part, load_point_data

#: Output formats by ending.
FORMATS: tuple[str, ...] = (".stl", ".ply")

#: Bytes of a binary STL record (normal, three corners as float32, attribute).
STL_RECORD: int = 50
#: Attempts at removing the blocks' folder after a failure (0.1 s apart).
DISCARD_TRIES: int = 50
#: Bytes copied at a time when placing a block.
COPY_CHUNK: int = 1 << 26


@dataclass
class FaceBlock:
    """Some faces of a mesh, as the worker that made them hands them to the writers."""

    #: (k, 3) float64 coordinates and (m, 3) int64 rows of them, counter-clockwise in the
    #: projection plane: face i's corners are ``vertices[local[i]]`` (the producer's own
    #: arrays: no per-face copy is made unless a format needs it)
    vertices: np.ndarray
    local: np.ndarray
    #: the global point index of each row of ``vertices``: a (k,) int64 array, or an int
    #: when the rows are the consecutive points from that index on
    index: np.ndarray | int
    #: additive quality sums ("faces", "tac_1", "tac_2_squared", "n_interior", "slivers",
    #: ...; "tac_inf" and "min_angle_deg" combine by max and min)
    sums: dict[str, float] = field(default_factory=dict)
    #: whether the faces must be turned round when written, decided only once every block
    #: is known (strips turn their mesh by the sign of the whole scan's area); None: never
    turn_key: str | None = None

    @property
    def faces(self) -> np.ndarray:
        """(m, 3) int64 global point indices of the faces. O(m), a new array."""
        if isinstance(self.index, (int, np.integer)):
            return self.local + int(self.index)
        return self.index[self.local]


@dataclass(frozen=True)
class Written:
    """A block written to its own file: where, how many bytes and faces, its sums."""

    path: str
    size: int
    sums: dict[str, float]
    turn_key: str | None


def check_output(output: str | os.PathLike) -> Path:
    """The output path, refused unless its ending is a format written here and its folder
    exists (it must be shared with every worker), and refused for an object store URL
    (``s3://...``: see the module docstring)."""
    text = os.fspath(output)
    if "://" in text:
        raise ParameterError(
            f"output {text!r}: an object store URL cannot be written atomically by several"
            " workers (no writes at an offset into an object, no atomic rename); give a path"
            " on a filesystem every worker mounts, and copy the file to the store after"
        )
    target = Path(text)
    if target.suffix.lower() not in FORMATS:
        raise ParameterError(
            f"output must end in {' or '.join(FORMATS)} (written block by block), got {target}"
        )
    if not target.parent.is_dir():
        raise ParameterError(f"output folder {target.parent} does not exist")
    return target


def scratch_folder(target: Path) -> Path:
    """A new hidden folder beside ``target`` for the blocks (on the shared filesystem)."""
    folder = target.parent / f".{target.name}.scanmesh-{uuid.uuid4().hex[:12]}"
    folder.mkdir()
    return folder


def write_block(block: FaceBlock, path: str, kind: str) -> Written:
    """Write one block's records to ``path`` on the worker holding it. O(m)."""
    if kind == ".stl":
        records = _core.stl_records(
            np.ascontiguousarray(block.vertices, dtype=np.float64),
            np.ascontiguousarray(block.local, dtype=np.int64),
        )
        data = memoryview(records)
    else:
        out = np.empty(len(block.local), dtype=PLY_FACE)
        out["n"] = 3
        out["v"] = block.faces
        data = memoryview(out).cast("B")
    with open(path, "wb") as handle:
        handle.write(data)
    return Written(path, len(data), dict(block.sums), block.turn_key)


def write_vertices(part: Part, path: str, columns: dict[str, str]) -> Written:
    """Write one part's points as PLY vertex records: x, y, z little-endian float64, then
    its per-point values named in ``columns``, each in the PLY type given there (numpy
    type strings, the same for every part)."""
    points, _ = load_part(part)
    if columns:
        values = load_point_data(part)
        typed = {k: np.asarray(values[k]).astype(t) for k, t in columns.items()}
        data = memoryview(vertex_records(points, typed)).cast("B")
    else:
        data = memoryview(np.ascontiguousarray(points, dtype="<f8")).cast("B")
    with open(path, "wb") as handle:
        handle.write(data)
    return Written(path, len(data), {}, None)


def place(source: str, target: str, offset: int, turn: bool, kind: str) -> int:
    """Copy a block's file into ``target`` at ``offset`` (turning its faces round when
    ``turn``). Runs on a worker; returns the bytes copied. The block stays until the whole
    folder goes: a worker lost after placing it may be asked again."""
    size = os.path.getsize(source)
    fd_out = os.open(target, os.O_WRONLY)
    try:
        with open(source, "rb") as handle:
            done = 0
            while done < size:
                if not turn and _COPY_RANGE is not None:
                    # in the kernel, with no pass through this process's memory; a
                    # filesystem that refuses it is copied through memory
                    with contextlib.suppress(OSError):
                        copied = _COPY_RANGE(
                            handle.fileno(),
                            fd_out,
                            min(COPY_CHUNK, size - done),
                            done,
                            offset + done,
                        )
                        if copied > 0:
                            done += copied
                            continue
                chunk = os.pread(handle.fileno(), min(COPY_CHUNK, size - done), done)
                if turn:
                    chunk = _turned(chunk, kind)
                os.pwrite(fd_out, chunk, offset + done)
                done += len(chunk)
    finally:
        os.close(fd_out)
    return size


#: os.copy_file_range where the platform has it (Linux), else None: copy through memory.
_COPY_RANGE: Callable[..., int] | None = getattr(os, "copy_file_range", None)


def _turned(chunk: bytes, kind: str) -> bytes:
    """Records with each face's second and third corner swapped (and STL normals negated:
    the cross product of swapped edges is the exact negative)."""
    if kind == ".stl":
        rec = np.frombuffer(chunk, dtype=np.uint8).reshape(-1, STL_RECORD).copy()
        floats = rec[:, :48].view("<f4")
        floats[:, :3] = 0.0 - floats[:, :3]  # -x, and +0 for a zero normal
        floats[:, [6, 7, 8, 9, 10, 11]] = floats[:, [9, 10, 11, 6, 7, 8]]
        return rec.tobytes()
    faces = np.frombuffer(chunk, dtype=PLY_FACE).copy()
    faces["v"][:, [1, 2]] = faces["v"][:, [2, 1]]
    return faces.tobytes()


class StreamedMesh:
    """One mesh file written by the workers: blocks as they come, placed and renamed at the
    end (:meth:`finish`); :meth:`discard` (on any failure) removes every trace."""

    def __init__(
        self,
        client: Any,
        output: str | os.PathLike,
        parts: list[Part],
        columns: dict[str, str] | None = None,
        comments: tuple[str, ...] = (),
    ) -> None:
        """``columns``: the per-point values a PLY output carries, by name, each with its
        PLY type as a numpy type string (:func:`._source.common_point_data`); ``comments``:
        its header comment lines (the CRS and units, :func:`._source.common_georef`)."""
        self.client = client
        self.target = check_output(output)
        self.kind = self.target.suffix.lower()
        self.columns = dict(columns or {}) if self.kind == ".ply" else {}
        self.comments = comments
        self.folder = scratch_folder(self.target)
        self.temporary: Path | None = None  # created by finish (create_temporary)
        self.parts = parts
        self.blocks: list[Any] = []
        self.vertices: list[Any] = []
        if self.kind == ".ply":
            self.vertices = [
                client.submit(
                    write_vertices,
                    part,
                    str(self.folder / f"vertices_{part.index:06d}.bin"),
                    self.columns,
                    key=f"scanmesh-vertices-{part.index}-{uuid.uuid4().hex}",
                )
                for part in parts
            ]

    def add(self, block: Any) -> Any:
        """Have the worker holding ``block`` (a future of FaceBlock) write it; returns the
        future of its :class:`Written`."""
        i = len(self.blocks)
        written = self.client.submit(
            write_block,
            block,
            str(self.folder / f"faces_{i:06d}.bin"),
            self.kind,
            key=f"scanmesh-write-{i}-{uuid.uuid4().hex}",
        )
        self.blocks.append(written)
        return written

    def finish(self, turns: Callable[[list[Written]], list[bool]]) -> list[Written]:
        """Wait for every block, write the header, have the workers place the blocks, and
        rename the temporary onto the output. ``turns`` says, from every block's record,
        which are turned round as they are placed. Returns the blocks' :class:`Written`
        records, in order."""
        written: list[Written] = self.client.gather(self.blocks)
        vertices: list[Written] = self.client.gather(self.vertices)
        n_faces = sum(w.size for w in written) // (
            STL_RECORD if self.kind == ".stl" else PLY_FACE.itemsize
        )
        if self.kind == ".stl":
            header = STL_HEADER + struct.pack("<I", n_faces)
        else:
            typed = {k: np.empty(0, dtype=t) for k, t in self.columns.items()}
            header = ply_header(
                sum(p.count for p in self.parts), n_faces, point_data=typed, comments=self.comments
            )
        total = len(header) + sum(w.size for w in vertices) + sum(w.size for w in written)
        fd, self.temporary = create_temporary(self.target)  # the replaced file's mode kept
        with os.fdopen(fd, "wb") as handle:
            handle.write(header)
            handle.truncate(total)
        offset, placing = len(header), []
        flags = [False] * len(vertices) + list(turns(written))
        for w, flag in zip([*vertices, *written], flags, strict=True):
            placing.append(
                self.client.submit(
                    place,
                    w.path,
                    str(self.temporary),
                    offset,
                    flag,
                    self.kind,
                    key=f"scanmesh-place-{offset}-{uuid.uuid4().hex}",
                    pure=False,
                )
            )
            offset += w.size
        self.client.gather(placing)
        with open(self.temporary, "rb+") as handle:
            os.fsync(handle.fileno())
        os.replace(self.temporary, self.target)
        shutil.rmtree(self.folder, ignore_errors=True)
        remove_stale_temporaries(self.target)
        return written

    def discard(self) -> None:
        """Remove the blocks and the temporary (the output is left as it was). A block
        still being written when the folder goes fails to open its file; one that opened it
        just before can make the first removal miss the folder, so it is tried again."""
        for _ in range(DISCARD_TRIES):
            shutil.rmtree(self.folder, ignore_errors=True)
            if not self.folder.exists():
                break
            time.sleep(0.1)
        if self.temporary is not None:
            with contextlib.suppress(FileNotFoundError):
                self.temporary.unlink()
