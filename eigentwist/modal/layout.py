"""Where a modal test measured: DOFs on the platform and the model's mode shape there.

A translation DOF ``"NODE+AXIS"`` (:func:`.uff_io.dof_label`) is a node at position
``r`` (m, offset from the end-effector origin, platform axes: the platform does not
rotate between poses, so platform and base axes are parallel) and a unit direction
``e`` (+X, +Y or +Z). The model's mode shape there is the eigentwist ``t = [omega; v]``
(Eq. 6, rotation first) transported to the node and projected on the direction:

    u_d = e_d . (v + omega x r_d) = e_d^T T(r_d) t,   T(r) = [-[r]x, I3],

so the shape over D measured DOFs is ``P t`` with the (D, 6) projection ``P``
(:func:`projection`). A rigid model (3x3, translations only) has ``u_d = e_d . v``.
The measured and model shapes are compared by the MAC over those D DOFs
(:func:`eigentwist.diagnose.shapes.mac`). A layout gives a shape the model can be
compared with when every DOF's node has a position and ``P`` has rank >= 2
(:func:`shape_note` says why not, in one line).
"""

from __future__ import annotations

import numpy as np

from ..diagnose.shapes import transport_matrix
from .uff_io import parse_dof

__all__ = ["projection", "model_shapes", "shape_note", "note_line", "triaxial_node"]


def projection(dofs, coords: dict) -> np.ndarray:
    """(D, 6) rows ``e_d^T T(r_d)`` of the DOF labels ``dofs`` at node positions ``coords`` (m)."""
    rows = []
    for label in dofs:
        node, axis = parse_dof(label)
        rows.append(transport_matrix(np.asarray(coords[node], dtype=float))[axis - 1])
    return np.array(rows).reshape(-1, 6)


def model_shapes(eigentwists, P) -> np.ndarray:
    """(..., D, n) model shapes over the DOFs of projection ``P`` (D, 6) from eigentwists (..., n, n).

    Rigid models (n = 3, translations only) use the translation part ``P[:, 3:]``.
    """
    V = np.asarray(eigentwists)
    return (P[:, 3:] if V.shape[-2] == 3 else P) @ V


def shape_note(dofs, coords: dict) -> str | None:
    """None when the DOFs give a shape to compare with the model, else why not (a short phrase)."""
    if len(dofs) < 2:
        return f"one DOF, {', '.join(dofs)}"
    missing = sorted({parse_dof(d)[0] for d in dofs} - set(coords))
    if missing:
        listed = ", ".join(map(str, missing[:4])) + (", ..." if len(missing) > 4 else "")
        return f"no position of node{'s' if len(missing) > 1 else ''} {listed}"
    if np.linalg.matrix_rank(projection(dofs, coords), tol=1e-9) < 2:
        return "the DOFs see one motion"
    return None


def note_line(who: str, why: str) -> str:
    """The one line saying a layout gives no shape: ``WHO: no shape (WHY); frequencies and damping go on``."""
    return f"{who}: no shape ({why}); frequencies and damping go on"


def triaxial_node(dofs) -> int | None:
    """The first node measured along X, Y and Z among ``dofs`` (None when there is none)."""
    axes: dict[int, set] = {}
    for d in dofs:
        node, axis = parse_dof(d)
        axes.setdefault(node, set()).add(axis)
    return next((n for n, a in axes.items() if a == {1, 2, 3}), None)
