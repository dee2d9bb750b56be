"""Robot descriptions shipped with eigentwist. ``get(name)`` returns one.

The modules ``heli4`` and ``delta`` are public: a description file of the user's own
starts from one (``heli4.describe()``, ``heli4.EFFECTS``) and adds effects.
"""

from __future__ import annotations

from importlib import import_module

from ..errors import InputError

__all__ = ["get", "NAMES", "heli4", "delta", "hexapod"]

NAMES = ("heli4", "delta", "hexapod")


def get(name: str):
    """The description of robot ``name`` (one of :data:`NAMES`): a
    :class:`~eigentwist.description.RobotDescription`, or a joint-list
    :class:`~eigentwist.description.chain.ChainRobot` (the hexapod)."""
    if name not in NAMES:
        from ..description.names import did_you_mean  # SymPy: not imported by ``eigentwist --help``

        raise InputError(f"unknown robot {name!r}{did_you_mean(name, NAMES)}: expected one of {', '.join(NAMES)}")
    return import_module(f".{name}", __name__).describe()


def __getattr__(name: str):
    """``from eigentwist.robots import heli4`` without importing every robot up front."""
    if name in NAMES:
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
