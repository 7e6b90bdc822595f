"""USGS ASCII DEM: one scan line per elevation profile (B record)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_declared, check_text, quote, read_bytes
from scanmesh.formats.georef import Georef
from scanmesh.formats.points import ScanPoints

#: Elevation that marks a void (no data) in USGS DEM profiles.
DEM_VOID: int = -32767


# A record fields, 0-based [start, stop) byte offsets (1024-byte logical record).
_DEM_A = {
    "level": (144, 150),
    "pattern": (150, 156),
    "reference_system": (156, 162),
    "zone": (162, 168),
    "planimetric_units": (528, 534),
    "elevation_units": (534, 540),
    "sides": (540, 546),
    "corners": (546, 738),
    "elevation_range": (738, 786),
    "resolution": (816, 852),
    "rows_columns": (852, 864),
}
_DEM_UNITS = {0: "radians", 1: "feet", 2: "metres", 3: "arc-seconds"}

#: The A record's horizontal datum code (bytes 891-892, newer DEMs only) -> its name and
#: the EPSG code prefix of its UTM zones (None: no EPSG UTM series).
_DEM_DATUMS = {
    1: ("NAD27", 267),
    2: ("WGS72", 322),
    3: ("WGS84", 326),
    4: ("NAD83", 269),
    5: ("Old Hawaiian", None),
    6: ("Puerto Rico", None),
}

#: Unit names as :mod:`scanmesh.formats.georef` writes them, by DEM unit code.
_GEOREF_UNITS = {0: "radian", 1: "foot", 2: "metre", 3: "arc-second"}


def _georef(a: bytes, refsys: int, zone: int, plan_units: int, elev_units: int) -> Georef:
    """The DEM's reference system, datum (when recorded) and units as a Georef."""
    code = a[890:892].strip()
    datum = _DEM_DATUMS.get(int(code)) if code.isdigit() else None
    if refsys == 1:
        crs = f"UTM zone {zone}"
        if datum is not None and datum[1] is not None and 1 <= zone <= 60:
            crs = f"EPSG:{datum[1] * 100 + zone}"
    else:
        crs = {0: "geographic", 2: f"State Plane zone {zone}"}.get(refsys, f"system {refsys}")
    if datum is None:
        crs += ", datum not recorded"
    elif not crs.startswith("EPSG"):
        crs += f", {datum[0]}"
    return Georef(
        crs=crs,
        horizontal_units=_GEOREF_UNITS.get(plan_units),
        vertical_units=_GEOREF_UNITS.get(elev_units) if elev_units in (1, 2) else None,
    )


def _fortran_floats(path: Path, raw: bytes, width: int, what: str, offset: int) -> list[float]:
    """Fixed-width Fortran reals (``D`` or ``E`` exponents)."""
    out = []
    for i in range(0, len(raw), width):
        field_ = raw[i : i + width].strip().replace(b"D", b"E").replace(b"d", b"e")
        try:
            out.append(float(field_))
        except ValueError:
            raise FileFormatError(
                f"{path}: {what} at bytes {offset + i + 1}-{offset + i + width} is"
                f" {quote(raw[i : i + width])}, not a number (is this a USGS DEM?)"
            ) from None
    return out


def _fortran_ints(path: Path, raw: bytes, what: str, offset: int) -> list[int]:
    """Fixed-width (I6) integers."""
    out = []
    for i in range(0, len(raw), 6):
        try:
            out.append(int(raw[i : i + 6]))
        except ValueError:
            raise FileFormatError(
                f"{path}: {what} at bytes {offset + i + 1}-{offset + i + 6} is"
                f" {quote(raw[i : i + 6])}, not an integer (is this a USGS DEM?)"
            ) from None
    return out


def read_dem(path: str | os.PathLike) -> ScanPoints:
    """Read a USGS ASCII DEM: every profile (B record) is one scan line.

    The A record (1,024 bytes) gives the spatial resolution (dx, dy, dz) and the number of
    profiles; each B record gives its first point's ground coordinates (x0, y0), the local
    datum elevation and m elevations. Point k of a profile is
    ``(x0, y0 + k * dy, elevation_k * dz + datum)``; voids (-32767) are skipped.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64 in ground units (x, y) and elevation units (z);
        ``line_ids`` (N,) int64, the profile index (0 = first, westmost, profile);
        ``georef``: the reference system (UTM zone, as an EPSG code when the datum is
        recorded), the ground and elevation units.
    """
    path = Path(path)
    data = read_bytes(path)
    if len(data) < 1024:
        raise FileFormatError(
            f"{path}: {len(data)} bytes is too short for a USGS DEM (its A record alone is 1024)"
        )
    check_text(path, data, "a USGS ASCII DEM")
    # record length: 1024 bytes, or 1024 plus a line end that some copies carry
    record = 1024
    for tail in (b"\r\n", b"\n"):
        if data[1024 : 1024 + len(tail)] == tail:
            record += len(tail)
            break
    a = data[:1024]

    def ints(key: str) -> list[int]:
        s, e = _DEM_A[key]
        return _fortran_ints(path, a[s:e], f"A record '{key}'", s)

    def reals(key: str, width: int) -> list[float]:
        s, e = _DEM_A[key]
        return _fortran_floats(path, a[s:e], width, f"A record '{key}'", s)

    (level,) = ints("level")
    (refsys,) = ints("reference_system")
    (zone,) = ints("zone")
    (plan_units,) = ints("planimetric_units")
    (elev_units,) = ints("elevation_units")
    dx, dy, dz = reals("resolution", 12)
    n_rows, n_profiles = ints("rows_columns")
    corners = np.array(reals("corners", 24)).reshape(4, 2)
    emin, emax = reals("elevation_range", 24)
    if not (dx > 0 and dy > 0 and dz > 0) or n_profiles <= 0:
        raise FileFormatError(
            f"{path}: A record gives resolution ({dx}, {dy}, {dz}) and {n_profiles} profiles;"
            " not a valid USGS DEM"
        )
    # every profile takes at least one record, every elevation 6 bytes
    check_declared(path, n_profiles, record, len(data) - record, "profiles (B records)")
    xs, ys, zs, ids = [], [], [], []
    pos = record
    for profile in range(n_profiles):
        if pos + 144 > len(data):
            raise FileFormatError(
                f"{path}: truncated DEM: profile {profile + 1} of {n_profiles} should start at"
                f" byte {pos}, the file has {len(data)}"
            )
        head = data[pos : pos + 144]
        _, _, m, n = _fortran_ints(path, head[:24], f"B record {profile + 1} header", pos)
        x0, y0, datum, _, _ = _fortran_floats(
            path, head[24:144], 24, f"B record {profile + 1} header", pos + 24
        )
        if n != 1 or m < 0:
            raise FileFormatError(
                f"{path}: B record {profile + 1} at byte {pos} has {m} x {n} elevations;"
                " only single-column profiles (n = 1) are supported"
            )
        check_declared(path, m, 6, len(data) - pos - 144, f"elevations in profile {profile + 1}")
        # elevations: 146 in the first 1024-byte block after the header, then 170 per block
        fields, start, left, room = [], pos + 144, m, 146
        while left > 0:
            take = min(left, room)
            chunk = data[start : start + 6 * take]
            if len(chunk) < 6 * take:
                raise FileFormatError(
                    f"{path}: truncated DEM: profile {profile + 1} of {n_profiles} needs {m}"
                    f" elevations, the file ends at byte {len(data)}"
                )
            fields.append(chunk)
            left -= take
            if left:
                pos += record
                start, room = pos, 170
        pos += record
        raw = b"".join(fields)
        try:
            elev = np.frombuffer(raw, dtype="S6").astype(np.int64)
        except ValueError:
            bad = next(
                i for i in range(m) if not raw[6 * i : 6 * i + 6].strip().lstrip(b"-").isdigit()
            )
            raise FileFormatError(
                f"{path}: profile {profile + 1}, elevation {bad + 1}:"
                f" {quote(raw[6 * bad : 6 * bad + 6])} is not an integer"
            ) from None
        k = np.flatnonzero(elev != DEM_VOID)
        xs.append(np.full(len(k), x0))
        ys.append(y0 + k * dy)
        zs.append(elev[k] * dz + datum)
        ids.append(np.full(len(k), profile, dtype=np.int64))
    points = np.column_stack([np.concatenate(xs), np.concatenate(ys), np.concatenate(zs)])
    if not len(points):
        raise FileFormatError(f"{path}: every elevation in the DEM is void ({DEM_VOID})")
    extra = {
        "format": "usgs-dem",
        "level": level,
        "reference_system": {0: "geographic", 1: "UTM", 2: "state plane"}.get(refsys, refsys),
        "zone": zone,
        "planimetric_units": _DEM_UNITS.get(plan_units, plan_units),
        "elevation_units": {1: "feet", 2: "metres"}.get(elev_units, elev_units),
        "resolution": (dx, dy, dz),
        "corners": corners,
        "elevation_range": (emin, emax),
        "profiles": n_profiles,
        "line_ids_from": "profiles (B records)",
    }
    return ScanPoints(
        points=points,
        line_ids=np.concatenate(ids),
        source=path,
        extra=extra,
        georef=_georef(a, refsys, zone, plan_units, elev_units),
    )
