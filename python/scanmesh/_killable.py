"""Calls that may overrun their own time limit, run in a child process that is killed.

HiGHS (the exact optimum's MILP, through ``scipy.optimize.milp``) checks its time limit
between phases only: one presolve pass on 200 points took 26 s under ``time_limit=8``, and
scipy has no option to bound it. A thread cannot be stopped, so such a call runs in a child
process (``forkserver``: forked from a small server that imported scipy once, not from this
process's threads), which is terminated at a deadline or on Ctrl-C. The parent waits in
``POLL_SECONDS`` slices, so ``KeyboardInterrupt`` reaches the caller within about that.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from collections.abc import Callable, Mapping
from multiprocessing.connection import Connection
from typing import Any, TypeVar

from scanmesh._interrupt import POLL_SECONDS, interruptible
from scanmesh.errors import ScanmeshError

T = TypeVar("T")

#: Modules the fork server imports once, so that each child starts with them loaded.
PRELOAD: tuple[str, ...] = ("scipy.optimize",)

#: Seconds a terminated child (SIGTERM) gets before it is killed (SIGKILL).
GRACE_SECONDS: float = 0.2


def call_killable(
    fn: Callable[..., T],
    args: tuple[Any, ...] = (),
    kwargs: Mapping[str, Any] | None = None,
    *,
    deadline: float | None = None,
) -> T | None:
    """``fn(*args, **kwargs)`` in a child process; None when it was killed at ``deadline``
    (a ``time.monotonic()`` value; None: no deadline) before it returned.

    ``fn`` and its arguments are pickled (``fn`` by reference: a module-level function), as
    is its result; an exception of ``fn`` is re-raised here. Ctrl-C terminates the child
    and raises ``KeyboardInterrupt`` within about ``POLL_SECONDS``. Where a child cannot be
    started (in a daemonic process, such as a pool worker) the call runs in a worker thread
    of this process instead, interruptible but not killable.

    Raises
    ------
    ScanmeshError
        The child ended without an answer (killed from outside, out of memory).
    """
    kwargs = dict(kwargs or {})
    if multiprocessing.current_process().daemon:
        return interruptible(float("inf"), lambda: fn(*args, **kwargs))
    ctx = _context()
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(
        target=_child_main, args=(send, fn, args, kwargs), name="scanmesh-killable", daemon=True
    )
    child.start()
    send.close()
    try:
        while True:
            wait = POLL_SECONDS
            if deadline is not None:
                wait = min(wait, deadline - time.monotonic())
                if wait <= 0.0:
                    return None
            if receive.poll(wait):
                try:
                    kind, value = receive.recv()
                except EOFError:
                    child.join()
                    raise ScanmeshError(
                        f"the solver's child process ended without an answer (exit code"
                        f" {child.exitcode}: killed, or out of memory)"
                    ) from None
                if kind == "error":
                    raise value
                return value
    finally:
        _stop(child)
        receive.close()


def _context() -> Any:
    """The ``forkserver`` context (``spawn`` where there is none), its server preloading
    :data:`PRELOAD`."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    return ctx


def _child_main(
    send: Connection, fn: Callable[..., Any], args: tuple[Any, ...], kwargs: dict[str, Any]
) -> None:
    """The child: runs ``fn`` and sends ("result", value) or ("error", exception)."""
    # Ctrl-C at a terminal reaches the whole process group: the parent answers it (and
    # terminates this child), which must not print a traceback of its own.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        message: tuple[str, Any] = ("result", fn(*args, **kwargs))
    except Exception as exc:  # noqa: BLE001 - handed to the parent as it is
        message = ("error", exc)
    try:
        send.send(message)
    except Exception as exc:  # noqa: BLE001 - an unpicklable answer, said in words
        send.send(("error", ScanmeshError(f"the solver's answer could not be sent: {exc!r}")))
    finally:
        send.close()


def _stop(child: Any) -> None:
    """Ends ``child`` if it still runs: SIGTERM, then SIGKILL after GRACE_SECONDS."""
    if child.is_alive():
        child.terminate()
        child.join(GRACE_SECONDS)
    if child.is_alive():
        child.kill()
    child.join()


__all__ = ["call_killable", "GRACE_SECONDS", "PRELOAD"]
