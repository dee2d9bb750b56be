"""Figures of the report that show rather than tell: the lowest frequency over the
workspace, the MAC matrix of measured vs model mode shapes, the animated mode shapes.

Pure computations returning plain data (and PNG bytes); :mod:`.build` puts them in the
:class:`~.build.ReportData`, the template draws them.
"""

from __future__ import annotations

import io

import numpy as np

__all__ = ["lowest_frequency_map", "lowest_frequency_png", "mac_matrix", "final_values"]

MAP_GRID = 41  # points per axis of the workspace map


def final_values(diag, values: dict | None = None) -> dict:
    """The final model's parameter values (SI): the run's, then every value the diagnosis
    used or fitted (``FitResult.fixed``), then the data's constant parameter columns."""
    meas = diag.meas
    const = {k: float(v[0]) for k, v in getattr(meas, "params", {}).items() if np.all(v == v[0])}
    return {**dict(values or {}), **diag.final.fixed, **const}


def lowest_frequency_map(ev, effects, pose, k_a: float, values: dict, grid: int = MAP_GRID) -> dict:
    """The lowest natural frequency (Hz) over the workspace's first two coordinates (x, y),
    the others held at ``pose``: ``{"x", "y" (m), "f1" (grid, grid) Hz, NaN where unreachable}``;
    a model with damping adds the lowest damped frequency ``"f1_damped"`` (Hz) and the
    least damping ratio of any mode ``"zeta_min"`` (the least damped mode's), (grid, grid)."""
    box = getattr(ev.robot, "workspace", None)
    pose = np.asarray(pose, float)
    if box is None or len(box) < 2:
        half = 0.1
        box = ((pose[0] - half, pose[0] + half), (pose[1] - half, pose[1] + half))
    x = np.linspace(*box[0], grid)
    y = np.linspace(*box[1], grid)
    X, Y = np.meshgrid(x, y)
    poses = np.repeat(pose[None, :], X.size, axis=0)
    poses[:, 0], poses[:, 1] = X.ravel(), Y.ravel()
    modes = ev.modes(poses, effects, k_a=k_a, vectors=False, invalid="nan", **values)
    out = {"x": x, "y": y, "f1": modes.freq_hz[:, 0].reshape(X.shape)}
    if modes.damping is not None:
        with np.errstate(invalid="ignore"):
            out["f1_damped"] = np.nanmin(
                np.where(modes.damped_hz > 0, modes.damped_hz, np.nan),
                axis=1,
                initial=np.inf,
                where=~np.isnan(modes.damped_hz),
            ).reshape(X.shape)
            out["zeta_min"] = np.nanmin(
                modes.damping_ratio, axis=1, initial=np.inf, where=~np.isnan(modes.damping_ratio)
            ).reshape(X.shape)
        for key in ("f1_damped", "zeta_min"):
            out[key][~np.isfinite(out[key])] = np.nan
    return out


def lowest_frequency_png(ev, effects, pose, k_a: float, values: dict, measured_poses, title: str = "") -> bytes:
    """The map of :func:`lowest_frequency_map` as a PNG, the measured poses marked."""
    from ..matplotlib_agg import pyplot

    plt = pyplot()
    m = lowest_frequency_map(ev, effects, pose, k_a, values)
    damped = "f1_damped" in m
    f = m["f1_damped"] if damped else m["f1"]
    fig, ax = plt.subplots(figsize=(6.2, 4.8))
    mesh = ax.pcolormesh(m["x"], m["y"], f, shading="auto", cmap="viridis")
    if np.isfinite(f).sum() > 4:
        cs = ax.contour(m["x"], m["y"], f, levels=8, colors="white", linewidths=0.7)
        ax.clabel(cs, fontsize=7, fmt="%.3g")
    if damped and np.isfinite(m["zeta_min"]).sum() > 4:  # the least damped mode's ratio, dashed
        cz = ax.contour(m["x"], m["y"], m["zeta_min"], levels=5, colors="orange", linewidths=0.8, linestyles="--")
        ax.clabel(cz, fontsize=7, fmt="zeta %.2g")
    fig.colorbar(mesh, ax=ax, label="lowest damped frequency [Hz]" if damped else "lowest natural frequency f1 [Hz]")
    mp = np.asarray(measured_poses, float)
    ax.plot(mp[:, 0], mp[:, 1], "o", mfc="none", mec="red", mew=2, ms=9, label="measured poses")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


def mac_matrix(meas, ev, effects, values: dict) -> dict | None:
    """MAC of measured vs model mode shapes at the setting (pose, k_a) with the most measured
    shapes: ``{"pose", "k_a", "measured" (row labels), "model" (column labels), "mac"
    (rows x columns, 0..1)}``; None when the data have no shapes.

    Model shapes are the eigentwists transported to each row's sensor, v + omega x r
    (:func:`~eigentwist.diagnose.shapes.sensor_shapes`); MAC = |a^H b|^2 / (|a|^2 |b|^2).
    """
    from ..diagnose.shapes import mac, sensor_shapes

    shapes = getattr(meas, "shapes", None)
    if shapes is None:
        return None
    has = np.isfinite(shapes).all(axis=1)
    if not has.any():
        return None
    keys = np.column_stack([np.round(meas.poses, 9), meas.k_a])
    uniq, inv, counts = np.unique(keys[has], axis=0, return_inverse=True, return_counts=True)
    best = uniq[int(np.argmax(counts))]
    rows = np.flatnonzero(has & np.all(np.isclose(keys, best, atol=1e-9), axis=1))
    pose, k_a = best[:-1], float(best[-1])
    row_values = {**values, **{k: float(v[rows[0]]) for k, v in getattr(meas, "params", {}).items()}}
    modes = ev.modes(pose[None, :], effects, k_a=k_a, **row_values)
    n = modes.freq_hz.shape[1]
    out = np.zeros((len(rows), n))
    for i, r in enumerate(rows):
        model = sensor_shapes(modes.eigentwists, meas.sensor[r])[0]  # (3, n)
        out[i] = [float(mac(shapes[r], model[:, j])) for j in range(n)]
    order = np.argsort(meas.freq_hz[rows])
    return {
        "pose": pose.tolist(),
        "k_a": k_a,
        "measured": [f"{meas.mode[rows[i]]} {meas.freq_hz[rows[i]]:.4g} Hz" for i in order],
        "model": [f"{j + 1}: {modes.freq_hz[0, j]:.4g} Hz" for j in range(n)],
        "mac": out[order].tolist(),
    }
