"""Progress of long steps (reading, lines, strips, Delaunay, trimming, annealing, writing).

One convention for every stage, the one annealing started with: ``progress=True`` shows a
tqdm bar on stderr; a callable is called as ``progress(done, total, value)``. A callable
that accepts a keyword argument ``stage`` (or ``**kwargs``) is called for every stage, as
``progress(done, total, value, stage=name)``; one that does not is called for annealing
only, as before (so existing ``(done, total, energy)`` callbacks keep working and never see
bytes where they expect sweeps). Within a stage ``total`` never changes, ``done`` never
decreases and the last call has ``done == total``, except for annealing stopped early
(``time_limit``, ``patience``), whose last call has the sweeps that ran; ``value`` is the
energy for annealing and None elsewhere. Annealing also passes ``seconds_left=`` (its
estimated time left: the sweeps still planned at the rate so far, at most what
``time_limit`` leaves) to a callable that accepts that keyword (or ``**kwargs``). The
command's log (:class:`LogProgress`) is also told which stages are one native call
(``blocking=True``: they count nothing until they return), so that it says so instead of
"0 %"; other callables are called as above. The long native calls that count as they run
(Delaunay, the strips, merge's extraction) are given :attr:`Stage.counter` and followed by
:meth:`Stage.follow` while they run (``interruptible(..., watch=stage.follow)``): their
``done`` is the share of the call's passes done, in the stage's unit.
"""

from __future__ import annotations

import inspect
import math
import os
import sys
import threading
from collections.abc import Callable
from typing import Any

from scanmesh import _core

#: progress= of the public functions: a bool, or a callable(done, total, value[, stage=]).
Progress = bool | Callable[..., None] | None

#: Stage names, in pipeline order, with the unit of their ``done`` / ``total``.
STAGES: dict[str, str] = {
    "read": "bytes",
    "choose": "builds",
    "lines": "points",
    "strips": "points",
    "delaunay": "points",
    "trim": "faces",
    "noise": "points",
    "calibrate": "faces",
    "anneal": "sweeps",
    "polish": "faces",
    "steep": "faces",
    "write": "faces",
    "quality": "faces",
    "preview": "faces",
    "refine": "views",
    "integrate": "views",
    "carve": "views",
    "extract": "nodes",
    "grid": "cells",
    "truth": "samples",
}

#: A bar appears only for a stage still running after this many seconds (short steps stay
#: silent), and a bar over one blocking native call is redrawn this often so its clock runs.
BAR_DELAY_SECONDS: float = 1.0


def accepts(progress: Any, keyword: str) -> bool:
    """True when ``progress`` is a callable that accepts the keyword argument ``keyword``."""
    if not callable(progress) or isinstance(progress, bool):
        return False
    try:
        params = inspect.signature(progress).parameters.values()
    except (TypeError, ValueError):  # builtins without a signature: the original convention
        return False
    return any(
        p.kind is p.VAR_KEYWORD
        or (p.name == keyword and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD))
        for p in params
    )


def takes_stage(progress: Any) -> bool:
    """True when ``progress`` is a callable that accepts a ``stage`` keyword argument."""
    return accepts(progress, "stage")


class Stage:
    """Reports one stage: ``update(done, value)`` as it goes, ``close()`` at the end (which
    reports ``done == total``). Also a context manager. A no-op when nobody listens."""

    def __init__(self, progress: Progress, name: str, total: int, blocking: bool = False):
        self.name, self.total, self.done = name, max(int(total), 0), 0
        self._call: Callable[..., None] | None = None
        self._extra: dict[str, Any] = {}
        self._bar: Any = None
        self._ticker: threading.Event | None = None
        self._counter: Any = None
        if progress is True:
            from tqdm import tqdm  # loaded only when a bar is drawn: `import scanmesh` stays light

            self._bar = tqdm(
                total=self.total,
                desc=name,
                unit=STAGES.get(name, "it"),
                unit_scale=True,
                leave=False,
                delay=BAR_DELAY_SECONDS,
                # one native call moves no bar: show what runs, on how much, for how long
                bar_format="{desc} ({total_fmt} {unit}): {elapsed}" if blocking else None,
                **_bar_size(),
            )
            if blocking:  # no updates come during one native call: keep the clock moving
                self._ticker = threading.Event()
                threading.Thread(target=self._tick, daemon=True).start()
        elif takes_stage(progress):
            self._call = progress  # type: ignore[assignment]
            if blocking and isinstance(progress, LogProgress):
                self._extra = {"blocking": True}
        self.update(0)

    @property
    def counter(self) -> Any:
        """A ``_core.ProgressCounter`` for the one native call of this stage (its
        ``progress=``), read by :meth:`follow` while the call runs."""
        if self._counter is None:
            self._counter = _core.ProgressCounter()
        return self._counter

    def follow(self) -> None:
        """Report the share of its work the native call given :attr:`counter` has done, in
        this stage's unit (called from the waiting thread while the call runs)."""
        counter = self._counter
        if counter is None:
            return
        planned = counter.total
        if planned > 0:
            done = self.total * min(counter.done, planned) // planned
            if done > self.done:
                self.update(done)

    def _tick(self) -> None:
        assert self._ticker is not None
        while not self._ticker.wait(BAR_DELAY_SECONDS / 2):
            bar = self._bar
            if bar is not None:
                bar.update(0)

    def update(self, done: int, value: float | None = None) -> None:
        """Report ``done`` of ``total`` (clamped so that it never decreases)."""
        self.done = min(max(int(done), self.done), self.total)
        if self._call is not None:
            self._call(self.done, self.total, value, stage=self.name, **self._extra)
        elif self._bar is not None:
            self._bar.n = self.done
            self._bar.update(0)  # redraws, once BAR_DELAY_SECONDS have passed

    def close(self) -> None:
        """Report the stage complete and remove its bar."""
        if self._ticker is not None:
            self._ticker.set()
        if self.done < self.total or self._call is None:
            self.update(self.total)
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Stage:
        return self

    def __exit__(self, *exc: object) -> None:
        if exc[0] is None:
            self.close()
        elif self._bar is not None:  # failed or interrupted: drop the bar, report nothing
            if self._ticker is not None:
                self._ticker.set()
            self._bar.close()


#: Bar size where the terminal reports none (a pseudo-terminal without a size, as ``script``
#: makes without a terminal around it: tqdm draws nothing at 0 columns and 0 rows).
FALLBACK_SIZE: tuple[int, int] = (80, 24)


def _bar_size() -> dict[str, int]:
    """tqdm's ``ncols`` and ``nrows`` (:data:`FALLBACK_SIZE`) where stderr's terminal
    reports no size; else nothing (tqdm follows the terminal)."""
    try:
        size = os.get_terminal_size(sys.stderr.fileno())
    except (OSError, ValueError, AttributeError):  # not a terminal, or no file descriptor
        return {}
    if size.columns > 0 and size.lines > 0:
        return {}
    return {"ncols": FALLBACK_SIZE[0], "nrows": FALLBACK_SIZE[1]}


def anneal_progress(progress: Progress) -> Progress:
    """What annealing gets: the progress as it is, or for a stage-aware callable one that
    adds ``stage="anneal"`` (annealing keeps its own ``(done, total, energy)`` calls) and
    passes ``seconds_left`` on if the callable takes it."""
    if not takes_stage(progress):
        return progress
    call: Callable[..., None] = progress  # type: ignore[assignment]
    keep = accepts(progress, "seconds_left")

    def report(done: int, total: int, energy: float, **extra: Any) -> None:
        call(done, total, energy, stage="anneal", **(extra if keep else {}))

    return report


#: Silence of a running stage in a log (stderr not a terminal) before its first line and
#: between lines, in seconds, at first.
LOG_INTERVAL_SECONDS: float = 10.0

#: Lines of a long stage come apart by this share of its time so far (a 12-minute stage
#: writes about 25 lines, not 72), at most :data:`LOG_INTERVAL_MAX_SECONDS`.
LOG_INTERVAL_GROWTH: float = 0.2

#: Longest silence of a running stage in a log, in seconds.
LOG_INTERVAL_MAX_SECONDS: float = 60.0


def _duration(seconds: float) -> str:
    s = max(int(round(seconds)), 0)
    return f"{s // 3600} h {s // 60 % 60:02d} min" if s >= 3600 else f"{s // 60} min {s % 60:02d} s"


def _rate(count: float, seconds: float, unit: str) -> str:
    """``27,800 points/s``; ``1.5 sweeps/s`` below ten a second."""
    rate = count / seconds if seconds > 0 else math.inf
    if not math.isfinite(rate):
        return f"? {unit}/s"
    return f"{rate:,.0f} {unit}/s" if rate >= 10 else f"{rate:.2g} {unit}/s"


class LogProgress:
    """Progress for a log (stderr not a terminal, where bars would be carriage-return noise):
    a stage-aware callable (``progress(done, total, value, stage=, seconds_left=,
    blocking=)``) that writes one line, ``scanmesh: anneal: 1,200 / 5,000 sweeps (24 %),
    2 min 10 s elapsed, 9.2 sweeps/s, about 6 min 51 s left``, for every stage still running
    after ``interval`` seconds (default :data:`LOG_INTERVAL_SECONDS`, read when made), and
    again while it runs, also through one blocking native call (a watcher thread writes the
    last known state; short stages write nothing), the lines coming further apart as the
    stage goes on (:data:`LOG_INTERVAL_GROWTH`, at most :data:`LOG_INTERVAL_MAX_SECONDS`).
    A stage that was reported ends with a line of its total, time and rate. The time left is
    annealing's own estimate where it gives one, else the rate so far. A blocking stage
    (one native call, counting nothing until it returns) says so instead of "0 / N (0 %)".

    ``clock`` and ``start=False`` are for tests: call :meth:`tick` to write what is due.
    """

    def __init__(
        self,
        write: Callable[[str], Any],
        interval: float | None = None,
        clock: Callable[[], float] | None = None,
        start: bool = True,
    ) -> None:
        import time

        self._write = write
        self.interval = float(LOG_INTERVAL_SECONDS if interval is None else interval)
        self._clock = clock or time.monotonic
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None  # the running stage
        self._stop = threading.Event()
        if start:
            threading.Thread(target=self._watch, daemon=True).start()

    def __call__(
        self,
        done: int,
        total: int,
        value: float | None = None,
        stage: str = "anneal",
        seconds_left: float | None = None,
        blocking: bool = False,
    ) -> None:
        now = self._clock()
        with self._lock:
            s = self._state
            if s is None or s["stage"] != stage or done < s["done"]:
                s = self._state = {
                    "stage": stage,
                    "start": now,
                    "last": now,
                    "done": done,
                    "said": False,
                }
            s.update(done=done, total=total, left=seconds_left, blocking=blocking)
            finished = done >= total  # (a stage of nothing is done as it starts)
            if finished:
                self._state = None
        if finished:
            if s["said"]:  # it was reported: its total, time and rate
                unit = STAGES.get(stage, "items")
                took = now - s["start"]
                self._write(
                    f"scanmesh: {stage}: {total:,} {unit} done in {_duration(took)},"
                    f" {_rate(total, took, unit)}"
                )
            return
        self.tick()

    def tick(self) -> None:
        """Write a line for the running stage if its interval has passed since the last."""
        now = self._clock()
        with self._lock:
            s = self._state
            if s is None:
                return
            elapsed = now - s["start"]
            gap = self.interval
            if s["said"]:
                gap = max(gap, min(LOG_INTERVAL_GROWTH * elapsed, LOG_INTERVAL_MAX_SECONDS))
            if now - s["last"] < gap:
                return
            s["last"], s["said"] = now, True
            done, total, left = s["done"], s["total"], s["left"]
            unit = STAGES.get(s["stage"], "items")
            if s["blocking"]:
                line = (
                    f"scanmesh: {s['stage']}: {total:,} {unit} in one native call,"
                    f" {_duration(elapsed)} elapsed (it counts nothing until it returns)"
                )
            else:
                if left is None and 0 < done < total:
                    left = elapsed * (total - done) / done
                share = f" ({100 * done / total:.0f} %)" if total > 0 else ""
                rate = f", {_rate(done, elapsed, unit)}" if done > 0 else ""
                tail = "time left unknown" if left is None else f"about {_duration(left)} left"
                line = (
                    f"scanmesh: {s['stage']}: {done:,} / {total:,} {unit}{share},"
                    f" {_duration(elapsed)} elapsed{rate}, {tail}"
                )
        self._write(line)

    def _watch(self) -> None:
        while not self._stop.wait(min(self.interval / 4, 1.0)):
            self.tick()

    def close(self) -> None:
        """Stop the watcher thread."""
        self._stop.set()
