"""Stanford ``.conf`` files: where each range scan of a part sits in the part's coordinates.

The format of the Stanford 3D Scanning Repository (scanalyze, vrip)::

    camera tx ty tz qi qj qk qr
    mesh dragonStandRight_cybcyl tx ty tz qi qj qk qr
    bmesh bun000.ply 0 0 0 0 0 0 1
    bmesh bun045.ply -0.0520211 -0.000383981 -0.0109223 0.00548449 -0.294635 -0.0038555 0.955586

The ``camera`` line is the viewer's camera and a ``mesh`` line a mesh the viewer loaded
(the dragon's ``..._cybcyl``, the scanner's cylinder): neither is a scan, both are skipped.
Each ``bmesh`` line names a range scan (relative to the ``.conf`` file's folder; a missing
``FILE.ply`` is read from ``FILE.ply.gz`` when that exists, as many copies ship them) and
its pose: a translation ``t`` and a unit quaternion ``q = qr + qi i + qj j + qk k``.

The convention: a scan point ``p`` goes to ``world = R(q)ᵀ p + t``, ``R(q)`` the usual
rotation matrix of ``q`` (scipy's ``Rotation.from_quat([qi, qj, qk, qr]).as_matrix()``).
Measured on the three sets in ``../shared/data/multiview`` (each view's share of 3,000
points within 1 mm of the next view's points / of any other view's): the dragon's stand
series 46-94 % / at least 97.7 %, its side series 55-90 % / at least 94.2 %, the happy
Buddha 32-92 % / at least 87 %; with ``R(q) p + t`` 0-4 % / a median of 1.2-11.4 %
(a report on the bunny, astaka-pe/stanford_recon, found the same). ``inverse_rotation=
False`` reads a file as ``R(q) p + t``, for files written that way.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from scanmesh.errors import FileFormatError
from scanmesh.formats._source import quote, read_bytes

#: How far a quaternion's length may be from 1 before the file is refused (they are
#: written with 6 significant digits).
QUATERNION_TOL = 1e-3

#: Largest translation read (README: coordinates from 1e-300 to 1e300).
MAX_TRANSLATION = 1e300


def quaternion_matrix(q: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of the unit quaternion ``q = (qi, qj, qk, qr)`` (vector part first)."""
    x, y, z, w = (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def conf_poses(
    path: str | os.PathLike, *, inverse_rotation: bool = True
) -> list[tuple[Path, np.ndarray]]:
    """The scans a ``.conf`` file lists, as (scan path, (4, 4) scanner-to-world pose):
    ``world = R(q)ᵀ p + t``, or ``R(q) p + t`` with ``inverse_rotation=False``. A scan
    named ``FILE`` that does not exist is ``FILE.gz`` when that does.

    Raises FileFormatError naming the file, the line and the value for an unknown keyword,
    a missing or non-numeric field, a quaternion not of unit length, or no ``bmesh`` line.
    """
    path = Path(path)
    data = read_bytes(path)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(f"{path}: not a text .conf file ({exc.reason})") from None
    out = []
    for no, raw in enumerate(text.splitlines(), start=1):
        words = raw.split()
        if not words or words[0].startswith("#"):
            continue
        where = f"{path}, line {no}"
        if words[0] in ("camera", "mesh"):
            continue
        if words[0] != "bmesh":
            raise FileFormatError(
                f"{where}: expected 'camera', 'mesh' or 'bmesh', got {quote(raw)}"
            )
        if len(words) != 9:
            raise FileFormatError(
                f"{where}: 'bmesh file tx ty tz qi qj qk qr' needs 9 fields, got {len(words)}:"
                f" {quote(raw)}"
            )
        try:
            values = np.array([float(w) for w in words[2:]])
        except ValueError:
            bad = next(w for w in words[2:] if not _is_number(w))
            raise FileFormatError(f"{where}: {bad!r} is not a number") from None
        if not np.isfinite(values).all():
            raise FileFormatError(f"{where}: pose values must be finite, got {quote(raw)}")
        if np.abs(values[:3]).max() > MAX_TRANSLATION:
            raise FileFormatError(
                f"{where}: translation {values[:3].tolist()} is beyond the"
                f" {MAX_TRANSLATION:g} scanmesh reads coordinates to"
            )
        q = values[3:]
        length = float(np.linalg.norm(q))
        if abs(length - 1.0) > QUATERNION_TOL:
            raise FileFormatError(
                f"{where}: the quaternion (qi qj qk qr) = {q.tolist()} has length {length:.6g},"
                " not 1"
            )
        rotation = quaternion_matrix(q / length)
        pose = np.eye(4)
        pose[:3, :3] = rotation.T if inverse_rotation else rotation
        pose[:3, 3] = values[:3]
        scan = path.parent / words[1]
        packed = scan.with_name(scan.name + ".gz")
        out.append((packed if not scan.exists() and packed.exists() else scan, pose))
    if not out:
        raise FileFormatError(f"{path}: no 'bmesh' line: the file lists no scan")
    return out


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True
