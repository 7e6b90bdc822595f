"""What every subcommand uses: the console (results to stdout, notes and warnings to
stderr), JSON output, output checks before any work, and the command's wording of errors."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh._progress import LogProgress, Progress
from scanmesh.cli._args import READ_FLAGS, _method_flags, _read_options
from scanmesh.errors import ParameterError
from scanmesh.formats import read
from scanmesh.formats.write import (
    _same_file,
    check_not_input,
    refuse_remote,
    write_atomic,
)
from scanmesh.fusion.grid import TABLE as MERGE_OPTIONS
from scanmesh.methods import SHARED


def _json_safe(value: Any) -> Any:
    """Plain JSON types: numpy values unwrapped, paths as text, NaN and infinities as null."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return _json_safe(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)


def _dumps(data: Any) -> str:
    return json.dumps(_json_safe(data), indent=2, allow_nan=False)


def _write_text(path: Path, text: str) -> None:
    write_atomic(path, [text.encode("utf-8")])


#: Every flag that names a file or folder a command writes (argparse name: flag).
OUTPUT_FLAGS: dict[str, str] = {
    "output": "-o/--output",
    "output_dir": "-o/--output-dir",
    "report": "--report",
    "preview": "--preview",
    "picture": "--picture",
}


#: Every argument that names a file a command reads (argparse name): no output may be one
#: of them (:func:`_refuse_outputs_over_inputs`, run for every command).
INPUT_ARGS: tuple[str, ...] = ("input", "inputs", "mesh", "poses", "truth")


def _refuse_outputs_over_inputs(args: argparse.Namespace) -> None:
    """Refuse, before any command runs, an output flag's file that is a file an input
    argument names, by any alias (:func:`scanmesh.formats.write.check_not_input`); files
    found only by reading (the scans a ``.conf`` lists) are checked by their command."""
    inputs: list[Path] = []
    for name in INPUT_ARGS:
        given = getattr(args, name, None)
        if given:
            inputs.extend(Path(p) for p in (given if isinstance(given, list) else [given]))
    for name in OUTPUT_FLAGS:
        given = getattr(args, name, None)
        if given:
            check_not_input(Path(given), inputs)


def _refuse_remote_outputs(args: argparse.Namespace) -> None:
    """Outputs are files: a remote URL (``s3://...``) given for any output flag of any
    command is refused, naming the flag."""
    for name, flag in OUTPUT_FLAGS.items():
        given = getattr(args, name, None)
        if given:
            refuse_remote(given, flag)


def _check_outputs(inputs: Sequence[Path], outputs: Sequence[Path | None]) -> None:
    """Refuse, before any work, outputs that name an input or each other, or a missing folder."""
    given = [p for p in outputs if p is not None]
    for k, out in enumerate(given):
        check_not_input(out, inputs)
        for other in given[:k]:
            if _same_file(out, other):
                raise ParameterError(f"{out} is named for two outputs; give each its own file")
        folder = out.parent if str(out.parent) else Path(".")
        if not folder.is_dir():
            raise ParameterError(f"cannot write {out}: folder {folder} does not exist")


def _plural(count: int, word: str) -> str:
    """``1 face``, ``2 faces``, ``27,715 faces``."""
    return f"{count:,} {word}{'' if count == 1 else 's'}"


def _check_png(path: Path | None) -> None:
    if path is not None and path.suffix.lower() != ".png":
        raise ParameterError(f"pictures are written as PNG: {path} should end in .png")


def _quality_row(surface: Any) -> dict[str, Any]:
    q = surface.quality.as_dict()
    return {k: q[k] for k in ("tac_1", "tac_2", "tac_inf", "min_angle_deg", "sliver_fraction")}


def _fmt(value: Any, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


class _Console:
    """Where the command talks: results to stdout, notes and warnings to stderr."""

    def __init__(self, quiet: bool, as_json: bool) -> None:
        self.quiet = quiet
        self.json = as_json
        #: every warning of the run, in the command's words (for --report)
        self.warnings: list[str] = []
        #: the flag of the report the command writes ("--report") when one was asked for,
        #: "" when the command could write one, None when it writes none (warnings then
        #: point to nothing it does not write)
        self.report: str | None = None
        #: what the command is running (a method of compare), named in its warnings
        self.context: str | None = None
        self._log: LogProgress | None = None

    @property
    def progress(self) -> Progress:
        """Progress bars on a terminal; in a log (stderr not a terminal) a line at least every
        LOG_INTERVAL_SECONDS for each long stage (:class:`LogProgress`); nothing with --quiet."""
        if self.quiet:
            return False
        if sys.stderr.isatty():
            return True
        if self._log is None:
            self._log = LogProgress(lambda line: print(line, file=sys.stderr, flush=True))
        return self._log

    def close(self) -> None:
        """Stop the log's watcher thread, if a log was made (the run is over)."""
        if self._log is not None:
            self._log.close()

    def out(self, text: str = "") -> None:
        """Human output: the results asked for (nothing with --json)."""
        if not self.json:
            print(text, flush=True)

    def summary(self, text: str) -> None:
        """What was done and written (nothing with --json or --quiet)."""
        if not self.quiet:
            self.out(text)

    def warn(self, message, category, filename, lineno, file=None, line=None) -> None:
        """``warnings.showwarning``: one line on stderr naming flags (none with --quiet), kept
        for --report."""
        text = _speak_flags(" ".join(str(message).split()), self.report)
        if self.context is not None:
            text = f"{self.context}: {text}"
        if text in self.warnings:
            return  # the same step warned of the same thing again (compare's holdout)
        self.warnings.append(text)
        if not self.quiet:
            print(f"scanmesh: warning: {text}", file=sys.stderr, flush=True)

    def note(self, text: str) -> None:
        """A remark on stderr (nothing with --quiet)."""
        if not self.quiet:
            print(f"scanmesh: {text}", file=sys.stderr, flush=True)


def _read_scan(path: Path, progress: Progress = False, args: argparse.Namespace | None = None):
    return read(path, progress=progress, **_read_options(args))


def _background(fn: Callable[[], Any]) -> Callable[[], Any]:
    """Start ``fn()`` in a daemon thread; return a function that waits for its result (or
    raises its exception). Waiting stays interruptible by Ctrl-C, and a daemon thread does
    not hold up the exit of an interrupted command (a pool's worker would be joined)."""
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the waiting caller
            box["error"] = exc

    worker = threading.Thread(target=work, name="scanmesh-background", daemon=True)
    worker.start()

    def result() -> Any:
        while worker.is_alive():
            worker.join(0.05)
        if "error" in box:
            raise box["error"]
        return box["result"]

    return result


def _seconds(fn: Callable[[], Any]) -> float:
    """Seconds ``fn()`` takes."""
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())


#: Python advice in messages, and what the command's user types instead.
_PYTHON_WORDS = (
    (re.compile(r"reconstruct\(method='([\w-]+)'\)"), r"--method \1"),
    (re.compile(r"\bmath\.inf\b"), "inf"),
    # a message that names both (``columns= (--columns)``) names the flag alone
    (re.compile(r"\b[a-z][a-z_]*= \((--[a-z-]+)\)"), r"\1"),
)
#: Where a message sends the user to the surface's lists, and the report's names for them.
_LISTS = re.compile(r"(;\s*)?see Surface\.(options\['(\w+)'\]|duplicates)")


def _listed(match: re.Match, report: str | None) -> str:
    """``see Surface.options['unused']`` in the command's words: the report's entry when
    one is written, how to get one when it could be, nothing when the command writes none."""
    entry = "counts.duplicates" if match.group(2) == "duplicates" else f"options.{match.group(3)}"
    lead = match.group(1) or ""
    if report is None:
        return ""
    if report:
        return f"{lead}see the {report}'s {entry}"
    return f"{lead}--report lists them ({entry})"


def _speak_flags(text: str, report: str | None = "--report") -> str:
    """A library message in the command's words: ``name=`` of an option or a shared
    keyword becomes its flag (``--max-edge``), Python calls become flags; ``report`` as
    for :attr:`_Console.report`."""
    names = set(_method_flags()) | set(SHARED) | set(READ_FLAGS) | {"plane", "toward"}
    names |= set(MERGE_OPTIONS)
    text = _LISTS.sub(lambda m: _listed(m, report), text)
    for pattern, replacement in _PYTHON_WORDS:
        text = pattern.sub(replacement, text)

    def flag(m: re.Match) -> str:
        if m.group(1) not in names:
            return m.group(0)
        # a switch given as ``grid=True`` is the flag alone
        return "--" + m.group(1).replace("_", "-") + ("" if m.group(2) else " ")

    text = re.sub(r"\b([a-z][a-z_]*)=(?!=)(True\b)?", flag, text)
    return " ".join(text.replace(" ,", ",").replace(" )", ")").split())
