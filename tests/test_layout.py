"""The package's layout: no import circle among scanmesh's modules, no function-local import
of a scanmesh module (such an import only hides a circle; the command's entry point alone
defers its import of the command, which is its purpose), no file over 800 lines, and no
module named after a public attribute of ``scanmesh`` (the function would hide the module)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "python" / "scanmesh"
MAX_LINES = 800

#: The module that imports scanmesh inside a function on purpose: the command's entry point
#: imports the command once its Ctrl-C handler is in place.
DEFERRED_IMPORT = "scanmesh._entry_point"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def all_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def resolve(module: str, path: Path, node: ast.ImportFrom) -> str:
    """The absolute module an ``ImportFrom`` names (relative imports resolved)."""
    if node.level == 0:
        return node.module or ""
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    base = package[: len(package) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imported(module: str, path: Path, node: ast.Import | ast.ImportFrom, known) -> set[str]:
    """The scanmesh modules one import statement loads (``from a import b`` counts ``a.b``
    when ``b`` is a submodule, and ``a`` itself when ``b`` is a name defined there)."""
    if isinstance(node, ast.Import):
        names = {alias.name for alias in node.names}
    else:
        base = resolve(module, path, node)
        subs = {f"{base}.{alias.name}" for alias in node.names}
        subs = {s for s in subs if s in known or s == "scanmesh._core"}  # _core: the native module
        # names that are not submodules come from the package's __init__
        names = subs | ({base} if len(subs) < len(node.names) else set())
    return {n for n in names if n == "scanmesh" or n.startswith("scanmesh.")}


def top_level_imports(tree: ast.Module):
    """Import statements run when the module loads: the module's body and the bodies of its
    top-level ``if``/``try`` blocks (``if TYPE_CHECKING:`` included: the type checker follows
    those, and a circle there is a circle in the types)."""
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, (ast.If, ast.Try)):
            stack.extend(node.body)
            stack.extend(node.orelse)
            stack.extend(getattr(node, "finalbody", []))
            for handler in getattr(node, "handlers", []):
                stack.extend(handler.body)


def local_imports(tree: ast.Module):
    """Import statements inside a function or a class body (each once)."""
    seen: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            for inner in ast.walk(node):
                if isinstance(inner, (ast.Import, ast.ImportFrom)) and id(inner) not in seen:
                    seen.add(id(inner))
                    yield inner


def import_graph() -> dict[str, set[str]]:
    modules = all_modules()
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(), str(path))
        targets: set[str] = set()
        for node in top_level_imports(tree):
            targets |= imported(name, path, node, modules)
        # importing a.b.c runs a/__init__ and a/b/__init__ first, except the packages that
        # hold the importing module (they are already loading: their own arrows count)
        own = {name.rsplit(".", i)[0] for i in range(1, name.count(".") + 1)}
        edges = set(targets)
        for target in targets:
            parts = target.split(".")
            edges |= {".".join(parts[:i]) for i in range(2, len(parts))} - own
        graph[name] = {t for t in edges if t in modules and t != name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}  # 1: on the path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


@pytest.mark.slow
def test_no_import_circle():
    graph = import_graph()
    # the package's own __init__ imports its public modules; a submodule importing
    # ``scanmesh`` itself would close a circle through it, so it stays in the graph
    cycle = find_cycle(graph)
    assert cycle is None, "import circle: " + " -> ".join(cycle)


def test_no_function_local_import_of_scanmesh():
    modules = all_modules()
    found = []
    for name, path in modules.items():
        if name == DEFERRED_IMPORT:
            continue
        tree = ast.parse(path.read_text(), str(path))
        for node in local_imports(tree):
            if imported(name, path, node, modules) or (
                isinstance(node, ast.ImportFrom) and node.level > 0
            ):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, "function-local imports of scanmesh modules:\n" + "\n".join(found)


def test_no_python_file_over_800_lines():
    files = sorted(PACKAGE.rglob("*.py")) + sorted((ROOT / "tests").rglob("*.py"))
    long = [
        f"{p.relative_to(ROOT)}: {n} lines"
        for p in files
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    ]
    assert not long, "files over 800 lines:\n" + "\n".join(long)


def test_no_module_shares_a_name_with_a_package_attribute():
    """``scanmesh.quality`` must be the function, not sometimes the module: a module directly
    inside the package may not carry the name of anything ``scanmesh/__init__.py`` binds."""
    tree = ast.parse((PACKAGE / "__init__.py").read_text())
    bound: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            bound |= {alias.asname or alias.name for alias in node.names}
        elif isinstance(node, ast.Assign):
            bound |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            bound.add(node.name)
    children = {p.stem for p in PACKAGE.glob("*.py")} | {
        p.parent.name for p in PACKAGE.glob("*/__init__.py")
    }
    clash = sorted(bound & children)
    assert not clash, f"modules named after a public attribute of scanmesh: {clash}"
