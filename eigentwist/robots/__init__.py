"""Robot descriptions shipped with eigentwist. ``get(name)`` returns one."""
from __future__ import annotations

from importlib import import_module

from ..description import RobotDescription
from ..description.names import did_you_mean

__all__ = ["get", "NAMES"]

NAMES = ("heli4", "delta")


def get(name: str) -> RobotDescription:
    """The description of robot ``name`` (one of :data:`NAMES`)."""
    if name not in NAMES:
        raise ValueError(f"unknown robot {name!r}{did_you_mean(name, NAMES)}: expected one of {', '.join(NAMES)}")
    return import_module(f".{name}", __name__).describe()
