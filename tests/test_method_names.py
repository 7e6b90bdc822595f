"""Method names live in one place: the registry (``scanmesh.methods``).

Every other module asks the registry what a method can do (builds strips, runs in tiles,
anneals, is judged by the default, is compared, needs a range grid) instead of keeping its
own list of names or branching on a name: a new method is one entry in the table.
"""

from __future__ import annotations

import ast
from pathlib import Path

import scanmesh
from scanmesh.methods import METHODS

PACKAGE = Path(scanmesh.__file__).resolve().parent

#: Comparisons with a method name's spelling that are about something else, as (module,
#: the other operand): the PLY reader's ``lines="auto"`` (which direction is a scan line).
NOT_METHODS = {("formats/ply.py", "lines")}


def offences(root: Path) -> list[str]:
    """Where a module under ``root`` other than ``methods.py`` holds a list, tuple or set of
    two or more method names, or compares something with a method name (``==``, ``!=``,
    ``in``, ``not in``, ...). O(size of the package)."""
    names = set(METHODS)
    found = []
    for path in sorted(root.rglob("*.py")):
        module = path.relative_to(root).as_posix()
        if module == "methods.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
                held = {n for e in node.elts if (n := _name(e, names)) is not None}
                if len(held) >= 2:
                    found.append(f"{module}:{node.lineno}: lists {sorted(held)}")
            elif isinstance(node, ast.Compare):
                operands = [node.left, *node.comparators]
                named = [_name(o, names) for o in operands if _name(o, names) is not None]
                others = {ast.unparse(o) for o in operands if _name(o, names) is None}
                if named and not any((module, o) in NOT_METHODS for o in others):
                    found.append(f"{module}:{node.lineno}: compares {ast.unparse(node)}")
    return found


def _name(node: ast.AST, names: set[str]) -> str | None:
    """The method name a node spells as a string literal, else None."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in names:
        return node.value
    return None


def test_no_module_but_the_registry_lists_or_compares_method_names():
    assert offences(PACKAGE) == []


def test_the_scan_finds_a_list_of_names_and_a_branch_on_a_name(tmp_path):
    (tmp_path / "methods.py").write_text('TABLE = ("delaunay", "lop")\n')  # the registry: fine
    (tmp_path / "tiles.py").write_text(
        'METHODS = ("delaunay", "lop", "anneal")\n'
        "def run(method):\n"
        '    if method == "anneal":\n'
        "        return 1\n"
        '    return method in ("lop", "anneal")\n'
    )
    (tmp_path / "formats").mkdir()
    (tmp_path / "formats" / "ply.py").write_text('def read(lines):\n    return lines == "auto"\n')
    found = offences(tmp_path)
    lines = [f.split(":")[:2] for f in found]
    assert lines == [["tiles.py", "1"], ["tiles.py", "3"], ["tiles.py", "5"]]  # not ply.py
    assert "lists ['anneal', 'delaunay', 'lop']" in found[0]
