"""Modes of one setting from its FRFs: LSCF poles, automatic stabilisation, LSFD shapes.

1. **Poles** by sdypy-EMA's least-squares complex-frequency estimator (LSCF,
   ``sdypy.EMA.Model.get_poles("lscf")``) on every FRF of the setting at once (a common
   denominator), for model orders 2, 4, ..., ``2 * MAX_ORDER``.
2. **Stabilisation diagram, read automatically.** A pole is *physical* when its
   frequency lies in the band and its damping ratio in (0, ``ZETA_MAX``); it is *stable*
   at an order when the previous order has a physical pole within ``TOL_F`` in frequency
   and ``TOL_ZETA`` in damping (relative). Stable poles are sorted by frequency and
   linked into columns while neighbours are closer than ``TOL_CLUSTER`` (relative); a
   column is a mode when it holds stable poles of at least ``MIN_ORDERS`` orders; its
   start values are the medians over those orders (the pole nearest the column's
   median at each order).
3. **Refinement** (:func:`_refine`): the poles of the selected modes are refined by an
   output-error least-squares fit of the modal model to the FRFs on the band, the
   residues solved linearly by sdypy-EMA's LSFD at every trial (variable projection).
   LSCF's linearised equations multiply the noise by the denominator, which biases its
   poles by O(noise^2) (about -50 ppm at 0.5 % noise on the synthetic campaign, the
   same sign for every mode: enough to make the diagnosis add a spurious effect); the
   output error has no such bias. ``sigma_hz`` is the largest of the pole's standard
   deviation over the stable orders, the fit's standard error, and
   ``SIGMA_FLOOR_REL`` times the frequency.
4. **Shapes** by sdypy-EMA's least-squares frequency-domain estimator (LSFD, with
   lower and upper residuals) on the band: the residue of each mode on every measured
   pair (response DOF o, reference DOF r) is ``phi_o phi_r`` times a constant; its
   rank-one factors are found by alternating least squares over the measured pairs
   (the SVD of the residue matrix when every pair is measured). The shape is the factor
   over the side with more DOFs: the responses (accelerometers; a shaker or a fixed
   hammer), or the references when one response DOF sees a roving hammer. It is made
   real by rotating it to its dominant phase (the phase that maximises the norm of its
   real part), scaled to unit norm with its largest component positive; the modal
   complexity factor (MCF, 0 real ... 1 fully complex) is reported. A layout with a
   node measured along X, Y and Z labels each mode by the axis of its largest
   translation there (``x``, ``y``, ``z``); any other layout labels the modes by rank
   (``1`` the lowest identified, ...). A mode whose residues contribute less than
   ``MIN_CONTRIBUTION`` of the strongest mode's peak response (in the FRFs' own form:
   receptance residue / (zeta w) times w^0, w^1, w^2) is dropped (a pole fitted to noise).

Modes from a dataset 55 file (already identified) go through the same shape
normalisation; their ``sigma_hz`` is the floor.
"""

from __future__ import annotations

import contextlib
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..runtime import InputError
from .layout import triaxial_node
from .uff_io import FORM_RANK, FrfSet, ModeSet

__all__ = [
    "IdentifiedMode",
    "Stabilisation",
    "SettingModes",
    "identify_frfs",
    "modes_from_set",
    "real_shape",
    "rank_one",
    "shape_side",
    "MAX_ORDER",
    "SIGMA_FLOOR_REL",
    "TOL_F",
    "TOL_ZETA",
    "TOL_CLUSTER",
    "MIN_ORDERS",
    "ZETA_MAX",
]

MAX_ORDER = 30  # LSCF orders 2, 4, ..., 2 * MAX_ORDER
ZETA_MAX = 0.2  # physical poles: 0 < zeta < ZETA_MAX
TOL_F = 0.005  # stable: frequency within 0.5 % of a pole of the previous order
TOL_ZETA = 0.10  # ... and damping within 10 %
TOL_CLUSTER = 0.004  # stable poles closer than 0.4 % form one column of the diagram
MIN_ORDERS = 6  # a column with stable poles at >= 6 orders is a mode
SIGMA_FLOOR_REL = 0.001  # sigma_hz >= 0.1 % of the frequency (and = 0.1 % for dataset 55 modes)
MIN_CONTRIBUTION = 0.01  # drop modes whose peak response is < 1 % of the strongest mode's
AXES = ("x", "y", "z")


@dataclass
class IdentifiedMode:
    """One mode: freq_hz, sigma_hz (Hz), damping_ratio (-), real unit shape (D,) over the
    DOFs ``dofs`` (labels ``"NODE+AXIS"``), complexity (MCF, -), label (``x``, ``y``, ``z``
    or a rank ``1``, ``2``, ...), orders (how many stable orders support it; 0 for
    dataset 55 modes)."""

    freq_hz: float
    sigma_hz: float
    damping_ratio: float
    shape: np.ndarray
    complexity: float
    label: str
    orders: int = 0
    dofs: tuple = ()


@dataclass
class Stabilisation:
    """The stabilisation diagram: per order the physical poles (Hz, -) and which are stable."""

    orders: list
    freq_hz: list
    damping: list
    stable: list


@dataclass
class SettingModes:
    """Identification result of one setting."""

    modes: list
    source: str
    band: tuple
    stabilisation: Stabilisation | None = None
    frfs: FrfSet | None = None
    resynthesised: np.ndarray | None = None  # (F_band, P) LSFD reconstruction on the band
    band_index: slice | None = None
    seconds: float = 0.0
    notes: list = field(default_factory=list)
    coords: dict = field(default_factory=dict)  # node -> (3,) position, m (campaign)


def real_shape(u) -> tuple[np.ndarray, float]:
    """(real unit shape, MCF) of a complex shape ``u`` (D,).

    Rotated by the phase theta = arg(sum u_i^2) / 2, which maximises |Re(u e^-i theta)|;
    sign so that the largest component is positive.
    """
    u = np.asarray(u, dtype=complex)
    theta = 0.5 * np.angle(np.sum(u * u))
    phi = np.real(u * np.exp(-1j * theta))
    phi = phi / np.linalg.norm(phi)
    phi = phi * np.sign(phi[np.argmax(np.abs(phi))])
    sxx, syy, sxy = np.dot(u.real, u.real), np.dot(u.imag, u.imag), np.dot(u.real, u.imag)
    mcf = 1.0 - ((sxx - syy) ** 2 + 4 * sxy**2) / (sxx + syy) ** 2
    return phi, float(max(mcf, 0.0))


def _band(freq: np.ndarray, band, source: str) -> tuple[float, float]:
    lo_axis = freq[1] if freq[0] <= 0 else freq[0]
    lo, hi = band if band is not None else (lo_axis, freq[-1] * 0.99)
    if not (lo < hi) or hi <= lo_axis or lo >= freq[-1]:
        raise InputError(
            f"{source}: band {lo:g}..{hi:g} Hz lies outside the frequency axis {freq[0]:g}..{freq[-1]:g} Hz"
        )
    return max(lo, lo_axis), min(hi, freq[-1] * 0.99)


def _poles(frf: np.ndarray, freq: np.ndarray, band, form: str, max_order: int) -> list[np.ndarray]:
    """Complex poles (rad/s) per order 2, 4, ..., by sdypy-EMA's LSCF."""
    from sdypy import EMA

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = EMA.Model(frf=frf, freq=freq, lower=band[0], upper=freq[-1], pol_order_high=max_order, frf_form=form)
        model.get_poles("lscf", show_progress=False)
    return [np.asarray(p) for p in model.all_poles]


def _stabilisation(poles: list, band) -> Stabilisation:
    orders, fs, zs, st = [], [], [], []
    prev_f = prev_z = np.zeros(0)
    for k, p in enumerate(poles):
        with np.errstate(all="ignore"):
            f = np.abs(p) / (2 * np.pi) * np.sign(p.imag)
            z = -p.real / np.abs(p)
        keep = np.isfinite(f) & (f > band[0]) & (f < band[1]) & (z > 0) & (z < ZETA_MAX)
        f, z = f[keep], z[keep]
        order = np.argsort(f)
        f, z = f[order], z[order]
        if prev_f.size and f.size:
            df = np.abs(f[:, None] - prev_f[None, :]) / prev_f[None, :]
            dz = np.abs(z[:, None] - prev_z[None, :]) / prev_z[None, :]
            stable = np.any((df < TOL_F) & (dz < TOL_ZETA), axis=1)
        else:
            stable = np.zeros(f.shape, dtype=bool)
        orders.append(2 * (k + 1))
        fs.append(f)
        zs.append(z)
        st.append(stable)
        prev_f, prev_z = f, z
    return Stabilisation(orders, fs, zs, st)


def _columns(stab: Stabilisation) -> list[dict]:
    """Columns of stable poles: frequency, damping (medians), spread, orders, pole per order."""
    rows = [
        (f, z, k)
        for k, (fk, zk, sk) in enumerate(zip(stab.freq_hz, stab.damping, stab.stable))
        for f, z in zip(fk[sk], zk[sk])
    ]
    if not rows:
        return []
    rows.sort()
    groups, current = [], [rows[0]]
    for r in rows[1:]:
        if (r[0] - current[-1][0]) / current[-1][0] < TOL_CLUSTER:
            current.append(r)
        else:
            groups.append(current)
            current = [r]
    groups.append(current)
    out = []
    for g in groups:
        f_all = np.array([r[0] for r in g])
        centre = np.median(f_all)
        per_order: dict[int, tuple] = {}
        for f, z, k in g:  # one pole per order: nearest the centre
            if k not in per_order or abs(f - centre) < abs(per_order[k][0] - centre):
                per_order[k] = (f, z)
        if len(per_order) < MIN_ORDERS:
            continue
        f = np.array([v[0] for v in per_order.values()])
        z = np.array([v[1] for v in per_order.values()])
        out.append(
            {
                "freq_hz": float(np.median(f)),
                "damping": float(np.median(z)),
                "spread_hz": float(np.std(f, ddof=1)),
                "orders": len(per_order),
            }
        )
    return out


def _lsfd(frf, freq, poles_rad, band_index: slice, form: str):
    from sdypy.EMA.EMA import LSFD

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        A, H, _, _ = LSFD(poles_rad, frf, freq, True, True, band_index.start, band_index.stop, form)
    return A, H


def _refine(frf, freq, poles, band_index: slice, form: str):
    """Output-error least squares of the poles (variable projection over LSFD's residues).

    Minimises sum |H_meas - H_model(poles)|^2 over the band, the residues (and the lower
    and upper residuals) solved linearly by LSFD at every trial pole set. LSCF's linear
    formulation multiplies the noise by the denominator polynomial, which biases its
    poles by O(noise^2) (here 50 ppm at 0.5 % noise, consistently downwards); the output
    error does not. Returns the refined poles (rad/s) and the standard errors of their
    natural frequencies (Hz) from the Jacobian, or the input and NaN when the fit fails.
    """
    from scipy.optimize import least_squares

    band = frf[:, band_index]
    w0, z0 = np.abs(poles), -poles.real / np.abs(poles)

    def unpack(theta):
        w, z = np.exp(theta[::2]), theta[1::2]
        return -z * w + 1j * w * np.sqrt(1 - z**2)

    def residuals(theta):
        _, H = _lsfd(frf, freq, unpack(theta), band_index, form)
        r = (band - np.asarray(H)[:, band_index]).ravel()
        return np.concatenate([r.real, r.imag])

    theta0 = np.ravel(np.column_stack([np.log(w0), z0]))
    lo = np.ravel(np.column_stack([np.log(w0) - 0.02, np.full_like(z0, 1e-5)]))
    hi = np.ravel(np.column_stack([np.log(w0) + 0.02, np.full_like(z0, ZETA_MAX)]))
    try:
        res = least_squares(
            residuals,
            np.clip(theta0, lo, hi),
            bounds=(lo, hi),
            x_scale=np.abs(theta0) * 1e-3 + 1e-6,
            xtol=1e-10,
            ftol=1e-10,
            max_nfev=60,
        )
    except (ValueError, np.linalg.LinAlgError):
        return poles, np.full(len(poles), np.nan)
    if not res.success or not np.all(np.isfinite(res.x)):
        return poles, np.full(len(poles), np.nan)
    dof = max(res.fun.size - len(res.x) - 2 * band.shape[0] * (len(poles) + 2), 1)
    s2 = float(res.fun @ res.fun) / dof
    try:
        cov = np.linalg.pinv(res.jac.T @ res.jac) * s2
        std_hz = np.sqrt(np.clip(np.diag(cov)[::2], 0, None)) * np.exp(res.x[::2]) / (2 * np.pi)
    except np.linalg.LinAlgError:
        std_hz = np.full(len(poles), np.nan)
    return unpack(res.x), std_hz


def _one_blas_thread():
    """Small least-squares problems run fastest on one BLAS thread (threads spin on a busy machine)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional: only speed depends on it
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def identify_frfs(
    frfs: FrfSet, band=None, max_order: int = MAX_ORDER, sigma_floor_rel: float = SIGMA_FLOOR_REL
) -> SettingModes:
    """Identify the modes of one setting's FRFs (module doc); ``band`` (lo, hi) in Hz."""
    with _one_blas_thread():
        return _identify(frfs, band, max_order, sigma_floor_rel)


def _identify(frfs: FrfSet, band, max_order: int, sigma_floor_rel: float) -> SettingModes:
    t0 = time.perf_counter()
    freq = frfs.freq_hz
    _check_axis(freq, frfs.source)
    lo, hi = _band(freq, band, frfs.source)
    frf = np.ascontiguousarray(frfs.H.T)  # rows: measured pairs
    stab = _stabilisation(_poles(frf, freq, (lo, hi), frfs.form, max_order), (lo, hi))
    cols = _columns(stab)
    if not cols:
        raise InputError(
            f"{frfs.source}, dataset 58: no stable mode in the band {lo:g}..{hi:g} Hz "
            f"(LSCF orders 2..{2 * max_order}; widen --band or check the FRFs)"
        )
    w = 2 * np.pi * np.array([c["freq_hz"] for c in cols])
    zeta = np.array([c["damping"] for c in cols])
    poles = -zeta * w + 1j * w * np.sqrt(1 - zeta**2)
    band_index = slice(int(np.searchsorted(freq, lo)), int(np.searchsorted(freq, hi, side="right")))
    poles, std_hz = _refine(frf, freq, poles, band_index, frfs.form)
    A, H_rec = _lsfd(frf, freq, poles, band_index, frfs.form)
    w, zeta = np.abs(poles), -poles.real / np.abs(poles)
    strength = np.linalg.norm(A, axis=0) / (zeta * w) * w ** FORM_RANK[frfs.form]  # peak in the FRFs' form
    side, dofs = shape_side(frfs)
    modes = []
    for k, c in enumerate(cols):
        if strength[k] < MIN_CONTRIBUTION * strength.max():
            continue
        shape, mcf = real_shape(rank_one(A[:, k], frfs.pairs, len(frfs.responses), len(frfs.references))[side])
        f_k = w[k] / (2 * np.pi)
        sigma = float(np.nanmax([c["spread_hz"], std_hz[k], sigma_floor_rel * f_k]))
        modes.append(IdentifiedMode(f_k, sigma, zeta[k], shape, mcf, "", c["orders"], dofs))
    _label(modes)
    H_band = np.asarray(H_rec).T[band_index]  # LSFD returns (rows, F)
    return SettingModes(modes, frfs.source, (lo, hi), stab, frfs, H_band, band_index, time.perf_counter() - t0)


def shape_side(frfs: FrfSet) -> tuple[int, tuple]:
    """(0: responses or 1: references, their DOF labels): the side with more DOFs (module doc)."""
    if len(frfs.references) > len(frfs.responses):
        return 1, tuple(frfs.references)
    return 0, tuple(frfs.responses)


def rank_one(a, pairs, n_o: int, n_r: int, iterations: int = 50) -> tuple[np.ndarray, np.ndarray]:
    """Complex factors (x (n_o,), y (n_r,)) with ``a[p] ~ x[o_p] y[r_p]`` over the measured pairs.

    Alternating least squares from the SVD of the zero-filled residue matrix (exact, the
    SVD itself, when every pair is measured). ``x`` has unit norm.
    """
    o, r = np.array(pairs).T
    grid = np.zeros((n_o, n_r), dtype=complex)
    grid[o, r] = a
    U, s, Vh = np.linalg.svd(grid)
    x, y = U[:, 0], s[0] * Vh[0]
    if len(pairs) < n_o * n_r:
        for _ in range(iterations):
            x = np.array(
                [
                    np.vdot(y[r[o == i]], a[o == i]) / max(np.vdot(y[r[o == i]], y[r[o == i]]).real, 1e-300)
                    for i in range(n_o)
                ]
            )
            y = np.array(
                [
                    np.vdot(x[o[r == j]], a[r == j]) / max(np.vdot(x[o[r == j]], x[o[r == j]]).real, 1e-300)
                    for j in range(n_r)
                ]
            )
        scale = np.linalg.norm(x)
        x, y = x / scale, y * scale
    return x, y


def _label(modes: list) -> None:
    """Axis labels from a triaxial node, else ranks (module doc, step 4)."""
    node = triaxial_node(modes[0].dofs) if modes else None
    if node is None:
        for rank, m in enumerate(sorted(modes, key=lambda m: m.freq_hz)):
            m.label = str(rank + 1)
        return
    index = [m_dofs.index(f"{node}+{a}") for m_dofs in [modes[0].dofs] for a in "XYZ"]
    for m in modes:
        m.label = AXES[int(np.argmax(np.abs(m.shape[index])))]


def _check_axis(freq: np.ndarray, source: str) -> None:
    step = np.diff(freq)
    if freq.size < 16 or not np.all(step > 0) or np.ptp(step) > 1e-6 * step.mean():
        raise InputError(
            f"{source}, dataset 58: the frequency axis must be evenly spaced and increasing with at "
            f"least 16 lines (LSCF), got {freq.size} lines"
        )


def modes_from_set(modes: ModeSet, band=None, sigma_floor_rel: float = SIGMA_FLOOR_REL) -> SettingModes:
    """Already identified modes (dataset 55) in ``band`` (lo, hi) Hz, shapes normalised."""
    lo, hi = band if band is not None else (0.0, np.inf)
    out = []
    for f, z, u in zip(modes.freq_hz, modes.damping_ratio, modes.shapes):
        if not lo <= f <= hi:
            continue
        shape, mcf = real_shape(u)
        out.append(
            IdentifiedMode(
                float(f),
                sigma_floor_rel * float(f),
                float(z),
                shape,
                mcf,
                AXES[int(np.argmax(np.abs(shape)))],
                0,
                tuple(f"{modes.node}+{a}" for a in "XYZ"),
            )
        )
    if not out:
        raise InputError(
            f"{modes.source}, dataset 55: no mode in the band {lo:g}..{hi:g} Hz "
            f"(modes at {', '.join(f'{f:.4g}' for f in modes.freq_hz)} Hz)"
        )
    return SettingModes(out, modes.source, (lo, hi))
