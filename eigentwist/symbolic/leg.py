"""Unit twists and reciprocal wrenches of one RR(Pi)RR leg (Appendix A, corrected).

All screws are expressed at the end-effector origin with base-frame axes. The joint
angles ``q1, q2, q3`` are the actuated angle, the elbow angle and the parallelogram
angle; the two platform joints do not appear in any screw. Corrections from the facts
file: r_i2 of legs 2 and 3 in their general form, s_i4 normalised (its length is
cos q3), and the inverse-Jacobian rows built as wrench / reciprocal product (Huang's
method, Eq. 15 of the facts file), never by inverting a 6x6 matrix.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..description import Leg
from .program import Program
from .screw import cross, pure_moment, pure_translation, reciprocal_product, unit_twist, wrench_on_line

__all__ = ["LegScrews", "leg_screws"]

EZ = sp.Matrix([0, 0, 1])


@dataclass
class LegScrews:
    """Named screws of one leg (all 6x1 unless stated).

    twists : ``ta1..ta5`` (permission) and ``tc`` (restriction), Appendix A.
    rows : inverse-Jacobian rows ``w / (w . t)`` (1x6) for joints 1, 2, 3 and the
        constraint ``c``; row 3 maps to the parallelogram translation l2*q3 (m).
    frames : (rotation, origin) of the local frames J_i1 (lower link at the actuated
        joint), C_i3 (parallelogram centre), L_i2 (rod tips at a_i), E_i1 (lower link tip).
    """

    twists: dict
    wrenches: dict
    rows: dict
    frames: dict
    vectors: dict


def leg_screws(prog: Program, leg: Leg, q: tuple, l1, l2, tag: str) -> LegScrews:
    """Build the screws of ``leg`` at joint angles ``q = (q1, q2, q3)`` (rad) in ``prog``."""
    u, s, a = leg.vector("radial"), leg.vector("axis"), leg.vector("attachment")
    q1, q2, q3 = q
    L = lambda name, e: prog.let(f"{name}_{tag}", e)  # noqa: E731
    Lv = lambda name, m: prog.let_matrix(f"{name}_{tag}", m)  # noqa: E731
    c1, s1 = L("c1", sp.cos(q1)), L("s1", sp.sin(q1))
    c12, s12 = L("c12", sp.cos(q1 + q2)), L("s12", sp.sin(q1 + q2))
    c3, s3 = L("c3", sp.cos(q3)), L("s3", sp.sin(q3))
    r1 = Lv("r1", c1 * u - s1 * EZ)                    # lower link direction
    w = Lv("w", c12 * u - s12 * EZ)                    # parallelogram plane direction
    r2 = Lv("r2", c3 * w + s3 * s)                     # parallelogram centre line
    s3v = Lv("sp", c3 * s - s3 * w)                    # Pi translation direction s_i3
    s4 = Lv("s4", cross(cross(r2, s), s) / c3)         # |(r2 x s) x s| = cos q3 (misprint 3)
    elbow = Lv("pE", a - l2 * r2)                      # elbow, from the EE origin
    base = Lv("pB", elbow - l1 * r1)                   # actuated joint, from the EE origin

    ta = {
        1: unit_twist(s, base),
        2: unit_twist(s, elbow),
        3: pure_translation(s3v),
        4: unit_twist(s4, a),
        5: unit_twist(s, a),
    }
    f2 = Lv("f2", cross(cross(l1 * r1 + l2 * r2, s), s3v))
    f5 = Lv("f5", cross(cross(r1, s), s3v))
    cvec = cross(cross(f5, s4), s4)
    cnorm = L("nc", sp.sqrt(cvec.dot(cvec)))
    chat = Lv("ch", cvec / cnorm)
    ta["c"] = unit_twist(chat, a)                      # twist of restriction
    wa = {
        1: wrench_on_line(r2, a),
        2: wrench_on_line(f2, a),
        3: wrench_on_line(s, a),
        4: pure_moment(s4),
        5: wrench_on_line(f5, elbow + l2 * s3 * s),
        "c": pure_moment(cross(r2, s)),                # wrench of constraint
    }
    rows = {}
    for k in (1, 2, 3, 5, "c"):
        tw = Lv(f"t{k}", ta[k])
        wr = Lv(f"w{k}", wa[k])
        ta[k] = tw
        recip = L(f"rp{k}", reciprocal_product(wr, tw))
        rows[k] = Lv(f"j{k}", wr.T / recip)
    frames = {
        "J1": (sp.Matrix.hstack(r1, s, cross(r1, s)), base),
        "C3": (sp.Matrix.hstack(r2, s3v, cross(r2, s3v)), elbow + l2 / 2 * r2),
        "L2": (sp.Matrix.hstack(r2, s3v, cross(r2, s3v)), a),
        "E1": (sp.Matrix.hstack(r1, s, cross(r1, s)), elbow),
    }
    return LegScrews(ta, wa, rows, frames, dict(r1=r1, r2=r2, s3=s3v, s4=s4, c3=c3, u=u, s=s, a=a))
