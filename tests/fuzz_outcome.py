"""What one fuzz case's exception says about scanmesh, shared by the reconstruct and merge
fuzzers (:mod:`api_fuzz`, :mod:`api_fuzz_merge`): each returns the case's record
``{"outcome": ..., "finding": class or None, "detail": ...}``."""

from __future__ import annotations

from typing import Any


def refusal(label: str, exc: BaseException, bad: Any, named: bool) -> dict[str, Any]:
    """A ScanmeshError: a finding when its message is empty, or when the case had ``bad``
    inputs and the message names none of them (``named`` False)."""
    message = str(exc)
    outcome = f"refused: {type(exc).__name__}"
    if not message:
        return {"outcome": outcome, "finding": f"{label}: empty message", "detail": ""}
    if bad and not named:
        return {
            "outcome": outcome,
            "finding": f"{label}: refusal names none of the bad inputs",
            "detail": f"bad {bad}: {message[:300]}",
        }
    return {"outcome": outcome, "finding": None, "detail": message[:300]}


def crash(label: str, exc: BaseException) -> dict[str, Any]:
    """Any other exception (a panic is a BaseException): always a finding."""
    return {
        "outcome": "exception",
        "finding": f"{label}: {type(exc).__name__} instead of a ScanmeshError",
        "detail": str(exc)[:300],
    }
