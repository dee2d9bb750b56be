"""Unit twists, reciprocal wrenches and inverse-Jacobian rows of any joint chain (issue 15).

A leg (:class:`~eigentwist.description.chain.ChainLeg`) is a list of R, P, Pi, U and S
joints. Each joint contributes its unit twists ``[omega; v]`` at the platform origin in
base axes (U two, S three). Huang's method (paper Eqs. 15-20) gives the row of joint k
of the leg's inverse Jacobian as ``w_k^T / (w_k . t_k)``, where the wrench ``w_k`` is
reciprocal to every other unit twist of the leg: for six unit twists it is their
generalised cross product (the signed 5x5 minors), built here from named intermediates
without a branch on the chain. A leg with six freedoms has no constraint wrench; a leg
with fewer lists a ``"virtual"`` joint per constraint, the twist of restriction, whose
row is the constraint wrench normalised the same way.

``derive_chain(robot)`` returns the programs and outputs for a
:class:`~eigentwist.description.chain.ChainRobot`: M (Eq. 12) from every body of every
leg and the platform, K_R (Eq. 14) as ``sum_i j_a,i^T k_act,i j_a,i`` with the joint-series
effects in series with k_a, the actuation rows and levers, and the actuated joint
coordinates (leg lengths for a prismatic actuator).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from ..description import sym
from ..description.chain import ChainLeg, ChainRobot
from .program import Program, derivative
if TYPE_CHECKING:
    from .model import DerivedModel
from .screw import (inertia_to_frame, pure_translation, reciprocal_product, skew, stiffness_to_frame,
                     unit_twist)

__all__ = ["POSE6", "ROTATION", "ChainScrews", "joint_twists", "reciprocal_wrench", "chain_screws",
           "body_twist_map", "pose_inputs", "derive_chain"]

#: position inputs (m) of a 6-DoF pose; the rotation enters as the 3x3 matrix ROTATION
#: (the runtime turns the rotation vector into it by Rodrigues' formula)
POSE6 = (sym("x"), sym("y"), sym("z"))
ROTATION = sp.Matrix(3, 3, lambda i, j: sym(f"R_{i}{j}"))
BASE_AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def _vector(geometry: dict, item) -> sp.Matrix:
    return sp.Matrix(geometry[item]) if isinstance(item, str) else sp.Matrix(item)


def joint_twists(joint, geometry: dict, origin: sp.Matrix) -> list[sp.Matrix]:
    """The unit twists of one joint at the platform origin ``origin`` (m, base frame)."""
    axes = joint.axes or BASE_AXES
    if joint.kind in ("P", "Pi"):
        return [pure_translation(_vector(geometry, axes[0]))]
    point = _vector(geometry, joint.location) - origin
    return [unit_twist(_vector(geometry, a), point) for a in axes]


def _minor(prog: Program, T: sp.Matrix, rows: tuple, cols: tuple, memo: dict, tag: str):
    """Determinant of ``T[rows, cols]`` by Laplace expansion along its first row,
    sub-minors named once (``mn_<tag>_<rows>_<cols>``) and zero entries skipped."""
    key = (rows, cols)
    if key in memo:
        return memo[key]
    if len(rows) == 1:
        return T[rows[0], cols[0]]
    total = sp.Integer(0)
    for k, c in enumerate(cols):
        entry = T[rows[0], c]
        if entry == 0:
            continue
        sub = _minor(prog, T, rows[1:], cols[:k] + cols[k + 1:], memo, tag)
        if sub != 0:
            total += (-1) ** k * entry * sub
    name = f"mn_{tag}_{''.join(map(str, rows))}_{''.join(map(str, cols))}"
    memo[key] = prog.let(name, total) if len(rows) > 1 else total
    return memo[key]


def reciprocal_wrench(prog: Program, T: sp.Matrix, others: tuple, memo: dict, tag: str) -> sp.Matrix:
    """Wrench reciprocal to the five unit twists ``T[others, :]`` (rows of T): their
    generalised cross product, ``w_j = (-1)^j det(T[others, all but j])``."""
    cols = tuple(range(6))
    return sp.Matrix([(-1) ** j * _minor(prog, T, others, cols[:j] + cols[j + 1:], memo, tag) for j in range(6)])


@dataclass
class ChainScrews:
    """The named screws of one leg.

    twists : (6,) list of unit twists, in chain order (U and S expanded).
    joint_of : index of the joint each twist belongs to.
    wrenches : the reciprocal wrench of each twist (Huang's method).
    rows : the inverse-Jacobian row (1x6) of each twist: joint rate per platform twist.
    levers : the reciprocal products ``w_k . t_k``.
    actuated : index (into ``twists``) of the actuated joint's twist.
    geometry : the leg's named vectors at the pose.
    """

    twists: list
    joint_of: list
    wrenches: list
    rows: list
    levers: list
    actuated: int
    geometry: dict


def chain_screws(prog: Program, leg: ChainLeg, geometry: dict, origin: sp.Matrix, tag: str) -> ChainScrews:
    """Unit twists, reciprocal wrenches and inverse-Jacobian rows of ``leg`` (Huang's method)."""
    twists, joint_of = [], []
    for j, joint in enumerate(leg.joints):
        for t in joint_twists(joint, geometry, origin):
            twists.append(prog.let_matrix(f"t{len(twists) + 1}_{tag}", t))
            joint_of.append(j)
    if len(twists) != 6:
        raise ValueError(f"{leg.name}: {len(twists)} unit twists: a leg with fewer than six freedoms lists one "
                         f"'virtual' joint (its twist of restriction) per constraint, six twists in all")
    T = sp.Matrix.hstack(*twists).T
    memo: dict = {}
    wrenches, rows, levers = [], [], []
    for k in range(6):
        w = prog.let_matrix(f"w{k + 1}_{tag}", reciprocal_wrench(prog, T, tuple(i for i in range(6) if i != k),
                                                                   memo, tag))
        rp = prog.let(f"rp{k + 1}_{tag}", reciprocal_product(w, twists[k]))
        wrenches.append(w)
        levers.append(rp)
        rows.append(prog.let_matrix(f"j{k + 1}_{tag}", w.T / rp))
    actuated = next(k for k, j in enumerate(joint_of) if leg.joints[j].actuated)
    return ChainScrews(twists, joint_of, wrenches, rows, levers, actuated, geometry)


def _first_twists(screws: ChainScrews, leg: ChainLeg, after: int) -> list[int]:
    """Indices of the unit twists of the first ``after`` joints of the chain."""
    return [k for k, j in enumerate(screws.joint_of) if j < after]


def body_twist_map(screws: ChainScrews, leg: ChainLeg, after: int) -> tuple[sp.Matrix, sp.Matrix]:
    """``(T_b, rows_b)``: the unit twists moving a body carried by the first ``after``
    joints and their inverse-Jacobian rows; the body twist is ``T_b rows_b t``."""
    idx = _first_twists(screws, leg, after)
    return (sp.Matrix.hstack(*[screws.twists[k] for k in idx]),
            sp.Matrix.vstack(*[screws.rows[k] for k in idx]))


def body_inertia(prog: Program, screws: ChainScrews, leg: ChainLeg, body, origin: sp.Matrix, name: str) -> sp.Matrix:
    """Term ``rows_b^T (T_b^T M_b T_b) rows_b`` of Eq. 12 for one body of one leg, with
    ``M_b`` the body's spatial inertia moved from its frame to the platform origin."""
    g = screws.geometry
    rotation = sp.Matrix.hstack(*[_vector(g, a) for a in body.rotation])
    Mb = inertia_to_frame(sp.Matrix(body.inertia), rotation, _vector(g, body.origin) - origin)
    Tb, rows = body_twist_map(screws, leg, body.after)
    Mq = prog.let_matrix(f"Mq_{name}", Tb.T * Mb * Tb)
    return rows.T * Mq * rows


def pose_inputs() -> tuple:
    """The per-pose inputs of a 6-DoF robot's programs: ``x, y, z`` (m) and the rotation
    matrix entries ``R_00 .. R_22`` of the platform frame (base axes)."""
    return tuple(POSE6) + tuple(ROTATION[i, j] for i in range(3) for j in range(3))


def _check_effects(robot: ChainRobot, fx) -> None:
    kinds = {"joint_series", "added_inertia", "preload", "ground_spring"}
    for e in fx.effects:
        if e.kind not in kinds:
            raise ValueError(f"{robot.name}: effect {e.name!r} of kind {e.kind!r}: a chain robot takes effects of "
                             f"kinds {', '.join(sorted(kinds))}")
        if e.kind == "added_inertia" and e.body != "platform":
            raise ValueError(f"{robot.name}: effect {e.name!r} adds inertia to body {e.body!r}: a chain robot "
                             "takes added inertia on the 'platform' only")


def _inverse_kinematics(robot: ChainRobot):
    """IK program: pose and parameters -> each leg's actuated coordinate and its checks."""
    ik = Program()
    for s_ in pose_inputs() + tuple(p.symbol for p in robot.parameters):
        ik.declare(s_)
    p = {q.name: q.symbol for q in robot.parameters}
    n = len(robot.legs)
    coords, checks = [], {}
    for i, leg in enumerate(robot.legs):
        tag = str(i + 1)
        g = leg.geometry(sp.Matrix(POSE6), ROTATION, p)
        coords.append(ik.let(f"l_{tag}", g["length"]))
        for name in leg.checks:
            checks.setdefault(name, []).append(ik.let(f"{name}_{tag}", g[name]))
    outputs = {"q": ((n, 1), coords)}
    outputs.update({name: ((n,), v) for name, v in checks.items()})
    return ik, outputs


def _rotation_rate(k: int) -> sp.Matrix:
    """dR/d(eps) for a unit rotation about base axis ``k``: ``[e_k]x R``."""
    return skew(sp.Matrix([int(k == 0), int(k == 1), int(k == 2)])) * ROTATION


def _along_twists(prog: Program, col: sp.Matrix, joint, row: sp.Matrix) -> sp.Matrix:
    """6x6 matrix whose column k is d(col)/d(eps) along the platform's unit twist e_k
    (``[omega; v]`` at the origin, base axes): the origin moves by v, ``dR = [omega]x R``,
    and the leg's coordinate ``joint`` by ``row . e_k`` (its inverse-Jacobian row)."""
    d_pos = [derivative(prog, col, s_) for s_ in POSE6]
    d_rot = {(i, j): derivative(prog, col, ROTATION[i, j]) for i in range(3) for j in range(3)}
    d_q = derivative(prog, col, joint)
    G = sp.zeros(6, 6)
    for k in range(6):
        if k < 3:
            dR = _rotation_rate(k)
            c = sum((d_rot[i, j] * dR[i, j] for i in range(3) for j in range(3) if dR[i, j] != 0), sp.zeros(6, 1))
        else:
            c = d_pos[k - 3]
        G[:, k] = c + d_q * row[k]
    return G


def derive_chain(robot: ChainRobot) -> DerivedModel:
    """The :class:`~eigentwist.symbolic.model.DerivedModel` of a joint-list robot.

    * ``ik``: pose (x, y, z m; R_ij) -> ``q`` (legs, 1), each leg's actuated coordinate
      (m for a prismatic actuator: the leg length), and the legs' check quantities;
    * ``program``: leg coordinates, pose, parameters and switches -> M (Eq. 12: platform,
      payload and every body of every leg), K_R (Eq. 14: ``sum_i k_act,i j_a,i^T j_a,i``
      with the joint-series effects in series with k_a, N/m), K_F (= K_R: legs with six
      freedoms have no constraint wrench), ``J_rows`` (legs, 6, 6: the actuated joint's
      row first, then the other unit twists in chain order), ``lever`` (w_a . t_a),
      and the gravity terms ``G`` (legs, 1, 6, 6: d(j_a^T)/d(platform twist)), ``Kqe``
      (legs, 1, 1), ``k_act`` (legs,), ``W`` (6,) the preload wrench at the origin.
    """
    from .model import DerivedModel, EffectSymbols

    fx = EffectSymbols(robot)
    _check_effects(robot, fx)
    ik, ik_outputs = _inverse_kinematics(robot)
    joints = [sym(f"l_{i + 1}") for i in range(len(robot.legs))]
    prog = Program()
    for s_ in joints + list(pose_inputs()) + [p.symbol for p in robot.parameters] + fx.inputs():
        prog.declare(s_)
    p = {q.name: q.symbol for q in robot.parameters}
    origin = sp.Matrix(POSE6)
    S = _platform_inertia(robot, fx)
    M = S
    K = _ground_springs(fx)
    screws, J_rows, levers, G, Kqe, k_acts = [], [], [], [], [], []
    for i, leg in enumerate(robot.legs):
        tag = str(i + 1)
        geometry = {k: (prog.let_matrix(f"{k}_{tag}", v) if isinstance(v, sp.MatrixBase) else prog.let(f"{k}_{tag}", v))
                    for k, v in leg.geometry(origin, ROTATION, p, joints[i]).items()}
        ls = chain_screws(prog, leg, geometry, origin, tag)
        screws.append(ls)
        for b in leg.bodies:
            M += body_inertia(prog, ls, leg, b, origin, f"{b.name}_{tag}")
        c_act = 1 / robot.actuator_stiffness
        for e in fx.of_kind("joint_series"):
            on, ce = fx.term(e, i)
            c_act = c_act + on * ce
        k_act = prog.let(f"k_act_{tag}", 1 / prog.let(f"c_act_{tag}", c_act))
        row = ls.rows[ls.actuated]
        K += k_act * row.T * row
        order = [ls.actuated] + [k for k in range(6) if k != ls.actuated]
        J_rows.append(sp.Matrix.vstack(*[ls.rows[k] for k in order]))
        levers.append(ls.levers[ls.actuated])
        G.append(_along_twists(prog, row.T, joints[i], row))
        Kqe.append(k_act)
        k_acts.append(k_act)
    n = len(robot.legs)
    flat = lambda m: [m[i, j] for i in range(m.rows) for j in range(m.cols)]  # noqa: E731
    outputs = {
        "matrices": {"M": ((6, 6), flat(M)), "K_R": ((6, 6), flat(K)), "K_F": ((6, 6), flat(K))},
        "jacobians": {"J_rows": ((n, 6, 6), [e for r in J_rows for e in flat(r)]), "lever": ((n,), levers)},
        "gravity": {
            "G": ((n, 1, 6, 6), [e for g in G for e in flat(g)]),
            "Kqe": ((n, 1, 1), Kqe),
            "k_act": ((n,), k_acts),
            "W": ((6,), list(_preload_wrench(S, fx))),
        },
    }
    return DerivedModel(robot, ik, ik_outputs, prog, outputs, joints, screws, pose_inputs=pose_inputs())


def _ground_springs(fx) -> sp.Matrix:
    """Springs between the platform and the ground at the origin (K = A^T K_local A)."""
    K = sp.zeros(6, 6)
    for e in fx.of_kind("ground_spring"):
        on, (K_local, rotation, origin) = fx.term(e)
        K += on * stiffness_to_frame(sp.Matrix(K_local), sp.Matrix(rotation), sp.Matrix(origin))
    return K


def _preload_wrench(S: sp.Matrix, fx) -> sp.Matrix:
    """Static wrench [moment; force] (N m; N) at the platform origin of the platform and
    payload inertia ``S`` (base axes) under each preload's acceleration (Eq. 13)."""
    mass = S[3, 3]
    first_moment = sp.Matrix([S[2, 4], S[0, 5], S[1, 3]])          # m c, from m [c]x
    W = sp.zeros(6, 1)
    for e in fx.of_kind("preload"):
        on, g = fx.term(e)
        g = sp.Matrix(g)
        W += on * sp.Matrix.vstack(first_moment.cross(g), mass * g)
    return W


def _platform_inertia(robot: ChainRobot, fx) -> sp.Matrix:
    """The platform's and any added (payload) inertia at the platform origin in base axes."""
    M = robot.platform_inertia
    for e in fx.of_kind("added_inertia"):
        if e.body == "platform":
            on, inertia = fx.term(e)
            M = M + on * inertia
    return inertia_to_frame(M, ROTATION, sp.zeros(3, 1))
