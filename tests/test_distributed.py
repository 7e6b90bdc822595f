"""scanmesh.distributed on a LocalCluster of processes (2 workers): strips equal to one
process exactly, whatever the partitioning; output written by the workers, atomically;
a worker killed mid-run changes nothing. Skipped only when dask is not installed."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import scanmesh
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.formats.georef import Georef, from_comments
from scanmesh.formats.write import save_mesh

distributed = pytest.importorskip("distributed")
da = pytest.importorskip("dask.array")

from scanmesh.distributed import _median, _output, _tiles, reconstruct_distributed  # noqa: E402


def save_plain(surface: scanmesh.Surface, path: Path) -> None:
    """The mesh as the Dask path writes it: vertices, faces and the scan's per-point values
    (no normals, tac or height: :meth:`Surface.save` adds them from every face of a vertex,
    which no worker holds)."""
    save_mesh(path, surface.vertices, surface.faces, point_data=surface.point_data)


def wavy_scan(rows: int, cols: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A zig-zag scan of a wavy surface with jitter, a hole and lone points beside it."""
    rng = np.random.default_rng(seed)
    pts, ids = [], []
    for r in range(rows):
        c = np.arange(cols, dtype=float)
        if r % 2:
            c = c[::-1]
        x = c * 0.5 + 0.05 * (r % 3) + rng.normal(0, 0.02, cols)
        y = r * 0.7 + rng.normal(0, 0.02, cols)
        z = np.sin(0.4 * x) * np.cos(0.3 * y) + rng.normal(0, 0.01, cols)
        keep = (x - 6) ** 2 + (y - 0.35 * rows) ** 2 > 1.6**2
        keep |= (np.abs(x - 6) < 0.26) & (np.abs(y - 0.35 * rows) < 0.4)  # lone points
        pts.append(np.column_stack([x, y, z])[keep])
        ids.append(np.full(int(keep.sum()), 3 * r))  # ids need not be consecutive
    return np.concatenate(pts), np.concatenate(ids)


def write_files(folder: Path, points, ids, bounds, ending=".npz") -> list[str]:
    """The scan cut into files at the given line ids (each file a run of whole lines)."""
    paths = []
    for i, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        m = (ids >= a) & (ids < b)
        path = folder / f"part{i:02d}{ending}"
        if ending == ".npz":
            np.savez(path, points=points[m], line_ids=ids[m])
        else:
            np.savetxt(path, np.column_stack([points[m], ids[m]]), header="x y z line", fmt="%.17g")
        paths.append(str(path))
    return paths


@pytest.fixture(scope="module")
def client():
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as c,
    ):
        yield c


@pytest.fixture(scope="module")
def scan():
    return wavy_scan(40, 60)


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("method", "partition_lines", "ending"),
    [
        ("shortest-path", None, ".stl"),
        ("shortest-path", 3, ".ply"),
        ("lookahead", 7, ".stl"),
    ],
)
def test_strips_are_the_single_process_file_byte_for_byte(
    client, scan, tmp_path, method, partition_lines, ending
):
    points, ids = scan
    paths = write_files(tmp_path, points, ids, [0, 30, 93, 96, 200])
    single = scanmesh.reconstruct(points, method, lines=ids, plane="z")
    save_plain(single, tmp_path / f"single{ending}")
    out = tmp_path / f"dask{ending}"
    result = reconstruct_distributed(
        paths, method, client=client, output=out, partition_lines=partition_lines, plane="z"
    )
    assert out.read_bytes() == (tmp_path / f"single{ending}").read_bytes()
    assert result.n_faces == len(single.faces) and result.n_points == len(points)
    assert result.options["partitions"] > 4 if partition_lines else result.options["partitions"] > 2
    q = single.quality
    for key, value in q.as_dict().items():
        assert result.quality[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    assert result.options["unused"] == len(single.options["unused"])
    assert result.options["planar_valid"] is True and not leftovers(tmp_path)


def stepped_scan(rows: int = 24, cols: int = 30, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Zig-zag lines over two depth steps, one across the lines (between lines 10 and 11)
    and one along them, every fifth line swinging 1.2 line spacings to each side, so that it
    crosses its neighbours: strips are dropped at jumps and overlaps near every border."""
    rng = np.random.default_rng(seed)
    pts, ids = [], []
    for r in range(rows):
        c = np.arange(cols, dtype=float)[:: -1 if r % 2 else 1]
        x = c * 0.5 + rng.normal(0, 0.03, cols)
        y = r * 0.7 + rng.normal(0, 0.03, cols) + 1.2 * np.sin(1.3 * x + r) * (r % 5 == 2)
        z = 3.0 * (x > 8.0 + 0.3 * np.sin(r)) + 2.5 * (y > 7.3) + rng.normal(0, 0.01, cols)
        pts.append(np.column_stack([x, y, z]))
        ids.append(np.full(cols, r))
    return np.concatenate(pts), np.concatenate(ids)


@pytest.mark.slow
def test_drops_at_jumps_and_crossings_near_borders_are_the_single_process_ones(client, tmp_path):
    """Depth jumps and crossing lines at partition borders: every partitioning gives the
    one-process file. Each partition decided the drops there on its own triangles before
    (a depth jump's local spacing saw one side of the border line; 2 to 159 faces
    differed), now also on the lines beyond its borders."""
    points, ids = stepped_scan()
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    assert single.options["dropped_jumps"] > 50 and single.options["dropped_overlaps"] > 200
    save_plain(single, tmp_path / "single.ply")
    paths = write_files(tmp_path, points, ids, [0, 7, 11, 16, 24])
    for partition_lines in (None, *range(2, 9)):
        out = tmp_path / "dask.ply"
        result = reconstruct_distributed(
            paths,
            "shortest-path",
            client=client,
            output=out,
            partition_lines=partition_lines,
            plane="z",
        )
        assert out.read_bytes() == (tmp_path / "single.ply").read_bytes(), partition_lines
        assert result.options["cost"] == pytest.approx(single.options["cost"], rel=1e-12)
        assert result.options["unused"] == len(single.options["unused"]), partition_lines


def test_text_files_a_glob_and_a_detected_plane(client, scan, tmp_path):
    points, ids = scan
    write_files(tmp_path, points, ids, [0, 40, 80, 200], ending=".xyz")
    out = tmp_path / "m.stl"
    result = reconstruct_distributed(str(tmp_path / "part*.xyz"), client=client, output=out)
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane=result.options["plane"])
    single.save(tmp_path / "single.stl")
    assert out.read_bytes() == (tmp_path / "single.stl").read_bytes()


def _count_reads() -> None:
    """On a worker: record every path scanmesh.formats.read is asked for."""
    import scanmesh.formats as formats

    original = getattr(formats, "_uncounted_read", formats.read)
    formats._uncounted_read = original
    formats._reads = []

    def counted(path, **kwargs):
        formats._reads.append(str(path))
        return original(path, **kwargs)

    formats.read = counted


def _stop_counting() -> list[str]:
    """On a worker: the paths read since _count_reads, and read restored."""
    import scanmesh.formats as formats

    formats.read = formats._uncounted_read
    return formats._reads


@pytest.mark.slow
@pytest.mark.parametrize(("method", "ending"), [("shortest-path", ".ply"), ("delaunay", ".stl")])
def test_each_text_file_is_parsed_once(client, scan, tmp_path, method, ending):
    """The listing copies text parts to .npy; line statistics, strips or tiles and the
    PLY vertices read the copies. The mesh is the one a parse at every stage gave."""
    points, ids = scan
    paths = write_files(tmp_path, points, ids, [0, 40, 80, 200], ending=".xyz")
    client.run(_count_reads)
    try:
        out = tmp_path / f"m{ending}"
        lines = {"partition_lines": 4} if method == "shortest-path" else {}
        result = reconstruct_distributed(
            paths, method, client=client, output=out, plane="z", **lines
        )
    finally:
        reads = [path for done in client.run(_stop_counting).values() for path in done]
    assert sorted(reads) == sorted(paths)
    if method == "delaunay":
        single = scanmesh.reconstruct(points, method, plane="z")
        assert result.n_faces == len(single.faces)
        assert result.quality["tac_1"] == pytest.approx(single.quality.tac_1, rel=1e-9)
    else:
        single = scanmesh.reconstruct(points, method, lines=ids, plane="z")
        save_plain(single, tmp_path / f"single{ending}")
        assert out.read_bytes() == (tmp_path / f"single{ending}").read_bytes()
    assert not leftovers(tmp_path)


def test_a_dask_array_source(client, scan, tmp_path):
    points, ids = scan
    out = tmp_path / "m.ply"
    arrays = (da.from_array(points, chunks=(700, 3)), da.from_array(ids, chunks=700))
    with pytest.raises(ScanmeshError, match="continue into the next"):
        # chunks of 700 rows cut lines: each file (chunk) must hold whole lines
        reconstruct_distributed(arrays, client=client, output=out, plane="z")
    starts = np.flatnonzero(np.diff(ids)) + 1
    chunks = np.diff(np.concatenate([[0], starts[9::10], [len(ids)]]))
    stacked = da.from_array(np.column_stack([points, ids]), chunks=(tuple(chunks), 4))
    reconstruct_distributed(stacked, client=client, output=out, plane="z")
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    save_plain(single, tmp_path / "single.ply")
    assert out.read_bytes() == (tmp_path / "single.ply").read_bytes()
    assert not leftovers(tmp_path)


def test_turned_blocks_are_the_faces_turned_round(tmp_path):
    """A block placed turned round is the file of its faces with two corners swapped."""
    points, ids = wavy_scan(6, 12)
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    block = _output.FaceBlock(points, single.faces, 0)
    for kind in (".stl", ".ply"):
        written = _output.write_block(block, str(tmp_path / f"b{kind}"), kind)
        target = tmp_path / f"t{kind}"
        target.write_bytes(b"\0" * (written.size + 7))
        _output.place(written.path, str(target), 7, True, kind)
        turned = _output.FaceBlock(points, single.faces[:, [0, 2, 1]], 0)
        expected = _output.write_block(turned, str(tmp_path / f"e{kind}"), kind)
        assert target.read_bytes()[7:] == Path(expected.path).read_bytes()


def test_the_median_step_is_exact_over_parts(client):
    rng = np.random.default_rng(3)
    values = [np.sort(rng.lognormal(0, 1, n)) for n in (1000, 1, 2500)]
    values.append(np.sort(np.repeat([0.5, 2.0**-1074, 7.0], 400)))
    futures = client.scatter(values)
    everything = np.sort(np.concatenate(values))
    median = _median.exact_median(client, futures, len(everything))
    assert median == everything[len(everything) // 2]
    assert _median.exact_median(client, [], 0) == 0.0


def test_one_exact_median_serves_steps_and_tiles(client):
    """The one distributed median is numpy's median for an odd count, whether the workers
    hold the sorted values (the strips' steps) or tiles carrying them (the tiles'
    nearest-neighbour distances, read through ``_tiles.NEAREST``)."""
    rng = np.random.default_rng(11)
    values = [np.sort(rng.exponential(0.3, n)) for n in (301, 0, 1250, 2)]
    total = sum(len(v) for v in values)
    assert total % 2 == 1
    expected = np.median(np.concatenate(values))
    assert _median.exact_median(client, client.scatter(values), total) == expected
    tiles = [client.submit(SimpleNamespace, nearest=v, pure=False) for v in values]
    assert _median.exact_median(client, tiles, total, _tiles.NEAREST) == expected


def test_bad_requests_are_refused_before_any_work(client, scan, tmp_path):
    points, ids = scan
    paths = write_files(tmp_path, points, ids, [0, 60, 200])
    with pytest.raises(ParameterError, match=r"\.stl or \.ply"):
        reconstruct_distributed(paths, client=client, output=tmp_path / "m.obj")
    with pytest.raises(ParameterError, match="object store URL cannot be written atomically"):
        reconstruct_distributed(paths, client=client, output="s3://bucket/site.stl")
    with pytest.raises(ParameterError, match="unknown method 'strips'"):
        reconstruct_distributed(paths, "strips", client=client, output=tmp_path / "m.stl")
    with pytest.raises(ParameterError, match="method 'auto' does not run on Dask"):
        reconstruct_distributed(paths, "auto", client=client, output=tmp_path / "m.stl")
    with pytest.raises(ParameterError, match="partition_lines"):
        reconstruct_distributed(paths, client=client, output=tmp_path / "m.stl", partition_lines=0)
    with pytest.raises(ParameterError, match="partition_lines applies to the strip methods"):
        reconstruct_distributed(
            paths, "delaunay", client=client, output=tmp_path / "m.stl", partition_lines=5
        )
    with pytest.raises(ParameterError, match="matches no file"):
        reconstruct_distributed(str(tmp_path / "no*.xyz"), client=client, output=tmp_path / "m.stl")
    with pytest.raises(ScanmeshError, match="part00.npz"):  # files out of scan order
        reconstruct_distributed(paths[::-1], client=client, output=tmp_path / "m.stl", plane="z")
    with pytest.raises(ParameterError, match="unknown option"):
        reconstruct_distributed(paths, client=client, output=tmp_path / "m.stl", alpha=3)
    apart = np.array([[x, y, 0.0] for y, x0 in ((0, 0), (1, 100)) for x in range(x0, x0 + 9)])
    lone = write_files(tmp_path, apart, np.repeat([0, 1], 9), [0, 1, 2])
    with pytest.raises(scanmesh.DegenerateInputError, match="no strip"):
        scanmesh.reconstruct(apart, "shortest-path", lines=np.repeat([0, 1], 9), plane="z")
    with pytest.raises(scanmesh.DegenerateInputError, match="no strip"):
        reconstruct_distributed(lone, client=client, output=tmp_path / "m.stl", plane="z")
    assert not (tmp_path / "m.stl").exists() and not leftovers(tmp_path)


@pytest.mark.parametrize("fault", [KeyboardInterrupt, RuntimeError])
def test_a_failure_at_the_end_leaves_the_old_output_and_no_trace(
    client, scan, tmp_path, monkeypatch, fault
):
    points, ids = scan
    paths = write_files(tmp_path, points, ids, [0, 60, 200])
    out = tmp_path / "m.stl"
    out.write_bytes(b"the user's file")

    def broken_replace(*args):
        raise fault("stopped while renaming")

    # the last step: every block written and placed in the temporary
    monkeypatch.setattr(_output.os, "replace", broken_replace)
    with pytest.raises(fault):
        reconstruct_distributed(paths, client=client, output=out, plane="z")
    assert out.read_bytes() == b"the user's file" and not leftovers(tmp_path)


@pytest.mark.slow
def test_a_killed_worker_is_replaced_and_the_file_is_the_same(scan, tmp_path):
    points, ids = wavy_scan(120, 400, seed=1)  # 48k points, 12 partitions
    paths = write_files(tmp_path, points, ids, [0, *range(30, 360, 30), 1000])
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as c,
    ):
        reconstruct_distributed(paths, client=c, output=tmp_path / "calm.stl", plane="z")
        killed = []

        def kill_a_solving_worker():
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and not killed:
                for address, keys in c.processing().items():
                    if any(str(k).startswith("scanmesh-strips-") for k in keys):
                        pid = c.run(os.getpid, workers=[address])[address]
                        os.kill(pid, signal.SIGKILL)
                        killed.append(pid)
                        return
                time.sleep(0.005)

        killer = threading.Thread(target=kill_a_solving_worker)
        killer.start()
        reconstruct_distributed(paths, client=c, output=tmp_path / "killed.stl", plane="z")
        killer.join()
    assert killed, "no worker was solving strips while the run lasted"
    assert (tmp_path / "killed.stl").read_bytes() == (tmp_path / "calm.stl").read_bytes()
    assert not leftovers(tmp_path)


@pytest.mark.slow
def test_without_dask_the_extra_is_named(tmp_path):
    script = textwrap.dedent(
        """
        import importlib.abc, sys
        class Block(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in ("dask", "distributed"):
                    raise ModuleNotFoundError(name)
        sys.meta_path.insert(0, Block())
        import scanmesh
        from scanmesh.distributed import reconstruct_distributed
        try:
            reconstruct_distributed("x.xyz", output="m.stl")
        except scanmesh.MissingExtraError as exc:
            print(exc)
        """
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path, timeout=120
    )
    assert result.returncode == 0, result.stderr
    assert 'pip install "scanmesh[dask]"' in result.stdout


@pytest.mark.slow
def test_the_command_runs_on_a_local_cluster(scan, tmp_path, capsys):
    from scanmesh.cli import main

    points, ids = scan
    write_files(tmp_path, points, ids, [0, 60, 200])
    out = tmp_path / "m.stl"
    base = ["reconstruct", str(tmp_path / "part*.npz"), "-o", str(out), "--plane", "z"]
    for flags, message in (
        (["--workers", "2"], "--workers applies with --dask only"),
        (["--dask", "tcp://127.0.0.1:1", "--workers", "2"], "--workers applies with --dask local"),
        (["--dask", "local", "--preview", "p.png"], "--preview cannot be used with --dask"),
    ):
        with pytest.raises(SystemExit) as stop:
            main([*base, "--method", "shortest-path", *flags])
        assert stop.value.code == 2 and message in capsys.readouterr().err
    code = main([*base, "--method", "shortest-path", "--dask", "local", "--workers", "2", "--json"])
    assert code == 0
    report = json.loads(capsys.readouterr().out)
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    single.save(tmp_path / "single.stl")
    assert out.read_bytes() == (tmp_path / "single.stl").read_bytes()
    assert report["counts"]["faces"] == len(single.faces) and not leftovers(tmp_path)
    assert report["noise"] == single.options.get("noise")  # the one-process report's key


def _command(tmp_path: Path, *args: str) -> subprocess.Popen:
    """``scanmesh reconstruct ... --dask local --workers 1`` in its own process group, as
    a terminal runs it (Ctrl-C there reaches every process of the group)."""
    restore = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
    run = restore + "import sys\nfrom scanmesh.cli import main\nsys.exit(main())\n"
    return subprocess.Popen(
        [sys.executable, "-c", run, "reconstruct", *args, "--dask", "local", "--workers", "1"],
        cwd=tmp_path,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


@pytest.mark.slow
def test_a_bad_file_under_dask_is_one_line(tmp_path):
    (tmp_path / "bad.xyz").write_text("1 2 3\n4 5 x\n")
    proc = _command(tmp_path, "bad.xyz", "-o", "m.ply", "--method", "delaunay", "--quiet")
    err = proc.communicate(timeout=300)[1]
    assert proc.returncode == 1
    assert err.splitlines() == ["scanmesh: error: bad.xyz, line 2: 'x' is not a number: '4 5 x'"]


def _signal_a_dask_run(tmp_path: Path, kill: Callable[[int], None]) -> tuple[str, float, int]:
    """Start a long annealing run under --dask, ``kill(pid)`` once it works; return its
    stderr, the seconds it took to end after that, and its exit status."""
    rng = np.random.default_rng(0)
    xy = rng.random((60_000, 2))
    np.save(tmp_path / "scan.npy", np.column_stack([xy, np.sin(5 * xy[:, 0]) * xy[:, 1]]))
    proc = _command(
        tmp_path, "scan.npy", "-o", "m.ply", "--method", "anneal", "--sweeps", "100000", "--quiet"
    )
    try:
        deadline = time.monotonic() + 240
        while not leftovers(tmp_path) and time.monotonic() < deadline:  # the run's scratch
            time.sleep(0.05)
        time.sleep(1.0)  # well inside the annealing of the tiles
        assert proc.poll() is None
        sent = time.monotonic()
        kill(proc.pid)
        err = proc.communicate(timeout=120)[1]
        return err, time.monotonic() - sent, proc.returncode
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)


@pytest.mark.slow
def test_sigterm_under_dask_discards_the_temporaries(tmp_path):
    _, _, code = _signal_a_dask_run(tmp_path, lambda pid: os.kill(pid, signal.SIGTERM))
    assert code == -signal.SIGTERM  # still ended by the signal, after the cleanup
    assert not leftovers(tmp_path) and not (tmp_path / "m.ply").exists()


@pytest.mark.slow
def test_ctrl_c_under_dask_is_one_line_and_prompt(tmp_path):
    err, took, code = _signal_a_dask_run(tmp_path, lambda pid: os.killpg(pid, signal.SIGINT))
    assert code == 130
    assert err.splitlines() == ["scanmesh: interrupted"]
    # typically 1-2 s (4.2 s once on a fresh CI machine): the workers are stopped and the
    # cluster closed; the annealing it interrupts would run for many minutes
    assert took < 10.0
    assert not leftovers(tmp_path)


def test_per_point_values_reach_the_ply_as_in_one_process(client, scan, tmp_path):
    """Colours and intensities the files carry are the PLY's vertex properties, as one
    process writes them for the whole scan; a value one file holds as uint16 and another
    as float32 is written in the type that holds both."""
    from test_complete_ply import parse_ply

    points, ids = scan
    georef = Georef(crs="EPSG:26910", horizontal_units="metre", vertical_units="metre")
    crs = georef.comments()  # each file records the same CRS: the mesh names it
    rng = np.random.default_rng(5)
    rgb = rng.integers(0, 256, (len(points), 3), dtype=np.uint8)
    intensity = rng.integers(0, 4000, len(points)).astype(np.uint16)
    paths = []
    for i, (a, b) in enumerate([(0, 12), (12, 25), (25, 40)]):
        m = (ids >= a) & (ids < b)
        values = {"red": rgb[m, 0], "green": rgb[m, 1], "blue": rgb[m, 2]}
        values["intensity"] = intensity[m].astype(np.float32 if i == 1 else np.uint16)
        paths.append(tmp_path / f"part{i}.ply")
        save_mesh(
            paths[-1], points[m], np.empty((0, 3), np.int64), point_data=values, comments=crs
        )
    out = tmp_path / "m.ply"
    result = reconstruct_distributed([str(p) for p in paths], "delaunay", client=client, output=out)
    comments, v, faces = parse_ply(out)
    assert from_comments(comments) == georef
    assert list(v.dtype.names) == ["x", "y", "z", "red", "green", "blue", "intensity"]
    assert v["red"].dtype == np.uint8 and v["intensity"].dtype == np.float32
    order = np.concatenate([np.flatnonzero((ids >= a) & (ids < b)) for a, b in
                            [(0, 12), (12, 25), (25, 40)]])  # fmt: skip
    np.testing.assert_array_equal(np.column_stack([v["x"], v["y"], v["z"]]), points[order])
    # one process on the same points and values: the same vertex properties and faces
    whole = scanmesh.ScanPoints(
        points=points[order],
        line_ids=None,
        source=paths[0],
        point_data={"red": rgb[order, 0], "green": rgb[order, 1], "blue": rgb[order, 2],
                    "intensity": intensity[order].astype(np.float32)},
    )  # fmt: skip
    single = scanmesh.reconstruct(whole, "delaunay", plane=result.options["plane"])
    single.save(tmp_path / "single.ply")
    _, w, single_faces = parse_ply(tmp_path / "single.ply")
    for name in ("red", "green", "blue", "intensity"):
        np.testing.assert_array_equal(v[name], w[name])
    assert set(map(tuple, np.sort(faces, axis=1).tolist())) == set(
        map(tuple, np.sort(single_faces, axis=1).tolist())
    )
    assert not leftovers(tmp_path)


def test_values_some_files_lack_are_left_out_with_a_warning():
    from scanmesh.distributed._source import PartSummary, common_point_data

    def summary(count, *values):
        return PartSummary(count, np.zeros(3), np.ones(3), 0, 1, True, np.zeros((1, 3)),
                           point_data=tuple(values))  # fmt: skip

    parts = [
        summary(5, ("red", "|u1"), ("i", "<u2"), ("q", "<i4")),
        summary(0),  # no points: no say
        summary(5, ("red", "|u1"), ("i", "<f4"), ("q", "<u4")),
        summary(5, ("q", "<i4"), ("i", "<i2")),
    ]
    with pytest.warns(UserWarning, match="c.ply has no per-point 'red' that a.ply has"):
        got = common_point_data(["a.ply", "b.ply", "b2.ply", "c.ply"], parts)
    # u2 with f4 and i2: f4 holds them all; i4 with u4: no PLY integer does, so double
    assert got == {"i": "<f4", "q": "<f8"}


def test_a_crs_the_files_disagree_on_is_left_out_with_a_warning():
    from scanmesh.distributed._source import PartSummary, common_georef

    def summary(count, *georef):
        return PartSummary(count, np.zeros(3), np.ones(3), 0, 1, True, np.zeros((1, 3)),
                           georef=georef)  # fmt: skip

    same = [summary(5, "crs EPSG:2992"), summary(0), summary(5, "crs EPSG:2992")]
    assert common_georef(["a", "b", "c"], same) == ("crs EPSG:2992",)
    with pytest.warns(UserWarning, match="c.las records another CRS or units than a.las"):
        mixed = [summary(5, "crs EPSG:2992"), summary(0), summary(5, "crs EPSG:26910")]
        assert common_georef(["a.las", "b.las", "c.las"], mixed) == ()
