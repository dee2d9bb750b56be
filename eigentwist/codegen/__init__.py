"""Code generation: kernels (CSE), Jinja templates, render / write / check.

Public names (imported on first use, so that loading an evaluator never imports SymPy):

* :func:`kernels_for` — the CSE'd kernels (inverse kinematics, Jacobians, matrices,
  gravity) of a derived model (:func:`eigentwist.symbolic.derive`), as ``eigentwist
  generate`` builds them;
* :func:`render_robot`, :func:`render_all` — generated sources as ``{path: text}``;
* :func:`write`, :func:`stale` — write them / name the checked-in files that differ.
"""

__all__ = ["kernels_for", "render_robot", "render_all", "write", "stale"]


def __getattr__(name):
    if name in __all__:
        from . import generate

        return getattr(generate, name)
    raise AttributeError(f"module 'eigentwist.codegen' has no attribute {name!r}")
