"""Optional dependencies: the features that need a package the core install leaves out.

The core install (numpy, scipy, trimesh, rtree, tqdm) reads, reconstructs, judges, writes meshes
and PNG pictures; each extra adds one feature's packages (pyproject.toml lists them).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from scanmesh.errors import MissingExtraError


def require(module: str, extra: str, feature: str, instead: str = "") -> ModuleType:
    """Import ``module`` (dotted name) for ``feature``; when it is missing, raise a
    :class:`MissingExtraError` that says which extra installs it (and ``instead``, what
    works without it, when given). Commands call it before any work for what they will
    need at the end."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        package = module.split(".")[0]
        raise MissingExtraError(
            f'{feature} needs {package}, which is not installed: pip install "scanmesh[{extra}]"'
            + (f"; or {instead}" if instead else "")
        ) from exc
