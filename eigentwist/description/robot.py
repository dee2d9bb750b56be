"""A parallel manipulator described as data: legs as joint chains, bodies, compliances.

A description holds no derivation logic (a leg carries only its closed-form kinematics,
:mod:`.rrpirr`). The derivation (``eigentwist.symbolic``) reads
it; a second robot with the same joint types needs a new description only.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..errors import DescriptionError
from .parameters import Parameter
from .pose import TranslationPose

__all__ = ["resolve_effects", "Leg", "EECompliance", "Coupling", "RobotDescription"]


@dataclass(frozen=True)
class Leg:
    """One leg of a translational robot, as a joint list with its bodies.

    Vectors are 3-tuples of SymPy expressions in design-parameter symbols (m, unitless
    for directions); all are in base-frame axes.

    base : actuated joint centre B_i in the base frame (m).
    radial : outward unit vector u_i in the base plane.
    axis : actuator axis s_i, with ``radial x axis = e_z``.
    attachment : a_i, from the end-effector origin to the leg's connection point (m).
    joints : the joints from the base to the platform
        (:class:`~eigentwist.description.chain.ChainJoint`: kind, axes and location as
        names of the leg's geometry, actuated or not), then one ``virtual`` joint (the
        twist of restriction) per constraint of a leg with fewer than six freedoms.
    bodies : the leg's rigid bodies (:class:`~eigentwist.description.chain.ChainBody`:
        6x6 spatial inertia in the body frame, moved by the first ``after`` joints).
    frames : ``(name, (x, y, z axes), origin)`` of the frames that the leg's bodies and
        effects use (geometry names), e.g. ``J1``, ``C3``, ``L2``, ``E1``.
    kinematics : the leg's closed form: ``inverse_kinematics(prog, leg, pose, tag)`` ->
        (joint coordinates, reachability checks), ``geometry(prog, leg, q, tag)`` -> the
        named vectors, ``coordinates`` (joint index, rate of its coordinate per unit of
        q) and ``checks`` (names); see :mod:`.rrpirr`.
    platform_body : the platform body the leg attaches to.
    """

    name: str
    base: tuple
    radial: tuple
    axis: tuple
    attachment: tuple
    joints: tuple = ()
    bodies: tuple = ()
    frames: tuple = ()
    kinematics: Any = None
    platform_body: str = "platform"

    def vector(self, which: str) -> sp.Matrix:
        return sp.Matrix(getattr(self, which))


@dataclass(frozen=True)
class EECompliance:
    """End-effector assembly compliance split over the legs (App. D, Eqs. 45-49).

    ``per_leg`` maps a 0-based leg index to a 6x6 compliance in a frame at ``origin`` (m
    from the EE origin, axes parallel to the EE frame), in rad/(N m), m/N, in the
    ``ee_compliance`` effect's stiffness symbols (the derivation multiplies it by the
    effect's switch). Which leg carries which share is the robot's geometry.
    """

    origin: tuple
    per_leg: dict


@dataclass(frozen=True)
class Coupling:
    """A compliant coupling between the tool body (which carries the EE frame) and
    another rigid body of the platform, to which some legs attach.

    ``twists`` are the m unit twists ``[omega; v]`` of the compliant directions in a
    local frame at ``origin`` (m from the EE origin) with axes ``rotation`` (columns, in
    EE axes; identity by default); ``stiffness`` are the m stiffnesses (N m/rad for
    rotations, N/m for translations) as parameter expressions. The coupling is rigid
    in every other direction. ``effect`` names the effect that switches it on.
    """

    body: str
    origin: tuple
    twists: tuple
    stiffness: tuple
    rotation: tuple = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
    effect: str = "ee_coupling"
    doc: str = ""


def resolve_effects(description) -> None:
    """Normalise a frozen description's ``effects`` (catalogue names or :class:`Effect`
    objects) into names, keep the robot's own effects in ``custom_effects``, and append
    their parameters to ``parameters`` (each once). Shared by :class:`RobotDescription`
    and the joint-list descriptions (:mod:`.chain`)."""
    from .effects import EFFECTS, Effect

    custom = {e.name: e for e in description.custom_effects}
    names = []
    for e in description.effects:
        if isinstance(e, Effect):
            if e.name in EFFECTS and EFFECTS[e.name] is not e:
                raise DescriptionError(
                    f"{description.name}: effect {e.name!r} is already in the catalogue; name yours differently"
                )
            custom[e.name] = e
            names.append(e.name)
        elif e in EFFECTS or e in custom:
            names.append(e)
        else:
            raise DescriptionError(f"{description.name}: unknown effect {e!r}: expected a catalogue name or an Effect")
    have, extra = {p.name for p in description.parameters}, []
    for p in (p for e in custom.values() for p in e.params):
        if p.name not in have:
            have.add(p.name)
            extra.append(p)
    object.__setattr__(description, "effects", tuple(dict.fromkeys(names)))
    object.__setattr__(description, "custom_effects", tuple(custom.values()))
    object.__setattr__(description, "parameters", tuple(description.parameters) + tuple(extra))


@dataclass(frozen=True)
class RobotDescription:
    """Everything the derivation needs to know about one manipulator.

    Link and body data are expressions in the parameter symbols so that every design
    quantity stays symbolic:

    * ``legs``: each a joint list with its bodies and closed-form kinematics
      (:class:`Leg`; :func:`~eigentwist.description.rrpirr.rrpirr_leg` for RR(Pi)RR
      legs): the derivation reads the legs only;
    * ``l1``, ``l2``: lower link and parallelogram lengths (m), for the effects (rod
      and lower-link compliance) and the plots;
    * ``lower_link_inertia``: 6x6 spatial inertia of body 1 (link + rotor) in frame
      J_i1 (origin at the actuated joint, x = r_i1, y = s_i1), Eqs. 21-23, as the legs'
      body ``J1`` carries it;
    * ``rod``: dict of ``r_i``, ``r_o`` (m), ``rho`` (kg/m^3), ``w_pi`` (m) for the
      parallelogram tubes (Eqs. 27-29, App. C), for the rod-compliance effect;
    * ``ee_inertia``: 6x6 spatial inertia of the end-effector at its origin (Eq. 31);
    * ``ee_compliance``: :class:`EECompliance` or None (the paper's split, Eqs. 45-49);
    * ``actuator_stiffness``: commanded actuator stiffness k_a (N m/rad, Eq. 34);
    * ``rigid_compliance``: compliance given to the ideally rigid constrained direction
      of each leg so that K_F stays finite (rad/(N m), Eq. 42);
    * ``effects``: the effects this robot offers, by catalogue name
      (:data:`~eigentwist.description.effects.EFFECTS`) or as :class:`Effect` objects
      of the user's own (their parameters are added to ``parameters`` when missing);
    * ``couplings``: :class:`Coupling` of each platform body other than the tool body
      (``tool_body``); legs name the body they attach to (``Leg.platform_body``);
    * ``x_ref``: reference pose (m); ``pose``: its coordinates' names; ``pose_space``:
      how the pose enters the derivation (:class:`~.pose.TranslationPose`);
    * ``constraints``: conditions on several parameters together
      (:mod:`.constraints`: tube radii, inertia triangle inequalities).
    """

    name: str
    title: str
    parameters: tuple[Parameter, ...]
    legs: tuple[Leg, ...]
    l1: sp.Expr
    l2: sp.Expr
    lower_link_inertia: sp.Matrix
    rod: dict
    ee_inertia: sp.Matrix
    ee_compliance: EECompliance | None
    x_ref: tuple[float, float, float]
    actuator_stiffness: sp.Expr
    rigid_compliance: sp.Expr
    workspace: tuple = ((-0.1, 0.1), (-0.1, 0.1), (-0.70, -0.55))
    couplings: tuple = ()
    tool_body: str = "platform"
    source: str = ""
    effects: tuple = field(default=())
    custom_effects: tuple = field(default=())

    def __post_init__(self):
        resolve_effects(self)

    def effect(self, name: str):
        """The :class:`Effect` called ``name`` (the robot's own first, then the catalogue)."""
        for e in self.custom_effects:
            if e.name == name:
                return e
        return _catalogue()[name]

    constraints: tuple = ()
    #: names of the pose coordinates: ``x, y, z`` (m) for a 3-DoF translational robot
    pose: tuple = ("x", "y", "z")
    #: how the pose enters the derivation (:mod:`.pose`): a translational platform
    pose_space: Any = field(default_factory=TranslationPose)
    #: the robot's own presets (name -> effects) in place of the catalogue's of that name
    presets: dict = field(default_factory=dict)

    @property
    def platform_inertia(self) -> sp.Matrix:
        """The platform's spatial inertia at its origin (the EE's, Eq. 31)."""
        return self.ee_inertia

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


@functools.cache
def _catalogue() -> dict:
    """The effect catalogue (:data:`.effects.EFFECTS`, the same dict), imported on first use
    (that module imports this one)."""
    from .effects import EFFECTS

    return EFFECTS
