"""The RR(Pi)RR leg as a joint list, with its closed-form kinematics (Heli4, Delta).

The leg (Appendix A, with the facts file's corrections) is, from the base:

1. R, actuated: axis s_i through the actuated joint B_i (``pB``);
2. R: axis s_i through the elbow (``pE``);
3. Pi: the parallelogram, a curvilinear translation along s_i3 (``s3``); its coordinate
   is l2 q_i3 (m);
4. R: axis s_i4 (``s4``, normalised: its printed form has length cos q_i3) through a_i;
5. R: axis s_i through a_i;

and the ``virtual`` joint, the twist of restriction: a rotation about c_i1 (``ch``)
through a_i. Its bodies are the lower link with the rotor (frame J_i1) and the fictitious
rod replacing the parallelogram (frame C_i3). The derivation
(:mod:`eigentwist.symbolic.leg`) reads this list like any other; only the closed form of
the inverse kinematics and of the joint axes at the joint angles is specific to the
chain, and it lives here, as data of the leg (:class:`RRPiRRKinematics`).

All vectors are in base axes; points are measured from the end-effector origin.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from .chain import ChainBody, ChainJoint
from .robot import Leg

__all__ = ["RRPIRR_CHAIN", "RRPIRR_FRAMES", "RRPiRRKinematics", "rrpirr_leg"]

EZ = sp.Matrix([0, 0, 1])

#: the joints of an RR(Pi)RR leg, axes and locations named as in :meth:`RRPiRRKinematics.geometry`
RRPIRR_CHAIN = (
    ChainJoint("R", ("s",), "pB", actuated=True, doc="actuated base joint, axis s_i through B_i"),
    ChainJoint("R", ("s",), "pE", doc="elbow joint, axis s_i"),
    ChainJoint(
        "Pi",
        ("s3",),
        "pE",
        doc="parallelogram, translation along s_i3 (its coordinate is l2*q_i3, m); "
        "its rods swing by q_i3 about n_i2 (pivots on the elbow bar and at a_i)",
        swing=("n2", "l2"),
    ),
    ChainJoint("R", ("s4",), "a", doc="twist of the rods about each other, axis s_i4 through a_i"),
    ChainJoint("R", ("s",), "a", doc="joint at the platform, axis s_i through a_i"),
    ChainJoint("virtual", ("ch",), "a", doc="constrained rotation about c_i1 through a_i (twist of restriction)"),
)

#: frames of the leg's bodies, by name: (axes x, y, z as geometry names, origin)
RRPIRR_FRAMES = (
    ("J1", ("r1", "s", "n1"), "pB"),  # lower link at the actuated joint (Eq. 23)
    ("E1", ("r1", "s", "n1"), "pE"),  # lower link tip (the elbow)
    ("C3", ("r2", "s3", "n2"), "pC"),  # parallelogram centre (Eq. 26)
    ("L2", ("r2", "s3", "n2"), "a"),  # rod tips at a_i (App. C)
)


def _cross(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@dataclass(frozen=True)
class RRPiRRKinematics:
    """Closed-form kinematics of an RR(Pi)RR leg with lower link ``l1`` and parallelogram
    ``l2`` (m, parameter expressions).

    ``coordinates``: the IK's joint coordinates q1, q2, q3 (rad), each as (index of its
    joint in :data:`RRPIRR_CHAIN`, rate of that joint's coordinate per unit of q): the
    Pi joint's coordinate is l2 q3 (m). ``checks``: the reachability quantities (a pose
    is reachable iff both lie in [-1, 1]).
    """

    l1: Any
    l2: Any
    checks: tuple = ("sin_q3", "cos_q2")
    #: parallelogram width (m, the rods' spacing along s_i on the bars); with it the
    #: geometry also places the two rods (``pRa``, ``pRb`` pivots, ``cRa``, ``cRb`` centres)
    w_pi: Any = None

    @property
    def coordinates(self) -> tuple:
        return ((0, sp.Integer(1)), (1, sp.Integer(1)), (2, self.l2))

    #: unit twists (chain order) whose inverse-Jacobian rows ``J_rows`` reports: those of
    #: joints 1, 2, 3 (the IK coordinates) and the virtual joint
    jacobian_rows = (0, 1, 2, 5)

    def lever(self, screws, key):
        """The actuation lever (m): the reciprocal product ``w_a1 . t_a1`` of the actuation
        wrench scaled to a unit force, taken positive; ``l1 s.(r1 x r2)``."""
        force = screws.wrenches[key][3:, 0]
        return sp.sqrt(screws.products[key] ** 2 / force.dot(force))

    def inverse_kinematics(self, prog, leg: Leg, pose, tag: str):
        """Append the IK of ``leg`` at EE position ``pose.position`` (m; ``pose``: the
        robot's pose space, :mod:`.pose`) to ``prog`` (facts file).

        ``C_i = P + a_i``, ``D_i = C_i - B_i``; ``sin q3 = D_i . s_i / l2``; in the plane
        (u_i, -e_z) the two-link solution with lengths l1 and l2 cos q3 on the branch where
        the lower link points outward (q2 > 0). Returns ``(q, checks)``: the three joint
        angle symbols (rad) and ``{"sin_q3": ..., "cos_q2": ...}``.
        """
        l1, l2 = self.l1, self.l2
        u, s, a, B = (leg.vector(k) for k in ("radial", "axis", "attachment", "base"))
        D = prog.let_matrix(f"D_{tag}", pose.position + a - B)
        sin_q3 = prog.let(f"sin_q3_{tag}", D.dot(s) / l2)
        q3 = prog.let(f"q3_{tag}", sp.asin(sin_q3))
        lp = prog.let(f"lp_{tag}", l2 * sp.cos(q3))
        rho_u = prog.let(f"rhou_{tag}", D.dot(u))
        rho_z = prog.let(f"rhoz_{tag}", -D[2])
        cos_q2 = prog.let(f"cos_q2_{tag}", (rho_u**2 + rho_z**2 - l1**2 - lp**2) / (2 * l1 * lp))
        q2 = prog.let(f"q2_{tag}", sp.acos(cos_q2))
        q1 = prog.let(f"q1_{tag}", sp.atan2(rho_z, rho_u) - sp.atan2(lp * sp.sin(q2), l1 + lp * sp.cos(q2)))
        return (q1, q2, q3), {"sin_q3": sin_q3, "cos_q2": cos_q2}

    def geometry(self, prog, leg: Leg, q: tuple, pose, tag: str) -> dict:
        """The leg's named vectors at joint angles ``q = (q1, q2, q3)`` (rad; the pose
        enters through them only), appended to
        ``prog``: directions ``u, s, r1`` (lower link), ``w`` (parallelogram plane),
        ``r2`` (parallelogram centre line), ``s3`` (Pi translation), ``s4``, ``ch``
        (twist of restriction), ``n1 = r1 x s``, ``n2 = r2 x s3``; points (m from the EE
        origin) ``a``, ``pE`` (elbow), ``pB`` (actuated joint), ``pC`` (parallelogram
        centre); the scalar ``c3 = cos q3``."""
        l1, l2 = self.l1, self.l2
        u, s, a = leg.vector("radial"), leg.vector("axis"), leg.vector("attachment")
        q1, q2, q3 = q
        L = lambda name, e: prog.let(f"{name}_{tag}", e)  # noqa: E731
        Lv = lambda name, m: prog.let_matrix(f"{name}_{tag}", m)  # noqa: E731
        c1, s1 = L("c1", sp.cos(q1)), L("s1", sp.sin(q1))
        c12, s12 = L("c12", sp.cos(q1 + q2)), L("s12", sp.sin(q1 + q2))
        c3, s3 = L("c3", sp.cos(q3)), L("s3", sp.sin(q3))
        r1 = Lv("r1", c1 * u - s1 * EZ)  # lower link direction
        w = Lv("w", c12 * u - s12 * EZ)  # parallelogram plane direction
        r2 = Lv("r2", c3 * w + s3 * s)  # parallelogram centre line
        s3v = Lv("sp", c3 * s - s3 * w)  # Pi translation direction s_i3
        s4 = Lv("s4", _cross(_cross(r2, s), s) / c3)  # |(r2 x s) x s| = cos q3 (misprint 3)
        elbow = Lv("pE", a - l2 * r2)  # elbow, from the EE origin
        base = Lv("pB", elbow - l1 * r1)  # actuated joint, from the EE origin
        f5 = Lv("f5", _cross(_cross(r1, s), s3v))  # the force of wrench w_a5 (App. A)
        cvec = _cross(_cross(f5, s4), s4)
        chat = Lv("ch", cvec / L("nc", sp.sqrt(cvec.dot(cvec))))  # axis c_i1 of the twist of restriction
        g = dict(
            u=u,
            s=s,
            a=a,
            r1=r1,
            w=w,
            r2=r2,
            s3=s3v,
            s4=s4,
            c3=c3,
            pE=elbow,
            pB=base,
            ch=chat,
            pC=Lv("pC", elbow + l2 / 2 * r2),
            n1=_cross(r1, s),
            n2=_cross(r2, s3v),
            l2=l2,
        )
        if self.w_pi is not None:
            # the two rods, w_pi apart along s_i: pivots on the elbow bar, centres l2/2 along r2
            for side, sign in (("a", 1), ("b", -1)):
                g[f"pR{side}"] = elbow + sign * self.w_pi / 2 * s
                g[f"cR{side}"] = g["pC"] + sign * self.w_pi / 2 * s
        return g


def rrpirr_leg(
    name: str,
    base: tuple,
    radial: tuple,
    axis: tuple,
    attachment: tuple,
    l1,
    l2,
    lower_link: sp.Matrix,
    parallelogram: sp.Matrix,
    platform_body: str = "platform",
    w_pi=None,
) -> Leg:
    """An RR(Pi)RR leg as a joint list.

    base : actuated joint centre B_i (m, base frame); radial : outward unit vector u_i;
    axis : actuator axis s_i (``radial x axis = e_z``); attachment : a_i from the EE origin
    to the leg's connection point (m); l1, l2 : lower link and parallelogram lengths (m);
    lower_link : 6x6 spatial inertia of the lower link with its rotor in frame J_i1
    (Eqs. 21-23); parallelogram : 6x6 spatial inertia of the fictitious rod in frame C_i3
    (Eqs. 26-29); platform_body : the platform body the leg attaches to;
    w_pi : the parallelogram width (m); with it the leg also lists the two real rods
    ``rod_a``, ``rod_b`` (at +-w_pi/2 along s_i), hanging on the Pi joint's swing about their
    own pivots, with zero inertia: the fictitious rod C3 carries their mass unless the
    ``swinging_rods`` effect moves it onto them.
    """
    frames = dict((f, (axes, origin)) for f, axes, origin in RRPIRR_FRAMES)
    bodies = (
        ChainBody("J1", 1, lower_link, *frames["J1"], doc="lower link with the actuator rotor (Eqs. 21-23)"),
        ChainBody("C3", 3, parallelogram, *frames["C3"], doc="fictitious rod replacing the parallelogram (Eqs. 26-29)"),
    )
    if w_pi is not None:
        bodies += tuple(
            ChainBody(
                f"rod_{side}",
                3,
                sp.zeros(6, 6),
                ("r2", "s3", "n2"),
                f"cR{side}",
                pivot=f"pR{side}",
                doc=f"parallelogram rod {side}, swinging with q_i3 about its pivot on the elbow bar "
                "(no inertia unless the swinging_rods effect is on)",
            )
            for side in ("a", "b")
        )
    return Leg(
        name,
        base,
        radial,
        axis,
        attachment,
        joints=RRPIRR_CHAIN,
        bodies=bodies,
        frames=RRPIRR_FRAMES,
        kinematics=RRPiRRKinematics(l1, l2, w_pi=w_pi),
        platform_body=platform_body,
    )
