"""The Rust crates' layout: no module cycle in the core (counting the `crate::`, `super::` and
`self::` paths of non-test code) and no Rust file over 900 lines.

The module graph is read from the source text: each file is a module (`mod.rs` and `lib.rs`
name their folder); a path's longest prefix that is a module is the module it uses. A file
using its own folder's `mod.rs` (re-exports, shared types) is not counted: the folder is
one room, and its parent always declares it."""

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


def module_graph(src: Path) -> dict[Module, set[Module]]:
    files = {module_of(p, src): p for p in src.rglob("*.rs")}
    graph: dict[Module, set[Module]] = {m: set() for m in files}
    for me, path in files.items():
        if path.name == "tests.rs":
            continue
        folder = me if path.name in ("mod.rs", "lib.rs") else me[:-1]
        code = re.sub(r"\s+", "", without_tests_and_comments(path.read_text()))
        for found in re.findall(r"(?:crate|super|self)::[A-Za-z0-9_:{},*]+", code):
            for full in expand(found):
                segments = [s for s in full.split("::") if s]
                base: list[str] = []
                if segments[0] == "crate":
                    segments = segments[1:]
                else:
                    base = list(folder)
                    if segments[0] == "self":
                        segments = segments[1:]
                    while segments and segments[0] == "super":
                        segments, base = segments[1:], base[:-1]
                target = next(
                    (
                        t
                        for n in range(len(base + segments), 0, -1)
                        if (t := tuple((base + segments)[:n])) in files
                    ),
                    None,
                )
                if target and target != me and me[: len(target)] != target:
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
