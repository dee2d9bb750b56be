"""Pose checks the commands share: a warning outside the workspace box, where an
unreachable pose could go instead."""
from __future__ import annotations

from .common import CliError, eprint

__all__ = ["warn_workspace", "check_pose"]


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
