"""Derive the closed-form model of a described manipulator.

``derive(robot)`` returns two straight-line programs over named SymPy symbols:

* ``ik``: pose (x, y, z in m) and design parameters -> joint angles of every leg
  (rad) and the reachability quantities;
* ``program``: joint angles, design parameters and effect switches -> M (Eq. 12),
  K_R (Eq. 14), K_F (Eq. 13 with tau_e = 0), the legs' inverse-Jacobian rows, and the
  gravity-preload terms of Eq. 13.

Every number of the design is a symbol; nothing numeric is baked into the expressions.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..description import RobotDescription, sym
from ..description.effects import EffectContext, leg_input_name, leg_switch_name, switch_name
from .inertia import body_inertia_contribution, parallelogram_inertia
from .kinematics import leg_inverse_kinematics
from .leg import leg_screws
from .program import Program, derivative
from .screw import adjoint, compliance_to_frame, stiffness_to_frame
from .stiffness import condense_coupling, inverse_2x2, rows_outer

__all__ = ["DerivedModel", "derive", "POSE", "EffectSymbols"]

POSE = (sym("x"), sym("y"), sym("z"))


@dataclass
class DerivedModel:
    """The symbolic model of one robot.

    ``outputs`` maps a group name to ``{output name: (shape, list of expressions)}``:

    * ``matrices``: ``M``, ``K_R``, ``K_F`` (6, 6) in kg/kg m/kg m^2 and N/m, N, N m;
    * ``jacobians``: ``J_rows`` (legs, 4, 6): inverse-Jacobian rows of joints 1, 2, 3 and
      the virtual joint; ``lever`` (legs,): actuation lever w_a1 . t_a1 (m);
    * ``gravity``: ``G`` (legs, 2, 6, 6), the matrices multiplying the elastic joint
      torques tau_e in the first term of Eq. 13 (sum_j d(J_e,i^-T col k)/d theta_j . row j
      of J_i^-1, theta_3 = l2 q3); ``Kqe`` (legs, 2, 2), each leg's
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
    #: robot adds its rotation, see :mod:`eigentwist.symbolic.chain`)
    pose_inputs: tuple = POSE

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

    def of_kind(self, kind: str) -> list:
        return [e for e in self.effects if e.kind == kind]

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
        return {leg_input_name(q.name, k): f"{q.unit}, leg {k}" for e in self.effects if e.leg_level
                for k in range(1, len(self.robot.legs) + 1) for q in e.params}

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
    """Derive IK, M, K_R, K_F and the gravity terms of ``robot`` symbolically."""
    ik, ik_outputs, q_all = _inverse_kinematics(robot)
    fx = EffectSymbols(robot)
    prog = Program()
    joints = [qq for q in q_all for qq in q]
    for s_ in joints + [p.symbol for p in robot.parameters] + fx.inputs():
        prog.declare(s_)
    M = _platform_inertia(robot, fx)
    K_ground = _ground_springs(fx)  # in parallel with the legs: in K_R and K_F
    K_R = K_ground
    K_groups: dict = {}           # platform body -> Cartesian stiffness of its legs
    screws, J_rows, levers, Je_all, Kqe_all, k_acts = [], [], [], [], [], []
    for i, (leg, q) in enumerate(zip(robot.legs, q_all)):
        tag = str(i + 1)
        ls = leg_screws(prog, leg, q, robot.l1, robot.l2, tag)
        screws.append(ls)
        M += _leg_inertia(prog, robot, fx, ls, i)
        c_act = prog.let(f"c_act_{tag}", _joint_series(robot, fx, i))
        k_act = prog.let(f"k_act_{tag}", 1 / c_act)
        K_R += rows_outer(ls.rows[1], sp.Matrix([[k_act]]))                # Eqs. 14, 33, 34
        Je = sp.Matrix.vstack(ls.rows[1], ls.rows["c"])
        Cs = prog.let_matrix(f"Cs_{tag}", _body_compliance(fx, ls, i))
        Cq = Je * Cs * Je.T + sp.diag(c_act, robot.rigid_compliance)       # Eqs. 41-43
        Cq = prog.let_matrix(f"Cq_{tag}", Cq)
        Kqe = prog.let_matrix(f"Kqe_{tag}", inverse_2x2(Cq))             # Eq. 40 block
        body = leg.platform_body
        K_groups[body] = K_groups.get(body, sp.zeros(6, 6)) + rows_outer(Je, Kqe)
        J_rows.append(sp.Matrix.vstack(ls.rows[1], ls.rows[2], ls.rows[3], ls.rows["c"]))
        levers.append(_lever(prog, tag))
        Je_all.append(Je)
        Kqe_all.append(Kqe)
        k_acts.append(k_act)
    K_F = _platform_stiffness(prog, robot, K_groups, fx) + K_ground
    G = _preload_derivatives(prog, robot, q_all, screws, Je_all)
    n = len(robot.legs)
    sym6 = lambda m: [m[i, j] for i in range(6) for j in range(6)]  # noqa: E731
    outputs = {
        "matrices": {"M": ((6, 6), sym6(M)), "K_R": ((6, 6), sym6(K_R)), "K_F": ((6, 6), sym6(K_F))},
        "jacobians": {
            "J_rows": ((n, 4, 6), [e for r in J_rows for e in _flat(r)]),
            "lever": ((n,), levers),
        },
        "gravity": {
            "G": ((n, 2, 6, 6), [e for g in G for e in _flat(g)]),
            "Kqe": ((n, 2, 2), [e for k in Kqe_all for e in _flat(k)]),
            "k_act": ((n,), k_acts),
            "W": ((6,), list(_preload_wrench(robot, fx))),
        },
    }
    return DerivedModel(robot, ik, ik_outputs, prog, outputs, joints, screws)


def _inverse_kinematics(robot: RobotDescription):
    """The IK program: pose and parameters -> joint angles and reachability quantities."""
    ik = Program()
    for s_ in list(POSE) + [p.symbol for p in robot.parameters]:
        ik.declare(s_)
    pose = sp.Matrix(POSE)
    q_all, sin_q3, cos_q2 = [], [], []
    for i, leg in enumerate(robot.legs, start=1):
        q, checks = leg_inverse_kinematics(ik, leg, pose, robot.l1, robot.l2, str(i))
        q_all.append(q)
        sin_q3.append(checks["sin_q3"])
        cos_q2.append(checks["cos_q2"])
    n = len(robot.legs)
    outputs = {"q": ((n, 3), [qq for q in q_all for qq in q]), "sin_q3": ((n,), sin_q3), "cos_q2": ((n,), cos_q2)}
    return ik, outputs, q_all


def _platform_inertia(robot: RobotDescription, fx: EffectSymbols) -> sp.Matrix:
    """Inertia of the platform at the EE origin (Eq. 31) plus added inertia on it (payload)."""
    M = robot.ee_inertia
    for e in fx.of_kind("added_inertia"):
        if e.body == "platform":
            on, inertia = fx.term(e)
            M = M + on * inertia
    return M


def _leg_inertia(prog: Program, robot: RobotDescription, fx: EffectSymbols, ls, i: int) -> sp.Matrix:
    """Eq. 32 for one leg: body 1 (lower link, rotor and any inertia added to it) and
    body 3 (the parallelogram, Eqs. 26-29)."""
    rod, tag = robot.rod, str(i + 1)
    bodies = {"J1": robot.lower_link_inertia, "C3": parallelogram_inertia(rod["r_i"], rod["r_o"], rod["rho"], robot.l2)}
    for e in fx.of_kind("added_inertia"):
        if e.body != "platform":
            if e.body not in bodies:
                raise ValueError(f"effect {e.name!r}: added inertia on body {e.body!r}: expected one of "
                                 f"{', '.join(bodies)} or 'platform'")
            on, inertia = fx.term(e, i, ls)
            bodies[e.body] = bodies[e.body] + on * inertia
    return (body_inertia_contribution(prog, ls, 1, "J1", bodies["J1"], f"1_{tag}")
            + body_inertia_contribution(prog, ls, 3, "C3", bodies["C3"], f"3_{tag}"))


def _joint_series(robot: RobotDescription, fx: EffectSymbols, i: int):
    """Compliance of leg ``i``'s actuated joint: 1/k_a plus every joint-series effect (Eq. 34)."""
    c = 1 / robot.actuator_stiffness
    for e in fx.of_kind("joint_series"):
        on, ce = fx.term(e, i)
        c = c + on * ce
    return c


def _body_compliance(fx: EffectSymbols, ls, i: int) -> sp.Matrix:
    """Leg ``i``'s compliance at the EE origin: each body compliance moved from its
    body's frame (Eqs. 44, 49)."""
    Cs = sp.zeros(6, 6)
    for e in fx.of_kind("body_compliance"):
        on, C = fx.term(e, i, ls)
        if C is None:
            continue
        if e.body != "platform":
            if e.body not in ls.frames:
                raise ValueError(f"effect {e.name!r}: body {e.body!r}: expected a leg frame "
                                 f"({', '.join(ls.frames)}) or 'platform'")
            C = compliance_to_frame(C, *ls.frames[e.body])
        Cs += on * C
    return Cs


def _ground_springs(fx: EffectSymbols) -> sp.Matrix:
    """Springs between the tool and the ground, moved to the EE origin (K = A^T K_local A)."""
    K = sp.zeros(6, 6)
    for e in fx.of_kind("ground_spring"):
        on, (K_local, rotation, origin) = fx.term(e)
        K += on * stiffness_to_frame(sp.Matrix(K_local), sp.Matrix(rotation), sp.Matrix(origin))
    return K


def _preload_derivatives(prog: Program, robot: RobotDescription, q_all, screws, Je_all) -> list:
    """First term of Eq. 13: per leg and elastic joint, d(J_e^-T col k)/d q . J^-1.

    With tau_e the elastic joint torques of the loaded state (W_ext = J_e^-T tau_e,
    tau_e = K_qe J_e delta), d(J_e^-T tau_e)/dx gives +(d J_e^-T / d q . tau_e) J^-1:
    the paper's minus sign belongs to the opposite sign convention for tau_e. Checked: a
    hanging load stiffens the lateral modes (pendulum).
    """
    G = []
    for q, ls, Je in zip(q_all, screws, Je_all):
        joint_rows = (ls.rows[1], ls.rows[2], ls.rows[3])
        scale = (1, 1, 1 / robot.l2)          # the Pi joint coordinate is l2*q3 (m)
        for k in range(2):
            col = Je[k, :].T
            Gk = sp.zeros(6, 6)
            for qj, row, sc in zip(q, joint_rows, scale):
                Gk += derivative(prog, col, qj) * sc * row
            G.append(Gk)
    return G


def _preload_wrench(robot: RobotDescription, fx: EffectSymbols) -> sp.Matrix:
    """Static wrench [moment; force] (N m; N) at the EE origin of the platform's inertia
    (EE and added inertia on it) under each preload's acceleration."""
    S = _platform_inertia(robot, fx)
    mass = S[3, 3]
    first_moment = sp.Matrix([S[2, 4], S[0, 5], S[1, 3]])          # m c, from m [c]x
    W = sp.zeros(6, 1)
    for e in fx.of_kind("preload"):
        on, g = fx.term(e)
        g = sp.Matrix(g)
        W += on * sp.Matrix.vstack(first_moment.cross(g), mass * g)
    return W


def _platform_stiffness(prog: Program, robot: RobotDescription, K_groups: dict, fx: EffectSymbols) -> sp.Matrix:
    """K_F as the sum over platform bodies (issue 7): legs on the tool body add directly,
    legs on a body coupled to the tool add through the condensed coupling."""
    couplings = {c.body: c for c in robot.couplings}
    unknown = sorted(set(K_groups) - set(couplings) - {robot.tool_body})
    if unknown:
        raise ValueError(f"{robot.name}: legs attach to platform bodies {unknown} that are neither the tool body "
                         f"{robot.tool_body!r} nor coupled to it (couplings: {sorted(couplings)})")
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


def _lever(prog: Program, tag: str):
    """The reciprocal product w_a1 . t_a1 of leg ``tag`` (m): the actuation lever."""
    return sym(f"rp1_{tag}")
