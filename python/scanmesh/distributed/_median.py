"""The exact median of values spread over the workers, with no value gathered.

One algorithm serves both distributed medians: the strips' median step along the lines
(the core's ``scan_segments`` median, over the parts' steps) and the tiles' median
nearest-neighbour spacing (the core's ``median_spacing``, over the tiles' distances); see
:mod:`scanmesh.scan.spacing` for what each quantity is. Both take the upper median, element
``total // 2`` of the values in ascending order, as the core does.

The values are non-negative floats, held sorted on the workers. Their bits, read as
int64, ascend with them, so the median's bits are found in three rounds of counting
(:data:`ROUND_SHIFTS`: 22, 21 and 21 bits at a time): each worker counts its values below
the known prefix and the distinct next-bit keys above it (:func:`count_keys`), the client
adds up those counts and picks the key that holds the median's rank. Only counts travel.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import Any

import numpy as np

#: Bits of a value's float resolved by each counting round of :func:`exact_median`.
ROUND_SHIFTS: tuple[int, ...] = (42, 21, 0)


def count_keys(
    held: Any,
    lo_bits: int,
    hi_bits: int,
    shift: int,
    values: Callable[[Any], np.ndarray] | None = None,
) -> tuple[int, Any, Any]:
    """Of the sorted non-negative values ``values(held)`` (``held`` itself for None): how
    many lie below ``lo_bits`` (as float bits), and the distinct ``bits >> shift`` with
    their counts among those in [lo_bits, hi_bits). O(log n + keys)."""
    sorted_values = held if values is None else values(held)
    bits = np.ascontiguousarray(sorted_values, dtype=np.float64).view(np.int64)
    a, b = np.searchsorted(bits, [lo_bits, hi_bits])
    # non-negative floats' bits ascend with them: the keys come sorted, so runs, not a sort
    keys = bits[a:b] >> shift
    starts = np.flatnonzero(np.concatenate([[True], keys[1:] != keys[:-1]])) if b > a else keys
    counts = np.diff(np.append(starts, len(keys)))
    return int(a), keys[starts], counts


def exact_median(
    client: Any,
    held: list[Any],
    total: int,
    values: Callable[[Any], np.ndarray] | None = None,
) -> float:
    """The exact upper median (element ``total // 2`` in ascending order) of the values
    held on the workers, 0 for none.

    Parameters
    ----------
    client : distributed.Client
    held : list of distributed.Future
        Each holds, or (through ``values``) carries, a (n_i,) float64 array of
        non-negative values in ascending order.
    total : int
        The number of values over all of them.
    values : callable, optional
        Picks the sorted array out of what a future holds (run on the workers; a top-level
        function or an ``operator.attrgetter``); None: the future holds the array.

    Three rounds of :func:`count_keys` on every holder; only counts travel.
    """
    if total == 0:
        return 0.0
    rank, lo, hi = total // 2, 0, 1 << 63
    for shift in ROUND_SHIFTS:
        rounds = client.gather(
            [
                client.submit(
                    count_keys, h, lo, hi, shift, values, key=f"scanmesh-median-{uuid.uuid4()}"
                )
                for h in held
            ]
        )
        below = sum(r[0] for r in rounds)
        keys = np.concatenate([r[1] for r in rounds])
        counts = np.concatenate([r[2] for r in rounds])
        unique, inverse = np.unique(keys, return_inverse=True)
        merged = np.zeros(len(unique), dtype=np.int64)
        np.add.at(merged, inverse, counts)
        at = int(np.searchsorted(below + np.cumsum(merged), rank, side="right"))
        lo, hi = int(unique[at]) << shift, (int(unique[at]) + 1) << shift
    return float(np.array([lo], dtype=np.int64).view(np.float64)[0])


__all__ = ["exact_median", "count_keys", "ROUND_SHIFTS"]
