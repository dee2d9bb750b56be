"""Joint kinds as data: one record per kind, read by every layer.

A :class:`JointKind` says how many freedoms a joint of that kind has, whether each is a
rotation about an axis through the joint's location or a translation along an axis (its
unit twists ``[omega; v]``), its default axes, whether it may be actuated and the units
of its coordinate and of an actuator's stiffness. The descriptions
(:class:`~eigentwist.description.chain.ChainJoint`, :class:`~eigentwist.description.serial.Joint`)
check their joints against it, the derivation (:mod:`eigentwist.symbolic.leg`) builds the
unit twists from ``motion``, the runtime names coordinate units from ``unit``. Adding a
kind adds a record here (and, for a kind with its own kinematics like the parallelogram's
bar, its forward kinematics in :mod:`~eigentwist.description.serial`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import DescriptionError

__all__ = ["JointKind", "JOINT_KINDS", "JOINT_FREEDOMS", "joint_kind"]

BASE_AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


@dataclass(frozen=True)
class JointKind:
    """One kind of joint.

    name : its name in descriptions (``"R"``, ``"P"``, ...).
    freedoms : number of unit twists it contributes (coordinates; axes given per freedom).
    motion : ``"rotation"`` (each twist a rotation about an axis through the location) or
        ``"translation"`` (a translation along the axis, no location needed).
    default_axes : the axes when a description gives none (a spherical joint's x, y, z).
    actuatable : whether an actuator may drive it (one freedom, revolute or prismatic).
    unit : unit of its coordinate (``"rad"`` or ``"m"``).
    stiffness_unit : unit of an actuator's stiffness on it (N m/rad, N/m), or "".
    restriction : True for the twist of restriction of a leg with fewer than six
        freedoms (Huang's method): a constraint of the leg, not a freedom.
    doc : what it is.
    """

    name: str
    freedoms: int
    motion: str
    default_axes: tuple = ()
    actuatable: bool = False
    unit: str = "rad"
    stiffness_unit: str = ""
    restriction: bool = False
    doc: str = ""


#: every joint kind, by name
JOINT_KINDS = {
    k.name: k
    for k in (
        JointKind("R", 1, "rotation", actuatable=True, stiffness_unit="N m/rad", doc="revolute joint"),
        JointKind("P", 1, "translation", actuatable=True, unit="m", stiffness_unit="N/m", doc="prismatic joint"),
        JointKind(
            "Pi", 1, "translation", doc="parallelogram: R(q) R(-q) about two parallel axes, a curvilinear translation"
        ),
        JointKind("U", 2, "rotation", doc="universal joint: two revolute axes through one point"),
        JointKind(
            "S", 3, "rotation", default_axes=BASE_AXES, doc="spherical joint: three revolute axes through one point"
        ),
        JointKind(
            "virtual",
            1,
            "rotation",
            restriction=True,
            doc="twist of restriction of a leg with fewer than six freedoms: a rotation about its axis "
            "through its location, a constraint of the leg",
        ),
    )
}
#: number of unit twists each joint kind contributes
JOINT_FREEDOMS = {name: k.freedoms for name, k in JOINT_KINDS.items()}


def joint_kind(name: str) -> JointKind:
    """The record of joint kind ``name``; ``ValueError`` naming the kinds for another name."""
    try:
        return JOINT_KINDS[name]
    except (KeyError, TypeError):
        raise DescriptionError(f"joint kind {name!r}: expected one of {', '.join(JOINT_KINDS)}") from None
