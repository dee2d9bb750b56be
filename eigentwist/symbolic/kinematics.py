"""Closed-form inverse kinematics of RR(Pi)RR legs (facts file).

For a translational pose P = (x, y, z) (m, base frame, end-effector rotation 0):

* the leg's connection point is ``C_i = P + a_i`` and ``D_i = C_i - B_i``;
* ``sin q3 = D_i . s_i / l2`` (parallelogram angle);
* in the plane (u_i, -e_z) a two-link solution with lengths ``l1`` and
  ``l2 cos q3`` on the branch where the lower link points outward (q2 > 0).

Reachability is decided from ``sin_q3`` and ``cos_q2`` (both must lie in [-1, 1]);
the runtime checks them and names the pose and the leg when they do not.
"""
from __future__ import annotations

import sympy as sp

from ..description import Leg
from .program import Program

__all__ = ["leg_inverse_kinematics"]


def leg_inverse_kinematics(prog: Program, leg: Leg, pose: sp.Matrix, l1, l2, tag: str):
    """Append the IK of ``leg`` to ``prog``.

    Returns ``(q, checks)``: the three joint angle symbols (rad) and a dict with
    ``sin_q3`` and ``cos_q2`` (reachable iff both lie in [-1, 1]).
    """
    u, s, a, B = (leg.vector(k) for k in ("radial", "axis", "attachment", "base"))
    D = prog.let_matrix(f"D_{tag}", pose + a - B)
    sin_q3 = prog.let(f"sin_q3_{tag}", D.dot(s) / l2)
    q3 = prog.let(f"q3_{tag}", sp.asin(sin_q3))
    lp = prog.let(f"lp_{tag}", l2 * sp.cos(q3))
    rho_u = prog.let(f"rhou_{tag}", D.dot(u))
    rho_z = prog.let(f"rhoz_{tag}", -D[2])
    cos_q2 = prog.let(f"cos_q2_{tag}", (rho_u**2 + rho_z**2 - l1**2 - lp**2) / (2 * l1 * lp))
    q2 = prog.let(f"q2_{tag}", sp.acos(cos_q2))
    q1 = prog.let(f"q1_{tag}", sp.atan2(rho_z, rho_u) - sp.atan2(lp * sp.sin(q2), l1 + lp * sp.cos(q2)))
    return (q1, q2, q3), {"sin_q3": sin_q3, "cos_q2": cos_q2}
