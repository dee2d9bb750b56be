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
from ..description.effects import EFFECTS, switch_name
from .inertia import body_inertia_contribution, parallelogram_inertia, point_mass_inertia
from .kinematics import leg_inverse_kinematics
from .leg import leg_screws
from .program import Program, derivative
from .screw import adjoint, compliance_to_frame
from .stiffness import (condense_coupling, inverse_2x2, rod_pair_compliance, rows_outer,
                        tube_cantilever_compliance)

__all__ = ["DerivedModel", "derive", "POSE"]

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
      elastic joint stiffness (Eq. 40); ``k_act`` (), the actuator stiffness in series.
    """

    robot: RobotDescription
    ik: Program
    ik_outputs: dict
    program: Program
    outputs: dict
    joints: list
    screws: list = field(default_factory=list)

    @property
    def parameters(self) -> tuple[str, ...]:
        return self.robot.parameter_names

    @property
    def switches(self) -> tuple[str, ...]:
        return tuple(switch_name(e) for e in self.robot.effects)


def _flat(m: sp.Matrix) -> list:
    return [m[i, j] for i in range(m.rows) for j in range(m.cols)]


def derive(robot: RobotDescription) -> DerivedModel:
    """Derive IK, M, K_R, K_F and the gravity terms of ``robot`` symbolically."""
    params = {p.name: p.symbol for p in robot.parameters}
    on = {e: sym(switch_name(e)) for e in EFFECTS}
    l1, l2 = robot.l1, robot.l2

    ik = Program()
    for s_ in POSE:
        ik.declare(s_)
    for s_ in params.values():
        ik.declare(s_)
    pose = sp.Matrix(POSE)
    q_all, sin_q3, cos_q2 = [], [], []
    for i, leg in enumerate(robot.legs, start=1):
        q, checks = leg_inverse_kinematics(ik, leg, pose, l1, l2, str(i))
        q_all.append(q)
        sin_q3.append(checks["sin_q3"])
        cos_q2.append(checks["cos_q2"])
    n = len(robot.legs)
    ik_outputs = {
        "q": ((n, 3), [qq for q in q_all for qq in q]),
        "sin_q3": ((n,), sin_q3),
        "cos_q2": ((n,), cos_q2),
    }

    prog = Program()
    joints = [qq for q in q_all for qq in q]
    for s_ in joints + list(params.values()) + [on[e] for e in robot.effects]:
        prog.declare(s_)

    rod = robot.rod
    m_par = parallelogram_inertia(rod["r_i"], rod["r_o"], rod["rho"], l2)
    eta = 1 + on["actuator_loss"] * (params["eta_a"] - 1)
    c_act = prog.let("c_act", 1 / (eta * params["k_a"]) + on["transmission_compliance"] / params["k_t"])
    k_act = prog.let("k_act", 1 / c_act)
    tube = robot.lower_link_tube

    M = robot.ee_inertia + on["payload_mass"] * point_mass_inertia(
        params["m_p"], sp.Matrix([params["p_x"], params["p_y"], params["p_z"]]))
    K_R = sp.zeros(6, 6)
    K_groups: dict = {}           # platform body -> Cartesian stiffness of its legs
    screws, J_rows, levers, Je_all, Kqe_all = [], [], [], [], []
    for i, (leg, q) in enumerate(zip(robot.legs, q_all), start=1):
        tag = str(i)
        ls = leg_screws(prog, leg, q, l1, l2, tag)
        screws.append(ls)
        # inertia, Eq. 32: body 1 (lower link + rotor) and body 3 (parallelogram)
        M += body_inertia_contribution(prog, ls, 1, "J1", robot.lower_link_inertia, f"1_{tag}")
        M += body_inertia_contribution(prog, ls, 3, "C3", m_par, f"3_{tag}")
        # rigid-body stiffness, Eqs. 14, 33, 34
        ja = ls.rows[1]
        K_R += rows_outer(ja, sp.Matrix([[k_act]]))
        # flexible-body stiffness, Eqs. 13, 37-50
        Je = sp.Matrix.vstack(ls.rows[1], ls.rows["c"])
        rot, _ = ls.frames["L2"]
        d_pi = rod["w_pi"] * ls.vectors["c3"]
        C_rod = rod_pair_compliance(l2, rod["r_i"], rod["r_o"], rod["E"], rod["G"], d_pi)
        Cs = on["rod_compliance"] * compliance_to_frame(C_rod, rot, ls.vectors["a"])
        if robot.ee_compliance is not None and (i - 1) in robot.ee_compliance.per_leg:
            Cs += compliance_to_frame(robot.ee_compliance.per_leg[i - 1], sp.eye(3),
                                      sp.Matrix(robot.ee_compliance.origin))
        rot1, tip1 = ls.frames["E1"]
        C_ll = tube_cantilever_compliance(l1, tube["r_i"], tube["r_o"], tube["E"], tube["nu"])
        Cs += on["lower_link_compliance"] * compliance_to_frame(C_ll, rot1, tip1)
        Cs = prog.let_matrix(f"Cs_{tag}", Cs)
        Cq = Je * Cs * Je.T + sp.diag(c_act, params["c_rigid"])        # Eqs. 41-43
        Cq = prog.let_matrix(f"Cq_{tag}", Cq)
        Kqe = prog.let_matrix(f"Kqe_{tag}", inverse_2x2(Cq))             # Eq. 40 block
        body = leg.platform_body
        K_groups[body] = K_groups.get(body, sp.zeros(6, 6)) + rows_outer(Je, Kqe)
        J_rows.append(sp.Matrix.vstack(ls.rows[1], ls.rows[2], ls.rows[3], ls.rows["c"]))
        levers.append(_lever(prog, tag))
        Je_all.append(Je)
        Kqe_all.append(Kqe)

    K_F = _platform_stiffness(prog, robot, K_groups, on)

    # gravity preload, first term of Eq. 13. With tau_e the elastic joint torques of the
    # loaded state (W_ext = J_e^-T tau_e, tau_e = K_qe J_e delta), d(J_e^-T tau_e)/dx gives
    # +(d J_e^-T / d q . tau_e) J^-1: the paper's minus sign belongs to the opposite sign
    # convention for tau_e. Checked: a hanging load stiffens the lateral modes (pendulum).
    G = []
    for i, (q, ls, Je) in enumerate(zip(q_all, screws, Je_all)):
        joint_rows = (ls.rows[1], ls.rows[2], ls.rows[3])
        scale = (1, 1, 1 / l2)          # the Pi joint coordinate is l2*q3 (m)
        for k in range(2):
            col = Je[k, :].T
            Gk = sp.zeros(6, 6)
            for qj, row, sc in zip(q, joint_rows, scale):
                Gk += derivative(prog, col, qj) * sc * row
            G.append(Gk)

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
            "k_act": ((), [k_act]),
        },
    }
    return DerivedModel(robot, ik, ik_outputs, prog, outputs, joints, screws)


def _platform_stiffness(prog: Program, robot: RobotDescription, K_groups: dict, on: dict) -> sp.Matrix:
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
        K_F += condense_coupling(prog, Kp, G, Kc, on[c.effect], body)
    return K_F


def _lever(prog: Program, tag: str):
    """The reciprocal product w_a1 . t_a1 of leg ``tag`` (m): the actuation lever."""
    return sym(f"rp1_{tag}")
