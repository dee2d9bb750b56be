"""Maximise the worst-case lowest natural frequency over a workspace, with exact gradients.

Epigraph formulation over the design variables p (each inside its ``--vary`` range) and
the level t (Hz):

    maximise t   subject to   f_k(p, x_j) >= t   for every pose x_j and k = 1 .. n_track,

where f_1 <= f_2 <= ... are the model's natural frequencies at pose x_j. Tracking the lowest
``n_track`` (default 2) modes gives the solver one constraint per mode of a cluster: where
the two lowest modes meet, each keeps its own (individual, cluster-aware) derivative
(:meth:`eigentwist.runtime.Evaluator.sensitivities`). Every value and gradient comes from
one call of the generated sensitivity kernel per design point (no finite differences).

``moving-mass`` is the translational apparent mass of the platform at the robot's
reference pose x_ref: the mean of the diagonal of M's translational 3x3 block,
(M_xx + M_yy + M_zz) / 3 in kg (Eq. 12: end-effector, payload, parallelograms and lower
links seen at the end-effector). Its gradient is the same mean of dM/dp.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

from ..errors import InputError
import numpy as np

__all__ = ["Vary", "Constraint", "OptimizationResult", "optimize_worst_case", "moving_mass", "QUANTITIES"]

QUANTITIES = {"moving-mass": ("kg", "translational apparent mass at x_ref: mean diagonal of M's translational block")}


@dataclass(frozen=True)
class Vary:
    """A design variable: parameter ``name`` in ``[lo, hi]`` (SI units)."""

    name: str
    lo: float
    hi: float

    def __post_init__(self):
        if not (math.isfinite(self.lo) and math.isfinite(self.hi) and self.lo < self.hi):
            raise InputError(f"vary {self.name}: expected finite lo < hi, got {self.lo}:{self.hi}")


@dataclass(frozen=True)
class Constraint:
    """``quantity op value``, e.g. ``moving-mass <= 1.2`` (kg)."""

    quantity: str
    op: str
    value: float

    def __post_init__(self):
        if self.quantity not in QUANTITIES:
            raise InputError(f"constraint {self.quantity!r}: expected one of {', '.join(QUANTITIES)}")
        if self.op not in ("<=", ">="):
            raise InputError(f"constraint {self.quantity}{self.op}: expected <= or >=")

    def slack(self, value: float) -> float:
        """>= 0 when satisfied (same units as the quantity)."""
        return self.value - value if self.op == "<=" else value - self.value

    def __str__(self) -> str:
        return f"{self.quantity} {self.op} {self.value:g} {QUANTITIES[self.quantity][0]}"


@dataclass
class OptimizationResult:
    """The best design found.

    values : varied parameter -> value (SI); worst_hz : min over poses of f1 (Hz);
    f1_hz : (J,) lowest frequency per pose; poses : (J, 3) m, or (J, 6) m and rad for a
    6-DoF robot; start : the starting design and its worst_hz; active : the active bounds
    and constraints (strings);
    constraints : quantity -> value at the optimum; evaluations : sensitivity-kernel
    calls; nit : solver iterations; history : worst f1 per evaluation.
    """

    values: dict
    worst_hz: float
    f1_hz: np.ndarray
    poses: np.ndarray
    start: dict
    start_worst_hz: float
    active: list
    constraints: dict
    success: bool
    message: str
    nit: int
    evaluations: int
    dropped_poses: int = 0
    history: list = field(default_factory=list)


def moving_mass(ev, wrt, params: dict, model="paper", method: str = "exact"):
    """``(mass, gradient)``: the translational apparent mass at x_ref (kg), the mean of M's
    diagonal entries along v_x, v_y, v_z (Eq. 12), and d/dp (kg per SI unit): from the
    reverse-mode kernel the frequencies' derivatives use (``method="exact"``: one sweep for
    every parameter, ``Evaluator.sensitivity_route.weighted_mass``) or central differences of
    M (``"differences"``, nothing derived)."""
    x = np.asarray(ev.robot.x_ref, dtype=float)[None, :]
    tt = np.arange(3, 6)
    if method == "differences":
        out = ev.matrix_derivatives(x, tuple(wrt), model, **params)
        return float(out["M"][0, tt, tt].mean()), out["dM"][0][:, tt, tt].mean(axis=-1)
    weights = np.zeros((6, 6))
    weights[tt, tt] = 1.0 / 3.0
    value, gradient = ev.sensitivity_route.weighted_mass(x, tuple(wrt), model, dict(params), weights)
    return float(value[0]), gradient[0]


class _Problem:
    """Values and exact gradients of the epigraph problem, one kernel call per design point."""

    def __init__(self, ev, vary, poses, model, params, constraints, n_track, progress, jacobian="differences"):
        self.ev, self.vary, self.poses, self.model = ev, list(vary), poses, model
        self.jacobian = jacobian
        self.params = dict(params or {})
        self.constraints = list(constraints)
        self.n_track = n_track
        self.progress = progress
        self.wrt = tuple(v.name for v in self.vary)
        self.lo = np.array([v.lo for v in self.vary])
        self.span = np.array([v.hi - v.lo for v in self.vary])
        self.cache: dict = {}
        self.evaluations = 0
        self.history: list = []
        self.scale = 1.0

    def design(self, u) -> dict:
        return {name: float(v) for name, v in zip(self.wrt, self.lo + self.span * np.clip(u, 0.0, 1.0))}

    def evaluate(self, u):
        """(f (J, n_track) Hz, df/du (J, n_track, k), quantities {name: (value, grad_u)})."""
        from ..runtime.sensitivity import frequency_sensitivities

        key = np.asarray(u, dtype=float).tobytes()
        if key not in self.cache:
            values = {**self.params, **self.design(u)}
            modes, dfdp = frequency_sensitivities(
                self.ev, self.poses, self.wrt, self.model, values, method=self.jacobian, lowest=self.n_track
            )
            self.evaluations += 1
            f = modes.freq_hz[:, : self.n_track]
            dfdu = dfdp[:, : self.n_track, :] * self.span
            quantities = {}
            for c in self.constraints:
                if c.quantity == "moving-mass" and c.quantity not in quantities:
                    m, g = moving_mass(self.ev, self.wrt, values, self.model, self.jacobian)
                    quantities[c.quantity] = (m, g * self.span)
            self.cache = {key: (f, dfdu, quantities)}
            worst = float(f[:, 0].min())
            self.history.append(worst)
            if self.progress:
                design = ", ".join(f"{k} = {v:.6g}" for k, v in self.design(u).items())
                self.progress(f"evaluation {self.evaluations}: worst f1 = {worst:.6g} Hz at {design}")
        return self.cache[key]

    # SciPy callbacks on z = [u..., tau], t = tau * scale (Hz)
    def objective(self, z):
        return -z[-1]

    def objective_grad(self, z):
        g = np.zeros_like(z)
        g[-1] = -1.0
        return g

    def frequency_con(self, z):
        f, _, _ = self.evaluate(z[:-1])
        return (f.reshape(-1) - z[-1] * self.scale) / self.scale

    def frequency_jac(self, z):
        f, dfdu, _ = self.evaluate(z[:-1])
        jac = np.empty((f.size, z.size))
        jac[:, :-1] = dfdu.reshape(f.size, -1) / self.scale
        jac[:, -1] = -1.0
        return jac

    def quantity_con(self, c):
        def fun(z):
            value, _ = self.evaluate(z[:-1])[2][c.quantity]
            return np.array([c.slack(value) / abs(c.value or 1.0)])

        def jac(z):
            _, grad = self.evaluate(z[:-1])[2][c.quantity]
            sign = -1.0 if c.op == "<=" else 1.0
            return np.append(sign * grad / abs(c.value or 1.0), 0.0)[None, :]

        return fun, jac


def _usable_poses(ev, vary, poses, model, params) -> np.ndarray:
    """Poses valid (reachable, not singular) at the start and at every corner of the box."""
    ok = np.ones(len(poses), dtype=bool)
    corners = itertools.product(*[(v.lo, v.hi) for v in vary]) if len(vary) <= 6 else []
    for corner in itertools.chain([None], corners):
        values = dict(params or {})
        if corner is not None:
            values.update({v.name: c for v, c in zip(vary, corner)})
        ok &= ev.valid(poses, model, **values)
    return ok


def _check_vary_constraints(ev, vary, model, params) -> None:
    """Raise :class:`InputError` when a corner of the ``vary`` box breaks a constraint between
    parameters (``r_i_l1 < r_o_l1``, the inertia triangle inequality; linear, so the corners
    decide), the other parameters at ``params`` or their defaults: the optimiser never leaves them."""
    import itertools

    from ..description.effects import base_name, resolve_model
    from ..runtime.errors import InputError

    names = {v.name for v in vary}
    on = {base_name(e) for e in resolve_model(model, ev.robot)}
    values = {**ev.defaults, **(params or {})}
    for c in getattr(ev, "constraints", ()):
        if (c.effect is not None and c.effect not in on) or not names & set(c.names):
            continue
        box = [v for v in vary if v.name in c.names]
        for corner in itertools.product(*[(v.lo, v.hi) for v in box]):
            point = {**values, **{v.name: x for v, x in zip(box, corner)}}
            if not bool(np.all(c.holds(point))):
                shown = ", ".join(f"{n} = {float(point[n]):g}" for n in c.names)
                raise InputError(
                    f"vary {', '.join(f'{v.name}={v.lo:g}:{v.hi:g}' for v in box)}: at {shown} "
                    f"{c.constraint.doc}: expected a box inside {c.constraint}"
                )


def optimize_worst_case(
    ev,
    vary,
    poses,
    model="paper",
    params=None,
    constraints=(),
    *,
    method="SLSQP",
    n_track: int = 2,
    start=None,
    maxiter: int = 100,
    progress=None,
    jacobian: str = "differences",
) -> OptimizationResult:
    """Maximise min over ``poses`` of the lowest natural frequency over the ``vary`` box.

    Parameters
    ----------
    ev : evaluator; vary : list of :class:`Vary`; poses : (J, 3) m, or (J, 6) m and rad for
    a 6-DoF robot (poses that are not valid at the start and every corner of the box are
    dropped and counted);
    model : preset or effects; params : fixed parameter overrides (SI);
    constraints : list of :class:`Constraint`; method : ``"SLSQP"`` or ``"trust-constr"``;
    n_track : modes per pose in the epigraph (>= 1); start : starting values (default: the
    parameter's current value when inside its range, else the middle);
    progress : callable taking a message per evaluation; jacobian : ``"differences"`` (central
    differences of the matrices: nothing derived, the default) or ``"exact"`` (the generated
    sensitivity kernel, derived and cached on first use).
    """
    from scipy.optimize import NonlinearConstraint, minimize

    from ..runtime.errors import InputError

    vary = list(vary)
    for v in vary:
        if v.name not in ev.parameters:
            raise InputError(f"vary {v.name!r}: unknown parameter; expected one of {', '.join(ev.parameters)}")
        lo_b, hi_b = ev.parameters[v.name].bounds
        if not (lo_b <= v.lo and v.hi <= hi_b) or (lo_b == 0.0 and v.lo <= 0.0):
            raise InputError(f"vary {v.name}={v.lo:g}:{v.hi:g}: outside the parameter's bounds ({lo_b:g}, {hi_b:g})")
    _check_vary_constraints(ev, vary, model, params)
    if method not in ("SLSQP", "trust-constr"):
        raise InputError(f"method {method!r}: expected SLSQP or trust-constr")
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    ok = _usable_poses(ev, vary, poses, model, params)
    if not ok.any():
        raise InputError("no pose is reachable and non-singular over the whole --vary box")
    if jacobian not in ("differences", "exact"):
        raise InputError(f"jacobian {jacobian!r}: expected differences or exact")
    prob = _Problem(ev, vary, poses[ok], model, params, constraints, max(1, n_track), progress, jacobian)
    defaults = {**ev.defaults, **(params or {}), **(start or {})}
    u0 = np.array(
        [(defaults[v.name] - v.lo) / (v.hi - v.lo) if v.lo <= defaults[v.name] <= v.hi else 0.5 for v in vary]
    )
    f0 = prob.evaluate(u0)[0]
    prob.scale = float(f0[:, 0].min())
    start_worst = prob.scale
    z0 = np.append(u0, 1.0)
    bounds = [(0.0, 1.0)] * len(vary) + [(0.0, None)]
    if method == "SLSQP":
        cons = [dict(type="ineq", fun=prob.frequency_con, jac=prob.frequency_jac)]
        for c in prob.constraints:
            fun, jac = prob.quantity_con(c)
            cons.append(dict(type="ineq", fun=fun, jac=jac))
        res = minimize(
            prob.objective,
            z0,
            jac=prob.objective_grad,
            bounds=bounds,
            constraints=cons,
            method="SLSQP",
            options=dict(maxiter=maxiter, ftol=1e-10),
        )
    else:
        cons = [NonlinearConstraint(prob.frequency_con, 0.0, np.inf, jac=prob.frequency_jac)]
        for c in prob.constraints:
            fun, jac = prob.quantity_con(c)
            cons.append(NonlinearConstraint(fun, 0.0, np.inf, jac=jac))
        from scipy.optimize import Bounds

        res = minimize(
            prob.objective,
            z0,
            jac=prob.objective_grad,
            bounds=Bounds([0.0] * len(vary) + [0.0], [1.0] * len(vary) + [np.inf]),
            constraints=cons,
            method="trust-constr",
            hess=lambda z: np.zeros((z.size, z.size)),
            options=dict(maxiter=maxiter * 10, gtol=1e-9, xtol=1e-10),
        )
    return _result(prob, res, u0, start_worst, int(len(poses) - ok.sum()))


def _result(prob: _Problem, res, u0, start_worst: float, dropped: int) -> OptimizationResult:
    u = np.clip(res.x[:-1], 0.0, 1.0)
    f, _, quantities = prob.evaluate(u)
    f1 = f[:, 0]
    worst = float(f1.min())
    active = []
    for v, ui in zip(prob.vary, u):
        if ui <= 1e-6:
            active.append(f"{v.name} at its lower bound {v.lo:g}")
        elif ui >= 1 - 1e-6:
            active.append(f"{v.name} at its upper bound {v.hi:g}")
    values = {}
    for c in prob.constraints:
        value = quantities[c.quantity][0]
        values[c.quantity] = value
        if abs(c.slack(value)) <= 1e-6 * max(abs(c.value), 1.0):
            active.append(f"{c} (value {value:.6g})")
    near = np.flatnonzero(f1 <= worst * (1 + 1e-5))
    for j in near:
        active.append(f"f1 >= t at pose {np.round(prob.poses[j], 6).tolist()} m (f1 = {f1[j]:.6g} Hz)")
    return OptimizationResult(
        prob.design(u),
        worst,
        f1,
        prob.poses,
        prob.design(u0),
        start_worst,
        active,
        values,
        bool(res.success),
        str(res.message),
        int(getattr(res, "nit", 0)),
        prob.evaluations,
        dropped,
        list(prob.history),
    )
