"""The documentation and the repository's hygiene: Markdown's relative links resolve, anchors
name headings, files stay short, and no tracked text file carries working-diary residue
(issue numbers, talk of sessions, paths of one machine).

Reads files only (no build, no scanmesh import): runs from a fresh clone.
"""

from __future__ import annotations

import os
import re
import subprocess
import unicodedata
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Folders never searched when git is not available.
SKIP_DIRS = {".git", "target", ".venv", "venv", "node_modules", "__pycache__", "build", "dist"}

#: Text that belongs in a working diary, not in the documentation.
FORBIDDEN = {
    "an issue number": re.compile(r"#[0-9]{1,3}\b|\b[Ii]ssues? [0-9]"),
    "session talk": re.compile(r"\b[Ss]essions?\b"),
    "a machine path": re.compile(r"/(?:work|root)/"),
}

#: The same residue in any tracked text file, code included (this file's own examples are
#: built from pieces). Narrower than FORBIDDEN where code has real uses: pytest's and Dask's
#: sessions are words of their APIs, so only diary phrasing (the word after "this" or
#: "last", or before a number) counts.
RESIDUE = {
    "an issue number": FORBIDDEN["an issue number"],
    "session talk": re.compile(
        r"\b(?:this|that|last|previous|next|earlier|same|one|a) sessions?\b|\bsessions? #?[0-9]+\b",
        re.I,
    ),
    "a machine path": FORBIDDEN["a machine path"],
}
#: A hex colour, which the issue-number pattern would mistake for one (three digits after
#: the hash): only a quoted string that is nothing but the colour, or the value of a CSS
#: colour property.
HEX = r"#(?:[0-9a-fA-F]{8}|[0-9a-fA-F]{6}|[0-9a-fA-F]{3,4})\b"
COLOUR = re.compile(
    rf"([\"'])(?:{HEX})\1"
    rf"|\b(?:colou?r|background(?:-color)?|fill|stroke|border(?:-[a-z]+)*-color)\s*:\s*{HEX}"
)
#: Tracked files that are data, not text (read by programs, never by people).
DATA_SUFFIXES = {
    ".npz", ".npy", ".laz", ".las", ".dem", ".vtk", ".stl", ".ply", ".obj", ".off", ".glb",
    ".png", ".jpg", ".gz", ".jsonl", ".so", ".pyd",
}  # fmt: skip
DATA_NAMES = {"Cargo.lock"}

FENCE = re.compile(r"^ {0,3}(```|~~~).*?^ {0,3}\1[^\n]*$", re.S | re.M)
INLINE_CODE = re.compile(r"(`+)(?:(?!\1).)+?\1", re.S)
#: [text](target) and ![alt](target); the text may run over lines, the target may carry a title.
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^()\s<>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$", re.M)
#: A Markdown file named in prose or inline code (not part of a URL).
MD_NAME = re.compile(r"(?<![\w/.:-])((?:\.\./|[\w.-]+/)*[\w.-]+\.md)\b")
HTML_ANCHOR = re.compile(r"<a\s+(?:name|id)=\"([^\"]+)\"", re.I)


def repository_files(*patterns: str) -> list[Path]:
    """The repository's files matching git pathspecs (all files for none): git's tracked
    and new files, else (no git, as in a source archive) a walk."""
    try:
        out = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard", *patterns],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
            timeout=30,
        ).stdout
        files = sorted({ROOT / line for line in out.splitlines() if line})
        if files:
            return [f for f in files if f.is_file()]
    except (OSError, subprocess.SubprocessError):
        pass
    suffixes = tuple(p.lstrip("*") for p in patterns)
    found = []
    for folder, dirs, names in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not d.startswith(".")]
        found += [Path(folder) / n for n in names if not suffixes or n.endswith(suffixes)]
    return sorted(found)


def markdown_files() -> list[Path]:
    """Every Markdown file of the repository."""
    return repository_files("*.md")


def text_files() -> list[Path]:
    """Every text file of the repository: data files (by suffix, or NUL bytes) left out."""
    files = []
    for path in repository_files():
        if path.suffix.lower() in DATA_SUFFIXES or path.name in DATA_NAMES:
            continue
        if b"\0" in path.read_bytes()[:8192]:
            continue
        files.append(path)
    return files


def residue(text: str) -> list[str]:
    """``line: what: text`` for every line of ``text`` with diary residue (colours aside)."""
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        plain = COLOUR.sub("", line)
        hits = [what for what, pattern in RESIDUE.items() if pattern.search(plain)]
        found += [f"{number}: {what}: {line.strip()[:120]}" for what in hits]
    return found


def strip_code(text: str) -> str:
    """The text without fenced code blocks and inline code spans (links there are not links)."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation but - and _ dropped, spaces to -."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link shows its text
    text = re.sub(r"<[^>]+>", "", text).strip().lower()
    kept = []
    for ch in text:
        if ch in "-_" or ch.isspace():
            kept.append("-" if ch == " " else ch)
        elif unicodedata.category(ch)[0] in "LNM":
            kept.append(ch)
    return "".join(kept)


@cache
def anchors(path: Path) -> frozenset[str]:
    """Every anchor a Markdown file's headings produce (repeats numbered as GitHub does)."""
    text = FENCE.sub("", path.read_text(encoding="utf-8"))
    seen: dict[str, int] = {}
    result = set(HTML_ANCHOR.findall(text))
    for _, title in HEADING.findall(text):
        base = slug(title)
        n = seen.get(base, 0)
        seen[base] = n + 1
        result.add(base if n == 0 else f"{base}-{n}")
    return frozenset(result)


def relative_links(path: Path) -> list[str]:
    """The targets of the file's links that point inside the repository."""
    targets = LINK.findall(strip_code(path.read_text(encoding="utf-8")))
    return [t for t in targets if not re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", t)]


FILES = markdown_files()
IDS = [f.relative_to(ROOT).as_posix() for f in FILES]


def test_markdown_files_found():
    assert "README.md" in IDS and "BENCHMARKS.md" in IDS


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_relative_links_resolve(path: Path):
    broken = []
    for target in relative_links(path):
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target}: no heading gives #{anchor}")
    assert not broken, f"{path.relative_to(ROOT)}: " + "; ".join(broken)


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_named_markdown_files_exist(path: Path):
    """A Markdown file named in the prose (`benches/results/x.md`, DESIGN.md) is there."""
    missing = []
    prose = LINK.sub("", FENCE.sub("", path.read_text(encoding="utf-8")))  # links: above
    for name in set(MD_NAME.findall(prose)):
        if not any((base / name).exists() for base in (path.parent, ROOT)):
            missing.append(name)
    assert not missing, f"{path.relative_to(ROOT)} names missing files: {sorted(missing)}"


@pytest.mark.parametrize("path", FILES, ids=IDS)
def test_no_diary_notes(path: Path):
    found = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        hits = [what for what, pattern in FORBIDDEN.items() if pattern.search(line)]
        found += [f"{number}: {what}: {line.strip()}" for what in hits]
    assert not found, f"{path.relative_to(ROOT)}:\n" + "\n".join(found)


def test_no_diary_residue_in_any_file():
    """Every tracked text file, code included: no issue number, no diary talk, no path of
    one machine."""
    files = text_files()
    assert any(f.suffix == ".rs" for f in files) and any(f.suffix == ".py" for f in files)
    found = []
    for path in files:
        text = path.read_text(encoding="utf-8", errors="replace")
        found += [f"{path.relative_to(ROOT)}:{hit}" for hit in residue(text)]
    assert not found, "diary residue:\n" + "\n".join(found)


def test_residue_rule():
    # the examples are built from pieces, so this file passes its own test
    h, issue, session, work, root = "#", "is" + "sue", "ses" + "sion", "/wo" + "rk/", "/ro" + "ot/"
    assert residue(f"see {h}12 and {issue} 4") == [f"1: an issue number: see {h}12 and {issue} 4"]
    assert residue(f"As this {session.title()} showed") and residue(f"({session} 3)")
    assert residue(f"default {work}tmp") and residue(f"{root}x")
    # colours, pytest's session scope, Rust attributes, format specs: not residue
    assert not residue(f"body {{ color: {h}222; background: {h}fff; }}")
    assert not residue(f'colours = ["{h}fde3b5", "{h}1f77b4", \'{h}abc\']')
    assert not residue(f'@pytest.fixture(scope="{session}")')
    assert not residue(f'{h}[derive(Debug)] f"{{x:{h}010x}}" a Dask {session} object')
    # a colour on the line does not hide a number beside it
    assert residue(f"color: {h}222; fixes {h}222")


def line_count(name: str) -> int:
    return len((ROOT / name).read_text(encoding="utf-8").splitlines())


def test_benchmarks_is_short():
    assert line_count("BENCHMARKS.md") <= 150


def test_architecture_is_short():
    assert line_count("ARCHITECTURE.md") <= 120


#: Most lines any Markdown page may have (as for a Python file): a longer one is split.
MAX_MARKDOWN_LINES = 800


def test_every_markdown_page_is_under_its_cap():
    long = [f"{i}: {line_count(i)}" for i in IDS if line_count(i) > MAX_MARKDOWN_LINES]
    assert not long, "split these pages:\n" + "\n".join(long)


def test_slug_rule():
    assert slug("Speed against the peers") == "speed-against-the-peers"
    assert slug("Depth jumps: no curtains, walls") == "depth-jumps-no-curtains-walls"
    assert slug("The `scanmesh` command (α = 1)") == "the-scanmesh-command-α--1"
    assert slug("snake_case and hy-phen") == "snake_case-and-hy-phen"


#: Most words a cell of BENCHMARKS.md's headline table may hold (a figure, its ratio, a link).
HEADLINE_WORDS = 30


def headline_cells(text: str) -> list[str]:
    """The cells of the first table under BENCHMARKS.md's "## Headline", link targets left
    out (a link counts as the words of its text)."""
    section = text.split("\n## Headline\n", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("|")][2:]
    cells = []
    for row in rows:
        visible = re.sub(r"\]\([^)]*\)", "]", row)
        cells += [cell.strip() for cell in visible.strip().strip("|").split("|")]
    return cells


def test_benchmarks_opens_with_a_headline_of_short_cells():
    text = (ROOT / "BENCHMARKS.md").read_text(encoding="utf-8")
    headings = [title for _, title in HEADING.findall(FENCE.sub("", text))]
    assert headings[:2] == ["Benchmarks", "Headline"]
    cells = headline_cells(text)
    assert len(cells) >= 40  # a table of ten rows or more
    long = [f"{len(c.split())} words: {c}" for c in cells if len(c.split()) > HEADLINE_WORDS]
    assert not long, "headline cells over the cap:\n" + "\n".join(long)


def test_headline_rule():
    text = "# B\n\n## Headline\n\n| a | b |\n|---|---|\n| one [two](x.md#y) | three |\n\n## Next\n"
    assert headline_cells(text) == ["one [two]", "three"]
