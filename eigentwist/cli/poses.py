"""Pose checks the commands share: a warning outside the workspace box, where an
unreachable pose could go instead."""

from __future__ import annotations

from .common import CliError, eprint

__all__ = ["warn_workspace", "check_pose", "pose_argument", "POSE_HELP"]

POSE_HELP = (
    "pose: the end-effector position in the base frame, m (X Y Z) for a 3-DoF robot; the platform "
    "origin, m, and its rotation vector, rad (X Y Z ROT_X ROT_Y ROT_Z) for a 6-DoF robot (hexapod)"
)


def pose_argument(ev, values, option: str = "--pose"):
    """``values`` (a list of floats from ``nargs="+"``) as a pose of ``ev``'s robot, or its
    ``x_ref`` when None; a wrong count raises a :class:`CliError` naming the coordinates."""
    import numpy as np

    if values is None:
        return np.array(ev.robot.x_ref, dtype=float)
    names = tuple(getattr(ev.robot, "pose", ("x", "y", "z")))
    if len(values) != len(names):
        raise CliError(
            f"{option} {' '.join(f'{v:g}' for v in values)}: {ev.robot.name} takes {len(names)} "
            f"coordinates ({', '.join(names)}), got {len(values)}"
        )
    return np.array(values, dtype=float)


def warn_workspace(ev, poses, command: str) -> None:
    """Print one warning line on stderr when a pose lies outside the robot's workspace box."""
    from ..runtime.reach import outside_workspace

    msg = outside_workspace(ev.robot, poses)
    if msg:
        eprint(f"eigentwist {command}: warning: {msg}")


def check_pose(ev, pose, model, params: dict, command: str = "matrices") -> None:
    """For an unreachable or singular pose raise a :class:`CliError` that also says which
    heights are reachable at its x, y (the error is the only line); else warn when the
    pose lies outside the workspace box."""
    from ..runtime import SingularPoseError, UnreachablePoseError
    from ..runtime.reach import reach_hint

    try:
        ev.jacobians(pose, **params)
    except (UnreachablePoseError, SingularPoseError) as exc:
        hint = reach_hint(ev, pose, model, **params)
        raise CliError(f"{exc}" + (f"; {hint}" if hint else "")) from None
    warn_workspace(ev, pose, command)
