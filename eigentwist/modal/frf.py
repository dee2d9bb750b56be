"""Frequency-response functions of a model: M, K (Eqs. 12-14) with modal damping.

Responses are translational accelerations (or velocities, displacements) of the sensor
point along +X, +Y, +Z; references are forces along +X, +Y, +Z at the same point (a
hammer at the measurement node). With the M-orthonormal eigentwists ``t_k`` (Eq. 6) and
``T(r)`` the transport to the sensor (:func:`eigentwist.diagnose.shapes.transport_matrix`):

    H(w) = c(w) T(r) [ sum_k t_k t_k^T / (w_k^2 - w^2 + 2 i zeta w_k w) ] T(r)^T

with ``c = 1`` (receptance, m/N), ``i w`` (mobility, m/(N s)) and ``-w^2`` (accelerance,
m/(N s^2)); ``zeta`` is the modal damping ratio of every mode. A force at the sensor
acts on the end-effector as the wrench ``[r x F; F] = T(r)^T F``, so H is symmetric.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..diagnose.shapes import transport_matrix
from ..runtime.eigen import generalized_eigh

__all__ = ["FORMS", "modal_frf", "frf_from_modes", "form_factor"]

FORMS = ("receptance", "mobility", "accelerance")


def form_factor(freq_hz, form: str) -> np.ndarray:
    """(F,) factor turning receptance into ``form`` at ``freq_hz`` (Hz)."""
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    if form == "receptance":
        return np.ones_like(w, dtype=complex)
    if form == "mobility":
        return 1j * w
    if form == "accelerance":
        return -(w**2) + 0j
    raise InputError(f"FRF form {form!r}: expected one of {', '.join(FORMS)}")


def frf_from_modes(freq_hz, omega_k, shapes, zeta, form: str = "accelerance", ref_shapes=None) -> np.ndarray:
    """(F, O, R) FRF from natural angular frequencies ``omega_k`` (n,) rad/s and mode shapes.

    ``shapes`` (O, n) are the mass-normalised mode shapes (1/sqrt(kg)) at the response
    DOFs, ``ref_shapes`` (R, n) at the reference DOFs (default: ``shapes``, a force at each
    response DOF); ``zeta`` a scalar or (n,) damping ratio:
    ``H_or = c(w) sum_k U_ok U_rk / (w_k^2 - w^2 + 2 i zeta w_k w)``.
    """
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)[:, None]
    zeta = np.broadcast_to(np.asarray(zeta, dtype=float), omega_k.shape)
    denom = omega_k**2 - w**2 + 2j * zeta * omega_k * w  # (F, n)
    H = np.einsum("ik,fk,jk->fij", shapes, 1.0 / denom, shapes if ref_shapes is None else ref_shapes)
    return H * form_factor(freq_hz, form)[:, None, None]


def modal_frf(M, K, freq_hz, zeta, form: str = "accelerance", sensor=None) -> np.ndarray:
    """(F, 3, 3) FRF at the sensor of the model (M, K) (6x6 flexible or 3x3 rigid).

    Parameters
    ----------
    M, K : (n, n) inertia (kg, kg m, kg m^2) and stiffness at the end-effector origin.
    freq_hz : (F,) frequency axis, Hz.
    zeta : modal damping ratio (scalar or (n,)).
    form : ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    sensor : (3,) sensor offset from the end-effector origin, m (ignored by a rigid model).
    """
    lam, V = generalized_eigh(np.asarray(K)[None], np.asarray(M)[None])
    omega_k = np.sqrt(np.clip(lam[0], 0.0, None))
    V = V[0]
    U = V if V.shape[0] == 3 else transport_matrix(np.zeros(3) if sensor is None else sensor) @ V
    return frf_from_modes(freq_hz, omega_k, U, zeta, form)
