"""The Rust crates' layout: no module cycle in the core (counting the `crate::`, `super::` and
`self::` paths of non-test code) and no Rust file over 900 lines.

The module graph is read from the source text: each file is a module (`mod.rs` and `lib.rs`
name their folder); a path's longest prefix that is a module is the module it uses, and a
name that module re-exports (`pub use`, `pub(crate) use`) leads on to the file defining it,
so `crate::Error` is an edge to `error.rs`. `super::` in `a/b.rs` is `a`, as in Rust. A
file using its own folder's `mod.rs` (shared types) is not counted: the folder is one room,
and its parent always declares it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "rust" / "scanmesh-core" / "src"
MAX_LINES = 900

Module = tuple[str, ...]


def module_of(path: Path, src: Path) -> Module:
    parts = path.relative_to(src).with_suffix("").parts
    return parts[:-1] if parts[-1] in ("mod", "lib") else parts


def without_tests_and_comments(text: str) -> str:
    """The source without comments, string contents and `#[cfg(test)]` items."""
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    kept, i = [], 0
    while (j := text.find("#[cfg(test)]", i)) >= 0:
        kept.append(text[i:j])
        k, depth = j + len("#[cfg(test)]"), 0
        while k < len(text):  # to the item's closing brace, or its `;`
            if text[k] == "{":
                depth += 1
            elif text[k] == "}":
                depth -= 1
                if depth == 0:
                    break
            elif text[k] == ";" and depth == 0:
                break
            k += 1
        i = k + 1
    kept.append(text[i:])
    return "".join(kept)


def expand(path: str) -> list[str]:
    """`a::{b, c::{d, e}}` as `a::b`, `a::c::d`, `a::c::e`."""
    match = re.match(r"^(.*?)\{(.*)\}$", path)
    if not match:
        return [path]
    head, body = match.groups()
    parts, depth, current = [], 0, ""
    for char in body:
        if char == "," and depth == 0:
            parts.append(current)
            current = ""
            continue
        depth += (char == "{") - (char == "}")
        current += char
    parts.append(current)
    return [q for p in parts if p.strip() for q in expand(head + p.strip())]


def resolve(me: Module, path: str) -> list[str]:
    """`path` (`crate::`, `super::`, `self::` or relative to `me`) as absolute segments."""
    segments = [s for s in path.split("::") if s]
    if segments[0] == "crate":
        return segments[1:]
    base = list(me)
    if segments[0] == "self":
        segments = segments[1:]
    while segments and segments[0] == "super":
        segments, base = segments[1:], base[:-1]
    return base + segments


def reexports(files: dict[Module, Path]) -> dict[tuple[Module, str], list[str]]:
    """What each module re-exports: (module, name) -> the absolute path it stands for."""
    found: dict[tuple[Module, str], list[str]] = {}
    for me, path in files.items():
        code = without_tests_and_comments(path.read_text())
        for used in re.findall(r"\bpub(?:\([a-z]+\))?\s+use\s+([^;]+);", code):
            # `a::b as c` kept apart by a marker while the white space goes
            used = re.sub(r"\s+", "", re.sub(r"\s+as\s+", "@", used))
            for full in expand(used):
                target, _, alias = full.partition("@")
                found[(me, alias or target.split("::")[-1])] = resolve(me, target)
    return found


def module_of_path(
    segments: list[str], files: dict[Module, Path], aliases: dict[tuple[Module, str], list[str]]
) -> Module | None:
    """The file an absolute path leads to: its longest prefix that is a module, followed
    through the re-exports of that module (a few hops at most)."""
    for _ in range(8):
        n = next((n for n in range(len(segments), -1, -1) if tuple(segments[:n]) in files), None)
        if n is None:
            return None
        module = tuple(segments[:n])
        if n < len(segments) and (module, segments[n]) in aliases:
            segments = aliases[(module, segments[n])] + segments[n + 1 :]
            continue
        return module
    return None


def module_graph(src: Path) -> dict[Module, set[Module]]:
    files = {module_of(p, src): p for p in src.rglob("*.rs")}
    aliases = reexports(files)
    graph: dict[Module, set[Module]] = {m: set() for m in files}
    for me, path in files.items():
        if path.name == "tests.rs":
            continue
        code = re.sub(r"\s+", "", without_tests_and_comments(path.read_text()))
        for found in re.findall(r"(?:crate|super|self)::[A-Za-z0-9_:{},*]+", code):
            for full in expand(found):
                target = module_of_path(resolve(me, full), files, aliases)
                if target is not None and target != me and me[: len(target)] != target:
                    graph[me].add(target)
    return graph


def cycles(graph: dict[Module, set[Module]]) -> list[list[Module]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[Module, int] = {}
    low: dict[Module, int] = {}
    stack: list[Module] = []
    found: list[list[Module]] = []

    def visit(v: Module) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while (w := stack.pop()) != v:
                component.append(w)
            if component:
                found.append([v, *component])

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_graph_sees_a_cycle():
    """The reader finds a cycle written the ways the core writes paths."""
    graph = {("a",): set(), ("b",): set(), ("b", "c"): set()}
    graph[("a",)].add(("b", "c"))
    graph[("b", "c")].add(("a",))
    assert cycles(graph) and not cycles({("a",): {("b",)}, ("b",): set()})


def test_the_reader_sees_circles_between_files(tmp_path):
    """Two files of one folder using each other through `super::`, and a file reaching
    another through a re-export of the crate root, are circles; a file using its own
    folder's `mod.rs` is not."""
    files = {
        "lib.rs": "mod a; mod b; mod c; pub use b::Thing;",
        "a/mod.rs": "mod x; mod y; pub(crate) struct Shared;",
        "a/x.rs": "use super::y::Y; use super::Shared; pub(crate) struct X;",
        "a/y.rs": "use super::x::X; pub(crate) struct Y;",
        "b.rs": "use crate::c::C; pub struct Thing;",
        "c.rs": "use crate::Thing; pub(crate) struct C;",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    found = sorted(sorted(c) for c in cycles(module_graph(tmp_path)))
    assert found == [[("a", "x"), ("a", "y")], [("b",), ("c",)]]


def test_core_has_no_module_cycle():
    graph = module_graph(CORE)
    assert sum(map(len, graph.values())) > 20, "the reader found too few `use` paths"
    found = [" <-> ".join("::".join(m) for m in sorted(c)) for c in cycles(graph)]
    assert not found, f"module cycles in the core: {found}"


@pytest.mark.parametrize("crate", ["scanmesh-core", "scanmesh-py"])
def test_no_rust_file_over_the_limit(crate):
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "rust" / crate).rglob("*.rs")
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert not long, f"Rust files over {MAX_LINES} lines: {long}"
