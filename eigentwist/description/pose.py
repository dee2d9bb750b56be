"""How a robot's platform pose enters its derivation (issue 15): data, not a branch.

A robot declares its pose coordinates (``RobotDescription.pose``, names) and a pose
space (``pose_space``), which tells the one derivation (:func:`eigentwist.symbolic.derive`):

* ``inputs``: the symbols the inverse kinematics takes per pose;
* ``position`` (3x1, m) and ``rotation`` (3x3, platform axes in base axes) of the
  platform frame, as the legs' closed forms read them;
* ``origin``: the point (m, base frame) from which the derivation's program measures the
  legs' points; the unit twists ``[omega; v]`` are taken there;
* ``program_inputs``: the pose symbols the program (M, K, J, G) reads besides each leg's
  joint coordinates;
* ``motion``: each of those with its rate along the platform's six unit twists (1x6), for
  the derivatives of the first term of Eq. 13;
* ``inertia_in_base``: the platform's spatial inertia (at its origin, platform axes) in
  base axes.
"""
from __future__ import annotations

import sympy as sp

from .parameters import sym

__all__ = ["TranslationPose", "RigidPose", "POSE", "ROTATION"]

#: position inputs x, y, z (m) of the platform origin
POSE = (sym("x"), sym("y"), sym("z"))
#: entries R_ij of the platform's rotation matrix (the runtime turns the rotation vector
#: into it by Rodrigues' formula)
ROTATION = sp.Matrix(3, 3, lambda i, j: sym(f"R_{i}{j}"))


def _skew(v: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


class TranslationPose:
    """A translational platform (3-DoF: x, y, z in m, rotation 0). The legs' closed forms
    measure their points from the end-effector origin, so the program reads only the
    legs' joint coordinates: no pose input, no motion of its own."""

    inputs = POSE
    position = sp.Matrix(POSE)
    rotation = sp.eye(3)
    origin = sp.zeros(3, 1)
    program_inputs: tuple = ()

    def motion(self) -> list:
        """``[(symbol, rate 1x6)]`` of the program's pose inputs: none."""
        return []

    def inertia_in_base(self, inertia: sp.Matrix) -> sp.Matrix:
        """The platform's inertia at the EE origin (its axes are the base axes)."""
        return inertia


class RigidPose:
    """A platform free in 6 DoF: position x, y, z (m) and rotation matrix R_ij of its
    frame (from the rotation vector, rad). The program reads the pose (the legs' points
    are in base coordinates, measured from the platform origin)."""

    inputs = POSE + tuple(ROTATION[i, j] for i in range(3) for j in range(3))
    position = sp.Matrix(POSE)
    rotation = ROTATION
    origin = sp.Matrix(POSE)
    program_inputs = inputs

    def motion(self) -> list:
        """``[(symbol, rate 1x6)]``: along the unit twist ``e_k = [omega; v]`` at the
        platform origin the origin moves by ``v`` and the rotation by ``dR = [omega]x R``."""
        out = [(s, sp.Matrix([[int(k == 3 + i) for k in range(6)]])) for i, s in enumerate(POSE)]
        rates = [_skew(sp.Matrix([int(k == 0), int(k == 1), int(k == 2)])) * ROTATION for k in range(3)]
        for i in range(3):
            for j in range(3):
                out.append((ROTATION[i, j], sp.Matrix([[rates[k][i, j] for k in range(3)] + [0, 0, 0]])))
        return out

    def inertia_in_base(self, inertia: sp.Matrix) -> sp.Matrix:
        """The platform's inertia at its origin in base axes: ``A^T M A`` with
        ``A = diag(R^T, R^T)`` (the origin stays)."""
        A = sp.diag(ROTATION.T, ROTATION.T)
        return A.T * inertia * A
