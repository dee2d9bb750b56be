"""The pose box of a sweep: one (lo, hi) range per pose coordinate of the robot."""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["workspace_box"]


def workspace_box(box, robot) -> tuple:
    """The sweep box as ``((lo, hi), ...)`` per pose coordinate (m; rad for rotations):
    ``box`` flat or paired, or None for the robot's workspace box; errors name the
    robot's coordinates."""
    if box is None:
        return tuple(tuple(float(v) for v in b) for b in robot.workspace)
    names = tuple(getattr(robot, "pose", ("x", "y", "z")))
    flat = np.asarray(box, dtype=float).reshape(-1)
    if flat.shape != (2 * len(names),) or not np.isfinite(flat).all():
        what = " ".join(f"{a.upper()}LO {a.upper()}HI" for a in names)
        unit = "m" if len(names) == 3 else "m and rad"
        count = {6: "six", 12: "twelve"}.get(2 * len(names), str(2 * len(names)))
        raise InputError(f"box {np.asarray(box).tolist()}: expected {count} finite numbers {what} in {unit}")
    pairs = tuple((float(flat[2 * k]), float(flat[2 * k + 1])) for k in range(len(names)))
    for name, (lo, hi) in zip(names, pairs):
        if lo > hi:
            raise InputError(
                f"box {name} range [{lo:g}, {hi:g}] {'rad' if name.startswith('rot') else 'm'}: expected LO <= HI"
            )
    return pairs
