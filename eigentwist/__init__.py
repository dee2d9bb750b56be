"""eigentwist: closed-form natural-frequency models of parallel manipulators.

Method: Hoevenaars, Krut & Herder (2020), Jacobian-based natural frequency analysis of
parallel manipulators, Mechanism and Machine Theory 148, 103775,
DOI 10.1016/j.mechmachtheory.2019.103775.
"""

__version__ = "0.1.0"

__all__ = ["load", "__version__"]


def load(robot: str = "heli4", backend: str = "auto", **kwargs):
    """Load the generated evaluator of ``robot`` (see :func:`eigentwist.runtime.load`).

    ``backend="auto"`` (the default) uses the generated C library when a C compiler is
    available and falls back to the generated NumPy module with one warning otherwise;
    ``"numpy"`` and ``"c"`` choose explicitly.
    """
    from .runtime import load as _load

    return _load(robot, backend=backend, **kwargs)
