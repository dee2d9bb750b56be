"""Unit twists, reciprocal wrenches and inverse-Jacobian rows of one leg, from its joint list.

The leg (:class:`~eigentwist.description.Leg`) lists its joints (kind, axes and location
as names of its geometry) and the closed form that places them at the joint angles
(``leg.kinematics.geometry``). Each joint gives its unit twists ``[omega; v]`` at the
end-effector origin (:func:`eigentwist.symbolic.chain.joint_twists`); a leg with fewer
than six freedoms lists one ``virtual`` joint (its twist of restriction) per constraint.
Huang's method (Eq. 15 of the facts file) gives the row of twist k of the leg's inverse
Jacobian as ``w_k^T / (w_k . t_k)``, with ``w_k`` reciprocal to the five other unit
twists: their generalised cross product from 5x5 minors
(:func:`eigentwist.symbolic.chain.reciprocal_wrench`), never a 6x6 inverse. The wrench
of a virtual joint is a constraint wrench; the others are actuation wrenches. Nothing
here depends on which chain the leg is.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..description import Leg
from .chain import joint_twists, reciprocal_wrench
from .program import Program
from .screw import reciprocal_product

__all__ = ["LegScrews", "leg_screws"]


@dataclass
class LegScrews:
    """Named screws of one leg at its joint angles (all 6x1 unless stated).

    twists : unit twists keyed by their 1-based position in the chain (U and S give
        one per axis) and ``"c"`` for the twist of restriction (``"c1"``, ``"c2"``, ...
        when the leg has several).
    wrenches : the reciprocal wrench of each twist (any scale: Huang's method needs
        only its line); those of ``"c..."`` are the constraint wrenches.
    products : the reciprocal products ``w . t`` of each twist with its wrench.
    rows : inverse-Jacobian rows ``w / (w . t)`` (1x6) of each twist: its joint rate
        per unit platform twist (m/s per m/s for a P or Pi joint).
    keys : the twists' keys in chain order; ``joint_of``: the index of each one's joint.
    frames : (rotation, origin) of the leg's named frames (``Leg.frames``).
    vectors : the leg's geometry at the joint angles (named vectors and scalars).
    """

    twists: dict
    wrenches: dict
    products: dict
    rows: dict
    keys: list
    joint_of: list
    frames: dict
    vectors: dict

    def twists_of(self, joints: int) -> list:
        """Keys of the twists of the first ``joints`` joints of the chain."""
        return [k for k, j in zip(self.keys, self.joint_of) if j < joints]


def _keys(leg: Leg) -> tuple[list, list]:
    """Twist keys and joint indices in chain order: 1, 2, ... then c (or c1, c2, ...)."""
    n_virtual = sum(j.freedoms for j in leg.joints if j.kind == "virtual")
    keys, joint_of, real, virtual = [], [], 0, 0
    for j, joint in enumerate(leg.joints):
        for _ in range(joint.freedoms):
            if joint.kind == "virtual":
                virtual += 1
                keys.append("c" if n_virtual == 1 else f"c{virtual}")
            else:
                real += 1
                keys.append(real)
            joint_of.append(j)
    return keys, joint_of


def leg_screws(prog: Program, leg: Leg, q: tuple, tag: str) -> LegScrews:
    """Build the screws of ``leg`` at its joint coordinates ``q`` (the IK's, rad) in ``prog``.

    Raises ``ValueError`` when the joint list does not give six unit twists.
    """
    g = leg.kinematics.geometry(prog, leg, q, tag)
    origin = sp.zeros(3, 1)                         # the geometry is measured from the EE origin
    keys, joint_of = _keys(leg)
    if len(keys) != 6:
        raise ValueError(f"{leg.name}: {len(keys)} unit twists: a leg with fewer than six freedoms lists one "
                         f"'virtual' joint (its twist of restriction) per constraint, six twists in all")
    listed = [t for joint in leg.joints for t in joint_twists(joint, g, origin)]
    twists = {k: prog.let_matrix(f"t{k}_{tag}", t) for k, t in zip(keys, listed)}
    T = sp.Matrix.hstack(*twists.values()).T
    memo: dict = {}
    wrenches, products, rows = {}, {}, {}
    # the sparsest twists last: the small minors, shared between the wrenches, are then
    # the sparse ones (fewest minors to name); reordering the five twists only flips the
    # wrench's sign, which the row divides out
    order = sorted(range(6), key=lambda m: sum(1 for e in T[m, :] if e == 0))
    for i, k in enumerate(keys):
        others = tuple(m for m in order if m != i)
        w = prog.let_matrix(f"w{k}_{tag}", reciprocal_wrench(prog, T, others, memo, tag))
        recip = prog.let(f"rp{k}_{tag}", reciprocal_product(w, twists[k]))
        wrenches[k], products[k] = w, recip
        rows[k] = prog.let_matrix(f"j{k}_{tag}", w.T / recip)
    frames = {name: (sp.Matrix.hstack(*[sp.Matrix(g[a]) for a in axes]), sp.Matrix(g[origin_name]))
              for name, axes, origin_name in leg.frames}
    return LegScrews(twists, wrenches, products, rows, keys, joint_of, frames, g)
