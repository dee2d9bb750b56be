"""Unit twists, reciprocal wrenches and inverse-Jacobian rows of one leg, from its joint list.

The leg (:class:`~eigentwist.description.Leg`) lists its joints (kind, axes and location
as names of its geometry) and the closed form that places them at the joint angles
(``leg.kinematics.geometry``). Each joint gives its unit twists ``[omega; v]`` at the
platform origin (:func:`joint_twists`: a table from the joint kind to its twists); a leg with fewer
than six freedoms lists one ``virtual`` joint (its twist of restriction) per constraint.
Huang's method (Eq. 15 of the facts file) gives the row of twist k of the leg's inverse
Jacobian as ``w_k^T / (w_k . t_k)``, with ``w_k`` reciprocal to the five other unit
twists: their generalised cross product from 5x5 minors
(:func:`reciprocal_wrench`), never a 6x6 inverse. The wrench
of a virtual joint is a constraint wrench; the others are actuation wrenches. Nothing
here depends on which chain the leg is.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import DescriptionError
from ..description import Leg
from ..description.joints import JOINT_KINDS
from .program import Program
from ..description.screw import pure_translation, reciprocal_product, unit_twist

__all__ = ["LegScrews", "leg_screws", "joint_twists", "reciprocal_wrench", "TWISTS"]

BASE_AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def _vector(geometry: dict, item) -> sp.Matrix:
    return sp.Matrix(geometry[item]) if isinstance(item, str) else sp.Matrix(item)


def _rotations(axes, location, geometry: dict, origin: sp.Matrix) -> list:
    point = _vector(geometry, location) - origin
    return [unit_twist(_vector(geometry, a), point) for a in axes]


def _translation(axes, location, geometry: dict, origin: sp.Matrix) -> list:
    return [pure_translation(_vector(geometry, axes[0]))]


#: the unit twists of each joint kind, from its record's motion
#: (:data:`~eigentwist.description.joints.JOINT_KINDS`): rotations about its axes through its
#: location (R, U, S and the virtual joint's twist of restriction), or a translation along
#: its axis (P, and Pi: a curvilinear translation)
TWISTS = {
    name: {"rotation": _rotations, "translation": _translation}[kind.motion] for name, kind in JOINT_KINDS.items()
}


def joint_twists(joint, geometry: dict, origin: sp.Matrix) -> list[sp.Matrix]:
    """The unit twists ``[omega; v]`` of one joint at the platform origin ``origin`` (m,
    the frame of the geometry's points), base axes (none given: the base axes)."""
    return TWISTS[joint.kind](joint.axes or BASE_AXES, joint.location, geometry, origin)


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
        sub = _minor(prog, T, rows[1:], cols[:k] + cols[k + 1 :], memo, tag)
        if sub != 0:
            total += (-1) ** k * entry * sub
    name = f"mn_{tag}_{''.join(map(str, rows))}_{''.join(map(str, cols))}"
    memo[key] = prog.let(name, total) if len(rows) > 1 else total
    return memo[key]


def reciprocal_wrench(prog: Program, T: sp.Matrix, others: tuple, memo: dict, tag: str) -> sp.Matrix:
    """Wrench reciprocal to the five unit twists ``T[others, :]`` (rows of T): their
    generalised cross product, ``w_j = (-1)^j det(T[others, all but j])``."""
    cols = tuple(range(6))
    return sp.Matrix([(-1) ** j * _minor(prog, T, others, cols[:j] + cols[j + 1 :], memo, tag) for j in range(6)])


def _parity(order: list) -> int:
    """Sign (+1 or -1) of the permutation ``order`` of ``range(len(order))``."""
    sign, seen = 1, set()
    for start in range(len(order)):
        k, length = start, 0
        while k not in seen:
            seen.add(k)
            k, length = order[k], length + 1
        if length and length % 2 == 0:
            sign = -sign
    return sign


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
    frames : (rotation, origin) of the leg's named frames (``Leg.frames``), origins
        from the platform origin.
    vectors : the leg's geometry at the joint angles (named vectors and scalars).
    origin : the platform origin in the geometry's coordinates (m; zero when the
        geometry's points are measured from it).
    determinant : det of the six unit twists as rows in chain order (the reciprocal
        product of any twist with its wrench, up to the sign of the twists' order).
    """

    twists: dict
    wrenches: dict
    products: dict
    rows: dict
    keys: list
    joint_of: list
    frames: dict
    vectors: dict
    origin: sp.Matrix
    determinant: sp.Expr

    def twists_of(self, joints: int) -> list:
        """Keys of the twists of the first ``joints`` joints of the chain."""
        return [k for k, j in zip(self.keys, self.joint_of) if j < joints]


def _keys(leg: Leg) -> tuple[list, list]:
    """Twist keys and joint indices in chain order: 1, 2, ... then c (or c1, c2, ...)."""
    n_virtual = sum(j.freedoms for j in leg.joints if j.virtual)
    keys, joint_of, real, virtual = [], [], 0, 0
    for j, joint in enumerate(leg.joints):
        for _ in range(joint.freedoms):
            if joint.virtual:
                virtual += 1
                keys.append("c" if n_virtual == 1 else f"c{virtual}")
            else:
                real += 1
                keys.append(real)
            joint_of.append(j)
    return keys, joint_of


def leg_screws(prog: Program, leg: Leg, q: tuple, pose, tag: str) -> LegScrews:
    """Build the screws of ``leg`` at its joint coordinates ``q`` (the IK's: rad, or m for
    a P joint) and the pose space ``pose`` (:mod:`eigentwist.description.pose`: the twists
    are taken at ``pose.origin``) in ``prog``.

    Raises ``ValueError`` when the joint list does not give six unit twists.
    """
    g = leg.kinematics.geometry(prog, leg, q, pose, tag)
    origin = pose.origin
    keys, joint_of = _keys(leg)
    if len(keys) != 6:
        raise DescriptionError(
            f"{leg.name}: {len(keys)} unit twists: a leg with fewer than six freedoms lists one "
            f"'virtual' joint (its twist of restriction) per constraint, six twists in all"
        )
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
    frames = {
        name: (sp.Matrix.hstack(*[sp.Matrix(g[a]) for a in axes]), sp.Matrix(g[origin_name]) - origin)
        for name, axes, origin_name in leg.frames
    }
    first = [0] + [m for m in order if m != 0]
    determinant = _parity(first) * products[keys[0]]
    return LegScrews(twists, wrenches, products, rows, keys, joint_of, frames, g, origin, determinant)
