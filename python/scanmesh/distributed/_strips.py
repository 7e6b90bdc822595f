"""Strip methods on a cluster: partitions of consecutive lines, one line of overlap.

The strips between two lines depend on the rest of the scan only through a few numbers:
its bounding box (the origin of the projection and the unit box of the path weights), its
largest planar coordinate (the power-of-two planar scale), its median step (lengths and
gaps) and whether the partition's first line is turned round (the orientation walk over the
lines before it). So the work is three passes over the parts, each on the workers:

1. per part: lines, their chords and steps (:func:`line_stats`), the steps kept sorted on
   the worker that read them;
2. the exact median of all steps, by three rounds of counting on those workers
   (:func:`scanmesh.distributed._median.exact_median`, as the tiles' median spacing: 22,
   21 and 21 bits of the float at a time, no step is gathered);
3. per partition: ``scanmesh_core::strips::stitch_part`` with the scan's context (:func:`solve`).

Partitions start and end on a line that has a strip on both sides and no lone point (an
"eligible" line): each returns the strips from its first line to its last, and the next one
starts on that last line, so every strip is returned exactly once, as the whole scan solves
it. What is dropped at depth jumps and where lines cross is decided on the triangles around
a corner (local spacings, overlapping neighbours), which at a partition's border lie on
both sides of it: so each partition also solves :data:`OVERLAP_LINES` lines beyond each
border, and these only inform those decisions (the core's ``own_rows``). The faces are the
single-process faces exactly (tested), listed partition by partition.
The one whole-scan decision a partition cannot make, turning the mesh counter-clockwise by
the sign of its total planar area, is made when all partitions are done: each block is
turned round while it is written when its own sign differs (the "strips" turn key).
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._checks import check_options
from scanmesh.errors import DegenerateInputError
from scanmesh.scan.projection import PlaneSpec
from scanmesh.stages.strips import OPTIONS, solve_strips

from ._median import exact_median
from ._output import FaceBlock
from ._report import seam_sums, vertex_sums
from ._source import Part, load_part, project_as_whole

#: Lines beyond each border a partition solves as well, so that the drops at depth jumps
#: (decided on the triangles around each corner, one strip to each side) and at crossing
#: lines (on overlapping neighbours and the peeling after them) near the border are made
#: on the same triangles as in one process.
OVERLAP_LINES: int = 3


@dataclass(frozen=True)
class LineStats:
    """Per line of one part (L lines): what the client needs to plan the partitions."""

    #: (L,) int64 line ids, ascending
    ids: np.ndarray
    #: (L + 1,) int64 rows of the part where each line starts (and the part's end)
    starts: np.ndarray
    #: (L, 2) float64 planar position of each line's first and last point
    first: np.ndarray
    last: np.ndarray
    #: (L,) float64 shortest non-zero step of each line (inf: none)
    shortest: np.ndarray
    #: (L,) float64 largest over the line's points of min(step before, step after) (inf
    #: for a one-point line): a point is alone in its segment when this exceeds the gap
    lone: np.ndarray
    #: largest |planar coordinate| of the part
    largest: float
    #: number of non-zero steps
    n_steps: int


def line_stats(
    part: Part, plane: PlaneSpec, lo: np.ndarray, hi: np.ndarray
) -> tuple[LineStats, np.ndarray]:
    """A part's :class:`LineStats` and its sorted non-zero steps (kept on the worker).

    Steps are measured as ``scanmesh_core::strips::segment_lines`` measures them: between
    consecutive points of a line after dropping points that coincide in the plane with the
    previous one, by ``hypot`` of the planar differences. O(n log n).
    """
    points, ids = load_part(part)
    uv = project_as_whole(points, plane, lo, hi)
    n = len(points)
    change = np.flatnonzero(ids[1:] != ids[:-1]) + 1
    starts = np.concatenate([[0], change, [n]]).astype(np.int64)
    line_of = np.zeros(n, dtype=np.int64)
    line_of[change] = 1
    line_of = np.cumsum(line_of)
    repeat = np.zeros(n, dtype=bool)
    repeat[1:] = (ids[1:] == ids[:-1]) & (uv[1:] == uv[:-1]).all(axis=1)
    kept_uv, kept_line = uv[~repeat], line_of[~repeat]
    d = kept_uv[1:] - kept_uv[:-1]
    step = np.hypot(d[:, 0], d[:, 1])
    inside = kept_line[1:] == kept_line[:-1]
    n_lines = len(starts) - 1
    before = np.full(len(kept_uv), np.inf)
    after = np.full(len(kept_uv), np.inf)
    before[1:][inside] = step[inside]
    after[:-1][inside] = step[inside]
    # kept points are grouped by line: per-line min and max by reduceat on line starts
    first_kept = np.searchsorted(kept_line, np.arange(n_lines))
    shortest = np.minimum.reduceat(after, first_kept)
    lone = np.maximum.reduceat(np.minimum(before, after), first_kept)
    steps = np.sort(step[inside & (step > 0)])
    stats = LineStats(
        ids=ids[starts[:-1]].copy(),
        starts=starts,
        first=uv[starts[:-1]].copy(),
        last=uv[starts[1:] - 1].copy(),
        shortest=shortest,
        lone=lone,
        largest=float(np.abs(uv).max(initial=0.0)),
        n_steps=len(steps),
    )
    return stats, steps


@dataclass(frozen=True)
class Partition:
    """Consecutive lines solved together: global line indices ``first .. last`` inclusive."""

    first: int
    last: int
    #: (part, first row, end row) slices of the parts holding those lines and up to
    #: OVERLAP_LINES lines on each side
    slices: tuple[tuple[Part, int, int], ...]
    #: rows of those slices before the first line and after the last (the overlap)
    rows_before: int
    rows_after: int
    #: whether the first line with a strip in the slices is turned round in the whole scan
    first_turned: bool
    #: whether a partition comes before (its first line is shared) and after (its last)
    shares_first: bool
    shares_last: bool


def _scaled(x: np.ndarray, largest: float) -> np.ndarray:
    """Planar values scaled as ``unit_square_scaled_by`` scales them (two powers of two,
    values below 1e-40 flushed to zero)."""
    e = math.frexp(largest)[1] if largest > 0 else 0
    first, second = math.ldexp(1.0, int(-e / 2)), math.ldexp(1.0, -e - int(-e / 2))
    y = x * first * second
    return np.where(np.abs(y) < 1e-40, 0.0, y)


def turned_lines(
    first: np.ndarray, last: np.ndarray, kept: np.ndarray, largest: float
) -> np.ndarray:
    """(L,) bool: which lines the whole scan turns round (the core's walk over the chords
    of the kept lines: a chord against the previous kept line's turned one). O(L)."""
    chords = _scaled(last, largest) - _scaled(first, largest)
    turned = np.zeros(len(first), dtype=bool)
    previous = None
    for line in np.flatnonzero(kept):
        c = chords[line]
        if previous is not None and previous[0] * c[0] + previous[1] * c[1] < 0.0:
            turned[line] = True
            c = -c
        previous = c
    return turned


def plan(
    parts: list[Part],
    stats: list[LineStats],
    gap: float,
    largest: float,
    partition_lines: int | None,
) -> list[Partition]:
    """Partitions of about ``partition_lines`` lines (None: one per part), each starting on
    the first eligible line at or after its nominal start."""
    shortest = np.concatenate([s.shortest for s in stats])
    lone = np.concatenate([s.lone for s in stats])
    kept = shortest <= gap
    eligible = kept & ~(lone > gap)
    turned = turned_lines(
        np.concatenate([s.first for s in stats]),
        np.concatenate([s.last for s in stats]),
        kept,
        largest,
    )
    # where each part's lines start among all lines, and the part of every line
    counts = np.array([len(s.ids) for s in stats])
    line_start = np.concatenate([[0], np.cumsum(counts)])
    n_lines = int(line_start[-1])
    if partition_lines is None:
        nominal = line_start[1:-1]
    else:
        nominal = np.arange(partition_lines, n_lines, partition_lines)
    bounds = [0]
    for start in nominal:
        nxt = np.flatnonzero(eligible[start:])
        if len(nxt) and start + nxt[0] > bounds[-1] and start + nxt[0] < n_lines - 1:
            bounds.append(int(start + nxt[0]))
    bounds = sorted(set(bounds))

    def slices_of(first: int, last: int) -> list[tuple[Part, int, int]]:
        """(part, first row, end row) of the lines first..last."""
        slices = []
        for p, s in enumerate(stats):
            lo_line, hi_line = max(first, line_start[p]), min(last, line_start[p + 1] - 1)
            if lo_line <= hi_line:
                rows = s.starts[lo_line - line_start[p]], s.starts[hi_line - line_start[p] + 1]
                slices.append((parts[p], int(rows[0]), int(rows[1])))
        return slices

    def rows(first: int, last: int) -> int:
        return sum(b - a for _, a, b in slices_of(first, last))

    out = []
    for i, b in enumerate(bounds):
        last = bounds[i + 1] if i + 1 < len(bounds) else n_lines - 1
        lo, hi = max(b - OVERLAP_LINES, 0), min(last + OVERLAP_LINES, n_lines - 1)
        first_kept = np.flatnonzero(kept[lo : hi + 1])
        out.append(
            Partition(
                first=b,
                last=last,
                slices=tuple(slices_of(lo, hi)),
                rows_before=rows(lo, b - 1),
                rows_after=rows(last + 1, hi),
                first_turned=bool(turned[lo + first_kept[0]]) if len(first_kept) else False,
                shares_first=i > 0,
                shares_last=i + 1 < len(bounds),
            )
        )
    return out


def strip_options(method: str, options: dict[str, Any]) -> dict[str, Any]:
    """The strip method's options checked (as :func:`scanmesh.stages.strips.strip_surface` does)."""
    return check_options(OPTIONS[method], options, f"method {method!r}")


def solve(
    partition: Partition,
    method: str,
    params: dict[str, Any],
    plane: PlaneSpec,
    lo: np.ndarray,
    hi: np.ndarray,
    largest: float,
    median: float,
) -> tuple[FaceBlock, dict[str, Any]]:
    """Solve one partition's strips on a worker: its face block (global indices) and what
    its seams with the neighbouring partitions need (faces and unused points on the shared
    lines). O(n log n) plus the strips' own cost."""
    loaded: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    pts, ids, index = [], [], []
    for part, a, b in partition.slices:
        if part.index not in loaded:
            loaded[part.index] = load_part(part)
        p, line = loaded[part.index]
        pts.append(p[a:b])
        ids.append(line[a:b])
        index.append(np.arange(part.offset + a, part.offset + b, dtype=np.int64))
    points = np.ascontiguousarray(np.concatenate(pts))
    line_ids = np.ascontiguousarray(np.concatenate(ids))
    global_index = np.concatenate(index)
    del loaded, pts, ids, index
    uv = project_as_whole(points, plane, lo, hi)
    # the partition's own rows, between the overlap lines
    a, b = partition.rows_before, len(points) - partition.rows_after
    solved = solve_strips(
        points,
        uv,
        line_ids,
        method,
        params,
        params["gap_factor"],
        _core.ScanContext(
            lo=tuple(lo),
            hi=tuple(hi),
            largest_planar=largest,
            median_step=median,
            first_turned=partition.first_turned,
            own_rows=(a, b),
        ),
    )
    points, line_ids, global_index = points[a:b], line_ids[a:b], global_index[a:b]
    # consecutive lines of consecutive parts: global indices are one offset away
    start = int(global_index[0])
    contiguous = bool(global_index[-1] - start == len(global_index) - 1)
    n = len(points)
    faces, unused = solved.faces - a, solved.unused - a
    duplicates = solved.duplicates
    duplicates = duplicates[((duplicates >= a) & (duplicates < b)).all(axis=1)] - a
    # rows of the shared lines: the first line when a partition comes before, the last
    # when one comes after (owned by that one: its points are counted there)
    first_end = int(np.searchsorted(line_ids, line_ids[0], side="right"))
    last_start = int(np.searchsorted(line_ids, line_ids[-1], side="left"))
    shared = np.zeros(n, dtype=bool)
    if partition.shares_first:
        shared[:first_end] = True
    if partition.shares_last:
        shared[last_start:] = True
    owned_end = last_start if partition.shares_last else n
    sums = vertex_sums(points, faces, ~shared)
    sums.update(
        n_strips=float(solved.n_strips),
        cost=float(solved.cost),
        signed_area=float(solved.signed_area),
        planar_invalid=float(solved.planar_error is not None),
        dropped_jumps=float(solved.dropped_jumps),
        dropped_overlaps=float(solved.dropped_overlaps),
        duplicates=float(np.count_nonzero(duplicates[:, 0] < owned_end)),
        unused=float(np.count_nonzero(~shared[unused])),
    )

    def to_global(local: np.ndarray) -> np.ndarray:
        return local + start if contiguous else global_index[local]

    # columnwise: numpy's reductions along a 3-wide axis are several times slower
    lowest = np.minimum(np.minimum(faces[:, 0], faces[:, 1]), faces[:, 2])
    highest = np.maximum(np.maximum(faces[:, 0], faces[:, 1]), faces[:, 2])
    seams = {}
    for side, lo_row, hi_row, touching in (
        ("first", 0, first_end, lowest < first_end),
        ("last", last_start, n, highest >= last_start),
    ):
        near = faces[touching]
        seams[side] = {
            "vertices": to_global(np.arange(lo_row, hi_row)),
            "faces": to_global(near),
            "corners": np.take(points, near, axis=0),
            "unused": to_global(unused[(unused >= lo_row) & (unused < hi_row)]),
        }
    block = FaceBlock(
        vertices=points,
        local=faces,
        index=start if contiguous else global_index,
        sums=sums,
        turn_key="strips",
    )
    return block, seams


def seam(left: dict[str, Any], right: dict[str, Any]) -> dict[str, float]:
    """The quality sums of a shared line's vertices (from the faces on both sides of it)
    and its unused points (those in no strip of either side)."""
    sums = seam_sums(
        left["vertices"],
        np.concatenate([left["faces"], right["faces"]]),
        np.concatenate([left["corners"], right["corners"]]),
    )
    sums["unused"] = float(len(np.intersect1d(left["unused"], right["unused"])))
    return sums


def strip_blocks(
    client: Any,
    parts: list[Part],
    method: str,
    options: dict[str, Any],
    *,
    plane: PlaneSpec,
    lo: np.ndarray,
    hi: np.ndarray,
    partition_lines: int | None,
) -> tuple[list[Any], list[Any], dict[str, Any]]:
    """Submit the strips of a scan: futures of its FaceBlocks, futures of its seams' sums,
    and what the client learnt (lines, median step, partitions)."""
    params = strip_options(method, options)
    stats_steps = [
        client.submit(line_stats, p, plane, lo, hi, key=f"scanmesh-lines-{p.index}-{uuid.uuid4()}")
        for p in parts
    ]
    stats_f = [client.submit(_first, f, key=f"scanmesh-stats-{uuid.uuid4()}") for f in stats_steps]
    steps = [client.submit(_second, f, key=f"scanmesh-steps-{uuid.uuid4()}") for f in stats_steps]
    stats: list[LineStats] = client.gather(stats_f)
    del stats_steps
    largest = max(s.largest for s in stats)
    median = exact_median(client, steps, sum(s.n_steps for s in stats))
    del steps
    gap = params["gap_factor"] * median
    partitions = plan(parts, stats, gap, largest, partition_lines)
    if sum(len(s.ids) for s in stats) < 2:
        raise DegenerateInputError("no strip to build: the scan has fewer than two lines")
    solved = [
        client.submit(
            solve,
            q,
            method,
            params,
            plane,
            lo,
            hi,
            largest,
            median,
            key=f"scanmesh-strips-{i}-{uuid.uuid4()}",
        )
        for i, q in enumerate(partitions)
    ]
    blocks = [client.submit(_first, f, key=f"scanmesh-block-{uuid.uuid4()}") for f in solved]
    sides = [client.submit(_second, f, key=f"scanmesh-seams-{uuid.uuid4()}") for f in solved]
    seams = [
        client.submit(_seam_of, sides[i], sides[i + 1], key=f"scanmesh-seam-{i}-{uuid.uuid4()}")
        for i in range(len(sides) - 1)
    ]
    info = {
        "n_lines": int(sum(len(s.ids) for s in stats)),
        "median_step": median,
        "partitions": len(partitions),
        **{k: v for k, v in params.items() if k != "weight"},
        "weight": dict(params["weight"]),
    }
    return blocks, seams, info


def _first(pair: tuple[Any, Any]) -> Any:
    return pair[0]


def _second(pair: tuple[Any, Any]) -> Any:
    return pair[1]


def _seam_of(left: dict[str, Any], right: dict[str, Any]) -> dict[str, float]:
    return seam(left["last"], right["first"])
