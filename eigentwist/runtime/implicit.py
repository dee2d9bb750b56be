"""Derivatives through coordinates that are solved, not written in closed form.

Legs in URDF form have joint coordinates ``q`` defined implicitly by their loop closure
``r(q, p) = 0`` (:mod:`.levenberg_marquardt`). By the implicit function theorem,

    J_q dq/dp = -dr/dp,

with ``J_q`` the closure's exact Jacobian (the generated ``loop_closure`` kernel's
``dresidual``) and ``dr/dp`` the residual's derivative at fixed ``q`` (central differences
of the residual kernel: the closure is a smooth expression of the parameters, so the
truncation is ~h^2 and no Newton solve is repeated). A leg with more closure rows than
coordinates (a consistent system) takes the least-squares solution. Along that tangent,
the matrices' total derivatives are central differences at ``q +- h dq/dp`` and ``p +- h``
(the second-order terms of the solution path cancel in the symmetric difference).

A lower-mobility platform's rigid model lives on allowed twists ``B(p)`` that turn with
the pose and the parameters; its pencil ``(B^T K_R B, B^T M B)`` is differentiated by
central differences with the followers re-solved; the eigenvalue derivatives
``v^T (dK - lambda dM) v`` hold for any smooth choice of ``B`` (:mod:`.sensitivity`).
Its flexible models' matrices depend on the parameters also through the followers (the
pose coordinates the legs' closures fix): the total derivative adds ``(dX/dx) dx/dp`` to
the one at fixed pose (:func:`follower_terms`).
"""

from __future__ import annotations

import numpy as np

from .levenberg_marquardt import tangent

__all__ = [
    "difference_steps",
    "follower_terms",
    "joint_derivatives",
    "numeric_matrix_derivatives",
    "reduced_derivatives",
]

#: pose step (m, rad) of the central differences along the followers' tangent
POSE_STEP = 1e-6


def difference_steps(ev, wrt, params: dict):
    """``[(name, value, h, central), ...]``: each parameter's value and step
    (:func:`.sensitivity.difference_step`, the one step rule of the differences) and whether a
    central difference stays above the parameter's lower bound (else one-sided, second order)."""
    from .sensitivity import difference_step

    out = []
    for name in wrt:
        value, h = difference_step(ev, name, params)
        base = name.partition("@")[0]
        out.append((name, value, h, bool(np.all(value - h > ev.parameters[base].bounds[0]))))
    return out


def _difference(f, name, value, h, central: bool, params: dict, at0=None):
    """d f / d name by central differences (or one-sided, second order), ``f(params)``
    returning arrays or dicts of arrays; h broadcasts against the leading axis."""

    def div(a, b, c=None):
        hh = np.reshape(h, np.shape(h) + (1,) * (np.ndim(a) - np.ndim(h)))
        return (a - b) / (2 * hh) if c is None else (4 * a - 3 * b - c) / (2 * hh)

    hi = f({**params, name: value + h})
    if central:
        lo = f({**params, name: value - h})
        return {k: div(hi[k], lo[k]) for k in hi} if isinstance(hi, dict) else div(hi, lo)
    hi2 = f({**params, name: value + 2 * h})
    return {k: div(hi[k], at0[k], hi2[k]) for k in hi} if isinstance(hi, dict) else div(hi, at0, hi2)


def joint_derivatives(ev, poses: np.ndarray, wrt, params: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(q, dq/dp)``: joint coordinates (N, legs, n_q) of legs solved numerically at the
    completed ``poses`` and their derivatives (N, legs, n_q, len(wrt)) (rad, m for a
    prismatic joint, per SI unit of each parameter)."""
    n = len(poses)
    p = ev.parameter_values(n, "paper", **params)
    ev.joint_angles(poses, **params)  # unreachable or singular: one line
    q = ev.solve_joints(poses, p)
    closure = ev.kernels.loop_closure

    def inputs(pp: dict) -> dict:
        return ev.closure_inputs(poses, pp)

    A = closure(q, inputs(p))["dresidual"]  # (N, legs, rows, n_q)
    r0 = None
    cols = []
    for name, value, h, central in difference_steps(ev, wrt, params):

        def residual(pp: dict):
            return closure(q, inputs(ev.parameter_values(n, "paper", **pp)))["residual"]

        if not central and r0 is None:
            r0 = closure(q, inputs(p))["residual"]
        cols.append(_difference(residual, name, value, h, central, params, r0))
    dr = np.stack(cols, axis=-1)  # (N, legs, rows, P)
    return q, tangent(A, dr)


def numeric_matrix_derivatives(ev, poses: np.ndarray, wrt, model, params: dict) -> dict:
    """``M, K_R, K_F`` (N, 6, 6) and ``dM, dK_R, dK_F`` (N, P, 6, 6) of a robot whose legs
    are solved numerically: central differences along the implicit tangent
    ``(q + h dq/dp, p + h)`` (:func:`joint_derivatives`), no Newton solve repeated."""
    n = len(poses)
    q, dq = joint_derivatives(ev, poses, wrt, params)
    names = ("M", "K_R", "K_F")

    def matrices(qq: np.ndarray, pp: dict) -> dict:
        out = ev.kernels.matrices(qq, {**ev.parameter_values(n, model, **pp), **ev.pose_inputs(poses)})
        return {k: out[k] for k in names}

    out = matrices(q, params)
    d = {"d" + k: np.empty((n, len(wrt), 6, 6)) for k in names}
    for j, (name, value, h, central) in enumerate(difference_steps(ev, wrt, params)):
        hq = np.reshape(h, np.shape(h) + (1, 1)) * dq[..., j]

        def along(pp: dict, name=name, value=value):
            t = (np.asarray(pp[name]) - value) / np.where(h > 0, h, 1.0)  # -1, 1 or 2
            return matrices(q + np.reshape(t, np.shape(t) + (1, 1)) * hq, pp)

        step = _difference(along, name, value, h, central, params, out)
        for k in names:
            d["d" + k][:, j] = step[k]
    out.update(d)
    return out


def reduced_derivatives(ev, given, wrt, model, params: dict) -> dict:
    """``M, K`` (N, n, n) of the rigid model on the allowed twists and ``dM, dK``
    (N, P, n, n): central differences of the reduced pencil with the followers and the
    basis recomputed at each step (commanded ``given`` poses)."""
    M, K = ev.stiffness(given, model, **params)
    out = {
        "M": M,
        "K": K,
        "dM": np.empty((len(M), len(wrt)) + M.shape[1:]),
        "dK": np.empty((len(M), len(wrt)) + M.shape[1:]),
    }

    def pencil(pp: dict) -> dict:
        Mp, Kp = ev.stiffness(given, model, **pp)
        return {"M": Mp, "K": Kp}

    for j, (name, value, h, central) in enumerate(difference_steps(ev, wrt, params)):
        step = _difference(pencil, name, value, h, central, params, {"M": M, "K": K})
        out["dM"][:, j], out["dK"][:, j] = step["M"], step["K"]
    return out


def follower_terms(ev, given, poses, wrt, model, params: dict) -> dict:
    """``dM, dK_R, dK_F`` (N, len(wrt), 6, 6): what a lower-mobility platform's followers add
    to the matrices' derivatives as they move with the parameters, ``(dX/dx) dx/dp``.
    ``dx/dp`` (N, 6) by central differences of the follower solution at the commanded
    ``given`` poses (the commanded coordinates do not move); ``(dX/dx) dx/dp`` by central
    differences at fixed parameters along that tangent from the completed ``poses``, a step
    of :data:`POSE_STEP` in its largest coordinate. Zero for a parameter the followers do not
    depend on (masses, stiffnesses)."""
    names = ("M", "K_R", "K_F")
    base = np.asarray(poses, dtype=float)
    d = {"d" + k: np.zeros((len(base), len(wrt), 6, 6)) for k in names}

    def completed(pp: dict) -> np.ndarray:
        return np.asarray(ev.completed_poses(given, **pp), dtype=float)

    for j, (name, value, h, central) in enumerate(difference_steps(ev, wrt, params)):
        dx = _difference(completed, name, value, h, central, params, base)
        size = np.max(np.abs(dx), axis=1)
        moving = size > 0
        if not moving.any():
            continue
        t = (POSE_STEP / size[moving])[:, None]
        hi, lo = (ev.matrices((base[moving] + s * t * dx[moving]).view(type(poses)), model, **params) for s in (1, -1))
        for k in names:
            d["d" + k][moving, j] = (hi[k] - lo[k]) / (2 * t[:, :, None])
    return d
