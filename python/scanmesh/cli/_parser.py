"""The command's argument parser: argparse with short errors that suggest what was meant.

A usage error prints one short usage line (the command, its positionals and required
flags; ``--help`` lists the rest), the error, and for a misspelt subcommand, method or
choice ("invalid choice") or an unknown flag ("unrecognized arguments") the closest
spellings the command knows (:func:`difflib.get_close_matches`), then exits with 2.
"""

from __future__ import annotations

import argparse
import difflib
import re
from collections.abc import Sequence
from typing import Any, NoReturn

#: How alike a known word must be to be suggested (difflib's ratio, 0..1).
SUGGEST_CUTOFF: float = 0.6

_INVALID_CHOICE = re.compile(r"invalid choice: '([^']*)' \(choose from (.*)\)")


def suggestions(word: str, known: Sequence[str]) -> list[str]:
    """The known words closest to ``word`` (at most 3, best first). Flags are matched
    without their dashes, so ``-method`` and ``--methd`` both find ``--method``."""
    bare = {k.lstrip("-"): k for k in known}
    close = difflib.get_close_matches(word.lstrip("-"), list(bare), n=3, cutoff=SUGGEST_CUTOFF)
    return [bare[c] for c in close]


def _did_you_mean(words: list[str]) -> str:
    return "" if not words else f"; did you mean {' or '.join(words)}?"


class Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are short and suggest the nearest known spelling."""

    def short_usage(self) -> str:
        """``usage: scanmesh reconstruct IN -o OUT [options]``: positionals and required
        flags only."""
        parts = [self.prog]
        for action in self._actions:  # positionals, in order
            if isinstance(action, argparse._SubParsersAction):
                parts.append("COMMAND")
            elif not action.option_strings:
                parts.append(str(action.metavar or action.dest))
        for action in self._actions:  # then the flags that must be given
            if action.option_strings and action.required:
                parts.append(f"{action.option_strings[0]} {action.metavar or action.dest.upper()}")
        return f"usage: {' '.join(parts)} [options]"

    def flags(self) -> list[str]:
        """Every option string this parser takes."""
        return [s for a in self._actions for s in a.option_strings if s.startswith("--")]

    def error(self, message: str) -> NoReturn:
        """Print the short usage, the error with suggestions and where the full help is."""
        found = _INVALID_CHOICE.search(message)
        if found:
            choices = re.findall(r"'([^']*)'", found.group(2))
            message += _did_you_mean(suggestions(found.group(1), choices))
        self.exit(
            2,
            f"{self.short_usage()}\n{self.prog}: error: {message}\n"
            f"(all options: {self.prog} --help)\n",
        )

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:  # type: ignore[override]
        """As argparse's, but unknown flags are reported by the subcommand that was given
        (``_parser`` in its defaults), with the nearest flags it takes."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            owner = getattr(parsed, "_parser", self)
            hints: list[str] = []
            for word in extras:
                if word.startswith("-"):
                    hints += suggestions(word.split("=")[0], owner.flags())
            message = f"unrecognized arguments: {' '.join(extras)}"
            owner.error(message + _did_you_mean(list(dict.fromkeys(hints))))
        return parsed
