"""Legs in the usual robotics form, with no closed-form inverse kinematics.

A :class:`SerialLeg` lists its joints from the base mounting to the platform attachment
as URDF or Pinocchio do: each :class:`Joint`'s origin (m) and axes in its parent body's
frame (the base frame for the first joint). eigentwist derives the leg's forward
kinematics and the loop-closure equations (the chain's end = the platform attachment
point, and its frame unless the chain ends in a spherical joint) with their exact Jacobian
(:mod:`eigentwist.symbolic.serial`), generates them with the evaluator, and solves them per
pose by a damped Newton method (:mod:`eigentwist.runtime.levenberg_marquardt`) started from the leg's
``reference`` configuration: which assembly branch (elbow up or down) the robot is on is
the description's choice. A pose where Newton does not converge is unreachable.

Joint coordinates (one per freedom, rad or m): R a rotation about its axis; P a
translation along it; U two rotations (the second axis in the frame after the first);
S three rotations (axes x, y, z of its frame unless given) -- a final S joint at the
platform has no coordinates (its three rotations take up the platform's orientation);
Pi a parallelogram whose ``bar`` (m, joint frame, perpendicular to the axis) turns about
the axis while the child frame keeps its orientation (its unit twist is a translation;
coordinate in rad); ``virtual`` the twist of restriction of a leg with fewer than six
freedoms (a rotation about its axis through its origin, no coordinate).

Example, one leg of a 6-UPS hexapod (base U joint at ``b``, prismatic strut, platform S
joint at ``a`` in the platform frame; the strut along the joint frame's x axis)::

    leg = SerialLeg(
        "leg 1",
        joints=(Joint("U", origin=b, rotation=up_tangent, axes=((0, 1, 0), (0, 0, 1))),
                Joint("P", axes=((1, 0, 0),), actuated=True),
                Joint("S")),
        bodies=(Body("cylinder", after=1, inertia=cylinder),      # in the U joint's child frame
                Body("piston", after=2, inertia=piston)),
        attachment=a,
        reference=(0.0, 0.0, 0.85))      # U angles (rad), strut length (m): the assembly branch
    robot = ChainRobot(..., legs=tuple(leg.chain_leg() for leg in legs), ...)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from ..errors import DescriptionError
from .chain import ChainBody, ChainJoint, ChainLeg
from .joints import JOINT_FREEDOMS, joint_kind

__all__ = [
    "Joint",
    "Body",
    "SerialLeg",
    "NumericKinematics",
    "NumericChainLeg",
    "coordinate_count",
    "CLOSURE_TOL",
    "padded_references",
    "padded_units",
    "ROTATION_TOL",
]

#: a solved configuration closes the loop when the residual (m and rad) is below this
CLOSURE_TOL = 1e-9


@dataclass(frozen=True)
class Joint:
    """One joint, in its parent body's frame (URDF form).

    kind : ``"R"``, ``"P"``, ``"U"``, ``"S"``, ``"Pi"`` or ``"virtual"``.
    origin : the joint frame's origin in the parent frame (m; 3 expressions).
    rotation : the joint frame's axes in the parent frame (3x3, columns; None: identity).
    axes : unit axes in the joint frame: one for R, P, Pi and virtual, two for U, three for
        S (default x, y, z).
    bar : Pi only: the bar from the joint to the child frame's origin at coordinate 0
        (m, joint frame, perpendicular to the axis).
    actuated : True for the actuated joint (R or P).
    """

    kind: str
    origin: tuple = (0, 0, 0)
    axes: tuple = ()
    rotation: Any = None
    bar: tuple | None = None
    actuated: bool = False
    name: str = ""

    def __post_init__(self):
        kind = joint_kind(self.kind)  # the record of its kind (:mod:`.joints`)
        if self.actuated and not kind.actuatable:
            raise DescriptionError(f"an actuated joint is revolute or prismatic, not {self.kind!r}")
        n = kind.freedoms
        axes = self.axes or kind.default_axes
        if len(axes) != n:
            raise DescriptionError(f"joint {self.kind!r} has {n} axes, got {len(axes)}")
        if self.kind == "Pi" and self.bar is None:
            raise DescriptionError(
                "a Pi joint needs its bar (m, joint frame): the vector from the joint to its child frame"
            )
        object.__setattr__(self, "axes", tuple(tuple(a) for a in axes))
        _check_rotation(self.rotation, f"joint {self.name or self.kind!r}")


#: a numeric joint rotation is a rotation when R^T R equals the identity and det R = +1 to this
ROTATION_TOL = 1e-9


def _check_rotation(rotation, what: str) -> None:
    """Refuse a numeric 3x3 ``rotation`` whose columns are not orthonormal and right-handed
    (within :data:`ROTATION_TOL`); expressions of parameters are taken as written."""
    if rotation is None:
        return
    R = sp.Matrix(rotation)
    if R.shape != (3, 3):
        raise DescriptionError(f"{what}: rotation of shape {R.shape}: expected 3x3 (the frame's axes as columns)")
    if R.free_symbols:
        return
    import numpy as np

    Rn = np.array(R.evalf(), dtype=float)
    gap = max(float(np.abs(Rn.T @ Rn - np.eye(3)).max()), abs(float(np.linalg.det(Rn)) - 1.0))
    if gap > ROTATION_TOL:
        raise DescriptionError(
            f"{what}: rotation {Rn.round(6).tolist()} is not a rotation (R^T R - I or det R - 1 reaches "
            f"{gap:.3g}): expected orthonormal right-handed columns (exact values, e.g. sp.sqrt(2)/2)"
        )


@dataclass(frozen=True)
class Body:
    """A rigid body on the child frame of joint ``after`` (1-based; U and S count once):
    ``inertia`` its 6x6 spatial inertia in that frame (kg, kg m, kg m^2; twists [omega; v],
    :func:`eigentwist.description.screw.spatial_inertia`)."""

    name: str
    after: int
    inertia: sp.Matrix
    doc: str = ""


def coordinate_count(joints, last_real: int) -> int:
    """Joint coordinates of a chain: one per freedom, none for virtual joints and for a
    final spherical joint (index ``last_real``)."""
    return sum(
        JOINT_FREEDOMS[j.kind]
        for k, j in enumerate(joints)
        if j.kind != "virtual" and not (k == last_real and j.kind == "S")
    )


def _padded(rows: list, fill) -> tuple:
    width = max(len(r) for r in rows)
    return tuple(tuple(r) + (fill,) * (width - len(r)) for r in rows)


def padded_references(legs) -> tuple:
    """Each numerically solved leg's reference configuration (rad; m for P), padded with
    zeros to the largest leg's number of coordinates (legs that differ: the loop closure
    holds a padded coordinate at zero, :func:`eigentwist.symbolic.kinematics.loop_closure`).
    A closed-form leg among them starts from zeros: its loop closure is its closed form,
    ``q - q(pose) = 0``, linear in its coordinates."""
    return _padded(
        [getattr(leg.kinematics, "reference", (0.0,) * len(leg.kinematics.coordinates)) for leg in legs], 0.0
    )


def padded_units(legs) -> tuple:
    """Each leg's coordinate units (``"rad"``; ``"m"`` for a prismatic joint's), padded
    like :func:`padded_references` (a padded coordinate counts as ``"m"``: never wrapped)."""
    return _padded(
        [tuple(joint_kind(leg.joints[c[0]].kind).unit for c in leg.kinematics.coordinates) for leg in legs], "m"
    )


@dataclass(frozen=True)
class SerialLeg:
    """A leg as a serial chain in URDF form, solved numerically (no closed-form IK).

    joints : :class:`Joint` from the base to the platform (then any ``virtual`` joints);
        one of them actuated, or none (a passive leg: its constraints and inertia only).
        Legs of one robot may differ in their chains and numbers of coordinates.
    bodies : :class:`Body` list.
    attachment : the chain end's point in the platform frame (m).
    attachment_rotation : the chain end frame's axes in the platform frame when the chain
        does not end in a spherical joint (3x3 columns; None: the platform's axes).
    reference : the joint coordinates (rad; m for P) of the assembly branch the robot is
        on, in chain order, one per coordinate (:func:`coordinate_count`): Newton starts
        there.
    platform_body : the platform body the leg attaches to.
    stiffness : the actuated joint's own stiffness (N/m for a P joint, N m/rad for an R
        joint; :class:`~eigentwist.description.chain.ChainLeg`); None: the robot's
        ``actuator_stiffness``.
    """

    name: str
    joints: tuple
    bodies: tuple
    attachment: tuple
    reference: tuple
    attachment_rotation: Any = None
    platform_body: str = "platform"
    stiffness: Any = None

    def __post_init__(self):
        real = [k for k, j in enumerate(self.joints) if j.kind != "virtual"]
        if not real:
            raise DescriptionError(f"{self.name}: no joints: expected the chain from the base to the platform")
        if sum(j.actuated for j in self.joints) > 1:
            raise DescriptionError(
                f"{self.name}: {sum(j.actuated for j in self.joints)} actuated joints: expected one "
                "(or none: a passive leg)"
            )
        n = coordinate_count(self.joints, real[-1])
        if len(self.reference) != n:
            raise DescriptionError(
                f"{self.name}: reference has {len(self.reference)} coordinates: expected {n} "
                "(one per joint freedom, none for virtual joints and a final S joint)"
            )
        for b in self.bodies:
            if not 1 <= b.after <= len(real) or (b.after == len(real) and self.joints[real[-1]].kind == "S"):
                raise DescriptionError(
                    f"{self.name}: body {b.name!r} after joint {b.after}: expected 1..{len(real)} "
                    "(not after a final S joint: that is the platform)"
                )

    @property
    def last_real(self) -> int:
        """Index of the last joint that is not virtual (the platform joint)."""
        return max(k for k, j in enumerate(self.joints) if j.kind != "virtual")

    @property
    def ends_spherical(self) -> bool:
        """True when a spherical joint attaches the chain to the platform: the loop closes
        on the point only."""
        return self.joints[self.last_real].kind == "S"

    def chain_leg(self) -> ChainLeg:
        """The :class:`~eigentwist.description.chain.ChainLeg` the derivation reads: joints and
        bodies named after the forward kinematics' vectors, kinematics solved by Newton
        (:class:`NumericKinematics`)."""
        joints = []
        for k, j in enumerate(self.joints):
            final_s = k == self.last_real and j.kind == "S"
            axes = () if final_s else tuple(axis_name(k, m) for m in range(len(j.axes)))
            joints.append(ChainJoint(j.kind, axes, point_name(k), actuated=j.actuated, doc=j.name))
        real = [k for k, j in enumerate(self.joints) if j.kind != "virtual"]
        bodies = tuple(
            ChainBody(b.name, b.after, b.inertia, *frame_names(real[b.after - 1]), doc=b.doc) for b in self.bodies
        )
        frames = tuple(
            (f"link{n + 1}", *frame_names(k))
            for n, k in enumerate(real)
            if not (k == self.last_real and self.joints[k].kind == "S")
        )
        return NumericChainLeg(
            self.name,
            tuple(joints),
            bodies,
            None,
            platform_body=self.platform_body,
            frames=frames,
            stiffness=self.stiffness,
            numeric=NumericKinematics(self),
        )


def axis_name(k: int, m: int) -> str:
    """Geometry name of axis ``m`` of joint ``k`` (0-based) in base axes (a Pi joint's: its
    unit translation)."""
    return f"ax{k}_{m}"


def point_name(k: int) -> str:
    """Geometry name of joint ``k``'s origin (m)."""
    return f"o{k}"


def frame_names(k: int) -> tuple:
    """((x, y, z axis names), origin name) of joint ``k``'s child frame."""
    return (f"fx{k}", f"fy{k}", f"fz{k}"), f"fo{k}"


def _skew(v: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _matrix(m) -> sp.Matrix:
    return sp.eye(3) if m is None else sp.Matrix(m)


@dataclass(frozen=True)
class NumericChainLeg(ChainLeg):
    """A :class:`~eigentwist.description.chain.ChainLeg` whose kinematics is solved
    numerically (:class:`NumericKinematics`) instead of a closed-form geometry."""

    numeric: Any = None

    @property
    def kinematics(self):
        return self.numeric


class NumericKinematics:
    """The kinematics of a :class:`SerialLeg` as the derivation reads it: forward
    kinematics (the named vectors at the joint coordinates), the loop-closure residual,
    and the IK coordinates as *inputs* of the IK program (solved by the runtime's Newton
    method, :mod:`eigentwist.runtime.levenberg_marquardt`; the IK program checks the closure).

    ``coordinates``: (joint index, rate of its unit twist's coordinate per unit of q,
    freedom within the joint) of each coordinate: rate 1, a Pi joint's ``|bar|`` (m/rad).
    """

    checks = ("closure",)

    def __init__(self, leg: SerialLeg):
        self.leg = leg

    def __repr__(self) -> str:
        # the leg's data in full: a description's content hash (runtime.userfile) reads reprs
        return f"NumericKinematics({self.leg!r})"

    @property
    def reference(self) -> tuple:
        """The reference configuration (rad; m for P): where Newton starts."""
        return tuple(float(v) for v in self.leg.reference)

    def _moving(self):
        """(joint index, joint) of the joints with coordinates, in chain order."""
        return [
            (k, j)
            for k, j in enumerate(self.leg.joints)
            if j.kind != "virtual" and not (k == self.leg.last_real and j.kind == "S")
        ]

    @property
    def coordinates(self) -> tuple:
        out = []
        for k, j in self._moving():
            rate = sp.sqrt(sp.Matrix(j.bar).dot(sp.Matrix(j.bar))) if j.kind == "Pi" else sp.Integer(1)
            out += [(k, rate, m) for m in range(len(j.axes))]
        return tuple(out)

    @property
    def jacobian_rows(self) -> tuple:
        """All six unit twists' rows: the actuated joint's first, then chain order."""
        joints = self.leg.joints
        last = self.leg.last_real
        of = []
        for k, j in enumerate(joints):
            n = 3 if (k == last and j.kind == "S") else len(j.axes)
            of += [k] * n
        act = [i for i, k in enumerate(of) if joints[k].actuated]
        return tuple(act + [i for i in range(len(of)) if i not in act])

    def lever(self, screws, key):
        """The determinant of the leg's six unit twists (chain order): zero where they are
        dependent, its sign the assembly branch."""
        return screws.determinant

    def symbols(self, tag: str) -> tuple:
        """The coordinate symbols of the leg tagged ``tag``: ``q1_<tag>``, ``q2_<tag>``, ..."""
        from .parameters import sym

        return tuple(sym(f"q{m + 1}_{tag}") for m in range(len(self.coordinates)))

    def forward(self, prog, q: tuple, tag: str) -> dict:
        """Forward kinematics at coordinates ``q``, appended to ``prog``: each joint's origin
        (``o<k>``, m, base frame) and axes (``ax<k>_<m>``, base axes), each joint's child
        frame (``fx<k>, fy<k>, fz<k>``, ``fo<k>``), and the chain end (``end_R`` 3x3,
        ``end_p``)."""
        R, o = sp.eye(3), sp.zeros(3, 1)
        g: dict = {}
        coords = iter(q)
        L = lambda name, m: prog.let_matrix(f"{name}_{tag}", m)  # noqa: E731
        last = self.leg.last_real
        for k, j in enumerate(self.leg.joints):
            Rj = R * _matrix(j.rotation)
            oj = L(point_name(k), o + R * sp.Matrix(j.origin))
            g[point_name(k)] = oj
            if j.kind == "virtual":
                g[axis_name(k, 0)] = L(axis_name(k, 0), Rj * sp.Matrix(j.axes[0]))
                continue
            if k == last and j.kind == "S":
                R, o = Rj, oj  # virtual joints after it sit in its frame
                continue
            child = oj
            for m, axis in enumerate(j.axes):
                a_local = sp.Matrix(axis)
                a = L(axis_name(k, m), Rj * a_local)
                g[axis_name(k, m)] = a
                qk = next(coords)
                if joint_kind(j.kind).motion == "rotation":
                    c, s = prog.let(f"c{k}_{m}_{tag}", sp.cos(qk)), prog.let(f"s{k}_{m}_{tag}", sp.sin(qk))
                    K = _skew(a_local)
                    Rj = L(f"Rj{k}_{m}", Rj * (sp.eye(3) + s * K + (1 - c) * K * K))
                elif j.kind == "P":
                    child = oj + qk * a
                else:  # Pi: the bar turns about the axis
                    c, s = prog.let(f"c{k}_{m}_{tag}", sp.cos(qk)), prog.let(f"s{k}_{m}_{tag}", sp.sin(qk))
                    K = _skew(a_local)
                    bar = L(f"bar{k}", Rj * (sp.eye(3) + s * K + (1 - c) * K * K) * sp.Matrix(j.bar))
                    child = oj + bar
                    length = sp.sqrt(sp.Matrix(j.bar).dot(sp.Matrix(j.bar)))
                    g[axis_name(k, m)] = L(f"tpi{k}", a.cross(bar) / length)
            R, o = Rj, L(f"fo{k}", child)
            axes, origin = frame_names(k)
            for col, name in enumerate(axes):
                g[name] = R[:, col]
            g[origin] = o
        g["end_R"], g["end_p"] = R, o
        return g

    def residual(self, prog, pose, q: tuple, tag: str) -> sp.Matrix:
        """Loop closure at ``pose`` (:mod:`.pose`): the chain end's point minus the platform's
        attachment point (m), preceded, unless the chain ends in a spherical joint, by the
        orientation error ``vee(E - E^T)/2`` (rad for small errors) of ``E = R_t^T R_end``
        with ``R_t`` the attachment frame (platform rotation times ``attachment_rotation``)."""
        g = self.forward(prog, q, tag)
        target = pose.position + pose.rotation * sp.Matrix(self.leg.attachment)
        r = [g["end_p"][i] - target[i] for i in range(3)]
        if not self.leg.ends_spherical:
            E = (pose.rotation * _matrix(self.leg.attachment_rotation)).T * g["end_R"]
            r = [(E[2, 1] - E[1, 2]) / 2, (E[0, 2] - E[2, 0]) / 2, (E[1, 0] - E[0, 1]) / 2] + r
        return sp.Matrix(r)

    def inverse_kinematics(self, prog, leg, pose, tag: str):
        """Declare the leg's coordinates as inputs of the IK program ``prog`` (the runtime
        solves them by Newton) and append the closure check ``|r|^2 / CLOSURE_TOL^2``
        (within [-1, 1] iff the loop closes; NaN coordinates fail it)."""
        q = tuple(prog.declare(s) for s in self.symbols(tag))
        r = self.residual(prog, pose, q, tag)
        return q, {"closure": prog.let(f"closure_{tag}", r.dot(r) / CLOSURE_TOL**2)}

    def geometry(self, prog, leg, q: tuple, pose, tag: str) -> dict:
        """The named vectors at coordinates ``q``: base-frame points, shifted to the platform
        origin when the pose space measures points from it (``pose.origin`` zero: a
        translational platform, origin = chain end - attachment)."""
        g = self.forward(prog, q, tag)
        if all(e == 0 for e in pose.origin):
            shift = g["end_p"] - pose.rotation * sp.Matrix(self.leg.attachment)
            shift = prog.let_matrix(f"shift_{tag}", shift)
            for name, v in list(g.items()):
                if name.startswith("o") or name.startswith("fo") or name == "end_p":
                    g[name] = prog.let_matrix(f"{name}s_{tag}", v - shift)
        return g
