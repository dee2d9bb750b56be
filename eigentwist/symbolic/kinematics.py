"""The inverse-kinematics program of any robot: pose -> every leg's joint coordinates.

Each leg carries its own closed form (``Leg.kinematics``: the RR(Pi)RR legs of
:mod:`eigentwist.description.rrpirr`, the pose-driven legs of
:class:`eigentwist.description.chain.PoseKinematics`); this module only strings the legs
together. For a pose (the robot's ``pose_space.inputs``: x, y, z in m, and for a 6-DoF
robot the rotation matrix R_ij) the program gives each leg's joint coordinates ``q`` (rad,
or m for a prismatic joint) and its reachability quantities (``checks``, named by the
leg's kinematics: ``sin_q3`` and ``cos_q2`` for RR(Pi)RR legs, ``cos_u`` for the
hexapod's, reachable iff they lie in [-1, 1]); the runtime checks them and names the pose
and the leg when they fail.
"""

from __future__ import annotations

import sympy as sp

from ..errors import DescriptionError
from ..description import RobotDescription

from ..description.pose import POSE
from .program import Program, derivative

__all__ = ["POSE", "inverse_kinematics", "loop_closure", "closures", "padding_symbols", "pose_closure"]


def _numeric(leg) -> bool:
    """Whether a leg's kinematics is solved numerically (a loop-closure residual, legs in URDF form)."""
    return hasattr(leg.kinematics, "residual")


def padding_symbols(count: int, width: int, tag: str) -> tuple:
    """The padded coordinates ``q<m>_<tag>``, m = count + 1 .. width, of a leg solved
    numerically with ``count`` coordinates among legs with up to ``width``."""
    from ..description import sym

    return tuple(sym(f"q{m + 1}_{tag}") for m in range(count, width))


def inverse_kinematics(robot: RobotDescription):
    """``(ik, outputs, q_all)``: the IK program over the pose inputs and the parameters, its
    outputs ``{"q": ((legs, n_q), ...), <check>: ((legs,), ...)}`` and each leg's joint
    coordinate symbols. Legs may name different checks (legs that differ): a check a leg
    does not name is 0 there (within [-1, 1]: it says nothing). Legs solved numerically
    may have different numbers of coordinates: each is padded to the largest leg's with
    inputs the loop closure holds at zero (:func:`padding_symbols`), and so may a closed-form
    leg beside them. Raises ``DescriptionError`` when legs, all in closed form, differ in their
    numbers of coordinates."""
    ik = Program()
    pose = robot.pose_space
    for s_ in list(pose.inputs) + [p.symbol for p in robot.parameters]:
        ik.declare(s_)
    q_all, per_leg = [], []
    for i, leg in enumerate(robot.legs, start=1):
        if leg.kinematics is None:
            raise DescriptionError(
                f"{robot.name}: {leg.name} has no closed-form kinematics (Leg.kinematics): expected "
                "one, e.g. a leg built by eigentwist.description.rrpirr.rrpirr_leg"
            )
        q, c = leg.kinematics.inverse_kinematics(ik, leg, pose, str(i))
        q_all.append(tuple(q))
        per_leg.append(dict(c))
    width = max(len(q) for q in q_all)
    mixed = any(_numeric(leg) for leg in robot.legs)  # a loop closure holds padded coordinates
    for i, (leg, q) in enumerate(zip(robot.legs, q_all)):
        if len(q) == width:
            continue
        if not mixed:
            raise DescriptionError(
                f"{robot.name}: {leg.name} has {len(q)} joint coordinates in closed form; "
                f"expected {width} like the others (legs with fewer coordinates are written in URDF form, "
                "eigentwist.description.serial.SerialLeg, or beside one)"
            )
        # a leg solved numerically with fewer coordinates than the largest: padded coordinates,
        # inputs of the IK held at zero by the loop closure (:func:`loop_closure`)
        q_all[i] = q + tuple(ik.declare(s_) for s_ in padding_symbols(len(q), width, str(i + 1)))
    names = list(dict.fromkeys(name for c in per_leg for name in c))
    checks = {name: [c.get(name, sp.Integer(0)) for c in per_leg] for name in names}
    n = len(robot.legs)
    outputs = {"q": ((n, len(q_all[0])), [qq for q in q_all for qq in q])}
    outputs.update({name: ((n,), values) for name, values in checks.items()})
    return ik, outputs, q_all


class _Symbols(dict):
    """``{name: symbol}`` of any parameter name, made on demand."""

    def __missing__(self, name: str):
        from ..description import sym

        return sym(name)


def closures(robot):
    """``(program, outputs)`` of the legs' closure equations, or None when the
    robot's pose space has no followers (:class:`~eigentwist.description.pose.LowerMobilityPose`).

    Over the pose inputs (x, y, z m and the rotation matrix R_ij) and the parameters:
    ``closure`` (n_c,), every leg's ``closures`` in leg order (geometry scalars, zero where
    the platform can be; legs may name different ones, or none, one per follower in all),
    and ``closure_rate`` (n_c, 6), their exact derivatives along
    the platform's six unit twists ``[omega; v]`` at its origin (``pose_space.motion``:
    ``dr/dt_k = sum_s dr/ds . ds/dt_k``), for the runtime's Newton steps. Legs solved
    numerically name no closures: their loop closures fix the followers
    (:func:`pose_closure`), and this gives None.
    """
    pose = robot.pose_space
    if not getattr(pose, "followers", ()) or any(_numeric(leg) for leg in robot.legs):
        return None
    count = sum(len(leg.closures) for leg in robot.legs)
    if count != len(pose.followers):
        raise DescriptionError(
            f"{robot.name}: pose space {pose!r} has {len(pose.followers)} followers "
            f"({', '.join(pose.followers)}) and the legs name {count} closures "
            f"({[leg.closures for leg in robot.legs]}, ChainLeg.closures: scalars of a leg's geometry "
            "that vanish where the platform can be): expected one closure per follower"
        )
    prog = Program()
    for s_ in list(pose.inputs) + [p.symbol for p in robot.parameters]:
        prog.declare(s_)
    motion = pose.motion()
    values, rates = [], []
    for i, leg in enumerate(robot.legs, start=1):
        if not leg.closures:
            continue
        g = leg.geometry(pose.position, pose.rotation, _Symbols())
        for name in leg.closures:
            r = sp.sympify(g[name])
            values.append(prog.let(f"{name}_{i}", r))
            d = {s_: sp.diff(r, s_) for s_, _ in motion}
            rate = sum((d[s_] * row for s_, row in motion if d[s_] != 0), sp.zeros(1, 6))
            rates += [prog.let(f"d{name}_{i}_{k}", rate[0, k]) for k in range(6)]
    return prog, {"closure": ((count,), values), "closure_rate": ((count, 6), rates)}


def loop_closure(robot, q_all: list):
    """``(program, outputs)`` of the legs' loop-closure equations for a robot with legs whose
    kinematics is solved numerically (a ``leg.kinematics`` with a ``residual``), else
    ``(None, {})``.

    A leg in closed form beside them (legs that differ) closes its loop by its closed form,
    ``q - q(pose) = 0`` (rows linear in its coordinates: Newton lands there in a step or
    a few bounded ones), followed on a lower-mobility platform by its ``closures``.

    The program reads the pose inputs, the parameters and every leg's coordinates ``q_all``
    (the IK program's inputs); its outputs are ``residual`` (legs, rows): the chain end
    minus the platform attachment (m; with the orientation error first, rad, when the
    chain does not end in a spherical joint), then a leg's padded coordinates (legs that
    differ: the largest leg's number of coordinates, :func:`padding_symbols`) and zero
    rows up to the largest leg's number of equations; and ``dresidual`` (legs, rows, n_q): its
    exact Jacobian with respect to the leg's coordinates (forward mode through the
    program, :func:`~eigentwist.symbolic.program.derivative`), for the runtime's damped
    Newton method (:mod:`eigentwist.runtime.levenberg_marquardt`).
    """
    numeric = [_numeric(leg) for leg in robot.legs]
    if not any(numeric):
        return None, {}
    prog = Program()
    pose = robot.pose_space
    for s_ in list(pose.inputs) + [p.symbol for p in robot.parameters] + [qq for q in q_all for qq in q]:
        prog.declare(s_)
    res, constraints = [], 0
    followers = getattr(pose, "followers", ())
    for i, (leg, q, own) in enumerate(zip(robot.legs, q_all, numeric), start=1):
        real = len(leg.kinematics.coordinates)
        if own:
            r = leg.kinematics.residual(prog, pose, q[:real], str(i))
            constraints += r.rows - real
        else:
            # a closed-form leg beside legs solved numerically: its closed form is its loop
            # closure (linear in its coordinates), then its closures of a lower-mobility pose
            given, _ = leg.kinematics.inverse_kinematics(prog, leg, pose, f"cf{i}")
            r = sp.Matrix([q[m] - given[m] for m in range(real)])
            named = getattr(leg, "closures", ()) if followers else ()
            if named:
                g = leg.geometry(pose.position, pose.rotation, _Symbols())
                r = sp.Matrix.vstack(r, sp.Matrix([sp.sympify(g[name]) for name in named]))
                constraints += len(named)
        # legs that differ: a padded coordinate's equation holds it at zero
        res.append(prog.let_matrix(f"r_{i}", sp.Matrix.vstack(r, sp.Matrix(len(q) - real, 1, list(q[real:])))))
    if followers and constraints < len(followers):
        raise DescriptionError(
            f"{robot.name}: pose space {pose!r} has {len(followers)} followers ({', '.join(followers)}) and the "
            f"legs' loop closures fix {constraints} (each leg solved numerically: its closure rows less its "
            "coordinates; each closed-form leg: its closures): expected at least one per follower"
        )
    rows = max(r.rows for r in res)
    res = [sp.Matrix.vstack(r, sp.zeros(rows - r.rows, 1)) for r in res]  # zero rows: no equation
    jac = [sp.Matrix.hstack(*[derivative(prog, r, qq) for qq in q]) for r, q in zip(res, q_all)]
    n, nq = len(robot.legs), len(q_all[0])
    outputs = {
        "residual": ((n, rows), [e for r in res for e in r]),
        "dresidual": ((n, rows, nq), [e for J in jac for e in J]),
    }
    return prog, outputs


def pose_closure(robot, prog, outputs: dict):
    """``(program, outputs)`` of the legs' loop closures as the equations of a
    lower-mobility platform's followers (:class:`~eigentwist.description.pose.LowerMobilityPose`
    with legs solved numerically), else None (no followers).

    ``prog`` and ``outputs`` are :func:`loop_closure`'s; the outputs gain ``dresidual_pose``
    (legs, rows, 6): the residual's exact derivatives along the platform's six unit twists
    ``[omega; v]`` at its origin (``pose_space.motion``), so that the runtime solves the
    followers and every leg's coordinates together by one damped Newton method
    (:func:`eigentwist.runtime.platform.follow_legs`): rows from every leg, unknowns the
    followers and every leg's coordinates.
    """
    pose = robot.pose_space
    if not getattr(pose, "followers", ()):
        return None
    (n, rows), flat = outputs["residual"]
    motion = pose.motion()
    rates = []
    for e in flat:
        d = {s_: derivative(prog, e, s_) for s_, _ in motion}
        rate = sum((d[s_] * row for s_, row in motion if d[s_] != 0), sp.zeros(1, 6))
        rates += list(rate)
    return prog, {**outputs, "dresidual_pose": ((n, rows, 6), rates)}
