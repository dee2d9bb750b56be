"""A leg's joints and bodies read from a URDF file of its serial chain (as CAD exporters write them).

:func:`urdf_leg` parses the file with Pinocchio's URDF parser (``pin.buildModelFromUrdf`` or
``buildModelFromXML``; the ``pin`` package, imported on first use) and returns the
:class:`~eigentwist.description.serial.SerialLeg` it stands for: each revolute (or
continuous) and prismatic joint, in chain order, with its placement in its parent's frame
and its axis; each link's mass, centre of mass and inertia on the joint that carries it
(fixed joints merged into their parent link by the parser). What a URDF file cannot say
comes from the description file: where the chain sits in the base frame (``base_origin``,
``base_rotation``: one file serves every leg), which joint is actuated, how the chain meets
the platform (a spherical joint at the ``end`` link's origin, ``platform_joint="S"``, or a
rigid attachment, ``None``), the attachment point (and frame) in the platform frame, the
virtual joints of a leg with fewer than six freedoms, and the reference configuration.
URDF has no universal or spherical joint: a U joint is two revolute joints whose axes
meet (zero offset between them), which is the same chain.
"""

from __future__ import annotations

from pathlib import Path

import sympy as sp

from ..errors import DescriptionError
from .screw import spatial_inertia
from .serial import Body, Joint, SerialLeg

__all__ = ["urdf_leg"]

_AXIS = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}


def _model(urdf):
    try:
        import pinocchio as pin
    except ImportError as exc:  # pragma: no cover - the test extra installs it
        raise ImportError(f'URDF legs need Pinocchio\'s URDF parser: pip install "pin>=3.0" ({exc})') from None
    text = str(urdf)
    if text.lstrip().startswith("<"):
        return pin.buildModelFromXML(text)
    if not Path(text).is_file():
        raise FileNotFoundError(f"URDF file {text!r} not found: expected a path or the XML text")
    return pin.buildModelFromUrdf(text)


def _kind_axis(joint, name: str) -> tuple[str, tuple]:
    """eigentwist's kind and the unit axis (joint frame) of a Pinocchio joint model."""
    short = joint.shortname()
    for prefix, kind in (("JointModelRUB", "R"), ("JointModelR", "R"), ("JointModelP", "P")):
        rest = short[len(prefix) :]
        if short.startswith(prefix) and rest in _AXIS:
            return kind, _AXIS[rest]
    if short in ("JointModelRevoluteUnaligned", "JointModelRevoluteUnboundedUnaligned", "JointModelPrismaticUnaligned"):
        axis = getattr(joint.extract(), "axis", None)
        if axis is None:  # the unbounded one has no axis in Pinocchio's bindings: its motion subspace [v; omega]
            axis = list(joint.createData().S.reshape(-1))[3:]
        axis = tuple(float(a) for a in axis)
        return ("P" if "Prismatic" in short else "R"), axis
    raise DescriptionError(
        f"URDF joint {name!r} is {short}: expected revolute, continuous or prismatic joints "
        "(fixed ones are merged; a U joint is two revolute joints, a spherical one is given by "
        "platform_joint)"
    )


def _link_name(model, joint: int) -> str:
    """The URDF name of the link joint ``joint`` carries (its child link; links on fixed
    joints after it are merged into it by the parser)."""
    import pinocchio as pin

    return next(
        (f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == joint),
        f"{model.names[joint]} link",
    )


def _numbers(m) -> sp.Matrix:
    return sp.Matrix(m.tolist()).applyfunc(lambda v: sp.Float(float(v), 17))


def urdf_leg(
    urdf,
    name: str,
    *,
    actuated: str | None,
    attachment,
    reference,
    end: str | None = None,
    platform_joint: str | None = "S",
    virtual: tuple = (),
    base_origin=(0, 0, 0),
    base_rotation=None,
    attachment_rotation=None,
    platform_body: str = "platform",
    stiffness=None,
) -> SerialLeg:
    """A :class:`~eigentwist.description.serial.SerialLeg` from the URDF of its serial chain.

    urdf : a path to a ``.urdf`` file, or its XML text; one chain from the root link (the
        leg's base mounting) to its last link (every joint's parent the joint before it).
    name : the leg's name; actuated : the URDF name of its actuated joint (revolute or
        prismatic), None for a passive leg.
    attachment, attachment_rotation : the chain end in the platform frame (m; 3x3 columns):
        the spherical joint's centre, or with ``platform_joint=None`` the ``end`` link's
        frame, rigidly on the platform.
    reference : the joint coordinates (rad; m for prismatic) of the assembly branch at the
        robot's ``x_ref``, one per URDF joint in chain order.
    end : the URDF link at the chain's end (a link after the last moving joint, e.g. a
        ``tip`` on a fixed joint); None: the last joint's own frame.
    platform_joint : ``"S"``: a spherical joint at ``end``'s origin meets the platform (the
        loop closes on the point); None: the chain ends rigidly on the platform.
    virtual : :class:`~eigentwist.description.serial.Joint` of kind ``"virtual"`` after the
        chain (the twists of restriction of a leg with fewer than six freedoms), in the
        frame of the last joint.
    base_origin, base_rotation : the URDF root link's origin (m) and axes (3x3 columns) in
        the robot's base frame (parameter expressions allowed).
    stiffness : the actuated joint's own stiffness (N/m or N m/rad; None: the robot's
        ``actuator_stiffness``), as :class:`~eigentwist.description.serial.SerialLeg`'s.
    """
    model = _model(urdf)
    if model.njoints < 2:
        raise DescriptionError(f"{name}: the URDF has no moving joint: expected the leg's chain")
    names = list(model.names)
    if actuated is not None and actuated not in names:
        raise DescriptionError(
            f"{name}: actuated joint {actuated!r} is not in the URDF (its joints: {', '.join(names[1:])})"
        )
    R0 = sp.eye(3) if base_rotation is None else sp.Matrix(base_rotation)
    p0 = sp.Matrix(base_origin)
    joints, bodies = [], []
    for i in range(1, model.njoints):
        if model.parents[i] != i - 1:
            raise DescriptionError(
                f"{name}: URDF joint {names[i]!r} hangs on {names[model.parents[i]]!r}, not on the "
                "joint before it: expected one serial chain"
            )
        kind, axis = _kind_axis(model.joints[i], names[i])
        placement = model.jointPlacements[i]
        R, p = _numbers(placement.rotation), _numbers(placement.translation)
        if i == 1:
            R, p = R0 * R, p0 + R0 * p
        joints.append(
            Joint(kind, origin=tuple(p), axes=(axis,), rotation=R, actuated=names[i] == actuated, name=names[i])
        )
        inertia = model.inertias[i]
        if inertia.mass > 0:
            c = _numbers(inertia.lever)
            I_origin = _numbers(inertia.inertia) + inertia.mass * (c.dot(c) * sp.eye(3) - c * c.T)
            bodies.append(Body(_link_name(model, i), i, spatial_inertia(sp.Float(inertia.mass, 17), c, I_origin)))
    tip_R, tip_p = sp.eye(3), sp.zeros(3, 1)
    if end is not None:
        frame = next((f for f in model.frames if f.name == end), None)
        if frame is None or frame.parentJoint != model.njoints - 1:
            raise DescriptionError(
                f"{name}: end link {end!r} is not on the chain's last joint "
                f"{names[model.njoints - 1]!r}: expected a link after it"
            )
        tip_R, tip_p = _numbers(frame.placement.rotation), _numbers(frame.placement.translation)
    if platform_joint == "S":
        joints.append(Joint("S", origin=tuple(tip_p), rotation=tip_R, name=f"{end or names[-1]} spherical joint"))
    elif platform_joint is None:
        # the chain's end is the last joint's frame: the attachment of the end link moved onto it
        Ra = sp.eye(3) if attachment_rotation is None else sp.Matrix(attachment_rotation)
        attachment = tuple(sp.Matrix(attachment) - Ra * tip_R.T * tip_p)
        attachment_rotation = Ra * tip_R.T
    else:
        raise DescriptionError(f"{name}: platform_joint {platform_joint!r}: expected 'S' or None (rigid)")
    return SerialLeg(
        name,
        tuple(joints) + tuple(virtual),
        tuple(bodies),
        tuple(attachment),
        tuple(reference),
        attachment_rotation=attachment_rotation,
        platform_body=platform_body,
        stiffness=stiffness,
    )
