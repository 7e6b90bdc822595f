"""Long native calls that Ctrl-C can interrupt: run them in a worker thread and wait.

The core releases the GIL for its long one-shot calls (Delaunay, trimming, strips), but
Python only handles a signal when it runs, so Ctrl-C would wait for the call to finish
(tens of seconds for millions of points). ``interruptible`` runs such a call in a daemon
thread and waits in short slices, so ``KeyboardInterrupt`` reaches the caller within
about ``POLL_SECONDS``. The abandoned call finishes in the background (its result is
dropped; it holds only its own copies of the inputs), or ends with the process.
"""

from __future__ import annotations

import importlib
import sys
import threading
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar

T = TypeVar("T")

#: Calls on fewer points than this run directly (they return within milliseconds).
THREAD_MIN_POINTS: int = 50_000

#: How often the waiting thread lets Python check for Ctrl-C (seconds).
POLL_SECONDS: float = 0.02


def interruptible(n_points: int, fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)``, run in a worker thread when ``n_points`` is large, so that Ctrl-C
    raises ``KeyboardInterrupt`` here within about ``POLL_SECONDS``; exceptions of ``fn``
    are re-raised unchanged."""
    if n_points < THREAD_MIN_POINTS or threading.current_thread() is not threading.main_thread():
        # Signals are delivered to the main thread only: elsewhere a worker gains nothing.
        return fn(*args)
    return _in_worker(fn, *args)


def import_interruptibly(name: str) -> ModuleType:
    """``importlib.import_module(name)``, the first time run in a worker thread while this
    one waits, so that Ctrl-C during the import is a ``KeyboardInterrupt`` here: trimesh
    guards its optional imports with ``except BaseException``, and a Ctrl-C landing in
    them (its first import takes about a second) was swallowed, the command running on.
    Later calls return the module from ``sys.modules``."""
    module = sys.modules.get(name)
    if module is not None:
        return module
    if threading.current_thread() is not threading.main_thread():
        return importlib.import_module(name)
    return _in_worker(importlib.import_module, name)


def _in_worker(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in a daemon thread, waited for in ``POLL_SECONDS`` slices."""
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller as it is
            box["error"] = exc

    worker = threading.Thread(target=work, name="scanmesh-native", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(POLL_SECONDS)
    if "error" in box:
        raise box["error"]
    return box["result"]
