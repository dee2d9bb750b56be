"""Where a robot can go: its documented workspace box and the reachable heights at an x, y.

Both answer a user whose pose was refused or is unusual: a pose outside the robot's
``workspace`` box (its documented, tested region) gets a warning naming the box; an
unreachable or singular pose gets the z-ranges that are valid at the same x, y, found
from the description's own inverse kinematics (``Evaluator.valid`` on a line of
heights, ends refined by bisection).
"""

from __future__ import annotations

import numpy as np

__all__ = ["outside_workspace", "reachable_z", "reach_hint", "box_text"]

SCAN = 2.0  # m scanned above and below the reference height
POINTS = 4001  # 1 mm spacing before bisection
BISECT = 30


def box_text(workspace, names=("x", "y", "z")) -> str:
    """``"x in [-0.1, 0.1], y in [-0.1, 0.1], z in [-0.7, -0.55] m"``; a 6-DoF box adds
    ``rot_x in [...]`` ... in rad."""
    text = ", ".join(f"{a} in [{lo:g}, {hi:g}]" for a, (lo, hi) in zip(names[:3], workspace)) + " m"
    if len(workspace) > 3:
        text += ", " + ", ".join(f"{a} in [{lo:g}, {hi:g}]" for a, (lo, hi) in zip(names[3:], workspace[3:])) + " rad"
    return text


def _names(robot) -> tuple:
    return tuple(getattr(robot, "pose", ("x", "y", "z")))


def outside_workspace(robot, poses) -> str | None:
    """A one-line warning when some poses lie outside ``robot.workspace``, else None."""
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    lo = np.array([a for a, _ in robot.workspace])
    hi = np.array([b for _, b in robot.workspace])
    out = np.flatnonzero(np.any((poses < lo - 1e-12) | (poses > hi + 1e-12), axis=1))
    if not len(out):
        return None
    first = poses[out[0]].tolist()
    many = f" ({len(out)} of {len(poses)} poses, first {first})" if len(poses) > 1 else f" ({first})"
    return (
        f"pose outside {robot.name}'s documented workspace box{many}: {box_text(robot.workspace, _names(robot))}; "
        "results there are not covered by the tests"
    )


def _at(rest, z) -> np.ndarray:
    """Poses (len(z), n): ``rest`` (x, y and any rotation) with its z replaced by ``z``."""
    out = np.tile(np.asarray(rest, dtype=float), (len(np.atleast_1d(z)), 1))
    out[:, 2] = z
    return out


def _edge(ev, rest, z_ok, z_bad, model, params) -> float:
    for _ in range(BISECT):
        mid = 0.5 * (z_ok + z_bad)
        if ev.valid(_at(rest, [mid]), model, **params)[0]:
            z_ok = mid
        else:
            z_bad = mid
    return z_ok


def reachable_z(ev, x: float, y: float, model="paper", *, rotation=(), **params) -> list[tuple[float, float]]:
    """Intervals [(z_lo, z_hi), ...] (m) where (x, y, z) is reachable and not singular
    (a 6-DoF robot: with the platform's ``rotation`` vector, rad, held)."""
    z0 = float(ev.robot.x_ref[2])
    z = np.linspace(z0 - SCAN, z0 + SCAN, POINTS)
    rest = [x, y, z0, *rotation]
    ok = ev.valid(_at(rest, z), model, **params)
    out = []
    k = 0
    while k < len(z):
        if not ok[k]:
            k += 1
            continue
        j = k
        while j + 1 < len(z) and ok[j + 1]:
            j += 1
        lo = _edge(ev, rest, z[k], z[k - 1], model, params) if k > 0 else z[k]
        hi = _edge(ev, rest, z[j], z[j + 1], model, params) if j + 1 < len(z) else z[j]
        out.append((float(lo), float(hi)))
        k = j + 1
    return out


def reach_hint(ev, pose, model="paper", **params) -> str:
    """What is valid at the pose's x, y: ``"at x = 0, y = 0 the valid heights are z in [...] m"``."""
    x, y = float(pose[0]), float(pose[1])
    scalars = {k: v for k, v in params.items() if np.ndim(v) == 0}
    try:
        spans = reachable_z(ev, x, y, model, rotation=[float(r) for r in np.ravel(pose)[3:]], **scalars)
    except ValueError:
        return ""
    where = f"at x = {x:g}, y = {y:g} m" + (" and this rotation" if len(np.ravel(pose)) > 3 else "")
    if not spans:
        return f"{where} no height is reachable (try x, y within {box_text(ev.robot.workspace, _names(ev.robot))})"
    return (
        f"{where} the reachable, non-singular heights are "
        + " or ".join(f"z in [{lo:.4f}, {hi:.4f}]" for lo, hi in spans)
        + " m"
    )
