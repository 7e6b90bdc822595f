"""CSV point files: comma- (or semicolon-) separated x, y, z rows, usually with a header."""

from __future__ import annotations

import os

from scanmesh._context import QUIET, Context
from scanmesh.formats.points import ScanPoints
from scanmesh.formats.xyz import Columns, read_points_table


def read_csv(
    path: str | os.PathLike,
    *,
    columns: Columns = None,
    decimal: str = ".",
    context: Context = QUIET,
) -> ScanPoints:
    """Read a CSV file of points: ``x,y,z`` or ``x,y,z,line`` per row.

    A header row, when present, must name the columns ``x``, ``y``, ``z`` and optionally a
    line id (``line``, ``line_id``, ``scan_line``, ...); other named columns are ignored.
    ``columns=`` chooses them otherwise (see :mod:`scanmesh.formats.xyz`). Without a header
    the columns follow the XYZ rules; ``decimal=","`` reads decimal commas (values then
    separated by semicolons, as spreadsheets in such locales write them). Parsed natively
    in chunks; ``context``: the call's progress (:func:`scanmesh.read`).

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64; ``line_ids`` (N,) int64 or None.
    """
    return read_points_table(path, "csv", columns=columns, decimal=decimal, context=context)
