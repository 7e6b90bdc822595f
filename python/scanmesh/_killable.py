"""Calls that may overrun their own time limit, run in a helper process that is killed.

HiGHS (the exact optimum's MILP, through ``scipy.optimize.milp``) checks its time limit
between phases only: one presolve pass on 200 points took 26 s under ``time_limit=8``, and
scipy has no option to bound it. A thread cannot be stopped, so such a call runs in a helper
process, which is killed at a deadline or on Ctrl-C. The parent waits in ``POLL_SECONDS``
slices, so ``KeyboardInterrupt`` reaches the caller within about that.

The helper is a fresh interpreter (``python -c``) that imports only what the call's pickle
names (scipy), never the caller's ``__main__``: the children of multiprocessing's ``spawn``
and ``forkserver`` re-run the main script first, so a user's script without an ``if __name__
== "__main__":`` guard started itself again in the child, which failed. One helper serves
the calls one after another (scipy is imported once); one that overran or was interrupted
is killed, and the next call starts another. Calls from several threads at once each get
a helper of their own.
"""

from __future__ import annotations

import atexit
import pickle
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import IO, Any, TypeVar

from scanmesh._interrupt import POLL_SECONDS
from scanmesh.errors import ScanmeshError

T = TypeVar("T")

#: Modules the helper imports when it starts, so that its first call finds them loaded.
PRELOAD: tuple[str, ...] = ("scipy.optimize",)

#: Seconds a terminated helper (SIGTERM) gets before it is killed (SIGKILL).
GRACE_SECONDS: float = 0.2

#: The last argument of the helper's command line, by which it can be told apart.
MARK = "scanmesh-killable"

#: The helper's program. Each request is, after its length, the caller's ``sys.path`` (a
#: pickle after its own length) and the pickle ``(fn, args, kwargs)``; each answer one
#: pickle ``("result", value)``, ``("error", exception)`` or ``("unsent", text)``. Answers
#: go to a private copy of stdout: whatever the call prints goes to stderr. Ctrl-C reaches
#: the whole process group: the parent answers it.
_SERVE = f"""
import os, pickle, signal, struct, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)
answers = os.fdopen(os.dup(1), "wb")
os.dup2(2, 1)
requests = sys.stdin.buffer
for name in {list(PRELOAD)!r}:
    __import__(name)
while True:
    head = requests.read(8)
    if len(head) < 8:
        break
    data = requests.read(struct.unpack("<Q", head)[0])
    try:
        split = 8 + struct.unpack("<Q", data[:8])[0]
        sys.path[:] = pickle.loads(data[8:split])
        fn, args, kwargs = pickle.loads(data[split:])
        message = ("result", fn(*args, **kwargs))
    except Exception as exc:
        message = ("error", exc)
    try:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        data = pickle.dumps(("unsent", repr(exc)))
    answers.write(struct.pack("<Q", len(data)) + data)
    answers.flush()
"""


class _Helper:
    """One helper process, its pipes and the file that keeps its error output."""

    def __init__(self) -> None:
        self.errors: IO[bytes] = tempfile.TemporaryFile()
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _SERVE, MARK],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.errors,
        )

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self) -> None:
        """Ends the helper: SIGTERM, then SIGKILL after GRACE_SECONDS."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(GRACE_SECONDS)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout, self.errors):
            if stream is not None:
                stream.close()

    def failure(self) -> ScanmeshError:
        """The error for a helper that ended without an answer, saying how it ended."""
        code = self.proc.wait()
        if code < 0:
            name = signal.Signals(-code).name if -code in signal.valid_signals() else -code
            how = f"was killed by signal {name}"
            if name == "SIGKILL":  # what the kernel sends when memory runs out
                how += " (from outside, or by the system when memory ran out)"
        else:
            self.errors.seek(0)
            lines = self.errors.read().decode("utf-8", "replace").strip().splitlines()
            how = f"ended with exit code {code}" + (f": {lines[-1]}" if lines else "")
        return ScanmeshError(f"the solver's helper process {how}")


_shared: _Helper | None = None
_shared_lock = threading.Lock()


@contextmanager
def _helper() -> Iterator[_Helper]:
    """The shared helper while this call holds it (started when there is none), or a helper
    of this call's own when another thread holds the shared one. A call that ends in any
    way but an answer (deadline, Ctrl-C, an error) stops its helper."""
    global _shared
    if not _shared_lock.acquire(blocking=False):
        own = _Helper()
        try:
            yield own
        finally:
            own.stop()
        return
    try:
        if _shared is None or not _shared.alive():
            _shared = _Helper()
        helper = _shared
        try:
            yield helper
        except BaseException:
            _shared = None
            helper.stop()
            raise
    finally:
        _shared_lock.release()


@atexit.register
def _stop_shared() -> None:
    if _shared is not None:
        _shared.stop()


def call_killable(
    fn: Callable[..., T],
    args: tuple[Any, ...] = (),
    kwargs: Mapping[str, Any] | None = None,
    *,
    deadline: float | None = None,
) -> T | None:
    """``fn(*args, **kwargs)`` in a helper process; None when it was killed at ``deadline``
    (a ``time.monotonic()`` value; None: no deadline) before it returned.

    ``fn`` and its arguments are pickled (``fn`` by reference: a module-level function
    importable on this process's ``sys.path``), as is its result; an exception of ``fn`` is
    re-raised here. Ctrl-C kills the helper and raises ``KeyboardInterrupt`` within about
    ``POLL_SECONDS``.

    Raises
    ------
    ScanmeshError
        The helper ended without an answer (killed from outside, out of memory, or it
        could not start), or the answer could not be pickled.
    """
    # sys.path first, on its own: the call's pickle may name modules found only there
    path = pickle.dumps(list(sys.path))
    call = pickle.dumps((fn, tuple(args), dict(kwargs or {})), protocol=pickle.HIGHEST_PROTOCOL)
    request = struct.pack("<Q", len(path)) + path + call
    box: dict[str, Any] = {}
    try:
        with _helper() as helper:
            reader = threading.Thread(
                target=_read_answer, args=(helper.proc.stdout, box), name=MARK, daemon=True
            )
            reader.start()
            try:
                assert helper.proc.stdin is not None
                helper.proc.stdin.write(struct.pack("<Q", len(request)) + request)
                helper.proc.stdin.flush()
            except (BrokenPipeError, ConnectionResetError):
                pass  # it ended: the reader meets the end of its output, said below
            while reader.is_alive():
                wait = POLL_SECONDS
                if deadline is not None:
                    wait = min(wait, deadline - time.monotonic())
                    if wait <= 0.0:
                        raise _Overran
                reader.join(wait)
            if "answer" not in box:
                raise helper.failure()
    except _Overran:
        return None
    kind, value = box["answer"]
    if kind == "error":
        raise value
    if kind == "unsent":
        raise ScanmeshError(f"the solver's answer could not be sent: {value}")
    return value


class _Overran(Exception):
    """Raised inside :func:`_helper` so that it stops the helper at the deadline."""


def _read_answer(stream: IO[bytes] | None, box: dict[str, Any]) -> None:
    """Reads one answer from ``stream`` into ``box["answer"]``; nothing when the stream
    ends first (the helper ended)."""
    assert stream is not None
    head = stream.read(8)
    if len(head) < 8:
        return
    size = struct.unpack("<Q", head)[0]
    data = stream.read(size)
    if len(data) == size:
        try:
            box["answer"] = pickle.loads(data)
        except Exception as exc:  # noqa: BLE001 - an exception class this side cannot build
            box["answer"] = ("unsent", repr(exc))


__all__ = ["call_killable", "GRACE_SECONDS", "MARK", "PRELOAD"]
