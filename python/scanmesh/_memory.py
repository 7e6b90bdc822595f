"""How much memory this process may still take, and the limit that sets it, for the checks
that refuse work before it allocates (Python's side of the core's ``budget::memory_room``).

The room is the smallest of the physical memory, what the address-space and data-size
limits leave (``RLIMIT_AS``, ``RLIMIT_DATA``: ``ulimit -v``, ``-d``) beyond what the
process holds now, and what its cgroup's ``memory.max`` leaves. Read from ``/proc`` and
``/sys/fs/cgroup``; where they do not tell (not Linux) only the physical memory counts.
"""

from __future__ import annotations

import os
import resource
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Room:
    """Bytes this process may still allocate and the limit that leaves them."""

    #: bytes
    bytes: int
    #: the limit for messages ("the 1.2 GiB left under RLIMIT_AS (ulimit -v) of 2.0 GiB")
    limit: str


def describe_bytes(count: int) -> str:
    """``1.5 GiB``, ``300.0 MiB``, ``512 bytes``."""
    if count >= 1 << 30:
        return f"{count / (1 << 30):.1f} GiB"
    if count >= 1 << 20:
        return f"{count / (1 << 20):.1f} MiB"
    return f"{count} bytes"


def _status_bytes(field: str) -> int | None:
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith(field):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_left() -> tuple[int, int] | None:
    """(bytes left, memory.max) of this process's cgroup v2, None without a limit."""
    try:
        text = Path("/proc/self/cgroup").read_text(encoding="ascii")
        line = next(row for row in text.splitlines() if row.startswith("0::"))
        folder = Path("/sys/fs/cgroup") / line[3:].strip().lstrip("/")
        top = int((folder / "memory.max").read_text().strip())  # "max": no limit
        used = int((folder / "memory.current").read_text().strip())
    except (OSError, ValueError, StopIteration):
        return None
    return max(top - used, 0), top


def memory_room() -> Room:
    """The memory this process may still allocate (see the module doc). O(1)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, OSError, ValueError):
        total = 1 << 40
    room = Room(total, f"the {describe_bytes(total)} of physical memory")
    for kind, field, name in (
        (resource.RLIMIT_AS, "VmSize:", "RLIMIT_AS (ulimit -v)"),
        (resource.RLIMIT_DATA, "VmData:", "RLIMIT_DATA (ulimit -d)"),
    ):
        soft = resource.getrlimit(kind)[0]
        if soft == resource.RLIM_INFINITY:
            continue
        left = max(soft - (_status_bytes(field) or 0), 0)
        if left < room.bytes:
            room = Room(
                left, f"the {describe_bytes(left)} left under {name} of {describe_bytes(soft)}"
            )
    cgroup = _cgroup_left()
    if cgroup is not None and cgroup[0] < room.bytes:
        left, top = cgroup
        room = Room(
            left,
            f"the {describe_bytes(left)} left under the cgroup's memory.max of"
            f" {describe_bytes(top)}",
        )
    return room
