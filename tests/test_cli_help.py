"""The command's help and usage errors: grouped help, a short usage line on errors, and
"did you mean" for misspelt subcommands, flags, methods and choices."""

from __future__ import annotations

import re

import pytest

from scanmesh.cli import build_parser, main
from scanmesh.cli._args import _method_flags
from scanmesh.cli._parser import suggestions
from scanmesh.methods import TABLE


def usage_error(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as stop:
        main(list(argv))
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) <= 3, err  # not the 20-line usage block
    return err


def test_a_misspelt_subcommand_gets_its_nearest(capsys):
    err = usage_error(capsys, "reconstrct", "scan.xyz", "-o", "m.stl")
    assert "did you mean reconstruct?" in err
    assert err.startswith("usage: scanmesh COMMAND [options]")


def test_a_misspelt_flag_gets_the_flags_of_its_subcommand(capsys):
    err = usage_error(capsys, "reconstruct", "scan.xyz", "-o", "m.stl", "--methd", "lop")
    assert "unrecognized arguments: --methd lop; did you mean --method?" in err
    assert err.startswith("usage: scanmesh reconstruct IN -o OUT [options]")
    err = usage_error(capsys, "render", "m.stl", "-o", "p.png", "--colour", "tac")
    assert "did you mean --color?" in err
    err = usage_error(capsys, "reconstruct", "s.xyz", "-o", "m.stl", "--sweps=5")
    assert "did you mean --sweeps?" in err


def test_a_misspelt_method_or_choice_gets_its_nearest(capsys):
    err = usage_error(capsys, "reconstruct", "s.xyz", "-o", "m.stl", "--method", "aneal")
    assert "did you mean anneal?" in err
    err = usage_error(capsys, "render", "m.stl", "-o", "p.png", "--color", "hieght")
    assert "did you mean height?" in err


def test_nothing_is_suggested_when_nothing_is_near(capsys):
    err = usage_error(capsys, "reconstruct", "s.xyz", "-o", "m.stl", "--xyzzy")
    assert "did you mean" not in err and "unrecognized arguments: --xyzzy" in err
    assert suggestions("--zzz", ["--method", "--report"]) == []
    assert suggestions("-method", ["--method", "--report"]) == ["--method"]


def test_help_lists_common_options_first_and_method_options_under_their_method():
    sub = build_parser()._subparsers._group_actions[0].choices["reconstruct"]  # type: ignore[union-attr]
    text = sub.format_help()
    headings = re.findall(r"^(\S[^\n]*):$", text, flags=re.MULTILINE)
    assert headings[:4] == [
        "positional arguments",
        "options",
        "triangulation (every method)",
        "reading the scan file",
    ]
    method_headings = [h for h in headings if h.startswith("options of --method")]
    assert method_headings and headings[-len(method_headings) :] == method_headings
    for name, (option, users) in _method_flags().items():
        # the flag sits under the heading of the first method that takes it
        heading = f"options of --method {users[0]} (and of the methods each names):"
        section = text.split(heading, 1)[1].split("\n\n", 1)[0]
        assert option.flag in section, (name, users)
    assert set(h.split()[3] for h in method_headings) <= set(TABLE)
    common = text.split("\noptions:\n", 1)[1].split("\n\n", 1)[0]
    for flag in ("--output", "--method", "--report", "--preview", "--view"):
        assert flag in common


def test_the_demos_help_says_where_it_writes(capsys):
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "-o DIR, --output-dir DIR" in text
    assert "into the current folder or -o DIR" in text and "made if missing" in text
