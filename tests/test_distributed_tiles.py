"""Delaunay, LOP and annealing in tiles on a Dask LocalCluster (scanmesh.distributed._tiles):
the same faces as one process for Delaunay, one valid mesh across the seams for all three,
annealing quality within 5 % of one process."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("dask")
pytest.importorskip("distributed")

from distributed import Client, LocalCluster, WorkerPlugin  # noqa: E402

import scanmesh  # noqa: E402
from scanmesh import _core  # noqa: E402
from scanmesh.distributed import _median, _tile, _tiles  # noqa: E402
from scanmesh.distributed._source import Part  # noqa: E402


def height(x: np.ndarray, y: np.ndarray, step: bool) -> np.ndarray:
    """A smooth hill, tilted, with (``step``) a round boss 2 units high: a depth jump."""
    z = 3.0 * np.sin(x / 4.0) * np.cos(y / 3.0) + 0.2 * x
    if step:
        z = z + np.where((x - 15.0) ** 2 + (y - 15.0) ** 2 < 9.0, 2.0, 0.0)
    return z


def line_scan(
    lines: int, per_line: int, step: bool, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Scan lines along x, 0.15 apart in y, points jittered along and across the lines."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 30.0, per_line)[None, :] + rng.uniform(-0.02, 0.02, (lines, per_line))
    y = 0.15 * np.arange(lines)[:, None] + rng.uniform(-0.01, 0.01, (lines, per_line))
    points = np.column_stack([x.ravel(), y.ravel(), height(x, y, step).ravel()])
    ids = np.repeat(np.arange(lines, dtype=np.int64), per_line)
    return points, ids


def write_parts(points: np.ndarray, ids: np.ndarray, count: int, folder) -> list[Part]:
    """The scan as ``count`` .npy files of consecutive lines."""
    parts, offset = [], 0
    for i, chunk in enumerate(np.array_split(np.unique(ids), count)):
        take = np.isin(ids, chunk)
        path = folder / f"part{i}.npy"
        np.save(path, np.column_stack([points[take], ids[take]]))
        parts.append(Part(i, str(path), offset, int(take.sum())))
        offset += int(take.sum())
    return parts


@pytest.fixture(scope="module")
def client():
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c


@pytest.fixture
def small_tiles(monkeypatch):
    """About 4-6 tiles on the test scans."""
    monkeypatch.setattr(_tiles, "TILE_POINTS", 12_000)


def run(client, parts, method, options, plane="z"):
    futures, info = _tiles.tile_blocks(client, parts, method, options, plane=plane, progress=False)
    blocks = client.gather(futures)
    faces = np.concatenate([b.faces for b in blocks])
    sums = {k: sum(b.sums[k] for b in blocks) for k in blocks[0].sums}
    return blocks, faces, sums, info


def face_set(faces: np.ndarray) -> set[tuple[int, ...]]:
    return set(map(tuple, np.sort(faces, axis=1).tolist()))


def edge_uses(faces: np.ndarray) -> dict[tuple[int, int], int]:
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(edges, axis=0, return_counts=True)
    return dict(zip(map(tuple, keys.tolist()), counts.tolist(), strict=True))


def planar_area(uv: np.ndarray, faces: np.ndarray) -> float:
    """Area the faces cover in the plane (each counted once)."""
    c = uv[faces]
    e1, e2 = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
    return float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() / 2)


def area_3d(points: np.ndarray, faces: np.ndarray) -> float:
    c = points[faces]
    return float(np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1).sum() / 2)


def seam_band(uv: np.ndarray, grid: _tiles.Grid, width: float) -> np.ndarray:
    return grid.near_borders(uv, width)


@pytest.mark.slow
@pytest.mark.parametrize("count", [2, 5])
def test_delaunay_equals_one_process(client, small_tiles, tmp_path, count):
    points, ids = line_scan(160, 250, step=True)
    parts = write_parts(points, ids, count, tmp_path)
    blocks, faces, sums, _ = run(client, parts, "delaunay", {})
    assert len(blocks) >= 4, "the scan must be cut into several tiles"
    one = scanmesh.delaunay(points, plane="z")
    assert face_set(faces) == face_set(one.faces)
    assert len(faces) == len(one.faces), "no face twice"
    assert sums["uncertified"] == 0
    # the corners are the points' own coordinates, and every block's faces are its own
    for b in blocks:
        np.testing.assert_array_equal(b.vertices[b.local], points[b.faces])
    # quality sums add up to the one-process figures
    q = scanmesh.quality(points, one.faces)
    assert sums["tac_1"] == pytest.approx(q.tac_1, rel=1e-9)
    assert sums["n_interior"] == q.n_interior
    # orientation kept: counter-clockwise in the plane like the one-process faces
    _core.validate(one.scan.uv, faces)


@pytest.mark.slow
def test_delaunay_with_max_edge_and_trimming_ties(client, small_tiles, tmp_path):
    """An explicit max_edge, and a scan whose depth jump pinches vertices after trimming
    (equal fans: the tie goes to the fan with the smallest sorted corner triple, so tiles
    decide it as the whole scan does)."""
    points, ids = line_scan(120, 300, step=True, seed=3)
    parts = write_parts(points, ids, 3, tmp_path)
    _, faces, _, _ = run(client, parts, "delaunay", {"max_edge": 0.5})
    one = scanmesh.delaunay(points, plane="z", max_edge=0.5)
    assert face_set(faces) == face_set(one.faces)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["lop", "anneal"])
def test_union_is_one_valid_mesh(client, small_tiles, tmp_path, method):
    points, ids = line_scan(120, 200, step=True, seed=1)
    parts = write_parts(points, ids, 3, tmp_path)
    options = {"sweeps": 30} if method == "anneal" else {}
    blocks, faces, sums, info = run(client, parts, method, options)
    one = scanmesh.delaunay(points, plane="z")
    # a valid planar triangulation: no overlap, manifold, counter-clockwise
    _core.validate(one.scan.uv, faces)
    assert len(face_set(faces)) == len(faces), "duplicate faces"
    uses = edge_uses(faces)
    assert max(uses.values()) <= 2
    # no gap: flips keep the outline, so the same area and the same boundary as Delaunay
    assert planar_area(one.scan.uv, faces) == pytest.approx(
        planar_area(one.scan.uv, one.faces), rel=1e-12
    )
    boundary = {e for e, n in uses.items() if n == 1}
    assert boundary == {e for e, n in edge_uses(one.faces).items() if n == 1}
    # the seam bands: every edge there with both ends in a band is used as often as an
    # edge of a closed mesh must be (twice, or once on the outline)
    grid = _tiles.make_grid(
        (
            one.scan.uv[:, 0].min(),
            one.scan.uv[:, 0].max(),
            one.scan.uv[:, 1].min(),
            one.scan.uv[:, 1].max(),
        ),
        len(points),
        1.0,
    )
    band = seam_band(one.scan.uv, grid, 1.0)
    seam_edges = [e for e in uses if band[e[0]] and band[e[1]]]
    assert seam_edges
    assert all(uses[e] == 2 or e in boundary for e in seam_edges)
    assert sums["area"] == pytest.approx(area_3d(points, faces), rel=1e-9)
    assert sums["faces"] == len(faces) == len(one.faces)
    # the optimization did something: fewer tac than Delaunay, whose tac_1 the blocks sum
    delaunay_tac = scanmesh.quality(points, one.faces).tac_1
    assert scanmesh.quality(points, faces).tac_1 < delaunay_tac
    assert sums["initial_tac_1"] == pytest.approx(delaunay_tac, rel=1e-9)
    # a given tie tolerance (annealing's default: exact ties) needs no noise pass
    assert info["tiles"] >= 2 and "noise" not in info


def ridge(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A surface curved across the diagonal: Delaunay's triangles cut across its ridges."""
    return 3.0 * np.sin((x + y) / 5.0) + 0.005 * (x - y) ** 2


def ridge_scan() -> np.ndarray:
    """Lines 0.5 apart across a ridge surface, 240 points per line jittered along it."""
    rng = np.random.default_rng(0)
    x = np.linspace(0.0, 30.0, 240)[None, :] + rng.uniform(-0.01, 0.01, (60, 240))
    y = 0.5 * np.arange(60)[:, None] + 0.0 * x
    return np.column_stack([x.ravel(), y.ravel(), ridge(x, y).ravel()])


def height_rms(points: np.ndarray, faces: np.ndarray, seed: int = 0) -> float:
    """RMS of the mesh's height error against the true surface at 100,000 random points
    on the faces (area weighted)."""
    rng = np.random.default_rng(seed)
    c = points[faces]
    area = np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]), axis=1)
    pick = rng.choice(len(faces), 100_000, p=area / area.sum())
    r1, r2 = rng.random((2, 100_000))
    s = np.sqrt(r1)
    w = np.column_stack([1 - s, s * (1 - r2), s * r2])
    p = np.einsum("ij,ijk->ik", w, c[pick])
    return float(np.sqrt(np.mean((p[:, 2] - ridge(p[:, 0], p[:, 1])) ** 2)))


@pytest.mark.slow
def test_anneal_quality_within_5_percent(client, small_tiles, tmp_path):
    points = ridge_scan()
    ids = np.repeat(np.arange(60, dtype=np.int64), 240)
    parts = write_parts(points, ids, 3, tmp_path)
    noise = {"sweeps": 100, "tie_tolerance": None}  # the automatic, noise-derived tolerance
    blocks, faces, _, info = run(client, parts, "anneal", noise)
    assert len(blocks) >= 2
    one = scanmesh.reconstruct(points, "anneal", plane="z", seed=0, **noise)
    base = scanmesh.delaunay(points, plane="z")
    tac, tac_one = scanmesh.quality(points, faces).tac_1, one.quality.tac_1
    assert tac_one < 0.85 * scanmesh.quality(points, base.faces).tac_1, "annealing must matter"
    assert tac <= 1.05 * tac_one
    assert height_rms(points, faces) <= 1.05 * height_rms(points, one.faces)
    # the noise reported is the tiles' median estimate: near the whole scan's (noise-free
    # here, so both are tiny against the 0.125 spacing), and the tie tolerance follows it
    assert info["noise"] == pytest.approx(scanmesh.noise(points, plane="z"), abs=1e-4)
    assert info["tie_tolerance"] == pytest.approx(one.options["tie_tolerance"], rel=0.5)


def test_bad_options_are_refused(client, tmp_path):
    points, ids = line_scan(10, 20, step=False)
    parts = write_parts(points, ids, 1, tmp_path)
    with pytest.raises(scanmesh.errors.ParameterError, match="sweeps"):
        _tiles.tile_blocks(client, parts, "anneal", {"sweeps": -1}, plane="z", progress=False)
    with pytest.raises(scanmesh.errors.ParameterError, match="initial"):
        _tiles.tile_blocks(
            client, parts, "lop", {"initial": "shortest-path"}, plane="z", progress=False
        )
    with pytest.raises(scanmesh.errors.ParameterError, match="shortest-path"):
        _tiles.tile_blocks(client, parts, "shortest-path", {}, plane="z", progress=False)


@pytest.mark.parametrize("values", ["ties", "distinct"])
def test_median_search_is_exact(client, values):
    """The distributed median of the tiles' nearest-neighbour distances is the value the
    core's median_spacing picks (index n // 2 of the sorted values), ties included (an
    exact grid has one distance almost everywhere)."""
    rng = np.random.default_rng(5)
    arrays = [
        np.sort(rng.integers(0, 7, n) * 0.125 if values == "ties" else rng.random(n))
        for n in (900, 0, 2500, 37)
    ]
    empty = dict(index=None, points=None, uv=None, lines=None, own=None, faces=None)
    # tasks, as in a run (scattered data cannot be recomputed if a worker lets it go)
    tiles = [
        client.submit(_tile.Tile, tile=i, nearest=a, **empty, pure=False)
        for i, a in enumerate(arrays)
    ]
    total = sum(len(a) for a in arrays)
    expected = np.sort(np.concatenate(arrays))[total // 2]
    assert _median.exact_median(client, tiles, total, _tiles.NEAREST) == expected


def test_exact_grid_gives_one_valid_mesh(client, monkeypatch, tmp_path):
    """On an exact grid every cell's four corners are cocircular: any diagonal is Delaunay.
    Each such tie is decided by the one tile holding the common circumcentre, so the union
    is still one valid mesh with the one-process area and face count."""
    monkeypatch.setattr(_tiles, "TILE_POINTS", 3_000)
    x, y = np.meshgrid(0.25 * np.arange(120), 0.5 * np.arange(100))
    points = np.column_stack([x.ravel(), y.ravel(), np.sin(x.ravel() / 3)])
    ids = np.repeat(np.arange(100, dtype=np.int64), 120)
    parts = write_parts(points, ids, 3, tmp_path)
    blocks, faces, sums, _ = run(client, parts, "delaunay", {})
    assert len(blocks) >= 4
    one = scanmesh.delaunay(points, plane="z")
    _core.validate(one.scan.uv, faces)
    assert len(faces) == len(one.faces) == sums["faces"]
    assert planar_area(one.scan.uv, faces) == pytest.approx(
        planar_area(one.scan.uv, one.faces), rel=1e-12
    )


class TileClock(WorkerPlugin):
    """Records on each worker when a tile task starts and stops executing, on the machine's
    monotonic clock, which every worker process shares. (The task stream's times are each
    worker's own clock shifted by its last heartbeat's delay, which differ by tens of
    milliseconds between workers on a loaded machine: too coarse to order short tiles.)"""

    name = "scanmesh-tile-clock"

    def setup(self, worker: object) -> None:
        self.events: list[tuple[str, float, int]] = []

    def transition(self, key: object, start: str, finish: str, **kwargs: object) -> None:
        if isinstance(key, str) and key.startswith("scanmesh-tile-"):
            if finish == "executing":
                self.events.append((key, time.monotonic(), 1))
            elif start == "executing":
                self.events.append((key, time.monotonic(), -1))


def tiles_at_once(events: list[tuple[str, float, int]], run: str) -> int:
    """Most tiles in flight at once in a run through the tiles: a tile is in flight from
    the start of its first task to the end of its last (the keys name run, stage and
    tile)."""
    spans: dict[int, list[float]] = {}
    for key, at, _ in events:
        _, _, name, _, tile, _ = key.split("-", 5)
        if name == run:
            span = spans.setdefault(int(tile), [at, at])
            span[0], span[1] = min(span[0], at), max(span[1], at)
    ends = sorted([(a, 1) for a, _ in spans.values()] + [(b, -1) for _, b in spans.values()])
    most = held = 0
    for _, step in ends:
        held += step
        most = max(most, held)
    return most


@pytest.mark.slow
@pytest.mark.parametrize("per_thread", [1, 2])
def test_tiles_in_flight_are_bounded(client, monkeypatch, tmp_path, per_thread):
    """A worker holds a few tiles, not its share of all of them: from its parts' binning to
    pass 1's file, at most TILES_PER_THREAD x threads tiles are in flight, and as many in
    every other run through the tiles; the faces do not depend on it."""
    points, ids = line_scan(120, 200, step=True, seed=1)
    parts = write_parts(points, ids, 3, tmp_path)
    monkeypatch.setattr(_tiles, "TILE_POINTS", 3_000)  # 8 tiles
    monkeypatch.setattr(_tiles, "TILES_PER_THREAD", per_thread)
    client.register_plugin(TileClock())
    try:
        noise = {"sweeps": 30, "tie_tolerance": None}  # with the noise pass through the tiles
        _, faces, _, info = run(client, parts, "anneal", noise)
        logs = client.run(lambda dask_worker: dask_worker.plugins[TileClock.name].events)
    finally:
        client.unregister_worker_plugin(TileClock.name)
    events = [event for log in logs.values() for event in log]
    threads = sum(client.nthreads().values())
    assert info["tiles"] > per_thread * threads  # else nothing to bound
    for run_name in ("nearest", "noise", "first", "second"):
        assert 1 <= tiles_at_once(events, run_name) <= per_thread * threads, run_name
    monkeypatch.setattr(_tiles, "TILES_PER_THREAD", 100)  # every tile at once
    _, unbounded, _, _ = run(client, parts, "anneal", noise)
    assert face_set(faces) == face_set(unbounded)
