"""Deprecated home of ``ChainEvaluator``: a description's evaluator is ``eigentwist.load(robot)``.

``ChainEvaluator(robot)`` warns (``DeprecationWarning``) and returns that evaluator, whose
``frequencies(poses, model, **params)`` the old one offered.
"""

from __future__ import annotations

import warnings

__all__ = ["ChainEvaluator"]


def ChainEvaluator(robot, **options):
    """``eigentwist.load(robot, **options)`` with a ``DeprecationWarning`` (``robot``: a
    description or a shipped robot's name)."""
    from .loader import load

    warnings.warn(
        "eigentwist.runtime.chain.ChainEvaluator is deprecated: use eigentwist.load(robot)",
        DeprecationWarning,
        stacklevel=2,
    )
    return load(robot, **options)
