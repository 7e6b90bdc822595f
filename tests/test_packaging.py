"""Packaging: one version, a lean core install that works without the extras, clear errors
naming the extra a feature needs, and a stripped native module."""

from __future__ import annotations

import importlib.metadata
import json
import re
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh import MissingExtraError, ScanmeshError
from scanmesh.present.panels import render_compare, render_panels
from scanmesh.present.render import plot_convergence, render_mesh

ROOT = Path(__file__).resolve().parents[1]

#: Modules only the extras install.
EXTRA_MODULES = ("matplotlib", "PIL", "laspy", "pye57", "pyvista", "open3d")

#: Put in front of a child's script: importing any extra's module fails, as on a core install.
BLOCK_EXTRAS = f"""
import importlib.abc, sys
class _Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {EXTRA_MODULES!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}} (blocked)", name=name)
sys.meta_path.insert(0, _Block())
"""


def run_without_extras(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", BLOCK_EXTRAS + textwrap.dedent(script)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
    )


def test_version_is_the_one_in_cargo_toml():
    text = (ROOT / "Cargo.toml").read_text()
    block = text[text.index("[workspace.package]") :]
    version = re.search(r'^version\s*=\s*"([^"]+)"', block, re.M).group(1)
    assert scanmesh.__version__ == version
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert 'dynamic = ["version"]' in pyproject
    assert not re.search(r"^version\s*=", pyproject, re.M)


def test_pip_show_gives_the_licence_and_no_invented_address():
    """``pip show scanmesh`` reads the ``License`` field (pip before 24 ignores PEP 639's
    ``License-Expression``): it must say MIT. The project has no public address, so the
    metadata names none."""
    shown = subprocess.run(
        [sys.executable, "-m", "pip", "show", "scanmesh"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert shown.returncode == 0, shown.stderr
    fields = dict(line.split(": ", 1) for line in shown.stdout.splitlines() if ": " in line)
    assert fields["License"] == "MIT"
    assert not fields.get("Home-page")
    meta = importlib.metadata.metadata("scanmesh")
    assert meta.get_all("Project-URL") is None and meta.get("Home-page") is None


def test_core_install_reconstructs_judges_and_draws_without_any_extra(tmp_path):
    result = run_without_extras(
        """
        import json, numpy as np, scanmesh
        from scanmesh.present.render import render_mesh
        from scanmesh.evaluate.truth import height_error
        points, ids = scanmesh.load_rod()
        keep = ids < 20
        s = scanmesh.reconstruct(points[keep], "anneal", lines=ids[keep], plane="y", seed=0)
        s.save("rod.stl")
        render_mesh(s, "rod.png", size=(120, 90), color_by="tac")
        err = height_error(s, scanmesh.demo.rod_truth(), n_samples=2000, seed=0)
        print(json.dumps({"faces": len(s.faces), "h_rms": err["h_rms"]}))
        """,
        tmp_path,
    )
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    assert out["faces"] > 100 and out["h_rms"] < 0.01
    assert (tmp_path / "rod.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "rod.stl").stat().st_size == 84 + 50 * out["faces"]


@pytest.mark.slow
@pytest.mark.parametrize(
    ("call", "extra"),
    [
        ("scanmesh.read(DATA / 'lidar' / 'autzen_trim.laz')", "las"),
        ("plot_convergence({'energy': [3.0, 2.0, 1.0]}, 'c.png')", "plots"),
        (
            "render_compare([scanmesh.delaunay(np.random.default_rng(0).random((9, 3)))], 'p.png')",
            "plots",
        ),
        (
            "render_panels([scanmesh.delaunay(np.random.default_rng(0).random((9, 3)))], 'p.png',"
            " color_by='tac')",
            "plots",
        ),
        ("scanmesh.delaunay(np.random.default_rng(0).random((9, 3))).to_pyvista()", "pyvista"),
        ("scanmesh.delaunay(np.random.default_rng(0).random((9, 3))).to_open3d()", "open3d"),
        ("Path('s.e57').write_bytes(b'ASTM-E57' + bytes(64)); scanmesh.read('s.e57')", "e57"),
    ],
)
def test_a_feature_without_its_extra_names_the_extra(tmp_path, call, extra):
    result = run_without_extras(
        f"""
        import numpy as np, scanmesh
        from pathlib import Path
        from scanmesh.present.panels import render_compare, render_panels
        from scanmesh.present.render import plot_convergence
        DATA = Path({str(DATA)!r})
        try:
            {call}
        except scanmesh.MissingExtraError as exc:
            assert isinstance(exc, ImportError) and isinstance(exc, scanmesh.ScanmeshError)
            print(exc)
        """,
        tmp_path,
    )
    assert result.returncode == 0, result.stderr
    assert f'pip install "scanmesh[{extra}]"' in result.stdout
    assert not list(tmp_path.glob("*.png"))


def test_the_command_names_the_extra_and_fails_cleanly(tmp_path):
    scan = DATA / "lidar" / "autzen_trim.laz"
    result = run_without_extras(
        f"""
        from scanmesh.cli import main
        sys.exit(main(["reconstruct", {str(scan)!r}, "-o", "m.stl", "--method", "delaunay"]))
        """,
        tmp_path,
    )
    assert result.returncode == 1
    assert "scanmesh: error:" in result.stderr and "scanmesh[las]" in result.stderr
    assert "Traceback" not in result.stderr and not (tmp_path / "m.stl").exists()


def test_extras_present_here_do_their_work(tmp_path):
    """The same calls succeed with the extras installed (the test extra installs them all)."""
    surface = scanmesh.reconstruct(np.random.default_rng(0).random((8, 3)) * [1, 1, 0.1], "optimal")
    assert surface.certified
    plot_convergence({"energy": [3.0, 2.0, 1.0]}, tmp_path / "c.png")
    render_compare([surface], tmp_path / "p.png")
    render_panels([surface], tmp_path / "q.png", color_by="height")
    render_mesh(surface, tmp_path / "m.png", size=(40, 30))
    assert all((tmp_path / n).stat().st_size > 100 for n in ("c.png", "p.png", "m.png"))
    with pytest.raises(ScanmeshError):  # a MissingExtraError is also an input-error class
        raise MissingExtraError("x")


def elf_section_names(path: Path) -> set[str]:
    """Section names of a 64-bit little-endian ELF file, from its section header table."""
    data = path.read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 2 and data[5] == 1, "not a 64-bit LE ELF"
    shoff = struct.unpack_from("<Q", data, 0x28)[0]
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)

    def header(k):  # (name offset, file offset) of section k
        base = shoff + k * shentsize
        return struct.unpack_from("<I", data, base)[0], struct.unpack_from("<Q", data, base + 24)[0]

    strtab = header(shstrndx)[1]
    names = set()
    for k in range(shnum):
        start = strtab + header(k)[0]
        names.add(data[start : data.index(b"\0", start)].decode())
    return names


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the ELF section table")
def test_the_native_module_is_stripped():
    names = elf_section_names(Path(scanmesh._core.__file__))
    assert ".text" in names and ".dynsym" in names  # the parse found real sections
    assert not {n for n in names if n.startswith(".debug_")}, sorted(names)
    assert ".symtab" not in names
