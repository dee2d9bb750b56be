"""The kernels' protocol: what a backend gives the evaluator, NumPy and C alike.

Every backend runs the same generated kernels with the same inputs and outputs: the NumPy
backend is the generated module itself (``eigentwist/generated/<robot>_numpy.py``, or a user
description's in the cache), the C backend a :class:`~eigentwist.runtime.c_kernels.CKernels`
over the compiled library. ``p`` is the inputs resolver's dict (:mod:`.inputs`), with the
pose where a kernel reads it; arrays are batched over poses (first axis N). A C backend also
gives the passes that only compiled code has (:class:`CompiledKernels`): the evaluator asks
for them only on that backend.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["Kernels", "CompiledKernels"]


@runtime_checkable
class Kernels(Protocol):
    """The generated kernels of one robot (both backends).

    ``OUTPUTS``: kernel name -> {output name: shape per pose}. Kernels that some robots
    have, named in ``OUTPUTS`` where present: ``legs(q, p)`` (each leg's joint compliance and
    transforms, for the exact condensation (:mod:`.condense`) and the damped models),
    ``loop_closure(q, p) -> {"residual", "dresidual"}`` (legs closed by Newton's method, URDF
    form), with it ``lever(q, p) -> {"lever"}`` (the jacobians kernel's levers alone, for the
    branch check of each Newton solution), and ``followers`` (a lower-mobility platform's
    dependent coordinates).
    """

    OUTPUTS: dict

    def inverse_kinematics(self, x, y, z, p: dict) -> dict:
        """Joint coordinates ``q`` (N, legs, joints; rad, m for a prismatic joint) and the
        checks of the poses (x, y, z in m)."""

    def jacobians(self, q, p: dict) -> dict:
        """The legs' Jacobians (screw rows, twist order [omega; v]) and the lever of each
        leg's serial singularity."""

    def matrices(self, q, p: dict) -> dict:
        """``M``, ``K_R``, ``K_F`` (N, 6, 6) at the end effector (Eqs. 12, 14, 13)."""

    def gravity(self, q, p: dict) -> dict:
        """The gravity preload's terms of the stiffness."""


@runtime_checkable
class CompiledKernels(Kernels, Protocol):
    """The C backend's kernels: :class:`Kernels` and the passes of compiled code.

    ``signature``: the library's description of its passes (``signature["eigh"]["dims"]``:
    the sizes its batched eigen-solver takes)."""

    signature: dict

    def fused(self, x, y, z, p: dict, *, threads: int = 1, **options) -> dict:
        """Poses to checked frequencies (and eigentwists, matrices) in one pass."""

    def prepare_fused(self, p: dict, pose_inputs: dict, *, model: str, vectors: bool = False, matrices=()):
        """The fused pass with its parameters packed once, for repeated calls."""

    def generalized_eigh(self, K, M, vectors: bool = True, threads: int = 1):
        """Eigenvalues (and eigenvectors) of K v = lambda M v, batched."""

    def jacobians(self, q, p: dict, threads: int = 1) -> dict:
        """:meth:`Kernels.jacobians`, its poses split on ``threads`` threads."""

    def newton(self, q, p: dict, iterations: int, tol: float, threads: int = 1):
        """The legs' Newton (Levenberg-Marquardt) iterations on ``loop_closure``."""

    def follow(self, q, p: dict, followers: list, iterations: int, tol: float, threads: int = 1):
        """A lower-mobility platform's followers solved by the same iterations."""

    def raise_invalid(self, k: int, x, y, z, p: dict, lead: tuple, legs=None, names=None) -> None:
        """Raise the typed error of pose ``k`` that the pass flagged."""
