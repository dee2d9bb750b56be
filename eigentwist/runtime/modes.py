"""The modes of a batch of poses: natural frequencies, eigentwists and what each route adds.

:class:`Modes` is what ``Evaluator.modes`` returns on every route (:mod:`.routes`); :data:`AXES`
names the six twist coordinates ``[omega; v]`` its columns are labelled by.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .labels import directions, energy_shares

__all__ = ["Modes", "AXES"]

AXES = ("rx", "ry", "rz", "x", "y", "z")


@dataclass
class Modes:
    """Natural frequencies and eigentwists of a batch of poses.

    freq_hz : (N, n) ascending, Hz. An unstable mode (negative stiffness: an eigenvalue
        omega^2 below round-off, see :data:`eigentwist.runtime.eigen.ROUNDOFF_EPS`) is NaN,
        never 0 Hz.
    eigentwists : (N, n, n), one column per mode, largest entry +1 (Eqs. 57, 65); None
        from ``modes(..., vectors=False)``.
    axes : names of the n coordinates (``("x", "y", "z")`` for a 3-DoF robot's rigid
        model, ``("rx", "ry", "rz", "x", "y", "z")`` for the flexible one and for every
        model of a 6-DoF robot).
    stiffness_model : ``"rigid"`` (K_R, Eq. 14: the 3x3 translational subsets for a 3-DoF
        robot, the full 6x6 for a 6-DoF one) or ``"flexible"`` (K_F, Eq. 13).
    valid : (N,) bool, which poses were evaluated (reachable, not singular); the others
        hold NaN. Set by ``modes(..., invalid="nan")``; None when every pose is valid.
    stable : (N,) bool, False where a mode is unstable (its frequency is NaN); all True
        unless the evaluator found one.
    constrained : (N, n) bool, True where a column is a rigid constraint's mode (infinite
        frequency: the value there is K_F's stand-in, ~1e6 Hz, not a measurable mode); None
        when no column is (:mod:`.condense`).
    shares : (N, n, n) each coordinate's share of each mode's energy
        (:func:`eigentwist.runtime.labels.energy_shares`) where the evaluator had M at hand
        (the C pass of a flexible model: from M and the eigentwists when first read, from
        :attr:`inertia`); None: computed from the eigentwists when needed.
    inertia : (N, n, n) the inertia matrix M the eigentwists are M-orthogonal in, where the
        evaluator had it at hand and :attr:`shares` were not read yet; None after.
    damping : the damped modes (:class:`eigentwist.runtime.damped.Damping`: poles, complex
        eigentwists) of a model with a damping effect (``servo_damping``, ``servo_delay``,
        ``structural_loss``) or where ``complex_shapes`` was asked; None: no damping, and
        :attr:`natural_hz` and :attr:`damped_hz` are :attr:`freq_hz`, :attr:`damping_ratio` 0.
    """

    freq_hz: np.ndarray
    eigentwists: np.ndarray | None
    axes: tuple
    stiffness_model: str
    valid: np.ndarray | None = None
    stable: np.ndarray | None = None
    constrained: np.ndarray | None = None
    damping: object = None
    inertia: np.ndarray | None = field(default=None, repr=False)
    _shares: np.ndarray | None = field(default=None, repr=False)
    #: the valid rows' joint coordinates, matrices, inputs and legs-kernel outputs where the
    #: pass computed them (reused by the damped modes, then dropped); None otherwise
    legs: dict | None = field(default=None, repr=False)

    def __post_init__(self):
        if self.stable is None:
            self.stable = np.ones(self.freq_hz.shape[:1], dtype=bool)

    @property
    def shares(self) -> np.ndarray | None:
        """The energy shares (see the class), from :attr:`inertia` on first reading (a call
        that never reads them does not pay for them); invalid poses' rows NaN."""
        if self._shares is None and self.inertia is not None and self.eigentwists is not None:
            with np.errstate(invalid="ignore", divide="ignore"):  # invalid poses: NaN rows
                self._shares = energy_shares(self.eigentwists, self.inertia)
            self.inertia = None
        return self._shares

    @shares.setter
    def shares(self, value: np.ndarray | None) -> None:
        """Set the shares (None: the eigentwists changed); the inertia kept for them goes."""
        self._shares, self.inertia = value, None

    @property
    def kind(self) -> str:
        """Deprecated name of :attr:`stiffness_model`."""
        warnings.warn("Modes.kind is deprecated: use Modes.stiffness_model", DeprecationWarning, stacklevel=2)
        return self.stiffness_model

    @property
    def natural_hz(self) -> np.ndarray:
        """(N, n) undamped natural frequency omega_n / 2 pi of each damped mode, Hz: the
        modulus of its pole (a curve fit's omega_n); :attr:`freq_hz` without damping."""
        return self.freq_hz if self.damping is None else self.damping.natural_hz

    @property
    def damped_hz(self) -> np.ndarray:
        """(N, n) damped frequency omega_d / 2 pi = omega_n sqrt(1 - zeta^2) / 2 pi, Hz (a
        free decay, a step response); :attr:`freq_hz` without damping."""
        return self.freq_hz if self.damping is None else self.damping.damped_hz

    @property
    def damping_ratio(self) -> np.ndarray:
        """(N, n) damping ratio zeta of each mode (-); 0 without damping."""
        if self.damping is None:
            return np.where(np.isnan(self.freq_hz), np.nan, 0.0)
        return self.damping.damping_ratio

    @property
    def complex_eigentwists(self) -> np.ndarray | None:
        """(N, n, n) complex eigentwists (columns, largest entry 1 + 0j) of the damped modes,
        from ``modes(..., complex_shapes=True)``; None otherwise."""
        return None if self.damping is None else self.damping.shapes

    @property
    def direction(self) -> np.ndarray:
        """(N, n) axis index (into :data:`AXES`) carrying the largest share of each mode's
        energy (:mod:`eigentwist.runtime.labels`: unit-free, not an entry of the eigentwist);
        a rigid model's coordinates are its allowed twists, named by :attr:`axes`."""
        if self.eigentwists is None:
            raise InputError("these modes were computed without eigentwists: call modes(..., vectors=True)")
        local = directions(self.eigentwists, shares=self.shares)
        return np.asarray([AXES.index(a) for a in self.axes])[local]  # the allowed twists' axes
