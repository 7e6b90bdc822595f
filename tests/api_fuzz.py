"""Seeded fuzz cases for the Python API: ``scanmesh.reconstruct`` with every method, points
of awkward kinds and sizes, and options of every type and size; every fifth seed a case of
``scanmesh.merge``, ``read_conf`` or the range-grid and gzip readers (:mod:`api_fuzz_merge`).

One integer seed fixes a case (:func:`make_case`). :func:`run_case` calls ``reconstruct``
in this process and returns a finding, or None. Allowed outcomes:

- a Surface whose faces are a valid triangulation in the scan's own plane
  (``_core.validate`` and exact orientation on ``surface.scan.uv``; skipped only where the
  strip methods report ``planar_valid`` other than True) that accounts for every point (a
  face vertex, a duplicate, ``options["trimmed"]`` or ``options["unused"]``);
- a ScanmeshError with a message; when the case holds a bad input (judged by
  :func:`valid_value`, independently of ``Option.check``), the message names one of them
  (the option or keyword, or "points").

Anything else is a finding: another exception type (a Rust panic arrives as pyo3's
PanicException, a BaseException), a bad value accepted, an invalid or empty mesh, a point
lost. Hangs and crashes are findings of :class:`Runner`, which runs cases in a child
process with a time limit per case and a memory limit.

The options are read from ``scanmesh.methods.TABLE``, so a new option is fuzzed as soon as
it is in the table. Valid values are drawn over the option's whole range, except the
sizes in :data:`COST_CAPS` (a valid huge ``sweeps`` is a long run, not a fault).

Used by tests/test_api_fuzz.py (a bounded number of seeds in CI) and by
benches/api_fuzz.py (the long run).
"""

from __future__ import annotations

import json
import math
import re
import resource
import selectors
import subprocess
import sys
import time
import warnings
from collections import Counter
from typing import Any

import numpy as np

import api_fuzz_merge
from fuzz_core import degenerate_faces
from fuzz_outcome import crash, refusal
from scanmesh import ScanmeshError, _core, reconstruct
from scanmesh._checks import Option
from scanmesh.methods import INITIALS, METHODS, SHARED, TABLE

#: Valid values of these options are drawn no larger (each example stays fast); every other
#: option is drawn over its whole valid range, its largest value included.
COST_CAPS: dict[str, float] = {"sweeps": 20, "time_limit": 0.2, "patience": 10**9}

#: Values of every type, most of them wrong for most options.
JUNK: tuple[Any, ...] = (
    2**64,
    10**30,
    10**9,
    10**6,
    -1,
    0,
    1,
    2**63,
    math.nan,
    math.inf,
    -math.inf,
    5e-324,
    -0.0,
    1e300,
    True,
    False,
    "abc",
    "1",
    "",
    None,
    1j,
    {},
    {"a": 1},
    b"z",
    [1],
    (1.0,),
    np.int64(3),
    np.float32("nan"),
    np.uint64(2**64 - 1),
    np.bool_(True),
    np.array([1.0, 2.0]),
)

#: Valid values of the options checked by a function of their own ("any" options).
ANY_VALID: dict[str, tuple[Any, ...]] = {
    "weight": ("angle", "length", "area", "dihedral", {"area": 1.0, "dihedral": 0.5}),
    "initial": ("delaunay", "shortest-path"),
    "incumbent": (None,),
}

PLANES_VALID: tuple[Any, ...] = (
    None,
    "best-fit",
    "x",
    "y",
    "z",
    "Z",
    (0.0, 0.0, 1.0),
    (1, 2, 3),
    np.array([0.1, -1.0, 0.3]),
)
PLANES_BAD: tuple[Any, ...] = (
    "w",
    "",
    b"z",
    {"a": 1},
    1j,
    3,
    [1, 2],
    (0, 0, 0),
    (math.nan, 0.0, 1.0),
    ("a", "b", "c"),
    np.array([[0.0, 0.0, 1.0]]),
    (1j, 0, 0),
    (math.inf, 1.0, 0.0),
)

VALID_KINDS = (
    "random",
    "integer-grid",
    "flat-grid",
    "scan-lines",
    "collinear-heavy",
    "duplicates",
    "clusters",
    "huge",
    "tiny",
    "offset",
    "all-collinear",
    "all-same",
)
BAD_KINDS = ("nan", "inf", "two-columns", "two-points", "strings", "complex", "ragged")


def valid_value(option: Option, value: Any) -> bool | None:
    """Whether ``option`` must accept ``value`` (None: not judged here, an "any" option).
    The rules of the Option docs, written out again so that the check is not its own judge."""
    if option.kind == "any":
        return None
    if value is None and (option.default is None or option.automatic):
        return True  # None is "not given" (max_edge, seed) or "from the data" (tie_tolerance)
    if option.kind == "bool":
        return isinstance(value, (bool, np.bool_))
    if option.kind == "choice":
        return any(type(value) is type(c) and value == c for c in option.choices)
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        return False
    if option.kind == "int" and not isinstance(value, (int, np.integer)):
        return False
    if option.kind == "float":
        if math.isnan(value) or (option.finite and math.isinf(value)):
            return False
        if option.choices:
            return float(value) in option.choices
    low, high = option.low, option.high
    if low is not None and not (value > low if option.low_open else value >= low):
        return False
    return high is None or bool(value < high if option.high_open else value <= high)


def _valid_draw(option: Option, rng: np.random.Generator) -> Any:
    """A value ``option`` must accept, from anywhere in its range (capped by COST_CAPS)."""
    if option.kind == "any":
        pool = ANY_VALID.get(option.name, (option.default,))
        return pool[rng.integers(len(pool))]
    if option.kind == "bool":
        return (True, False, np.bool_(False))[rng.integers(3)]
    if option.kind == "choice":
        return option.choices[rng.integers(len(option.choices))]
    if option.kind == "float" and option.choices:
        return option.choices[rng.integers(len(option.choices))]
    cap = COST_CAPS.get(option.name, math.inf)
    low = 0.0 if option.low is None else float(option.low)
    high = min(cap, math.inf if option.high is None else float(option.high))
    if option.kind == "int":
        lo, hi = int(low), int(min(high, 2**64 - 1))
        pick = rng.integers(4)
        if pick == 0:
            return lo
        if pick == 1:
            return hi
        # log-uniform between the ends, so that small values come often too
        span = max(hi - lo, 0)
        return lo + min(span, int(math.exp(rng.random() * math.log1p(span))))
    top = high if not option.high_open else math.nextafter(high, -math.inf)
    bottom = low if not option.low_open else math.nextafter(low, math.inf)
    candidates = [bottom, bottom + (min(top, bottom + 1e6) - bottom) * rng.random() ** 3]
    if math.isfinite(top):
        candidates.append(top)
    elif option.name not in COST_CAPS:
        candidates.append(1e300)
        if not option.finite:
            candidates.append(math.inf)
    return candidates[rng.integers(len(candidates))]


def _option_draw(option: Option, rng: np.random.Generator, junk: float) -> Any:
    """A value of JUNK with probability ``junk``, else a valid one; JUNK's valid values
    beyond COST_CAPS (sweeps=10**6) are replaced by valid ones under it."""
    if rng.random() >= junk:
        return _valid_draw(option, rng)
    value = JUNK[rng.integers(len(JUNK))]
    cap = COST_CAPS.get(option.name)
    # (None is valid where it means "no limit": fine where the capped sweeps bound the run)
    if cap is not None and value is not None and valid_value(option, value) and value > cap:
        return _valid_draw(option, rng)
    return value


def _points(kind: str, n: int, rng: np.random.Generator) -> tuple[Any, np.ndarray | None]:
    """(points, true line ids or None) of one kind."""
    line_ids = None
    if kind == "integer-grid":
        side = int(rng.integers(3, 11))
        k = rng.permutation(side * side)[: max(n, 5)]
        x, y = (k % side).astype(float), (k // side).astype(float)
        return np.column_stack([x, y, (x * y) % 3 - x // 2]), None
    if kind == "flat-grid":
        side = int(rng.integers(3, 11))
        x, y = np.meshgrid(np.arange(side, dtype=float), np.arange(side, dtype=float))
        return np.column_stack([x.ravel(), y.ravel(), np.zeros(side * side)]), None
    if kind == "scan-lines":
        rows = int(rng.integers(2, 7))
        per = max(2, n // rows)
        y = np.repeat(np.arange(rows, dtype=float), per) + 0.05 * rng.standard_normal(rows * per)
        x = np.tile(np.arange(per, dtype=float), rows) + 0.2 * rng.random(rows * per)
        line_ids = np.repeat(np.arange(rows), per)
        xy = np.column_stack([x, y])
    elif kind == "collinear-heavy":
        t = rng.integers(0, 20, size=n).astype(float)
        which = rng.integers(0, 3, size=n)
        xy = np.column_stack([t, 2.0 * which + 0.5 * t])
        off = rng.random(n) < 0.15
        xy[off] = rng.random((int(off.sum()), 2)) * 20
    elif kind == "duplicates":
        xy = rng.random((n, 2))
        xy[rng.integers(0, n, size=n // 2)] = xy[rng.integers(0, n, size=n // 2)]
    elif kind == "clusters":
        xy = rng.random((3, 2))[rng.integers(0, 3, size=n)] + 1e-9 * rng.random((n, 2))
    elif kind == "all-collinear":
        t = rng.random(n)
        xy = np.column_stack([t, 3 * t])
    elif kind == "all-same":
        xy = np.zeros((n, 2)) + rng.random(2)
    else:
        xy = rng.random((n, 2))
    z = 0.3 * np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1])
    pts = np.column_stack([xy, z])
    scale = {"huge": 10.0 ** rng.integers(100, 301), "tiny": 10.0 ** -rng.integers(100, 301)}
    if kind in scale:
        pts = pts * scale[kind]
    if kind == "offset":
        pts = pts + 1e9
    return pts, line_ids


def _bad_points(kind: str, n: int, rng: np.random.Generator) -> Any:
    pts = rng.random((n, 3))
    if kind in ("nan", "inf"):
        pts[rng.integers(n), rng.integers(3)] = math.nan if kind == "nan" else -math.inf
        return pts
    if kind == "two-columns":
        return pts[:, :2]
    if kind == "two-points":
        return pts[:2]
    if kind == "strings":
        return pts.astype(str)
    if kind == "complex":
        return pts + 1j
    return [[0.0, 0.0, 0.0], [1.0, 0.0], [0.0, 1.0, 0.0]]


def _lines_draw(
    n: int, truth: np.ndarray | None, rng: np.random.Generator, junk: float
) -> tuple[Any, bool]:
    """(a lines= value, whether it is valid); a bad one with probability about ``junk``."""
    pick = (
        int(rng.choice([4, 5, 6, 7, 8]))
        if rng.random() < junk
        else int(rng.choice([0, 1, 2, 3, 9, 10, 11]))
    )
    if pick == 0 and truth is not None:
        return truth, True
    if pick == 1:
        return rng.integers(0, 4, size=n), True
    if pick == 2:
        return rng.integers(0, 4, size=n).astype(float), True
    if pick == 3:
        return rng.integers(0, 4, size=n).astype(np.uint64), True
    if pick == 4:
        return rng.integers(0, 4, size=n) + 0.5, False
    if pick == 5:
        ids = np.zeros(n)
        ids[rng.integers(n)] = (1e300, math.nan, math.inf, 2.0**60)[rng.integers(4)]
        return ids, False
    if pick == 6:
        ids = np.zeros(n, dtype=np.uint64)
        ids[rng.integers(n)] = np.uint64(2**63 + int(rng.integers(0, 1000)))
        return ids, False
    if pick == 7:
        return np.arange(n + int(rng.choice([-1, 1]))), False
    if pick == 8:
        return (np.zeros(n, dtype=bool), ["a"] * n, np.zeros((n, 1), dtype=int), 3)[
            rng.integers(4)
        ], False
    if pick == 9:
        return list(range(n)), True
    if pick == 10 and truth is not None:
        return truth.astype(float), True
    return np.full(n, -(2**62)) + rng.integers(0, 2, size=n), True


def make_case(seed: int) -> dict[str, Any]:
    """The call of case ``seed`` and which of its inputs are bad (deterministic)."""
    rng = np.random.default_rng(seed)
    method = METHODS[rng.integers(len(METHODS))]
    junk = 0.0 if rng.random() < 0.5 else 0.35  # half of the cases draw valid values only
    spec = TABLE[method]
    n = int(rng.integers(5, 61))
    bad: list[str] = []  # inputs that must be refused
    suspects: list[str] = []  # inputs a refusal may name (an "any" option's odd value)
    if rng.random() < junk / 4:
        kind = BAD_KINDS[rng.integers(len(BAD_KINDS))]
        points, truth = _bad_points(kind, n, rng), None
        bad.append("points")
    else:
        kind = VALID_KINDS[rng.integers(len(VALID_KINDS))]
        points, truth = _points(kind, n, rng)
    n = len(points)
    kwargs: dict[str, Any] = {}
    for option in spec.options:
        # An expensive default (1000 sweeps, a minute of HiGHS) is always replaced, capped
        # (annealing's time_limit, None by default, is bounded by the capped sweeps).
        cap = COST_CAPS.get(option.name)
        expensive = cap is not None and option.default is not None and option.default > cap
        if expensive or rng.random() < 0.4:
            value = _option_draw(option, rng, junk)
            kwargs[option.name] = value
            judged = valid_value(option, value)
            if judged is False:
                bad.append(option.name)
            elif judged is None and not any(
                type(value) is type(v) and value == v for v in ANY_VALID.get(option.name, ())
            ):
                suspects.append(option.name)
    if rng.random() < junk / 4:
        others = sorted({o.name for m in TABLE.values() for o in m.options} | {"sweep", "bogus"})
        name = others[rng.integers(len(others))]
        if name not in kwargs and name not in {o.name for o in spec.options}:
            kwargs[name] = 1
            bad.append(name)
    used = spec.shared
    if spec.uses is not None:
        initial = kwargs.get("initial", "delaunay")
        used = spec.uses(
            {"initial": initial if isinstance(initial, str) and initial in INITIALS else "delaunay"}
        )
    strip_lines = "lines" in spec.shared
    if rng.random() < (0.5 if strip_lines else 0.1):
        value, ok = _lines_draw(n, truth, rng, junk)
        kwargs["lines"] = value
        if not ok or "lines" not in used:
            bad.append("lines")
    for name in ("max_edge", "seed"):
        if rng.random() < (0.3 if name in spec.shared else 0.05):
            value = _option_draw(SHARED[name], rng, junk)
            kwargs[name] = value
            if valid_value(SHARED[name], value) is False or (
                value is not None and name not in used
            ):
                bad.append(name)
    if rng.random() < 0.4:
        if rng.random() < junk:
            kwargs["plane"] = PLANES_BAD[rng.integers(len(PLANES_BAD))]
            bad.append("plane")
        else:
            kwargs["plane"] = PLANES_VALID[rng.integers(len(PLANES_VALID))]
    return {
        "seed": seed,
        "method": method,
        "kind": kind,
        "points": points,
        "kwargs": kwargs,
        "bad": bad,
        "suspects": suspects,
    }


def _names(message: str, name: str) -> bool:
    if name == "points":
        return re.search(r"\bpoints?\b", message) is not None
    return re.search(rf"(?<!\w){re.escape(name)}(?!\w)", message) is not None


def surface_fault(surface: Any, method: str, n_points: int) -> str | None:
    """What is wrong with a Surface returned by ``reconstruct(method=method)``, or None."""
    faces = surface.faces
    # "auto" returns the chosen method's Surface and says so
    expected = surface.options["method_choice"]["built"] if method == "auto" else method
    if surface.method != expected:
        return f"surface.method {surface.method!r}"
    if faces.dtype != np.int64 or faces.ndim != 2 or faces.shape[1] != 3:
        return f"faces of dtype {faces.dtype} and shape {faces.shape}"
    if len(faces) == 0:
        return "a Surface with no faces"
    if faces.min() < 0 or faces.max() >= n_points:
        return "a face index out of range"
    if surface.scan is None:
        return "no scan"
    uv = surface.scan.uv
    if surface.options.get("planar_valid", True) is True:
        try:
            _core.validate(uv, faces)
        except ScanmeshError as exc:
            return f"invalid mesh: _core.validate: {exc}"
        bad = degenerate_faces(uv, faces)
        if bad:
            return f"face {faces[bad[0]].tolist()} not counter-clockwise in scan.uv"
    seen = np.zeros(n_points, dtype=bool)
    seen[faces.ravel()] = True
    seen[surface.duplicates[:, 0]] = True
    for listed in ("trimmed", "unused"):
        seen[np.asarray(surface.options.get(listed, []), dtype=np.int64)] = True
    if not seen.all():
        return f"points {np.flatnonzero(~seen)[:5].tolist()} are in no face and no list"
    return None


#: Every MERGE_EVERY-th seed (those one short of a multiple) is a case of merge, read_conf
#: or the range-grid and gzip readers (:mod:`api_fuzz_merge`) instead of reconstruct.
MERGE_EVERY = 5


def is_merge_seed(seed: int) -> bool:
    """True for the seeds :mod:`api_fuzz_merge` makes."""
    return seed % MERGE_EVERY == MERGE_EVERY - 1


def run_case(seed: int) -> dict[str, Any]:
    """Runs case ``seed``: {"outcome": ..., "finding": class or None, "detail": ...}."""
    if is_merge_seed(seed):
        return api_fuzz_merge.run_case(seed)
    case = make_case(seed)
    method, bad, suspects = case["method"], case["bad"], case["suspects"]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            surface = reconstruct(case["points"], method, **case["kwargs"])
    except ScanmeshError as exc:
        named = any(_names(str(exc), name) for name in bad + suspects)
        return refusal(method, exc, bad, named)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a panic is a BaseException; the point of the fuzz
        return crash(method, exc)
    if bad:
        return {
            "outcome": "surface",
            "finding": f"{method}: bad {bad[0]} accepted",
            "detail": f"bad {bad}",
        }
    fault = surface_fault(surface, method, len(case["points"]))
    if fault is not None:
        kind = re.sub(r"[\d\[\], .-]+", " ", fault.split(":")[0]).strip()
        return {"outcome": "surface", "finding": f"{method}: {kind}", "detail": fault[:300]}
    return {"outcome": "surface", "finding": None, "detail": ""}


def reproducer(seed: int) -> str:
    """Python source that repeats case ``seed`` (points as make_case builds them)."""
    if is_merge_seed(seed):
        return api_fuzz_merge.reproducer(seed)
    case = make_case(seed)
    args = ", ".join(f"{k}={v!r}" for k, v in case["kwargs"].items())
    return (
        f"# case {seed}: {case['kind']} points, bad inputs {case['bad']}\n"
        f"import sys; sys.path.insert(0, 'tests')\n"
        f"from api_fuzz import make_case; import scanmesh, numpy as np\n"
        f"from numpy import array, bool_, float32, float64, inf, int64, nan, uint64\n"
        f"points = make_case({seed})['points']\n"
        f"scanmesh.reconstruct(points, {case['method']!r}{', ' if args else ''}{args})"
    )


class Runner:
    """Cases in a child process, one at a time, with a time limit per case and a limit on
    the child's address space; a child that hangs or dies is replaced, and every
    ``batch`` cases it is replaced anyway (memory a case leaks stays with its batch)."""

    def __init__(self, timeout: float, memory_bytes: int, batch: int = 500) -> None:
        self.timeout, self.memory, self.batch = timeout, memory_bytes, batch
        self.proc: subprocess.Popen[str] | None = None
        self.done = 0

    def _start(self) -> subprocess.Popen[str]:
        memory = self.memory

        def limit() -> None:
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

        return subprocess.Popen(
            [sys.executable, __file__, "--worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            bufsize=1,
            preexec_fn=limit,
        )

    def run(self, seed: int) -> dict[str, Any]:
        """The result of case ``seed`` (a timeout or a dead child is a finding)."""
        if self.proc is None or self.done >= self.batch:
            self.close()
            self.proc = self._start()
            self.done = 0
        proc = self.proc
        assert proc.stdin is not None and proc.stdout is not None
        self.done += 1
        proc.stdin.write(f"{seed}\n")
        proc.stdin.flush()
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stdout, selectors.EVENT_READ)
            ready = sel.select(self.timeout)
        method = "merge or a reader" if is_merge_seed(seed) else make_case(seed)["method"]
        if not ready:
            self.close()
            return {
                "outcome": "timeout",
                "finding": f"{method}: no answer in {self.timeout:g} s",
                "detail": "",
            }
        line = proc.stdout.readline()
        if not line:
            code = proc.wait()
            self.proc = None
            return {
                "outcome": "crash",
                "finding": f"{method}: child died (exit {code})",
                "detail": "",
            }
        return json.loads(line)

    def close(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait()
            self.proc = None


def run_many(
    seeds: range, timeout: float, memory_bytes: int, batch: int = 500
) -> tuple[dict[str, list[tuple[int, str]]], Counter[str]]:
    """Findings by class (seed, detail) and a count of outcomes, over ``seeds``."""
    findings: dict[str, list[tuple[int, str]]] = {}
    outcomes: Counter[str] = Counter()
    runner = Runner(timeout, memory_bytes, batch)
    try:
        for seed in seeds:
            result = runner.run(seed)
            outcomes[result["outcome"]] += 1
            if result["finding"]:
                findings.setdefault(result["finding"], []).append((seed, result["detail"]))
    finally:
        runner.close()
    return findings, outcomes


def _worker() -> None:
    """Reads seeds from stdin, writes one JSON line per case."""
    for line in sys.stdin:
        t0 = time.perf_counter()
        result = run_case(int(line))
        result["seconds"] = time.perf_counter() - t0
        print(json.dumps(result), flush=True)


if __name__ == "__main__" and sys.argv[1:] == ["--worker"]:
    _worker()
