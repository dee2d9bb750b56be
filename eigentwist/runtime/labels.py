"""Which axis a mode moves along: each coordinate's share of the mode's energy.

An eigentwist mixes rotations (rad) and translations (m), so comparing its entries says
nothing physical: the largest entry changes with the units and with the reference point.
The share of coordinate i in mode k's kinetic energy is unit-free,

    s_ik = t_ik (M t_k)_i / (t_k^T M t_k),

and does not depend on the scale of the eigentwist t_k. Because the eigentwists are
M-orthogonal (V^T M V diagonal, Eq. 6), M V = V^-T diag(t_k^T M t_k), so

    s_ik = V_ik (V^-1)_ki,

computable from the eigentwists alone (the modal participation factors). Each mode's
shares sum to 1 over the coordinates, and each coordinate's over the modes. The
potential-energy shares are the same (K t = omega^2 M t). A share can be slightly
negative where M couples a coordinate to the others; it is large and positive for the
coordinates the mode moves.

For a group of modes with (nearly) equal frequencies, any basis of their eigenspace is a
set of eigentwists; the group's share of a coordinate (the sum over its members, the
diagonal of the M-orthogonal projector onto the eigenspace) does not depend on the basis.
"""

from __future__ import annotations

import numpy as np

__all__ = ["energy_shares", "directions", "DEGENERATE_REL", "degenerate_groups", "group_shares"]

DEGENERATE_REL = 0.01  # modes closer than 1 % in frequency are one measured peak (module doc of matching)


def energy_shares(eigentwists: np.ndarray, M: np.ndarray | None = None) -> np.ndarray:
    """(N, n, n) shares s[r, i, k] of coordinate i in mode k's energy (module doc).

    ``eigentwists`` is (N, n, n), one column per mode, any scaling per column; rows with
    non-finite entries (invalid poses) give NaN. With the inertia matrix ``M`` (N, n, n)
    that the eigentwists are M-orthogonal in, the shares come from the definition,
    t_ik (M t_k)_i / (t_k^T M t_k) (one batched product instead of an inverse; the same
    values to round-off); without it, from V and V^-1.
    """
    v = np.asarray(eigentwists, dtype=float)
    if M is not None:
        num = v * (np.asarray(M, dtype=float) @ v)
        # t_k^T M t_k: the coordinates' rows added one after another (the order of NumPy's
        # reduction over that axis, at half its cost on a short middle axis)
        energy = num[..., 0, :].copy()
        for i in range(1, num.shape[-2]):
            energy += num[..., i, :]
        return num / energy[..., None, :]
    ok = np.isfinite(v).all(axis=(-2, -1))
    if ok.all():
        return v * np.swapaxes(np.linalg.inv(v), -1, -2)
    out = np.full(v.shape, np.nan)
    if ok.any():
        good = v[ok]
        out[ok] = good * np.swapaxes(np.linalg.inv(good), -1, -2)
    return out


def directions(eigentwists: np.ndarray, offset: int = 0, shares: np.ndarray | None = None) -> np.ndarray:
    """(N, n) index of the coordinate with the largest energy share of each mode, plus
    ``offset`` (3 maps the rigid model's x, y, z onto ``AXES``); ``shares``: the
    :func:`energy_shares` when they are known."""
    s = energy_shares(eigentwists) if shares is None else shares
    if np.isnan(s).any():
        s = np.nan_to_num(s, nan=-np.inf)
    return np.argmax(s, axis=-2) + offset


def degenerate_groups(freq_hz: np.ndarray, rel: float = DEGENERATE_REL) -> np.ndarray:
    """(N, n) group id of each mode: ascending modes whose gap to the previous one is at
    most ``rel`` times its frequency share the previous mode's group (chained)."""
    f = np.asarray(freq_hz, dtype=float)
    split = np.diff(f, axis=-1) > rel * np.abs(f[..., 1:])
    return np.concatenate([np.zeros(f.shape[:-1] + (1,), dtype=int), np.cumsum(split, axis=-1)], axis=-1)


def group_shares(shares: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """(N, n, n): for each coordinate i and mode k, the share of i summed over k's group."""
    same = groups[..., :, None] == groups[..., None, :]  # (N, n, n) mode k' in k's group
    return np.nan_to_num(shares) @ same.astype(float)
