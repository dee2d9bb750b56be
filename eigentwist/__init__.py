"""eigentwist: closed-form natural-frequency models of parallel manipulators.

Method: Hoevenaars, Krut & Herder (2020), Jacobian-based natural frequency analysis of
parallel manipulators, Mechanism and Machine Theory 148, 103775,
DOI 10.1016/j.mechmachtheory.2019.103775.
"""
__version__ = "0.1.0"

__all__ = ["load", "__version__"]


def load(robot: str = "heli4", backend: str = "numpy", **kwargs):
    """Load the generated evaluator of ``robot`` (see :func:`eigentwist.runtime.load`)."""
    from .runtime import load as _load

    return _load(robot, backend=backend, **kwargs)
