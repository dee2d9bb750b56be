"""How a robot's platform pose enters its derivation: data, not a branch.

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
  base axes;
* ``coordinates``: the names of the pose coordinates a user gives, each one of
  :data:`FULL` (``x, y, z`` m; ``rot_x, rot_y, rot_z`` rad, the rotation vector);
  ``followers``: the coordinates of :data:`FULL` the legs' constraints fix (solved per
  pose, :mod:`eigentwist.runtime.platform`); every other one is 0;
* ``basis``: the platform's allowed twists when the pose space fixes them (a 6 x n tuple
  of 0/1 rows: the translations of a translational platform, all six twists of a free
  one), None when they turn with the pose. Either way they are the rule's result
  (:func:`eigentwist.runtime.allowed.allowed_twists`: the null space of the legs'
  constraint wrenches), which the fixed ones only spare the runtime from computing.
"""

from __future__ import annotations

import sympy as sp

from ..errors import DescriptionError
from .parameters import sym

__all__ = [
    "TranslationPose",
    "RigidPose",
    "PlanarPose",
    "PointPose",
    "LowerMobilityPose",
    "POSE",
    "ROTATION",
    "FULL",
    "TWIST_AXIS",
    "twist_order",
]

#: position inputs x, y, z (m) of the platform origin
POSE = (sym("x"), sym("y"), sym("z"))
#: entries R_ij of the platform's rotation matrix (the runtime turns the rotation vector
#: into it by Rodrigues' formula)
ROTATION = sp.Matrix(3, 3, lambda i, j: sym(f"R_{i}{j}"))
#: the six pose coordinates of a rigid platform, in the order of a full pose
FULL = ("x", "y", "z", "rot_x", "rot_y", "rot_z")
#: index of each coordinate's unit twist in ``[omega; v]`` (``rot_x`` -> omega_x, ``x`` -> v_x)
TWIST_AXIS = {"rot_x": 0, "rot_y": 1, "rot_z": 2, "x": 3, "y": 4, "z": 5}


def twist_order(names) -> tuple:
    """The coordinates ``names`` in the order of their unit twists in ``[omega; v]``: the
    order of the rigid model's allowed twists (``("rot_z", "x", "y")`` for a planar robot)."""
    return tuple(sorted(names, key=TWIST_AXIS.__getitem__))


def _unit_columns(names) -> tuple:
    """The 6 x n basis (rows of 0/1) of the unit twists of coordinates ``names`` (twist order)."""
    return tuple(tuple(int(TWIST_AXIS[c] == k) for c in twist_order(names)) for k in range(6))


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
    coordinates = ("x", "y", "z")
    followers: tuple = ()
    #: the legs' constraint wrenches span the rotations: the allowed twists are the translations
    basis = _unit_columns(("x", "y", "z"))

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
    coordinates = FULL
    followers: tuple = ()
    #: no constraint wrench: every twist is allowed
    basis = _unit_columns(FULL)

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


class PlanarPose(RigidPose):
    """A planar platform (3-DoF: x, y in m and rot_z in rad, in the base's z = 0 plane):
    derived as a rigid platform (the legs' joint lists in 3-D, their constraint wrenches
    holding it in the plane) at the pose (x, y, 0, 0, 0, rot_z). Its allowed twists (the
    null space of the constraint wrenches, :mod:`eigentwist.runtime.allowed`) are
    omega_z, v_x, v_y wherever the legs' axes stay parallel to z."""

    coordinates = ("x", "y", "rot_z")
    basis = None

    def __repr__(self) -> str:
        return "PlanarPose()"


class PointPose(RigidPose):
    """A platform that is a point: it translates along its coordinates (a subset of
    ``x, y, z`` in m, e.g. a planar five-bar's end-effector ``("x", "y")``) and has no
    rotation of its own. Derived as a rigid platform at the pose (x, y, z, 0, 0, 0): its
    inertia is a point mass at its origin (no rotational inertia), and the legs end at it
    in passive revolute or spherical joints, whose rotations are the legs' own. Its
    allowed twists are the translations it is given, exactly: a point's coordinates are
    independent (no followers), and its rotation is no freedom of the mechanism, so the
    model has one mode per coordinate and none for the rotations the legs leave free."""

    followers: tuple = ()
    #: a point: its rotations carry neither inertia nor stiffness, so only the rigid model
    #: (on its translations) is defined; a structural effect's 6x6 flexible model is not
    point = True

    def __init__(self, coordinates=("x", "y", "z")):
        coordinates = tuple(coordinates)
        if (
            not coordinates
            or len(set(coordinates)) != len(coordinates)
            or any(c not in ("x", "y", "z") for c in coordinates)
        ):
            raise DescriptionError(
                f"point coordinates {coordinates!r}: expected distinct names from x, y, z (a point has no rotation)"
            )
        self.coordinates = coordinates
        self.basis = _unit_columns(coordinates)

    def __repr__(self) -> str:
        return f"PointPose({self.coordinates!r})"


class LowerMobilityPose(RigidPose):
    """A platform with fewer than six freedoms whose description names the commanded
    coordinates (e.g. a 3-PRS: ``("z", "rot_x", "rot_y")``); the remaining ones of
    :data:`FULL` (its parasitic motions: x, y, rot_z) follow from the legs' constraints,
    the ``closures`` of each leg (:class:`~.chain.ChainLeg`: scalars of its geometry that
    vanish where the platform can be), solved per pose by a damped Newton method
    (:func:`eigentwist.runtime.platform.follow`). Derived as a rigid platform at the
    completed pose; its allowed twists turn with the pose (``basis`` None)."""

    basis = None

    def __init__(self, commanded):
        commanded = tuple(commanded)
        unknown = [c for c in commanded if c not in FULL]
        if unknown or not commanded or len(set(commanded)) != len(commanded):
            raise DescriptionError(
                f"commanded coordinates {commanded!r}: expected distinct names from {', '.join(FULL)}"
            )
        self.coordinates = commanded
        self.followers = tuple(c for c in FULL if c not in commanded)

    def __repr__(self) -> str:
        return f"LowerMobilityPose({self.coordinates!r})"
