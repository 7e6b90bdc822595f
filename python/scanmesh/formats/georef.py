"""Where a scan lies on the Earth and in what units: :class:`Georef`, as LAS/LAZ and USGS DEM
files record it, kept with the points, reported, and written to PLY and OBJ headers.

No projection library is needed: the names and codes are read as the file gives them
(a LAS GeoKey directory's EPSG code and unit codes, its OGC WKT; a DEM's reference system,
zone, datum and unit codes) and passed on unchanged; nothing is reprojected.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

#: EPSG unit-of-measure codes GeoTIFF keys use, by name.
EPSG_UNITS: dict[int, str] = {
    9001: "metre",
    9002: "foot",
    9003: "US survey foot",
    9102: "degree",
}

#: The header comment keys written (``comment <key> <value>``), in order.
COMMENT_KEYS: tuple[str, ...] = ("crs", "crs_wkt", "horizontal_units", "vertical_units")

_WKT_NAME = re.compile(r'^\s*[A-Z_]+\[\s*"([^"]*)"')
_WKT_UNIT = re.compile(r'UNIT\[\s*"([^"]*)"')


@dataclass(frozen=True)
class Georef:
    """The coordinate reference system and units a file records for its points (any may
    be None: not recorded). Values are the file's own words."""

    #: a name for the system: ``"EPSG:26910"``, a WKT or GeoTIFF citation name
    #: (``"NAD_1983_HARN_Lambert_Conformal_Conic"``), ``"UTM zone 10"``
    crs: str | None = None
    #: the OGC WKT text, when the file holds one
    wkt: str | None = None
    #: unit of x and y (``"metre"``, ``"foot"``, ``"US survey foot"``, ``"arc-second"``)
    horizontal_units: str | None = None
    #: unit of z
    vertical_units: str | None = None

    def as_dict(self) -> dict[str, str | None]:
        """The four fields by name, for reports and JSON."""
        return {key: getattr(self, _FIELD[key]) for key in COMMENT_KEYS}

    def comments(self) -> list[str]:
        """Header comment lines (without ``comment`` or ``#``) for the recorded fields:
        ``crs <name>``, ``crs_wkt <wkt>``, ``horizontal_units <unit>``, ``vertical_units
        <unit>``; line breaks in a value become spaces, so each is one line."""
        out = []
        for key, value in self.as_dict().items():
            if value:
                out.append(f"{key} {' '.join(value.split())}")
        return out


_FIELD = {"crs": "crs", "crs_wkt": "wkt", "horizontal_units": "horizontal_units",
          "vertical_units": "vertical_units"}  # fmt: skip


def from_comments(comments: Iterable[str]) -> Georef | None:
    """The Georef that :meth:`Georef.comments` wrote, from header comments (None when
    they hold none of its keys)."""
    found: dict[str, str] = {}
    for text in comments:
        key, _, value = text.strip().partition(" ")
        if key in _FIELD and value.strip():
            found[_FIELD[key]] = value.strip()
    return Georef(**found) if found else None


def wkt_name(wkt: str) -> str | None:
    """The name of the outermost WKT object (``PROJCS["name", ...]``), or None."""
    match = _WKT_NAME.match(wkt)
    return match.group(1) if match else None


def wkt_unit(wkt: str) -> str | None:
    """The outermost object's own unit (a ``UNIT[...]`` directly inside it: the projected
    axes' unit of a PROJCS, not its GEOGCS's degrees), or None. Names are kept as written
    (``"foot"``, ``"Foot_US"``). O(len(wkt))."""
    for match in _WKT_UNIT.finditer(wkt):
        before = wkt[: match.start()]
        if before.count("[") - before.count("]") == 1:
            return match.group(1)
    return None
