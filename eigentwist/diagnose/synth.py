"""Synthetic measurements from a truth model with a hidden effect, and noise.

A truth is written ``PRESET[+EFFECT[:PARAM=VALUE,...]]...``, e.g.
``paper+transmission_compliance:k_t=8000`` or ``rigid+payload_mass:m_p=0.5``; any item
may carry parameter values (``paper:m_e=0.7``), ``none`` is the bare model. Rows are
every (pose, k_a, mode) combination; the measured value is
``f_true (1 + noise * N(0, 1))`` and ``sigma_hz = sigma * f`` (``sigma`` is the stated
relative uncertainty, by default equal to ``noise``; state it apart to make data whose
uncertainty is over- or understated). The normal draws come from a generator seeded by
(``seed``, noise level) (:func:`noise_generator`), so the same seed at two noise levels
gives independent draws, not one draw scaled.

``extra_stiffness`` adds a spring to ground at the end-effector origin (N/m along x, y,
z; N m/rad about rx, ry, rz) to the truth's stiffness matrix: a physical effect that
the catalogue does not contain (a cable carrier or hose pulling on the end-effector), to
test that a diagnosis says so.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..description.effects import EFFECTS, PRESETS, resolve_model
from ..description.names import did_you_mean
from ..runtime import InputError, Modes
from ..runtime.eigen import frequencies_hz, generalized_eigh, normalize_eigentwists, unstable_modes
from .evaluators import resolve
from .matching import DIRECTIONS, match_frequencies, parse_mode
from .measurements import Measurements

__all__ = ["Truth", "parse_truth", "synth", "parse_noise", "noise_generator"]


class Truth:
    """A parsed truth spec: ``effects`` (tuple) and parameter ``values`` (SI)."""

    def __init__(self, effects, values):
        self.effects = tuple(effects)
        self.values = dict(values)

    def __repr__(self) -> str:
        return f"Truth(effects={self.effects}, values={self.values})"


def parse_truth(spec: str, ev, what: str = "truth") -> Truth:
    """Parse ``PRESET[+EFFECT:PARAM=VALUE,...]`` (see module doc); errors name the item.

    ``what`` names the spec in messages (``"truth"``, ``"--model"``); the same syntax
    gives ``--model`` of the commands that evaluate a model.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InputError(
            f"{what} spec is empty: expected PRESET[+EFFECT:PARAM=VALUE,...], e.g. paper+payload_mass:m_p=0.5"
        )
    names: list[str] = []
    values: dict[str, float] = {}
    for item in spec.split("+"):
        head, _, tail = item.partition(":")
        for head in filter(None, (h.strip() for h in head.split(","))):
            if head.lower() == "none":
                continue
            if head not in PRESETS and head.partition("@")[0] not in set(EFFECTS) | set(ev.effects):
                valid = list(PRESETS) + list(ev.effects)
                raise InputError(
                    f"{what} item {item!r}: {head!r} is not a preset or effect{did_you_mean(head, valid)} "
                    f"(expected one of {', '.join(valid)} or none)"
                )
            names.append(head)
        for assignment in filter(None, (a.strip() for a in tail.split(","))):
            name, sep, text = assignment.partition("=")
            name = name.strip()
            if not sep:
                raise InputError(f"{what} item {item!r}: {assignment!r} is not PARAM=VALUE")
            if not ev.accepts(name):
                raise InputError(
                    f"{what} item {item!r}: unknown parameter {name!r}{did_you_mean(name, ev.parameters)} "
                    f"(parameters of {ev.robot.name}: {', '.join(ev.parameters)})"
                )
            try:
                values[name] = float(text)
            except ValueError:
                raise InputError(f"{what} item {item!r}: value {text!r} of {name} is not a number") from None
            try:
                ev.parameter(name).check(values[name])
            except ValueError as exc:
                raise InputError(f"{what} item {item!r}: {exc}") from None
    try:
        effects = resolve_model(names, ev.robot)
    except ValueError as exc:
        raise InputError(f"{what} {spec!r}: {exc}") from None
    return Truth(effects, values)


def parse_noise(text, what: str = "noise") -> float:
    """``"0.5%"`` -> 0.005, ``"0.005"`` -> 0.005; must be in [0, 1). ``what`` names it in errors."""
    s = str(text).strip()
    try:
        value = float(s[:-1]) / 100 if s.endswith("%") else float(s)
    except ValueError:
        raise InputError(f"{what} {text!r} is not a number: expected e.g. 0.5% or 0.005") from None
    if not 0 <= value < 1:
        raise InputError(f"{what} {text!r}: expected a relative value in [0, 100%)")
    return value


def noise_generator(seed: int, noise: float) -> np.random.Generator:
    """The generator of ``synth``'s normal draws: seeded by ``seed`` and the noise level.

    The level enters the seed sequence in parts per billion, so two levels give
    independent streams and the same (seed, level) the same stream on every platform.
    """
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(round(float(noise) * 1e9))]))


def _truth_modes(ev, truth: Truth, poses, k_a, extra_stiffness) -> Modes:
    if not extra_stiffness:
        return ev.modes(poses, truth.effects, k_a=k_a, **truth.values)
    M, K = ev.stiffness(poses, truth.effects, k_a=k_a, **truth.values)
    axes = DIRECTIONS[3:] if M.shape[-1] == 3 else DIRECTIONS
    K = K.copy()
    for axis, k in extra_stiffness.items():
        if axis not in axes:
            raise InputError(f"extra stiffness along {axis!r}: the truth model has coordinates {', '.join(axes)}")
        if not k >= 0:
            raise InputError(f"extra stiffness {axis}={k!r}: expected a value >= 0 (N/m or N m/rad)")
        j = axes.index(axis)
        K[:, j, j] += k
    lam, V = generalized_eigh(K, M)
    return Modes(
        frequencies_hz(lam),
        normalize_eigentwists(V),
        axes,
        "rigid" if len(axes) == 3 else "flexible",
        stable=~unstable_modes(lam).any(axis=-1),
    )


def synth(
    truth: str,
    k_a,
    poses=None,
    modes=("x", "y", "z"),
    noise=0.005,
    seed: int = 0,
    robot: str = "heli4",
    ev=None,
    extra_stiffness: dict | None = None,
    sigma=None,
    values: dict | None = None,
    kind: str = "undamped",
    zeta_noise=None,
) -> Measurements:
    """Measurements of every (pose, k_a, mode) from the truth model, with relative noise.

    Parameters
    ----------
    truth : ``PRESET[+EFFECT:PARAM=VALUE,...]`` (module doc).
    k_a : commanded actuator stiffnesses, N m/rad.
    poses : (P, 3) end-effector positions, m (default: the robot's x_ref).
    modes : mode labels (directions or ranks).
    noise : relative standard deviation (0.005 or ``"0.5%"``).
    seed : seed of the noise generator (:func:`noise_generator`, keyed on the noise level too).
    extra_stiffness : {axis: stiffness} added at the EE origin (outside the catalogue).
    sigma : relative standard uncertainty written to ``sigma_hz`` (``"1%"``); default:
        ``noise`` (no column, i.e. the 2 % default, when both are 0).
    values : parameter values (SI) of the truth besides those in ``truth`` (which win).
    kind : ``"undamped"`` (omega_n / 2 pi of the truth's poles) or ``"damped"`` (omega_d / 2 pi,
        a free decay), the CSV column ``kind``; they differ where the truth has a damping effect.
    zeta_noise : relative noise of the truth's damping ratios, written with their uncertainty
        (columns ``damping_ratio``, ``sigma_damping_ratio``); None: no damping ratios.
    """
    ev = resolve(ev, robot)
    t = parse_truth(truth, ev)
    t.values = {**dict(values or {}), **t.values}
    rel = parse_noise(noise)
    stated = rel if sigma is None else parse_noise(sigma, "sigma")
    if sigma is not None and stated == 0:
        raise InputError(
            f"sigma {sigma!r}: a stated standard uncertainty must be > 0, e.g. 0.5% "
            "(leave it out to state the noise level)"
        )
    poses = np.atleast_2d(np.asarray(ev.robot.x_ref if poses is None else poses, dtype=float))
    k_a = np.atleast_1d(np.asarray(k_a, dtype=float))
    labels = [parse_mode(m) for m in modes]
    rows = list(itertools.product(range(len(poses)), range(len(k_a)), labels))
    if not rows:
        raise InputError("synth: no rows (expected at least one pose, k_a and mode)")
    row_poses = poses[[r[0] for r in rows]]
    row_ka = k_a[[r[1] for r in rows]]
    row_modes = [r[2] for r in rows]
    m = _truth_modes(ev, t, row_poses, row_ka, extra_stiffness)
    f_true, idx = match_frequencies(m, row_modes, strict=True)
    if kind not in ("undamped", "damped"):
        raise InputError(f"synth kind {kind!r}: expected 'undamped' or 'damped'")
    at = np.arange(len(idx))
    if m.damping is not None:
        f_true = (m.damped_hz if kind == "damped" else m.natural_hz)[at, idx]
    gen = noise_generator(seed, rel)
    f = f_true * (1.0 + rel * gen.standard_normal(len(f_true)))
    sigma_hz = stated * f if stated > 0 else None
    modal = None
    if zeta_noise is not None:
        z_rel = parse_noise(zeta_noise, "zeta_noise")
        z = m.damping_ratio[at, idx]
        modal = {"damping_ratio": z * (1.0 + z_rel * gen.standard_normal(len(z))), "sigma_damping_ratio": z_rel * z}
    return Measurements.from_arrays(
        row_ka,
        row_modes,
        f,
        row_poses,
        sigma_hz,
        robot=ev.robot.name,
        source=f"synth({truth})",
        ev=ev,
        modal=modal,
        kind=None if kind == "undamped" else kind,
    )
