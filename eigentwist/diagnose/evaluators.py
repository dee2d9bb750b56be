"""One generated evaluator per (robot, backend), loaded once per process."""

from __future__ import annotations

from functools import lru_cache

__all__ = ["evaluator"]


@lru_cache(maxsize=None)
def evaluator(robot: str = "heli4", backend: str = "numpy"):
    """The :class:`eigentwist.runtime.Evaluator` of ``robot`` (cached; never re-derives)."""
    from ..runtime import load

    return load(robot, backend=backend)


def resolve(ev=None, robot: str = "heli4", backend: str = "numpy"):
    """``ev`` if given, else the cached evaluator of ``robot``."""
    return ev if ev is not None else evaluator(robot, backend)
