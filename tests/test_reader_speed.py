"""Readers take time linear in their input: a hostile wide row is refused at once."""

from __future__ import annotations

import time

import pytest

import scanmesh
from scanmesh.errors import FileFormatError


def _refuse_seconds(path, n_values: int) -> float:
    """Seconds ``scanmesh.read`` takes to refuse a file whose rows hold ``n_values`` values."""
    row = " ".join(["1.5"] * n_values)
    path.write_text(f"{row}\n{row}\n")
    t0 = time.perf_counter()
    with pytest.raises(FileFormatError, match="line 1"):
        scanmesh.read(path)
    return time.perf_counter() - t0


def test_wide_first_row_is_refused_quickly(tmp_path):
    # a list membership test per column made this quadratic: 100,000 values took 36 s
    assert _refuse_seconds(tmp_path / "wide.xyz", 100_000) < 5.0


def test_wide_row_refusal_is_linear(tmp_path):
    small = min(_refuse_seconds(tmp_path / "small.xyz", 20_000) for _ in range(3))
    large = min(_refuse_seconds(tmp_path / "large.xyz", 80_000) for _ in range(3))
    # linear: 4 times the values take about 4 times as long (quadratic: 16 times)
    assert large < 8 * small + 0.05


def _gunzip_seconds(megabytes: int) -> float:
    """Seconds to decompress ``megabytes`` MB of incompressible bytes (a compressed stream
    as long as its content), the best of three."""
    import os
    import zlib
    from pathlib import Path

    from scanmesh.formats._source import gunzip

    pack = zlib.compressobj(0, zlib.DEFLATED, 31)  # stored: compressed size = content
    data = pack.compress(os.urandom(1 << 20) * megabytes) + pack.flush()
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        assert len(gunzip(Path("big.gz"), data)) == megabytes << 20
        best = min(best, time.perf_counter() - t0)
    return best


def test_gzip_decompression_is_linear():
    """Each inflate call was given all the compressed bytes left, and copied back the rest
    it did not read (its unconsumed_tail) per MB of output: quadratic in the file (a 121 MB
    .gz took 27 s, where zlib in one call takes 3 s; 2.8 s now)."""
    small = _gunzip_seconds(16)
    large = _gunzip_seconds(64)
    # linear: 4 times the bytes take about 4 times as long (quadratic: 16 times)
    assert large < 8 * small + 0.05, (small, large)
