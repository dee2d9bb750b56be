"""Legs as data: any serial chain of R, P, U, S and Pi joints with its bodies.

The legs of one robot may differ: each has its own joints, bodies, closed form, checks and
closures, its own actuator (R or P, its own ``stiffness``) or none (a passive leg: a
constraint only). The joint kinds are records (:mod:`.joints`).

A :class:`ChainLeg` lists its joints from the base to the platform and the bodies they
carry. Axes and locations are *names* of vectors that the leg's closed-form geometry
(:attr:`ChainLeg.geometry`) returns at the current pose, or explicit 3-tuples of
parameter expressions; every location is a point in base-frame coordinates. The
derivation (:func:`eigentwist.symbolic.derive`, :mod:`eigentwist.symbolic.leg`) turns the list into unit twists,
reciprocal wrenches and inverse-Jacobian rows by Huang's method without knowing which
chain it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import sympy as sp

from ..errors import DescriptionError
from .joints import JOINT_FREEDOMS, joint_kind
from .parameters import Parameter, sym
from .pose import RigidPose
from .robot import resolve_effects

__all__ = ["JOINT_FREEDOMS", "ChainJoint", "ChainBody", "PoseKinematics", "ChainLeg", "ChainRobot"]


@dataclass(frozen=True)
class ChainJoint:
    """One joint of a leg.

    kind : ``"R"`` revolute, ``"P"`` prismatic, ``"Pi"`` parallelogram (a curvilinear
        translation), ``"U"`` universal (two revolute axes through one point), ``"S"``
        spherical (three revolute axes through one point).
    axes : one axis for R, P and Pi, two for U, three for S (none: the base axes);
        each a geometry name or a 3-tuple of expressions (unit vectors, base axes).
    location : a point on the axes (geometry name or 3-tuple, m, base frame); unused
        for P, and for a Pi joint without ``swing``.
    actuated : True for the actuated joint (R or P); its coordinate's unit follows.
    swing : Pi only, optional ``(axis, length)``: the rods' pivot axis (unit, geometry
        name or 3-tuple) and their length (m, geometry name or expression). A Pi joint is
        R(q)·R(-q) about two parallel axes ``length`` apart: its coordinate is ``length * q``
        (m) and its moving parts (the rods) swing by q about ``axis``; ``location`` is then
        the near pivot of the rods' centre line. Bodies hang on the rods with
        :attr:`ChainBody.pivot`.
    """

    kind: str
    axes: tuple = ()
    location: Any = None
    actuated: bool = False
    doc: str = ""
    swing: tuple = ()

    def __post_init__(self):
        kind = joint_kind(self.kind)  # the record of its kind (:mod:`.joints`)
        if self.actuated and not kind.actuatable:
            raise DescriptionError(f"an actuated joint is revolute or prismatic, not {self.kind!r}")
        n = kind.freedoms
        if self.axes and len(self.axes) != n:
            raise DescriptionError(f"joint {self.kind!r} has {n} axes, got {len(self.axes)}")
        if self.swing and (self.kind != "Pi" or len(self.swing) != 2):
            raise DescriptionError(
                f"joint {self.kind!r}: swing is (axis, length) of a Pi joint's rods, got {self.swing!r}"
            )

    @property
    def freedoms(self) -> int:
        return joint_kind(self.kind).freedoms

    @property
    def virtual(self) -> bool:
        """True for a twist of restriction (a constraint of the leg, not a freedom)."""
        return joint_kind(self.kind).restriction


@dataclass(frozen=True)
class ChainBody:
    """A rigid body of a leg, moved by the first ``after`` joints of the chain.

    inertia : 6x6 spatial inertia (kg, kg m, kg m^2) in the body frame, twists ``[omega; v]``.
    rotation : the body frame's axes (three geometry names or 3-tuples: the columns).
    origin : the body frame's origin (geometry name or 3-tuple, m, base frame).
    pivot : for a body on the moving part of a Pi joint (a rod that swings with its
        angle), the point (geometry name or 3-tuple, m) its swing axis passes through;
        ``after`` then counts the Pi joint, which moves the body by a rotation about its
        ``swing`` axis through ``pivot`` instead of its translation.
    """

    name: str
    after: int
    inertia: sp.Matrix
    rotation: tuple
    origin: Any
    doc: str = ""
    pivot: Any = None


class _ParameterSymbols(dict):
    """``{name: symbol}`` of any parameter name, made on demand (``sym(name)``)."""

    def __missing__(self, name: str):
        return sym(name)


@dataclass(frozen=True)
class PoseKinematics:
    """Closed form of a leg whose geometry follows from the platform pose, with one IK
    coordinate: the actuated joint's (e.g. a UPS strut's length, m).

    ``leg`` is the :class:`ChainLeg` whose ``geometry(position, rotation, p, q=None)``
    gives the named vectors; ``coordinate`` names the geometry entry that is the actuated
    joint's coordinate (``"length"``); ``symbol`` prefixes its IK output (``l_1``, ...).
    """

    leg: "ChainLeg"
    coordinate: str = "length"
    symbol: str = "l"

    @property
    def checks(self) -> tuple:
        return self.leg.checks

    @property
    def coordinates(self) -> tuple:
        """(index of the joint, rate 1) of the IK's one coordinate per leg: the actuated
        joint's, or a passive leg's first one-freedom joint (R or P)."""
        joints = self.leg.joints
        k = next((j for j, joint in enumerate(joints) if joint.actuated), None)
        if k is None:
            k = next(j for j, joint in enumerate(joints) if joint_kind(joint.kind).actuatable)
        return ((k, sp.Integer(1)),)

    @property
    def jacobian_rows(self) -> tuple:
        """Indices of the unit twists whose inverse-Jacobian rows ``J_rows`` reports: the
        actuated joint's first, then every other in chain order."""
        of = [j for j, joint in enumerate(self.leg.joints) for _ in range(joint.freedoms)]
        act = [k for k, j in enumerate(of) if self.leg.joints[j].actuated]
        return tuple(act + [k for k in range(len(of)) if k not in act])

    def inverse_kinematics(self, prog, leg, pose, tag: str):
        """Append the leg's coordinate (``l_<tag>``) and its checks at ``pose`` (a pose
        space, :mod:`.pose`) to ``prog``; returns ``((coordinate,), {check: value})``."""
        g = self.leg.geometry(pose.position, pose.rotation, _ParameterSymbols())
        q = prog.let(f"{self.symbol}_{tag}", g[self.coordinate])
        return (q,), {name: prog.let(f"{name}_{tag}", g[name]) for name in self.checks}

    def geometry(self, prog, leg, q: tuple, pose, tag: str) -> dict:
        """The leg's named vectors at ``pose`` with its coordinate ``q`` (from the IK),
        each appended to ``prog`` as ``<name>_<tag>``."""
        g = self.leg.geometry(pose.position, pose.rotation, _ParameterSymbols(), q[0])
        return {
            k: (prog.let_matrix(f"{k}_{tag}", v) if isinstance(v, sp.MatrixBase) else prog.let(f"{k}_{tag}", v))
            for k, v in g.items()
        }

    def lever(self, screws, key):
        """The actuation lever the runtime's singularity check reads: the determinant of
        the leg's six unit twists (chain order), zero where they are dependent."""
        return screws.determinant


@dataclass(frozen=True)
class ChainLeg:
    """One leg: its joints from base to platform, its bodies, and its closed-form geometry.

    geometry : ``geometry(position, rotation, p, q=None) -> dict`` of named SymPy vectors
        and scalars at the pose (``position`` 3x1 m, ``rotation`` 3x3 platform axes,
        ``p`` parameter symbols by name). It must hold ``"length"`` for a prismatic
        actuator (its joint coordinate, m) and every name the joints and bodies use;
        given ``q`` (a symbol: the actuated coordinate, computed by the inverse
        kinematics), the geometry uses it instead of recomputing the coordinate.
    stiffness : the actuated joint's own stiffness (an expression: N/m for a P joint, N m/rad
        for an R joint); None: the robot's ``actuator_stiffness``. A leg without an
        actuated joint is passive: a constraint only (e.g. a Tricept's central leg), its
        IK coordinate its first R or P joint's (``coordinate`` names it in the geometry).
    checks : names of geometry scalars that must lie within [-1, 1] for the pose to be
        reachable (e.g. the cosine between a strut and a U joint's fixed axis; NaN counts
        as unreachable: a zero leg length gives NaN directions).
    closures : names of geometry scalars (m) that vanish where the platform can be: the
        leg's constraint on the pose, which a lower-mobility pose space
        (:class:`~.pose.LowerMobilityPose`) solves for its followers (e.g. a 3-PRS leg's
        spherical joint stays in the plane of its revolute joint: its distance from it).
    """

    name: str
    joints: tuple
    bodies: tuple
    geometry: Callable
    platform_body: str = "platform"
    checks: tuple = ()
    frames: tuple = ()
    closures: tuple = ()
    #: the geometry entry that is the actuated joint's coordinate (m or rad)
    coordinate: str = "length"
    #: the actuated joint's own stiffness (None: the robot's actuator_stiffness)
    stiffness: Any = None

    def __post_init__(self):
        n = sum(1 for j in self.joints if j.actuated)
        if n > 1:
            raise DescriptionError(f"{self.name}: {n} actuated joints: expected one, or none for a passive leg")
        if self.stiffness is not None and n == 0:
            raise DescriptionError(f"{self.name}: a stiffness on a passive leg (no actuated joint): expected none")

    @property
    def kinematics(self) -> PoseKinematics:
        """The leg's closed form as the derivation reads it (:class:`PoseKinematics`)."""
        return PoseKinematics(self, self.coordinate)

    @property
    def freedoms(self) -> int:
        """The leg's degrees of freedom (virtual joints excluded)."""
        return sum(j.freedoms for j in self.joints if not j.virtual)

    @property
    def actuated(self) -> ChainJoint | None:
        """The actuated joint, None for a passive leg."""
        return next((j for j in self.joints if j.actuated), None)


@dataclass(frozen=True)
class ChainRobot:
    """A parallel manipulator whose legs are :class:`ChainLeg` joint lists.

    pose : names of the pose coordinates (``x, y, z`` m; ``rot_x, rot_y, rot_z`` rad,
        the rotation vector of the platform frame).
    platform_inertia : 6x6 spatial inertia of the platform at its origin, platform axes.
    actuator_stiffness : k_a as an expression; its unit is the actuated joint's
        (N/m for prismatic, N m/rad for revolute actuators); a leg with its own
        ``stiffness`` (legs that differ: R and P actuators) uses that instead.
    effects : catalogue names or :class:`~eigentwist.description.effects.Effect` objects.
    pose_space : how the pose enters the derivation (:mod:`.pose`: ``RigidPose()``, the
        default; ``TranslationPose()``, ``PlanarPose()``, ``LowerMobilityPose(commanded)``);
        ``pose`` names its coordinates.

    It offers the derivation (:func:`eigentwist.symbolic.derive`) the interface a
    :class:`~eigentwist.description.RobotDescription` does: legs with joint lists and
    ``kinematics``, ``platform_inertia``, ``actuator_stiffness``, ``couplings`` (none),
    ``tool_body``, ``rigid_compliance`` (unused: its legs have six freedoms).
    """

    name: str
    title: str
    parameters: tuple[Parameter, ...]
    legs: tuple[ChainLeg, ...]  # or SerialLeg (URDF form, numeric IK: :mod:`.serial`)
    platform_inertia: sp.Matrix
    actuator_stiffness: sp.Expr
    x_ref: tuple
    pose: tuple = ("x", "y", "z", "rot_x", "rot_y", "rot_z")
    workspace: tuple = ()
    source: str = ""
    effects: tuple = field(default=())
    custom_effects: tuple = field(default=())
    constraints: tuple = ()
    #: how the pose enters the derivation (:mod:`.pose`): a platform free in 6 DoF
    pose_space: Any = field(default_factory=RigidPose)
    #: compliant couplings between platform bodies (none: every leg on the tool body)
    couplings: tuple = ()
    tool_body: str = "platform"
    #: compliance of each virtual joint (Eq. 42); unused by legs with six freedoms
    rigid_compliance: Any = sp.Integer(0)
    #: the robot's own presets (name -> effects), in place of the catalogue's of that name
    #: (:func:`~eigentwist.description.effects.presets_of`): values measured on one robot
    #: (the Heli4's eta_a) are not another's default
    presets: dict = field(default_factory=dict)

    def __post_init__(self):
        coordinates = tuple(getattr(self.pose_space, "coordinates", self.pose))
        if tuple(self.pose) != coordinates:
            raise DescriptionError(
                f"{self.name}: pose {tuple(self.pose)!r} differs from its pose space's coordinates "
                f"{coordinates!r}: expected the same names"
            )
        # a leg in URDF form (:class:`~.serial.SerialLeg`) becomes the joint list it stands for
        object.__setattr__(
            self, "legs", tuple(leg.chain_leg() if hasattr(leg, "chain_leg") else leg for leg in self.legs)
        )
        resolve_effects(self)
        structural = [e for e in self.effects if self.effect(e).structural]
        if getattr(self.pose_space, "point", False) and structural:
            raise DescriptionError(
                f"{self.name}: effect(s) {', '.join(structural)} on a point platform "
                f"({self.pose_space!r}): expected effects without structural compliance (a point's "
                "rotations carry neither inertia nor stiffness: only its rigid model is defined)"
            )

    @property
    def pose_units(self) -> tuple:
        """Unit of each pose coordinate: ``m`` for positions, ``rad`` for rotations."""
        return tuple("rad" if c.startswith("rot") else "m" for c in self.pose)

    def effect(self, name: str):
        from .effects import EFFECTS

        for e in self.custom_effects:
            if e.name == name:
                return e
        return EFFECTS[name]

    def parameter(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def defaults(self) -> dict[str, float]:
        return {p.name: p.default for p in self.parameters}
