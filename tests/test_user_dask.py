"""A scan as users cut it, on Dask: text files of blank-line-separated scan lines, as a glob."""

from __future__ import annotations

import numpy as np
import pytest

import scanmesh

distributed = pytest.importorskip("distributed")

from scanmesh.distributed import reconstruct_distributed  # noqa: E402


def test_blank_line_text_files_as_a_glob_number_their_lines_on(tmp_path):
    rng = np.random.default_rng(2)
    rows, cols = 12, 15
    lines = []
    for r in range(rows):
        x = np.arange(cols) * 0.5 + rng.normal(0, 0.02, cols)
        y = np.full(cols, r * 0.6) + rng.normal(0, 0.02, cols)
        lines.append(np.column_stack([x, y, np.sin(0.4 * x) * np.cos(0.3 * y)]))
    for k, (a, b) in enumerate([(0, 5), (5, 6), (6, 12)]):
        with open(tmp_path / f"cut{k}.xyz", "w") as f:  # each file's lines numbered from 0
            for line in lines[a:b]:
                np.savetxt(f, line, fmt="%.17g")
                f.write("\n")
    points = np.concatenate(lines)
    ids = np.repeat(np.arange(rows), cols)
    single = scanmesh.reconstruct(points, "shortest-path", lines=ids, plane="z")
    single.save(tmp_path / "single.stl")
    out = tmp_path / "dask.stl"
    with (
        distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster,
        distributed.Client(cluster) as client,
    ):
        result = reconstruct_distributed(
            str(tmp_path / "cut*.xyz"), "shortest-path", client=client, output=out, plane="z"
        )
    assert result.n_points == len(points)
    assert out.read_bytes() == (tmp_path / "single.stl").read_bytes()
