"""What every stage of one call receives: where its progress goes and the seed of its random
choices, decided once where the call comes in.

Public functions keep their ``progress=`` and ``seed=`` keywords; they make one
:class:`Context` (:meth:`Context.of`) and hand it down, so the stages below them take one
argument instead of each keyword threaded through every signature. Ctrl-C and the memory
budget are not per call: ``scanmesh._interrupt`` answers Ctrl-C during native calls for the
whole process, and the core reads the process's memory limits itself.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from scanmesh._progress import Progress, Stage


@dataclass(frozen=True)
class Context:
    """The progress and the seed of one call (see the module docstring)."""

    #: ``progress=`` of the public function called (``scanmesh._progress``)
    progress: Progress = False
    #: the seed of every random choice (a given ``seed=None`` is 0: :meth:`of`)
    seed: int = 0

    @classmethod
    def of(cls, progress: Progress = False, seed: int | None = None) -> Context:
        """The context of a call given ``progress=`` and ``seed=`` (:func:`seed_of`; the
        value itself is checked by the option that takes it)."""
        return cls(progress=progress, seed=seed_of(seed))

    def stage(self, name: str, total: int, blocking: bool = False) -> Stage:
        """A :class:`scanmesh._progress.Stage` reporting to this call's progress."""
        return Stage(self.progress, name, total, blocking=blocking)

    def quiet(self) -> Context:
        """The same call without progress (work whose stages are not the call's own, such
        as the default's trial builds on parts of the scan)."""
        return dataclasses.replace(self, progress=False)


def seed_of(seed: int | None) -> int:
    """The seed of a call given ``seed=``: None (not given) is 0. The one place that says so."""
    return 0 if seed is None else seed


#: The context of a call that reports nothing and was given no seed.
QUIET = Context()

__all__ = ["Context", "QUIET", "seed_of"]
