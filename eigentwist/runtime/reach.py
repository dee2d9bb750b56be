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

SCAN = 2.0        # m scanned above and below the reference height
POINTS = 4001     # 1 mm spacing before bisection
BISECT = 30


def box_text(workspace) -> str:
    """``"x in [-0.1, 0.1], y in [-0.1, 0.1], z in [-0.7, -0.55] m"``."""
    return ", ".join(f"{a} in [{lo:g}, {hi:g}]" for a, (lo, hi) in zip("xyz", workspace)) + " m"


def outside_workspace(robot, poses) -> str | None:
    """A one-line warning when some poses lie outside ``robot.workspace``, else None."""
    poses = np.atleast_2d(np.asarray(poses, dtype=float))
    lo = np.array([a for a, _ in robot.workspace])
    hi = np.array([b for _, b in robot.workspace])
    out = np.flatnonzero(np.any((poses < lo - 1e-12) | (poses > hi + 1e-12), axis=1))
    if not len(out):
        return None
    first = poses[out[0]].tolist()
    many = f" ({len(out)} of {len(poses)} poses, first {first} m)" if len(poses) > 1 else f" ({first} m)"
    return (f"pose outside {robot.name}'s documented workspace box{many}: {box_text(robot.workspace)}; "
            "results there are not covered by the tests")


def _edge(ev, x, y, z_ok, z_bad, model, params) -> float:
    for _ in range(BISECT):
        mid = 0.5 * (z_ok + z_bad)
        if ev.valid(np.array([[x, y, mid]]), model, **params)[0]:
            z_ok = mid
        else:
            z_bad = mid
    return z_ok


def reachable_z(ev, x: float, y: float, model="paper", **params) -> list[tuple[float, float]]:
    """Intervals [(z_lo, z_hi), ...] (m) where (x, y, z) is reachable and not singular."""
    z0 = float(ev.robot.x_ref[2])
    z = np.linspace(z0 - SCAN, z0 + SCAN, POINTS)
    ok = ev.valid(np.column_stack([np.full_like(z, x), np.full_like(z, y), z]), model, **params)
    out = []
    k = 0
    while k < len(z):
        if not ok[k]:
            k += 1
            continue
        j = k
        while j + 1 < len(z) and ok[j + 1]:
            j += 1
        lo = _edge(ev, x, y, z[k], z[k - 1], model, params) if k > 0 else z[k]
        hi = _edge(ev, x, y, z[j], z[j + 1], model, params) if j + 1 < len(z) else z[j]
        out.append((float(lo), float(hi)))
        k = j + 1
    return out


def reach_hint(ev, pose, model="paper", **params) -> str:
    """What is valid at the pose's x, y: ``"at x = 0, y = 0 the valid heights are z in [...] m"``."""
    x, y = float(pose[0]), float(pose[1])
    scalars = {k: v for k, v in params.items() if np.ndim(v) == 0}
    try:
        spans = reachable_z(ev, x, y, model, **scalars)
    except ValueError:
        return ""
    where = f"at x = {x:g}, y = {y:g} m"
    if not spans:
        return f"{where} no height is reachable (try x, y within {box_text(ev.robot.workspace)})"
    return f"{where} the reachable, non-singular heights are " + " or ".join(
        f"z in [{lo:.4f}, {hi:.4f}]" for lo, hi in spans) + " m"
