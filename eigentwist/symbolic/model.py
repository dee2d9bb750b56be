"""Derive the closed-form model of a described manipulator.

``derive(robot)`` returns two straight-line programs over named SymPy symbols:

* ``ik``: pose (x, y, z in m; a 6-DoF robot's rotation matrix R_ij too) and design
  parameters -> joint coordinates of every leg (rad; m for a prismatic joint) and the
  reachability quantities;
* ``program``: joint angles, design parameters and effect switches -> M (Eq. 12),
  K_R (Eq. 14), K_F (Eq. 13 with tau_e = 0), the legs' inverse-Jacobian rows, and the
  gravity-preload terms of Eq. 13.

Every robot goes through the one :func:`derive`. Every leg is read from its joint list
(:class:`~eigentwist.description.Leg`, :class:`~eigentwist.description.chain.ChainLeg`:
joints, bodies, frames and its closed-form kinematics as data), the pose from the robot's
pose space (:mod:`eigentwist.description.pose`); nothing here depends on which robot or
which chain it is (``tests/test_no_branch.py``). Every number of the design is a symbol; nothing numeric is
baked into the expressions.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import sympy as sp

from ..errors import DescriptionError
from ..description import RobotDescription, sym
from ..description.effects import EffectContext, leg_input_name, leg_switch_name, switch_name
from .inertia import body_inertia_contribution
from .kinematics import POSE, closures, inverse_kinematics, loop_closure, pose_closure
from .leg import LegScrews, leg_screws
from .program import Program, derivative
from ..description.screw import adjoint, compliance_to_frame, stiffness_to_frame
from .stiffness import condense_coupling, inverse_small, rows_outer

__all__ = ["DerivedModel", "derive", "POSE", "EffectSymbols"]


@dataclass
class DerivedModel:
    """The symbolic model of one robot.

    ``outputs`` maps a group name to ``{output name: (shape, list of expressions)}``:

    * ``matrices``: ``M``, ``K_R``, ``K_F`` (6, 6) in kg/kg m/kg m^2 and N/m, N, N m;
    * ``jacobians``: ``J_rows`` (legs, rows, 6): the inverse-Jacobian rows each leg's
      kinematics reports (``jacobian_rows``; RR(Pi)RR: joints 1, 2, 3 and the virtual
      joint, (legs, 4, 6); the hexapod: the actuated joint's, then the other five,
      (legs, 6, 6)); ``lever`` (legs,): the leg kinematics' actuation lever (RR(Pi)RR:
      w_a1 . t_a1 with w_a1 a unit force, m; a pose-driven leg: the determinant of its
      six unit twists);
    * ``gravity``: ``G`` (legs, n_e, 6, 6), the matrices multiplying the elastic joint
      torques tau_e (the actuated joint, then the virtual joints; RR(Pi)RR: 2) in the
      first term of Eq. 13 (sum_j d(J_e,i^-T col k)/d theta_j . row j of J_i^-1,
      theta_3 = l2 q3 for the Pi joint; zeros for a robot that offers no preload effect,
      where tau_e = 0); ``Kqe`` (legs, n_e, n_e), each leg's
      elastic joint stiffness (Eq. 40); ``k_act`` (legs,), each leg's actuated-joint
      stiffness with its joint-series effects; ``W`` (6,), the static preload wrench on
      the platform at the EE origin (N m; N).
    """

    robot: RobotDescription
    ik: Program
    ik_outputs: dict
    program: Program
    outputs: dict
    joints: list
    screws: list = field(default_factory=list)
    #: symbols the IK program takes per pose (``x, y, z`` m for a 3-DoF robot; a 6-DoF
    #: robot adds its rotation matrix R_ij: ``robot.pose_space.inputs``,
    #: :mod:`eigentwist.description.pose`)
    pose_inputs: tuple = POSE
    #: legs solved numerically (:mod:`eigentwist.description.serial`): the loop-closure
    #: program (residual and its Jacobian) and its outputs; None for closed-form IK
    closure: Program | None = None
    closure_outputs: dict = field(default_factory=dict)

    @property
    def ik_joint_inputs(self) -> tuple[str, ...]:
        """Joint coordinates the IK program reads instead of computing (numeric IK: solved
        by the runtime and passed in by name; none for closed-form IK)."""
        declared = {s.name for s in self.ik.inputs}
        return tuple(s.name for s in self.joints if s.name in declared)

    #: ``(program, outputs)`` of the pose space's closure equations, whose followers the
    #: runtime solves (:func:`~eigentwist.symbolic.kinematics.closures`; legs solved
    #: numerically: their loop closures with the rates along the platform's twists,
    #: :func:`~eigentwist.symbolic.kinematics.pose_closure`), else None
    followers: tuple | None = None

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.robot.parameter_names

    @property
    def switches(self) -> tuple[str, ...]:
        """Names of the 0/1 effect switches (``on_E``; ``on_E__N`` per leg for a leg-level effect)."""
        return tuple(EffectSymbols(self.robot).switches())

    @property
    def leg_copies(self) -> dict[str, str]:
        """Each leg's copy of a leg-level effect's parameter or switch -> the shared name
        (``"eta_a__3": "eta_a"``, ``"on_actuator_loss__3": "on_actuator_loss"``)."""
        return {name: name.rpartition("__")[0] for name in self.inputs if "__" in name}

    @property
    def inputs(self) -> tuple[str, ...]:
        """Names of the generated code's parameter inputs: the robot's parameters, then
        each effect's switch (and each leg's copies for a leg-level effect)."""
        return self.parameters + tuple(s.name for s in EffectSymbols(self.robot).inputs())


def _flat(m: sp.Matrix) -> list:
    return [m[i, j] for i in range(m.rows) for j in range(m.cols)]


class EffectSymbols:
    """The switch and parameter symbols of each effect, per leg for leg-level ones.

    A leg-level effect E has on leg N the switch ``on_E__N`` and its own copy
    ``P__N`` of each parameter P, so that ``E@N`` needs no regeneration; every other
    effect has one switch ``on_E`` and its parameters' own symbols.
    """

    def __init__(self, robot: RobotDescription):
        self.robot = robot
        self.effects = [robot.effect(e) for e in robot.effects]

    def of_primitive(self, primitive: str) -> list:
        """The terms of ``primitive`` (an effect of several parts gives one per term, each under its switch)."""
        return [t for e in self.effects for t in e.parts() if t.primitive == primitive]

    def switch(self, effect, leg: int | None = None) -> sp.Symbol:
        if effect.leg_level:
            return sym(leg_switch_name(effect.name, leg + 1))
        return sym(switch_name(effect.name))

    def context(self, effect, leg: int | None = None, screws=None) -> EffectContext:
        if effect.leg_level:
            p = {q.name: sym(leg_input_name(q.name, leg + 1)) for q in effect.params}
        else:
            p = {q.name: q.symbol for q in effect.params}
        return EffectContext(self.robot, p, leg, None if leg is None else self.robot.legs[leg], screws)

    def term(self, effect, leg: int | None = None, screws=None):
        """(switch, built term) of ``effect`` on ``leg`` (0-based, None: the platform)."""
        return self.switch(effect, leg), effect.build(self.context(effect, leg, screws))

    def units(self) -> dict:
        """Unit of each leg copy of a parameter, ``{"eta_a__3": "-, leg 3"}``."""
        return {
            leg_input_name(q.name, k): f"{q.unit}, leg {k}"
            for e in self.effects
            if e.leg_level
            for k in range(1, len(self.robot.legs) + 1)
            for q in e.params
        }

    def switches(self) -> list[str]:
        """Names of the 0/1 switch inputs."""
        return [s.name for s in self.inputs() if s.name not in self.units()]

    def inputs(self) -> list:
        """Every generated-code input the effects add: leg copies of parameters and switches."""
        out = []
        for e in self.effects:
            if e.leg_level:
                for k in range(1, len(self.robot.legs) + 1):
                    out += [sym(leg_input_name(q.name, k)) for q in e.params] + [sym(leg_switch_name(e.name, k))]
            else:
                out.append(sym(switch_name(e.name)))
        return out


def derive(robot: RobotDescription) -> DerivedModel:
    """Derive IK, M, K_R, K_F and the gravity terms of any ``robot`` symbolically.

    Every leg is read from its joint list (:class:`~eigentwist.description.Leg` or
    :class:`~eigentwist.description.chain.ChainLeg`) and its closed form
    (``leg.kinematics``); the pose from the robot's ``pose_space``
    (:mod:`eigentwist.description.pose`). The legs' unit twists, reciprocal wrenches and
    inverse-Jacobian rows come from Huang's method
    (:func:`eigentwist.symbolic.leg.leg_screws`), their bodies' inertia from Eq. 12 per
    body, and their elastic joints are the actuated joint (k_a in series with the
    joint-series effects, Eq. 34) and each virtual joint (``rigid_compliance``, Eq. 42;
    a leg with six freedoms has none). Nothing here depends on which robot or chain it is.

    Legs may differ: in their chains, their actuator (R or P, the leg's own ``stiffness``)
    or none (a passive leg: its virtual joints' constraints only, no term in K_R). The
    per-leg outputs are padded to the largest leg's: a padded elastic joint is a zero row
    with unit compliance and no stiffness, a padded inverse-Jacobian row zero.
    """
    ik, ik_outputs, q_all = inverse_kinematics(robot)
    pose = robot.pose_space
    fx = EffectSymbols(robot)
    prog = Program()
    joints = [qq for q in q_all for qq in q]
    for s_ in joints + list(pose.program_inputs) + [p.symbol for p in robot.parameters] + fx.inputs():
        prog.declare(s_)
    S = _platform_inertia(robot, fx)
    M = S
    K_ground = _ground_springs(fx)  # in parallel with the legs: in K_R and K_F
    K_R = K_ground
    K_groups: dict = {}  # platform body -> Cartesian stiffness of its legs
    screws, J_rows, levers, Je_all, Kqe_all, k_acts, G = [], [], [], [], [], [], []
    Cq_phys = []  # each leg's joint compliance without rigid_compliance
    preloaded = bool(fx.of_primitive("preload"))
    for i, (leg, q) in enumerate(zip(robot.legs, q_all)):
        tag = str(i + 1)
        q = q[: len(leg.kinematics.coordinates)]  # without a numeric leg's padded coordinates
        ls = leg_screws(prog, leg, q, pose, tag)
        screws.append(ls)
        M += _leg_inertia(prog, fx, leg, ls, i)
        act, virtual, coords = _joint_keys(leg, ls)
        actuated = [] if act is None else [act]  # a passive leg: constraints only
        if act is None:
            k_act = sp.Integer(0)
            c_act = []
        else:
            c_act = [prog.let(f"c_act_{tag}", _joint_series(robot, fx, i))]
            k_act = prog.let(f"k_act_{tag}", 1 / c_act[0])
            K_R += rows_outer(ls.rows[act], sp.Matrix([[k_act]]))  # Eqs. 14, 33, 34
        elastic = [ls.rows[k] for k in actuated + virtual]
        Je = sp.Matrix.vstack(*elastic) if elastic else sp.zeros(0, 6)  # elastic joints
        Cs = prog.let_matrix(f"Cs_{tag}", _body_compliance(fx, ls, i)) if Je.rows else sp.zeros(6, 6)
        if Je.rows:
            Cq = Je * Cs * Je.T + sp.diag(*c_act, *[robot.rigid_compliance] * len(virtual))  # Eqs. 41-43
            Cq_phys.append(Je * Cs * Je.T + sp.diag(*c_act, *[0] * len(virtual)))
            Cq = prog.let_matrix(f"Cq_{tag}", Cq)
            Kqe = prog.let_matrix(f"Kqe_{tag}", _joint_stiffness(robot, Cq, len(actuated)))  # Eq. 40 block
        else:
            Cq_phys.append(sp.zeros(0, 0))
            Kqe = sp.zeros(0, 0)
        body = leg.platform_body
        K_groups[body] = K_groups.get(body, sp.zeros(6, 6)) + (rows_outer(Je, Kqe) if Je.rows else sp.zeros(6, 6))
        J_rows.append(sp.Matrix.vstack(*[ls.rows[ls.keys[k]] for k in leg.kinematics.jacobian_rows]))
        levers.append(prog.let(f"lever_{tag}", leg.kinematics.lever(ls, act)))
        motion = [(qj, ls.rows[key] / rate) for qj, (key, rate) in zip(q, coords)] + pose.motion()
        if preloaded:
            G.append(_preload_derivatives(prog, motion, ls, actuated + virtual, tag))
        else:  # no preload effect: Eq. 13's first term vanishes (tau_e = 0)
            G.append([sp.zeros(6, 6)] * len(actuated + virtual))
        Je_all.append(Je)
        Kqe_all.append(Kqe)
        k_acts.append(k_act)
    K_F = _platform_stiffness(prog, robot, K_groups, fx) + K_ground
    # legs that differ (joint chains, passive legs): every leg's arrays padded to the largest,
    # a padded elastic joint a zero row with unit compliance and no stiffness (it adds nothing)
    n, n_e = len(robot.legs), max(j.rows for j in Je_all)
    n_rows = max(r.rows for r in J_rows)
    J_rows = [sp.Matrix.vstack(r, sp.zeros(n_rows - r.rows, 6)) for r in J_rows]
    G = [g + [sp.zeros(6, 6)] * (n_e - len(g)) for g in G]
    Kqe_all = [sp.diag(k, sp.zeros(n_e - k.rows, n_e - k.rows)) if k.rows < n_e else k for k in Kqe_all]
    Cq_phys = [sp.diag(c, sp.eye(n_e - c.rows)) if c.rows < n_e else c for c in Cq_phys]
    Je_all = [sp.Matrix.vstack(j, sp.zeros(n_e - j.rows, 6)) for j in Je_all]
    G = [g for leg_g in G for g in leg_g]
    sym6 = lambda m: [m[i, j] for i in range(6) for j in range(6)]  # noqa: E731
    outputs = {
        "matrices": {"M": ((6, 6), sym6(M)), "K_R": ((6, 6), sym6(K_R)), "K_F": ((6, 6), sym6(K_F))},
        "jacobians": {
            "J_rows": ((n,) + J_rows[0].shape, [e for r in J_rows for e in _flat(r)]),
            "lever": ((n,), levers),
        },
        "gravity": {
            "G": ((n, n_e, 6, 6), [e for g in G for e in _flat(g)]),
            "Kqe": ((n, n_e, n_e), [e for k in Kqe_all for e in _flat(k)]),
            "k_act": ((n,), k_acts),
            "W": ((6,), list(_preload_wrench(S, fx))),
        },
        "legs": _legs_outputs(robot, Je_all, Cq_phys, K_ground),
    }
    closure, closure_outputs = loop_closure(robot, q_all)
    return DerivedModel(
        robot,
        ik,
        ik_outputs,
        prog,
        outputs,
        joints,
        screws,
        pose_inputs=tuple(pose.inputs),
        closure=closure,
        closure_outputs=closure_outputs,
        followers=closures(robot) if closure is None else pose_closure(robot, closure, closure_outputs),
    )


def _legs_outputs(robot: RobotDescription, Je_all: list, Cq_phys: list, K_ground: sp.Matrix) -> dict:
    """Outputs of the ``legs`` kernel: what the exact condensation of rigid constraints
    (:mod:`eigentwist.runtime.condense`) needs instead of K_F's penalty.

    ``Je`` (legs, e, 6): each leg's elastic-joint rows (the actuated joint, then the
    virtual joints; twists ``[omega; v]``); ``Cq`` (legs, e, e): their compliance
    (Eqs. 41-43) **without** ``rigid_compliance``, so an ideally rigid direction is an
    exact zero; ``K_ground`` (6, 6): springs in parallel with the legs; and per coupling
    (sorted by body, as K_F condenses them) ``G_c`` (couplings, 6, m) its unit twists at
    the EE origin and ``K_c`` (couplings, m) its stiffnesses.
    """
    n, n_e = len(Je_all), Je_all[0].rows  # padded alike by derive
    flat = lambda m: [m[i, j] for i in range(m.rows) for j in range(m.cols)]  # noqa: E731
    out = {
        "Je": ((n, n_e, 6), [e for j in Je_all for e in flat(j)]),
        "Cq": ((n, n_e, n_e), [e for c in Cq_phys for e in flat(c)]),
        "K_ground": ((6, 6), flat(K_ground)),
    }
    couplings = sorted(robot.couplings, key=lambda c: c.body)
    if couplings and len({len(c.twists) for c in couplings}) == 1:
        G, Kc = [], []
        for c in couplings:
            G += flat(adjoint(sp.Matrix(c.rotation).T, sp.Matrix(c.origin)) * sp.Matrix([list(t) for t in c.twists]).T)
            Kc += list(c.stiffness)
        m = len(couplings[0].twists)
        out["G_c"] = ((len(couplings), 6, m), G)
        out["K_c"] = ((len(couplings), m), Kc)
    return out


def _joint_keys(leg, ls: LegScrews):
    """Twist keys of the leg's actuated joint, of its virtual joints, and (key, rate)
    of each IK coordinate's joint (``Leg.kinematics.coordinates``)."""
    first = {j: k for k, j in reversed(list(zip(ls.keys, ls.joint_of)))}
    actuated = [j for j, joint in enumerate(leg.joints) if joint.actuated]
    if len(actuated) > 1:
        raise DescriptionError(f"{leg.name}: {len(actuated)} actuated joints: expected one, or none for a passive leg")
    virtual = [k for k, j in zip(ls.keys, ls.joint_of) if leg.joints[j].virtual]
    # (joint, rate[, freedom within the joint]): a U or S joint's coordinates address its twists
    coords = [
        (ls.keys[ls.joint_of.index(c[0]) + (c[2] if len(c) > 2 else 0)], c[1]) for c in leg.kinematics.coordinates
    ]
    return (first[actuated[0]] if actuated else None), virtual, coords


def _joint_stiffness(robot, Cq: sp.Matrix, n_act: int) -> sp.Matrix:
    """Eq. 40's block ``Kqe = Cq^-1`` of one leg's elastic joints (the ``n_act`` actuated
    ones first, then the virtual ones). A robot whose ``rigid_compliance`` is exactly 0
    (no penalty: its constraints exact, in its allowed twists and the ``legs`` kernel's
    condensation) gives its virtual joints no spring in K_F: ``Kqe`` is the inverse of the
    actuated block, zero elsewhere."""
    if sp.sympify(robot.rigid_compliance) != 0 or Cq.rows == n_act:
        return inverse_small(Cq)
    K = sp.zeros(Cq.rows, Cq.rows)
    if n_act:
        K[:n_act, :n_act] = inverse_small(Cq[:n_act, :n_act])
    return K


def actuator_stiffness(robot, leg):
    """The stiffness of ``leg``'s actuated joint: its own (``stiffness``, N/m or N m/rad by
    its kind) or the robot's ``actuator_stiffness``."""
    own = getattr(leg, "stiffness", None)
    return robot.actuator_stiffness if own is None else own


def _platform_inertia(robot: RobotDescription, fx: EffectSymbols) -> sp.Matrix:
    """Inertia of the platform at its origin (Eq. 31) plus added inertia on it (payload),
    given in platform axes, in base axes (``pose_space.inertia_in_base``)."""
    M = robot.platform_inertia
    for e in fx.of_primitive("added_inertia"):
        if e.body == "platform":
            on, inertia = fx.term(e)
            M = M + on * inertia
    return robot.pose_space.inertia_in_base(M)


def _leg_inertia(prog: Program, fx: EffectSymbols, leg, ls: LegScrews, i: int) -> sp.Matrix:
    """Eq. 32 for one leg: the sum of Eq. 12's term over the leg's bodies (each with any
    inertia an effect adds to it, e.g. the rotor on the lower link J1)."""
    inertia = {b.name: b.inertia for b in leg.bodies}
    for e in fx.of_primitive("added_inertia"):
        if e.body != "platform":
            if e.body not in inertia:
                raise DescriptionError(
                    f"effect {e.name!r}: added inertia on body {e.body!r}: expected one of "
                    f"{', '.join(inertia)} or 'platform'"
                )
            on, added = fx.term(e, i, ls)
            # one body's inertia, or {body: inertia} for an effect that moves mass between bodies
            for body, term in added.items() if isinstance(added, dict) else ((e.body, added),):
                if body not in inertia:
                    raise DescriptionError(
                        f"effect {e.name!r}: added inertia on body {body!r}: expected one of {', '.join(inertia)}"
                    )
                inertia[body] = inertia[body] + on * term
    M = sp.zeros(6, 6)
    for b in leg.bodies:
        # a body's name in the generated code's intermediates: letters, digits and underscores
        tag = re.sub(r"\W", "_", b.name)
        M += body_inertia_contribution(prog, ls, b, inertia[b.name], f"{tag}_{i + 1}", leg.joints)
    return M


def _joint_series(robot: RobotDescription, fx: EffectSymbols, i: int):
    """Compliance of leg ``i``'s actuated joint: 1/k plus every joint-series effect (Eq. 34),
    k the leg's own actuator stiffness (``leg.stiffness``) or the robot's k_a."""
    c = 1 / actuator_stiffness(robot, robot.legs[i])
    for e in fx.of_primitive("joint_series"):
        on, ce = fx.term(e, i)
        c = c + on * ce
    return c


def _body_compliance(fx: EffectSymbols, ls, i: int) -> sp.Matrix:
    """Leg ``i``'s compliance at the EE origin: each body compliance moved from its
    body's frame (Eqs. 44, 49)."""
    Cs = sp.zeros(6, 6)
    for e in fx.of_primitive("body_compliance"):
        on, C = fx.term(e, i, ls)
        if C is None:
            continue
        if e.body != "platform":
            if e.body not in ls.frames:
                raise DescriptionError(
                    f"effect {e.name!r}: body {e.body!r}: expected a leg frame ({', '.join(ls.frames)}) or 'platform'"
                )
            C = compliance_to_frame(C, *ls.frames[e.body])
        Cs += on * C
    return Cs


def _ground_springs(fx: EffectSymbols) -> sp.Matrix:
    """Springs between the tool and the ground, moved to the EE origin (K = A^T K_local A)."""
    K = sp.zeros(6, 6)
    for e in fx.of_primitive("ground_spring"):
        on, (K_local, rotation, origin) = fx.term(e)
        K += on * stiffness_to_frame(sp.Matrix(K_local), sp.Matrix(rotation), sp.Matrix(origin))
    return K


def _preload_derivatives(prog: Program, motion: list, ls: LegScrews, elastic: list, tag: str) -> list:
    """First term of Eq. 13 for one leg: per elastic joint k, ``d(j_k^T)/dx``, the change
    of its inverse-Jacobian row (a column of J_e^-T) per unit platform twist:
    ``sum_s d(j_k^T)/ds . rate_s`` over the symbols ``s`` the leg's screws depend on,
    each with its rate along the six platform unit twists (``motion``: each IK coordinate
    q_j with ``j_(q_j) / rate_j``, the row of q_j's joint over that joint's coordinate per
    unit of q_j (the Pi joint's is l2 q3); the pose inputs of a 6-DoF robot with theirs,
    ``pose_space.motion``). The rows are those of ``T^-1`` (T: the six unit twists as
    columns, Huang's method), so ``dj_k/ds = -sum_m (j_k . dt_m/ds) j_m``: only the twists
    are differentiated, never the minors.

    With tau_e the elastic joint torques of the loaded state (W_ext = J_e^-T tau_e,
    tau_e = K_qe J_e delta), d(J_e^-T tau_e)/dx gives +(d J_e^-T / d q . tau_e) J^-1:
    the paper's minus sign belongs to the opposite sign convention for tau_e. Checked: a
    hanging load stiffens the lateral modes (pendulum).
    """
    dT = {s_: {m: derivative(prog, ls.twists[m], s_) for m in ls.keys} for s_, _ in motion}
    G = []
    for k in elastic:
        Gk = sp.zeros(6, 6)
        for s_, rate in motion:
            drow = sp.zeros(1, 6)
            for m in ls.keys:
                if any(e != 0 for e in dT[s_][m]):
                    coef = prog.let(f"dj_{k}_{m}_{s_.name}_{tag}", -(ls.rows[k] * dT[s_][m])[0, 0])
                    drow += coef * ls.rows[m]
            Gk += drow.T * rate
        G.append(Gk)
    return G


def _preload_wrench(S: sp.Matrix, fx: EffectSymbols) -> sp.Matrix:
    """Static wrench [moment; force] (N m; N) at the platform origin of the platform's
    inertia ``S`` (with added inertia on it; base axes) under each preload's acceleration."""
    mass = S[3, 3]
    first_moment = sp.Matrix([S[2, 4], S[0, 5], S[1, 3]])  # m c, from m [c]x
    W = sp.zeros(6, 1)
    for e in fx.of_primitive("preload"):
        on, g = fx.term(e)
        g = sp.Matrix(g)
        W += on * sp.Matrix.vstack(first_moment.cross(g), mass * g)
    return W


def _platform_stiffness(prog: Program, robot: RobotDescription, K_groups: dict, fx: EffectSymbols) -> sp.Matrix:
    """K_F as the sum over platform bodies: legs on the tool body add directly,
    legs on a body coupled to the tool add through the condensed coupling."""
    couplings = {c.body: c for c in robot.couplings}
    unknown = sorted(set(K_groups) - set(couplings) - {robot.tool_body})
    if unknown:
        raise DescriptionError(
            f"{robot.name}: legs attach to platform bodies {unknown} that are neither the tool body "
            f"{robot.tool_body!r} nor coupled to it (couplings: {sorted(couplings)})"
        )
    K_F = sp.zeros(6, 6)
    for body in sorted(K_groups):
        Kp = K_groups[body]
        c = couplings.get(body)
        if c is None:
            K_F += Kp
            continue
        Ad = adjoint(sp.Matrix(c.rotation).T, sp.Matrix(c.origin))
        G = Ad * sp.Matrix([list(t) for t in c.twists]).T
        Kc = sp.diag(*c.stiffness)
        K_F += condense_coupling(prog, Kp, G, Kc, fx.switch(robot.effect(c.effect)), body)
    return K_F
