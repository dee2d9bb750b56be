"""Bounded weighted least squares of model parameters on measured frequencies.

Minimises chi2 = sum(((f_pred,i(p) - f_meas,i) / sigma_i)^2) with
``scipy.optimize.least_squares`` (trust-region reflective, bounds) in a well-scaled
parameterisation: theta = ln(p) for parameters that are positive by their bounds (all
of the catalogue's fitted parameters: stiffnesses, moduli, masses, inertias, g, eta_a),
theta = (p - p_default)/scale otherwise. The search range is the parameter's physical
bounds intersected with [p_default/1000, 1000 p_default] (``SPAN``).

The Jacobian is, by default, a central difference in theta computed in the same evaluator
call as the residuals (B = 1 + 2P parameter sets): measured faster than the exact one on every
diagnosis case of ``benchmarks/diagnosis_jacobian.py`` and needing no generated sensitivity
kernel. ``jacobian="exact"`` (``eigentwist diagnose --jacobian exact``, or
:func:`using_jacobian`) uses the generated design sensitivities of the matched modes
(``Predictor.predict_with_jacobian``, one kernel call with the residuals), falling
back to differences, with the reason in ``FitResult.jacobian``, where no sensitivity is
generated (gravity preload) or a row has no single mode (shape-matched rows, groups of
near-equal modes). A coarse grid of starts (the new
parameters at 1/10 ... 10 times their start value) is screened in one batch first, so
a fit does not hinge on the default being close, together with the corners of the new
parameters' search ranges: where the fit from the grid's best start ends above a corner
(among them the effect switched off, the model the fit nests), it is fitted again from that
corner and the lower end is kept, so a candidate never fits worse than the model it extends
for want of a start (a torque lag makes the stiff settings unstable over its whole grid). A
fit whose chi2 has fallen by less than
``STALL_CHI2`` over its last ``STALL_EVALS`` new points stops at its best point (its message
says so): a parameter the data do not want otherwise crawls towards its bound for dozens of
evaluations without meeting the solver's tolerances.

Standard errors: cov_theta = (J^T J)^-1 * max(1, chi2/(n-k)) with J the whitened
Jacobian at the optimum (absolute sigma, inflated by the Birge ratio when the fit is
worse than the stated uncertainty), propagated to p by the delta method
(std_p = p std_theta for log-parameters). A parameter that the data do not determine
(J^T J singular in its direction) gets std = inf.
"""

from __future__ import annotations

import contextlib
import contextvars
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..runtime.errors import InputError
from .compare import Comparison
from .damping import attach_damping, zeta_count, zeta_residuals, zeta_rows as _zeta_rows
from .predict import FirstSet, Predictor
from .stats import aicc, gof_p_value

__all__ = ["FitResult", "fit", "Transform", "SPAN", "JACOBIANS", "using_jacobian", "constraint_range"]

SPAN = 1e3  # search range: default / SPAN ... default * SPAN (within the physical bounds)
STEP = 1e-2  # central-difference step in theta (1 % in p): K_F carries ~1e-7 relative
# round-off (the 1e-12 rad/(N m) "rigid" compliances), so smaller steps give noise
START_FACTORS = (0.1, 0.3, 1.0, 3.0, 10.0)
ROUNDOFF = 1e-9  # relative frequency change per central-difference pair treated as none
STALL_CHI2 = 1e-3  # a fit whose chi2 has fallen by less than this (a tenth of the AICc resolution of
STALL_EVALS = 8  # the selection, select.AICC_DIGITS) over its last STALL_EVALS new points has stalled:
# it stops at its best point (a parameter the data do not want crawls towards its "switched off"
# limit, stiffness -> inf, without meeting the solver's own tolerances)
# The Jacobian kinds: "differences" (central, in the residuals' evaluator call) and "exact"
# (the generated sensitivities: one kernel for every fitted parameter of the
# catalogue and each leg's own copy, generated and compiled once per cache). Measured
# (benchmarks/diagnosis_jacobian.py, CPU, cold and warm; benchmarks/README.md): the same
# selections and values, differences faster on every case (1-3 parameters per fit), and the
# exact kind's first run derives and compiles a kernel. Differences are the default.
JACOBIANS = ("differences", "exact")
EXACT_JACOBIAN = False  # the default kind when none is given (True: "exact")
_KIND: contextvars.ContextVar = contextvars.ContextVar("eigentwist_jacobian", default=None)


@contextlib.contextmanager
def using_jacobian(kind: str | None):
    """Fits inside this block use the Jacobian ``kind`` (:data:`JACOBIANS`; None: the default)."""
    if kind is not None and kind not in JACOBIANS:
        raise InputError(f"jacobian {kind!r}: expected one of {', '.join(JACOBIANS)}")
    token = _KIND.set(kind)
    try:
        yield
    finally:
        _KIND.reset(token)


def _exact_wanted(kind: str | None) -> bool:
    kind = kind if kind is not None else _KIND.get()
    if kind is None:
        return EXACT_JACOBIAN
    if kind not in JACOBIANS:
        raise InputError(f"jacobian {kind!r}: expected one of {', '.join(JACOBIANS)}")
    return kind == "exact"


@dataclass(frozen=True)
class Transform:
    """Map between a parameter p (SI) and the fit variable theta."""

    name: str
    log: bool
    lo: float
    hi: float
    ref: float
    scale: float

    @classmethod
    def of(cls, parameter) -> "Transform":
        lo, hi = parameter.bounds
        d = float(parameter.default)
        if lo >= 0 and d > 0:
            lo_f = max(d / SPAN, lo * (1 + 1e-9) if lo > 0 else 0.0, np.nextafter(lo, np.inf))
            hi_f = min(d * SPAN, hi * (1 - 1e-9))
            return cls(parameter.name, True, lo_f, hi_f, d, 1.0)
        scale = max(abs(d), (hi - lo) / 20 if math.isfinite(hi - lo) else 1.0, 1e-12)
        return cls(parameter.name, False, max(lo, d - SPAN * scale), min(hi, d + SPAN * scale), d, scale)

    def within(self, lo: float, hi: float) -> "Transform":
        """This transform with its search range cut to the open interval (lo, hi) (the range a
        constraint between parameters leaves, :func:`constraint_range`)."""
        import dataclasses

        margin = 1e-9 if self.log else 1e-9 * self.scale
        new_lo = max(self.lo, lo * (1 + margin) if self.log else lo + margin) if math.isfinite(lo) else self.lo
        new_hi = min(self.hi, hi * (1 - margin) if self.log else hi - margin) if math.isfinite(hi) else self.hi
        if not new_lo < new_hi:
            raise InputError(
                f"parameter {self.name!r}: the constraints between parameters leave it no range "
                f"(from {lo:g} to {hi:g}): expected the other parameters' values to admit one"
            )
        return dataclasses.replace(self, lo=new_lo, hi=new_hi)

    def theta(self, p):
        p = np.clip(p, self.lo, self.hi)
        return np.log(p) if self.log else (p - self.ref) / self.scale

    def value(self, theta):
        return np.exp(theta) if self.log else self.ref + self.scale * np.asarray(theta)

    @property
    def bounds(self) -> tuple[float, float]:
        return float(self.theta(self.lo)), float(self.theta(self.hi))

    def std(self, value: float, std_theta: float) -> float:
        """Delta method: std of p from the std of theta."""
        return float(value * std_theta) if self.log else float(self.scale * std_theta)


@dataclass
class FitResult:
    """A fitted model.

    effects : the model; names : fitted parameters; values, std : fitted values and
    standard errors (SI; std inf where the data do not determine a parameter);
    fixed : every parameter value used that differs from the default (fitted included).
    jacobian : ``"exact"`` (generated sensitivities) or ``"central differences"`` (the default),
        ``"central differences: <why>"`` where an exact Jacobian was asked for but not available.
    comparison : predictions and errors at the optimum; chi2, n, k, dof, aicc.
    at_bound : names that ended at an edge of their search range.
    """

    effects: tuple
    names: tuple
    values: dict
    std: dict
    fixed: dict
    comparison: Comparison
    chi2: float
    n: int
    k: int
    aicc: float
    success: bool = True
    message: str = ""
    nfev: int = 0
    at_bound: tuple = ()
    cov_theta: np.ndarray = field(default=None, repr=False)
    jacobian: str = "exact"

    @property
    def dof(self) -> int:
        return self.n - self.k

    @property
    def rms_pct(self) -> float:
        return self.comparison.rms_pct

    @property
    def max_pct(self) -> float:
        return self.comparison.max_pct

    @property
    def reduced_chi2(self) -> float:
        return self.chi2 / self.dof if self.dof > 0 else math.nan

    @property
    def gof_p_value(self) -> float:
        return gof_p_value(self.chi2, self.n, self.k)


class _Stalled(Exception):
    """Raised by :class:`_Objective` when the fit has stalled (``STALL_CHI2``, ``STALL_EVALS``)."""


class _Objective:
    """Residuals and their Jacobian from one batched evaluation per point; it records the best
    point seen and raises :class:`_Stalled` once chi2 has stopped falling."""

    def __init__(self, predictor: Predictor, transforms: list[Transform], jacobian: str | None = None):
        self.pred = predictor
        self.tr = transforms
        self.names = [t.name for t in transforms]
        self.meas = predictor.meas
        self.cache: dict = {}
        self.nfev = 0
        self.best: tuple = (math.inf, None)  # (chi2, theta) of the best point evaluated
        self.since = 0  # new points since chi2 last fell by more than STALL_CHI2
        self.stall = False  # whether _Stalled is raised (only inside the solver's run)
        self.exact = _exact_wanted(jacobian)
        self.fallback = ""
        # measured damping ratios are residuals too, and a damped row's decay bounds zeta >= 0
        ev = getattr(predictor, "ev", None)
        damped = ev is not None and ev.damped_model(predictor.effects)
        self.zeta = None if self.meas is None else _zeta_rows(self.meas, damped)
        if self.zeta is not None:
            self.exact = False

    def _sets(self, theta: np.ndarray) -> np.ndarray:
        """theta, then for each j the points theta -/+ STEP e_j (shifted inside the bounds)."""
        p = len(theta)
        thetas = np.repeat(theta[None, :], 1 + 2 * p, axis=0)
        for j, t in enumerate(self.tr):
            lo, hi = t.bounds
            centre = min(max(theta[j], lo + STEP), hi - STEP) if hi - lo > 2 * STEP else theta[j]
            thetas[1 + 2 * j, j] = centre - STEP
            thetas[2 + 2 * j, j] = centre + STEP
        return thetas

    def _eval(self, theta: np.ndarray):
        key = theta.tobytes()
        value = self.cache.get(key)
        if value is None and self.exact:
            try:
                value = self._exact(theta)
            except InputError as exc:  # no generated sensitivities (gravity preload): differences
                self.exact = False
                self.fallback = str(exc)
        if value is None:
            thetas = self._sets(theta)
            values = np.column_stack([t.value(thetas[:, j]) for j, t in enumerate(self.tr)])
            f, r, first = self._residuals(values)
            self.nfev += 1
            # a change below round-off (|df/f| <= ROUNDOFF for a 1 % step) is no influence:
            # noise there would send the Gauss-Newton step to a search bound
            flat = np.abs(f[2::2] - f[1::2]) <= ROUNDOFF * np.abs(f[0])
            jac = np.where(flat, 0.0, (r[2::2] - r[1::2]) / (2 * STEP)).T
            value = (r[0], jac, first)
        if key in self.cache:
            return value
        # a new point: it and the best point seen are kept. The solver asks for the Jacobian
        # where it has just evaluated, and its optimum (the last accepted point, the lowest
        # chi2 so far; a stalled fit's best) costs no evaluation at the end
        chi2 = float(value[0] @ value[0])
        if chi2 < self.best[0] or self.best[1] is None:  # this point is the best now (or none is)
            self.cache = {key: value}
        else:
            best = self.best[1].tobytes()
            self.cache = {**{k: v for k, v in self.cache.items() if k == best}, key: value}
        self._progress(theta, chi2)
        return value

    def _progress(self, theta: np.ndarray, chi2: float) -> None:
        """Record a new point; raise :class:`_Stalled` when chi2 has not fallen by more than
        STALL_CHI2 over the last STALL_EVALS new points."""
        if chi2 < self.best[0] - STALL_CHI2:
            self.since = 0
        else:
            self.since += 1
        if chi2 < self.best[0]:
            self.best = (chi2, theta.copy())
        if self.stall and self.since >= STALL_EVALS:
            raise _Stalled

    def _residuals(self, values: np.ndarray):
        """``(f, r, first)`` for B parameter sets: frequencies (B, N), whitened residuals
        (B, N [+ Z]) and the first set's prediction with its modes (:class:`.predict.FirstSet`)."""
        if self.zeta is None:
            f, kept = self.pred.predict_sets(self.names, values, strict=False, first=True)
            return f, (f - self.meas.freq_hz) / self.meas.sigma_hz, kept
        (f, z, least), kept = self.pred.predict_sets(self.names, values, strict=False, zeta=True, first=True)
        r = (f - self.meas.freq_hz) / self.meas.sigma_hz
        rz = zeta_residuals(self.meas, z, self.zeta, least)
        return np.concatenate([f, rz * self.zeta[1]], axis=1), np.concatenate([r, rz], axis=1), kept

    def first_set(self, theta) -> "FirstSet | None":
        """The prediction with its modes at ``theta`` where an evaluation kept it (the point
        asked for last and the best point, differences), else None."""
        value = self.cache.get(np.asarray(theta, dtype=float).tobytes())
        return None if value is None else value[2]

    def _exact(self, theta: np.ndarray):
        """Residuals and the exact Jacobian in theta (generated sensitivities), no first set (None)."""
        values = np.array([t.value(theta[j]) for j, t in enumerate(self.tr)])
        f, dfdp = self.pred.predict_with_jacobian(self.names, values, strict=False)
        self.nfev += 1
        dpdtheta = np.array([v if t.log else t.scale for t, v in zip(self.tr, values)])
        return (f - self.meas.freq_hz) / self.meas.sigma_hz, dfdp * dpdtheta / self.meas.sigma_hz[:, None], None

    def residuals(self, theta):
        return self._eval(np.asarray(theta, dtype=float))[0]

    def jacobian(self, theta):
        return self._eval(np.asarray(theta, dtype=float))[1]

    def chi2_of(self, value_table: np.ndarray) -> np.ndarray:
        _, r, _ = self._residuals(value_table)
        self.nfev += 1
        return np.sum(r * r, axis=1)


def constraint_range(ev, name: str, values: dict, effects) -> tuple[float, float]:
    """The open interval the constraints between parameters (``r_i_l1 < r_o_l1``, the inertia
    triangle inequality; :mod:`eigentwist.description.constraints`) leave parameter ``name``
    (``P`` or a leg's own ``P@N``) with every other parameter at ``values`` (else its default),
    for the model ``effects``: the fit's search range is cut to it, so that neither a step
    nor a difference crosses it."""
    from ..runtime.constraints import interval

    compiled = getattr(ev, "constraints", None) or ()
    base, _, leg = name.partition("@")

    def value(n):
        for key in ((f"{n}@{leg}",) if leg else ()) + (n,):
            if key in values:
                return float(values[key])
        return float(ev.parameter(n).default)

    names = {n for c in compiled if base in c.names for n in c.names}
    if not names:
        return -math.inf, math.inf
    return interval(compiled, base, {n: value(n) for n in names}, {e.partition("@")[0] for e in effects})


def _comparison(meas, effects, ev, values: dict, first: "FirstSet | None" = None) -> Comparison:
    """The :class:`Comparison` at ``values``; with measured damping ratios or damped rows it
    carries the whitened damping-ratio residuals (:func:`zeta_residuals`; a model without
    damping predicts zeta = 0), which its chi2 includes. ``first``: the prediction at
    ``values`` kept from the fit's evaluation there (:class:`.predict.FirstSet`), else
    evaluated."""
    if first is not None:
        pred, idx, modes = first.predict()
    else:
        pred, idx, modes = Predictor(meas, effects, ev, values).predict(strict=False, return_modes=True)
    comp = Comparison(meas, tuple(effects), pred, idx, values)
    spec = _zeta_rows(meas, ev.damped_model(tuple(effects)))
    return comp if spec is None else attach_damping(comp, meas, modes, idx, spec)


def _explored(t, explore, given: dict | None) -> bool:
    """Whether the start grid varies parameter ``t``: asked for, positive (log-transformed) and
    without given start values."""
    return t.name in explore and t.log and not (given and t.name in given)


def _grid(transforms, levels) -> np.ndarray:
    """(K, P): every combination of each parameter's ``levels(t)``, clipped to its search range."""
    grids = [[float(np.clip(v, t.lo, t.hi)) for v in levels(t)] for t in transforms]
    return np.array(list(itertools.product(*grids)))


def _starts(transforms, start: dict, explore, given: dict | None = None) -> np.ndarray:
    def levels(t):
        if given and t.name in given:
            return given[t.name]
        return [start[t.name] * f for f in (START_FACTORS if _explored(t, explore, given) else (1.0,))]

    return _grid(transforms, levels)


def _ends(transforms, start: dict, explore, given: dict | None = None) -> np.ndarray:
    """(E, P) the corners of the explored box: every combination of the two ends of each
    explored positive parameter's search range (the parameters :func:`_starts` multiplies
    by :data:`START_FACTORS`), the others at ``start`` (one given start values, ``given``, at
    its first); (0, P) where none is explored. A
    parameter that sets an effect's strength (a lag, a mass, a loss factor at its least; a
    stiffness at its most) switches the effect off at one end, so one corner is the model
    without the effects being fitted: the fit of a model that nests another can start no
    worse than that model, however rough the landscape between (a torque lag makes the stiff
    settings unstable over the whole start grid)."""
    if not any(_explored(t, explore, given) for t in transforms):
        return np.empty((0, len(transforms)))

    def levels(t):
        if _explored(t, explore, given):
            return [t.lo, t.hi]
        return [given[t.name][0] if given and t.name in given else start[t.name]]

    return _grid(transforms, levels)


def _best_start(table: np.ndarray, chi2: np.ndarray) -> np.ndarray:
    """The row of ``table`` with the lowest finite ``chi2`` (a start where the model cannot be
    evaluated, chi2 NaN, is never taken while another can be); the first row where none is
    finite (the solver then names the failure)."""
    return table[int(np.argmin(np.where(np.isfinite(chi2), chi2, np.inf)))]


def _solve(least_squares, obj: "_Objective", transforms, start_values, lo, hi, max_nfev: int):
    """Trust-region least squares from ``start_values`` (P,) on ``obj``: ``(theta, success,
    message)``; a stalled run (:class:`_Stalled`) ends at its best point."""
    theta0 = np.array([t.theta(v) for t, v in zip(transforms, start_values)])
    theta0 = np.clip(theta0, lo + 1e-12, hi - 1e-12)
    obj.stall = True
    try:
        res = least_squares(
            obj.residuals,
            theta0,
            jac=obj.jacobian,
            bounds=(lo, hi),
            method="trf",
            x_scale=1.0,
            xtol=1e-8,
            ftol=1e-9,
            gtol=1e-9,
            max_nfev=max_nfev,
        )
        theta, success, message = res.x, bool(res.success), str(res.message)
    except _Stalled:
        theta = obj.best[1]
        success, message = True, f"stalled: chi2 fell by less than {STALL_CHI2:g} over {STALL_EVALS} new points"
    obj.stall = False
    return theta, success, message


def _chi2(obj: "_Objective", theta) -> float:
    r = obj.residuals(theta)
    return float(r @ r)


def _covariance(jac: np.ndarray, chi2: float, dof: int) -> np.ndarray:
    """(J^T J)^-1 scaled by the Birge ratio squared when above 1; infinite in the rows and columns
    of parameters along an undetermined direction (fewer rows than parameters included)."""
    if jac.shape[0] < jac.shape[1]:  # the SVD of a wide J would leave its null space out
        jac = np.vstack([jac, np.zeros((jac.shape[1] - jac.shape[0], jac.shape[1]))])
    u, s, vt = np.linalg.svd(jac, full_matrices=False)
    tol = s.max() * 1e-9 if s.size and s.max() > 0 else 1.0
    inv = np.where(s > tol, 1.0 / np.where(s > tol, s, 1.0) ** 2, np.inf)
    cov = (vt.T * np.where(np.isfinite(inv), inv, 0.0)) @ vt
    null = vt[~np.isfinite(inv)]
    if null.size:
        undetermined = np.any(np.abs(null) > 1e-3, axis=0)
        cov[undetermined, :] = np.inf
        cov[:, undetermined] = np.inf
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    return cov * scale


def fit(
    meas,
    effects,
    ev,
    names,
    start: dict | None = None,
    fixed: dict | None = None,
    explore=None,
    starts: dict | None = None,
    max_nfev: int = 200,
    jacobian: str | None = None,
) -> FitResult:
    """Fit parameters ``names`` of the model ``effects`` to the measurements.

    Parameters
    ----------
    meas : :class:`~eigentwist.diagnose.measurements.Measurements`.
    effects : tuple of effect names (the model).
    ev : evaluator.
    names : parameters to fit (SI); parameters given as data columns are not fitted.
    start : start values (default: the ``fixed`` value of a fitted name, e.g. ``--set``,
        else the parameter default).
    fixed : parameter values (SI) held fixed (e.g. from an earlier step or ``--set``);
        a name also in ``names`` is fitted, starting from this value.
    explore : names whose start is screened over a grid (default: all).
    starts : name -> start values screened for it instead (e.g. both signs of an offset,
        where the Jacobian at 0 is singular).
    max_nfev : most batched evaluations of the least-squares solver.
    jacobian : ``"differences"`` or ``"exact"`` (:data:`JACOBIANS`); None: the kind set by
        :func:`using_jacobian`, else the default (differences).

    Returns
    -------
    :class:`FitResult`.
    """
    from scipy.optimize import least_squares  # on first use: commands without it start faster

    names = tuple(n for n in names if n not in meas.params)
    given = dict(fixed or {})
    fixed = {k: v for k, v in given.items() if k not in names}
    predictor = Predictor(meas, effects, ev, fixed)
    n = len(meas)
    n += zeta_count(meas)
    if not names:
        comp = _comparison(meas, effects, ev, dict(fixed))
        chi2 = comp.chi2
        return FitResult(tuple(effects), (), {}, {}, dict(fixed), comp, chi2, n, 0, aicc(chi2, n, 0))
    start = {nm: float((start or {}).get(nm, given.get(nm, ev.parameter(nm).default))) for nm in names}
    transforms = [
        Transform.of(ev.parameter(nm)).within(*constraint_range(ev, nm, {**given, **start}, effects)) for nm in names
    ]
    obj = _Objective(predictor, transforms, jacobian)
    explored = set(names if explore is None else explore)
    table = _starts(transforms, start, explored, starts)
    ends = _ends(transforms, start, explored, starts)
    chi2 = obj.chi2_of(np.vstack([table, ends]))  # one batched evaluation of every start
    lo = np.array([t.bounds[0] for t in transforms])
    hi = np.array([t.bounds[1] for t in transforms])
    theta, success, message = _solve(
        least_squares, obj, transforms, _best_start(table, chi2[: len(table)]), lo, hi, max_nfev
    )
    end_chi2 = chi2[len(table) :]
    reached = _chi2(obj, theta) if len(ends) else math.inf
    if np.isfinite(end_chi2).any() and np.nanmin(end_chi2) < reached - STALL_CHI2:
        # the fit ended above a corner of the box (the nested model among them): a local
        # minimum; fitted again from that corner, the lower of the two ends is kept
        again = _Objective(predictor, transforms, jacobian)
        found = _solve(least_squares, again, transforms, _best_start(ends, end_chi2), lo, hi, max_nfev)
        if _chi2(again, found[0]) < reached:
            again.nfev += obj.nfev
            obj, (theta, success, message) = again, found
    values = {t.name: float(t.value(theta[j])) for j, t in enumerate(transforms)}
    all_values = {**fixed, **values}
    comp = _comparison(meas, effects, ev, all_values, obj.first_set(theta))
    chi2 = comp.chi2
    k = len(names)
    cov = _covariance(obj.jacobian(theta), chi2, n - k)
    std = {t.name: t.std(values[t.name], math.sqrt(cov[j, j])) for j, t in enumerate(transforms)}
    at_bound = tuple(
        t.name
        for j, t in enumerate(transforms)
        if min(theta[j] - lo[j], hi[j] - theta[j]) < 1e-6 * max(1.0, abs(theta[j]))
    )
    return FitResult(
        tuple(effects),
        names,
        values,
        std,
        all_values,
        comp,
        chi2,
        n,
        k,
        aicc(chi2, n, k),
        success,
        message,
        obj.nfev,
        at_bound,
        cov,
        "exact" if obj.exact else "central differences" + (f": {obj.fallback}" if obj.fallback else ""),
    )
