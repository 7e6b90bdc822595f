"""Long native calls that Ctrl-C can interrupt: run them in a worker thread and wait.

The core releases the GIL for its long one-shot calls (Delaunay, trimming, strips), but
Python only handles a signal when it runs, so Ctrl-C would wait for the call to finish
(tens of seconds for millions of points). ``interruptible`` runs such a call in a daemon
thread and waits in short slices, so ``KeyboardInterrupt`` reaches the caller within
about ``POLL_SECONDS``. The abandoned call finishes in the background (its result is
dropped; it holds only its own copies of the inputs), or ends with the process.

Whether a call goes to a worker is decided by its expected cost, not its input's size: a
quadratic solver on 40,000 points, or the exact optimum on 200, takes seconds. Cheap calls
run directly (a worker thread costs a fraction of a millisecond, too much for the many
tiny calls of a fuzz run).
"""

from __future__ import annotations

import importlib
import math
import sys
import threading
from collections.abc import Callable
from types import ModuleType
from typing import Any, TypeVar

from scanmesh.errors import MemoryLimitError

T = TypeVar("T")

#: Calls of an expected cost below this run directly (they return within milliseconds).
#: Cost is counted in points of a linear-time stage (Delaunay, banded strips: about a
#: microsecond each); callers of costlier algorithms scale their estimate to that unit.
THREAD_MIN_COST: float = 50_000

#: The cost of calls that cannot be bounded cheaply beforehand (the exact optimum's MILP):
#: they always run in a worker.
UNBOUNDED: float = math.inf

#: How often the waiting thread lets Python check for Ctrl-C (seconds).
POLL_SECONDS: float = 0.02


def interruptible(
    cost: float, fn: Callable[..., T], *args: Any, watch: Callable[[], None] | None = None
) -> T:
    """``fn(*args)``, run in a worker thread when its expected ``cost`` (see
    :data:`THREAD_MIN_COST`; the number of points for a linear-time call) is large, so that
    Ctrl-C raises ``KeyboardInterrupt`` here within about ``POLL_SECONDS``; exceptions of
    ``fn`` are re-raised unchanged. ``watch`` is called every ``POLL_SECONDS`` while the
    worker runs (the progress of a call that counts: ``Stage.follow``)."""
    if cost < THREAD_MIN_COST or threading.current_thread() is not threading.main_thread():
        # Signals are delivered to the main thread only: elsewhere a worker gains nothing.
        return fn(*args)
    return _in_worker(fn, *args, watch=watch)


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


def _in_worker(fn: Callable[..., T], *args: Any, watch: Callable[[], None] | None = None) -> T:
    """``fn(*args)`` in a daemon thread, waited for in ``POLL_SECONDS`` slices, ``watch``
    called after each."""
    box: dict[str, Any] = {}

    def work() -> None:
        try:
            box["result"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller as it is
            box["error"] = exc

    worker = threading.Thread(target=work, name="scanmesh-native", daemon=True)
    try:
        worker.start()
    except RuntimeError as exc:  # "can't start new thread": no room for its stack
        raise MemoryLimitError(
            f"a worker thread for this stage needs a stack, more than this process may have ({exc})"
        ) from None
    while worker.is_alive():
        worker.join(POLL_SECONDS)
        if watch is not None:
            watch()
    if "error" in box:
        raise box["error"]
    return box["result"]
