"""Under a memory limit every stage refuses before it allocates, naming what it needs and the
limit, instead of dying in an allocation that fails (Rust aborts the process then).

Each case runs in its own process under ``RLIMIT_AS`` (``ulimit -v``), set just above what
the process holds once the points are made, so the stage itself is what does not fit.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import trimesh

from conftest import write_views
from scanmesh.evaluate.digitizer import axis_views

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/status").exists(), reason="the limits are read from /proc (Linux)"
)


def limited_child(make: str, command: str, call: str) -> str:
    """The script of a child process that makes its inputs (``make``, from its arguments),
    then limits its address space to ``room`` bytes above what it holds, then runs the
    command (``command``, when ``what`` is "command": its exit status is the child's) or
    the API call ``call``, printing "built", or "refused: " and the MemoryLimitError."""
    head = """
        import resource, sys
        import numpy as np
        import scanmesh
        from scanmesh.cli import main
        """
    limit = """
        np.ones((512, 512)) @ np.ones((512, 512))  # OpenBLAS takes its buffers at its first product
        size = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status")
                    if l.startswith("VmSize:"))
        resource.setrlimit(resource.RLIMIT_AS, (size + room, resource.RLIM_INFINITY))
        if what == "command":
        """
    outcome = """
            print("built")
        except scanmesh.MemoryLimitError as e:
            assert isinstance(e, scanmesh.ScanmeshError) and isinstance(e, MemoryError)
            print("refused:", e)
        """
    body = textwrap.dedent
    return "".join(
        [
            body(head),
            body(make),
            body(limit),
            textwrap.indent(body(command), "    "),
            "try:\n",
            textwrap.indent(body(call), "    "),
            body(outcome),
        ]
    )


def run(script: str, args: tuple[object, ...], timeout: float) -> subprocess.CompletedProcess[str]:
    """``script`` in a child with ``args``; a child still running after ``timeout`` seconds
    is killed (subprocess.TimeoutExpired)."""
    return subprocess.run(
        [sys.executable, "-c", script, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


# A wavy grid of points in scan order; `room` is what the limit leaves above the process's
# address space once they exist, far below what any stage needs for them.
CHILD = limited_child(
    """
    what, n, room = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    side = int(n ** 0.5)
    g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2) * 1.0
    X = np.c_[g, np.sin(g[:, 0] / 7)]
    scan = scanmesh.planar_scan(X, plane="z")
    faces = np.zeros((n, 3), dtype=np.int64)  # n faces on point 0: 50 n bytes of STL
    if what == "command":
        np.savetxt(sys.argv[4], X, fmt="%.6g")
    """,
    """
    sys.exit(main(["reconstruct", sys.argv[4], "-o", sys.argv[5], "--method", sys.argv[6],
                   "--plane", "z", "--quiet"]))
    """,
    """
    if what == "stl":
        scanmesh._core.stl_records(X, faces)
    elif what == "merge":  # the scan as one view from above, a voxel of half a spacing
        scanmesh.merge([(X, np.eye(4))], voxel=0.5, max_voxels=10**12)
    else:
        scanmesh.reconstruct(scan, what, **({"sweeps": 1} if what == "anneal" else {}))
    """,
)


def run_child(*args: object) -> subprocess.CompletedProcess[str]:
    return run(CHILD, args, timeout=120)


@pytest.mark.slow
@pytest.mark.parametrize(
    "method, stage",
    [
        ("delaunay", "Delaunay of"),
        ("shortest-path", "strips on"),
        ("lop", "Delaunay of"),
        ("anneal", "Delaunay of"),
    ],
)
def test_a_stage_beyond_the_address_space_limit_is_refused_with_need_and_limit(method, stage):
    """Before the refusal, Delaunay of 2 million points under a 700 MB limit died with
    SIGABRT ('memory allocation of 78726248 bytes failed'); the strips, LOP and annealing
    too. 90,000 points with 15 MB to spare trip the same check."""
    r = run_child(method, 90_000, 15_000_000)
    assert r.returncode == 0, (r.returncode, r.stderr[-800:])
    line = r.stdout.strip()
    assert line.startswith(f"refused: {stage} 90000 points") and "needs about" in line, line
    assert "MiB of memory, more than the" in line and "RLIMIT_AS (ulimit -v)" in line, line


@pytest.mark.slow
def test_no_limit_between_nothing_and_enough_aborts_the_process():
    """Whatever the room, the process ends normally: built, or refused with a
    MemoryLimitError (a ScanmeshError and a MemoryError); never killed by a signal."""
    for room in range(10_000_000, 130_000_000, 30_000_000):
        r = run_child("delaunay", 90_000, room)
        assert r.returncode == 0, (room, r.returncode, r.stderr[-800:])
        assert r.stdout.startswith(("built", "refused: ")), (room, r.stdout)


@pytest.mark.slow
def test_the_command_under_ulimit_v_exits_1_with_one_line(tmp_path):
    """`ulimit -v 700000` on the command aborted it with no message."""
    out = tmp_path / "mesh.ply"
    r = run_child("command", 90_000, 15_000_000, tmp_path / "scan.xyz", out, "delaunay")
    assert r.returncode == 1, (r.returncode, r.stderr[-800:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("scanmesh: error: Delaunay of 90000 points"), lines
    assert "RLIMIT_AS" in lines[0], lines
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("method", ["lop", "shortest-path"])
def test_lop_and_the_strips_end_in_one_line_or_a_mesh_at_any_room(tmp_path, method):
    """The command ends with a mesh or exits 1 with one line, never by a signal. 60, 106
    and 112 MB of room pass the strips' estimate but not the arrays after it (the quality's
    fans and corner angles): with 90,000 points the strips died there with SIGABRT
    ('memory allocation of 4291248 bytes failed'); now each allocation that grows with the
    input is fallible and ends in a MemoryLimitError naming it."""
    for room in (15_000_000, 60_000_000, 106_000_000, 112_000_000):
        out = tmp_path / f"{room}.ply"
        r = run_child("command", 90_000, room, tmp_path / "scan.xyz", out, method)
        assert r.returncode in (0, 1), (room, r.returncode, r.stderr[-800:])
        lines = r.stderr.strip().splitlines()
        if r.returncode == 1:  # the mesh may be written: the quality is measured beside it
            assert len(lines) == 1 and lines[0].startswith("scanmesh: error: "), (room, lines)
        else:
            assert out.exists(), (room, r.stderr[-800:])


def test_a_failed_allocation_is_a_memory_error_not_an_abort():
    """What the core sizes from its input without an estimate is reserved fallibly: the STL
    records of 2 million faces (100 MB) under 30 MB of room are a MemoryError."""
    r = run_child("stl", 2_000_000, 30_000_000)
    assert r.returncode == 0, (r.returncode, r.stderr[-800:])
    line = r.stdout.strip()
    assert line.startswith("refused: STL records (") and "the allocator" in line, line


def test_merge_beyond_the_address_space_limit_is_refused_naming_what_did_not_fit():
    """The fusion grid's blocks are allocated as the views need them, and the extraction's
    buffers after them, each allocation fallible: 90,000 points fused at half their
    spacing, refused under 60 MB of room with a MemoryLimitError naming the grid's blocks;
    under 400 MB the map of the mesh's edges (its 109 MB hash table aborted the process
    with SIGABRT before it was reserved fallibly); 1 GB builds the mesh."""
    for room, start in (
        (60_000_000, "refused: the fusion grid's blocks"),
        (400_000_000, "refused: the fused mesh's"),
        (1_000_000_000, "built"),
    ):
        r = run_child("merge", 90_000, room)
        assert r.returncode == 0, (room, r.returncode, r.stderr[-800:])
        assert r.stdout.startswith(start), (room, r.stdout)
        if start != "built":
            assert "the allocator" in r.stdout, r.stdout


# merge: the views made first, then the limit; every room ends in a mesh or a refusal

MERGE_CHILD = limited_child(
    """
    import trimesh
    from scanmesh.evaluate.digitizer import axis_views

    what, room, pool = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    views = axis_views(box, 0.02, noise=0.0004, seed=1)
    if pool == "started":  # the core's thread pool starts at its first parallel call
        scanmesh.quality(np.eye(3), [[0, 1, 2]])
    """,
    """
    names = [f"{sys.argv[4]}/v{k}.xyz" for k in range(len(views))]  # written by the parent
    sys.exit(main(["merge", *names, "--poses", f"{sys.argv[4]}/poses.json",
                   "-o", f"{sys.argv[4]}/part.ply", "--voxel", "0.01", "--quiet"]))
    """,
    """
    if what == "quality":
        scanmesh.quality(np.eye(3), [[0, 1, 2]])
    else:
        scanmesh.merge(views, voxel=0.01)
    """,
)


def run_merge_child(
    what: str, room: int, folder: Path | None = None, pool: str = "started", timeout: float = 300
) -> subprocess.CompletedProcess[str]:
    """The merge child: ``what`` ("api", "quality", or "command" on the views written into
    ``folder``), its ``room``, the core's thread pool "started" before the limit or
    "unstarted"; killed after ``timeout`` seconds."""
    args: tuple[object, ...] = (what, room, pool)
    if folder is not None:
        box = trimesh.creation.box((2.0, 1.0, 0.6))
        write_views(axis_views(box, 0.02, noise=0.0004, seed=1), folder)
        args += (folder,)
    return run(MERGE_CHILD, args, timeout)


def test_merge_refuses_what_it_can_foresee_and_names_what_it_could_not():
    """5 MB of room: refused with a MemoryLimitError naming what did not fit (the grid is
    allocated by blocks as the views need them, so what fails first is a view's depth
    image, named with need and limit, or the stage's worker thread, named by its stack).
    2 MB do not hold the views' world coordinates (numpy's MemoryError before): a
    MemoryLimitError too."""
    r = run_merge_child("api", 5_000_000)
    assert r.returncode == 0, (r.returncode, r.stderr[-800:])
    assert r.stdout.startswith("refused: "), r.stdout
    named = "needs about" in r.stdout and "RLIMIT_AS (ulimit -v)" in r.stdout
    assert named or "worker thread for this stage needs a stack" in r.stdout, r.stdout
    r = run_merge_child("api", 2_000_000)
    assert r.returncode == 0, (r.returncode, r.stderr[-800:])
    assert r.stdout.startswith("refused: ") and "RLIMIT_AS" in r.stdout, r.stdout


def test_merge_under_any_limit_builds_or_refuses_never_aborts():
    """550-900 MB of address space aborted merge with SIGABRT ('memory allocation of
    2228240 bytes failed'); here the same sweep at this part's scale."""
    for room in (5_000_000, 15_000_000, 30_000_000, 60_000_000, 120_000_000):
        r = run_merge_child("api", room)
        assert r.returncode == 0, (room, r.returncode, r.stderr[-800:])
        assert r.stdout.startswith(("built", "refused: ")), (room, r.stdout)


def test_the_merge_command_under_ulimit_v_ends_in_a_mesh_or_one_line(tmp_path):
    for room in (10_000_000, 40_000_000, 120_000_000):
        r = run_merge_child("command", room, tmp_path)
        assert r.returncode in (0, 1), (room, r.returncode, r.stderr[-800:])
        if r.returncode == 1:
            lines = r.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("scanmesh: error: "), (room, lines)


def test_the_thread_pool_started_under_the_limit_is_smaller_or_refused_never_a_hang(tmp_path):
    """The core's thread pool starts at the first parallel call. Started under the limit,
    rayon's own start panicked when a worker's stack did not fit, and the panic's own
    allocations failed: the process hung (merge with 12-15 MB of room, killed by the
    timeout). Now the pool starts with the workers that fit, and with none a
    MemoryLimitError names the pool's threads, their stack and the limit; the next call
    tries again."""
    r = run_merge_child("quality", 1_000_000, pool="unstarted", timeout=60)
    assert r.returncode == 0, (r.returncode, r.stderr[-800:])
    assert r.stdout.startswith("refused: the core's thread pool ("), r.stdout
    assert "worker threads, none could start" in r.stdout, r.stdout
    assert "needs about 2.0 MiB" in r.stdout and "RLIMIT_AS (ulimit -v)" in r.stdout, r.stdout
    for room in (3_000_000, 12_000_000, 15_000_000, 30_000_000, 120_000_000):
        r = run_merge_child("api", room, pool="unstarted", timeout=60)
        assert r.returncode == 0, (room, r.returncode, r.stderr[-800:])
        assert r.stdout.startswith(("built", "refused: ")), (room, r.stdout)
    for room in (12_000_000, 40_000_000):
        r = run_merge_child("command", room, tmp_path, pool="unstarted", timeout=60)
        assert r.returncode in (0, 1), (room, r.returncode, r.stderr[-800:])
        if r.returncode == 1:
            lines = r.stderr.strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("scanmesh: error: "), (room, lines)
