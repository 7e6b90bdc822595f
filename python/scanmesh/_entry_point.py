"""The ``scanmesh`` command's entry point: Ctrl-C is quiet from its first instant.

The command imports numpy, scipy, trimesh and the native core before it parses its
arguments (1.3-1.8 s on a busy machine). A Ctrl-C in that time raised ``KeyboardInterrupt``
inside some import and printed its traceback, where everywhere else the command says one
line and exits 130. So this module, which imports nothing heavy (nor does the package
``scanmesh`` itself), installs a handler that does just that, imports the command, and
gives Ctrl-C back to Python for the command's own handling (:func:`scanmesh.cli.main`).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from types import FrameType


def _interrupted(signum: int, frame: FrameType | None) -> None:
    """Ctrl-C before the command started: the one line of an interrupted command, exit 130
    at once (nothing written yet; the half-imported modules need no teardown)."""
    print("scanmesh: interrupted", file=sys.stderr, flush=True)
    os._exit(130)


def main() -> int:
    """Run the ``scanmesh`` command in this process (the console script and ``python -m
    scanmesh``); return its exit status."""
    quiet = (
        threading.current_thread() is threading.main_thread()
        and signal.getsignal(signal.SIGINT) is signal.default_int_handler
    )  # not where Ctrl-C is ignored (a background job) or handled by the embedding program
    if quiet:
        signal.signal(signal.SIGINT, _interrupted)
    from scanmesh.cli import main as command

    if quiet:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    return command()
