"""docs/options.md is generated from the method registry and kept current."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from scanmesh.cli.reference import reference
from scanmesh.methods import TABLE

PAGE = Path(__file__).resolve().parent.parent / "docs" / "options.md"
REMAKE = "python -m scanmesh.cli.reference > docs/options.md"


def test_the_checked_in_reference_is_current():
    assert PAGE.read_text(encoding="utf-8") == reference(), f"out of date: run {REMAKE}"


def test_the_reference_names_every_method_and_option_with_its_flag():
    page = reference()
    for method in TABLE.values():
        section = page.split(f"\n## {method.name}\n")[1].split("\n## ")[0]
        rows = [line for line in section.splitlines() if line.startswith("| `")]
        assert len(rows) == len(method.options)
        for option, row in zip(method.options, rows, strict=True):
            assert row.startswith(f"| `{option.name}` |")
            assert option.doc.replace("|", "\\|") in row
    assert "`--time-limit X`" in page and "`--no-polish`" in page and "API only" in page


def test_the_module_prints_the_page():
    out = subprocess.run(
        [sys.executable, "-m", "scanmesh.cli.reference"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    ).stdout
    assert out == reference()
