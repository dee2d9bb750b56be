"""Descriptions of parallel manipulators as data (parameters, legs, bodies, effects)."""

from .parameters import Parameter, sym
from .robot import Coupling, Leg, RobotDescription, EECompliance
from .chain import ChainJoint as Joint
from .rrpirr import RRPIRR_CHAIN
from .effects import EFFECTS, KINDS, PRESETS, PRIMITIVES, Effect, EffectContext, Term, effect_parameters, resolve_model
from .constraints import Constraint, tube, triangle_inequality

__all__ = [
    "Parameter",
    "sym",
    "Coupling",
    "Joint",
    "Leg",
    "RobotDescription",
    "EECompliance",
    "RRPIRR_CHAIN",
    "EFFECTS",
    "KINDS",
    "PRIMITIVES",
    "PRESETS",
    "Effect",
    "EffectContext",
    "Term",
    "effect_parameters",
    "resolve_model",
    "Constraint",
    "tube",
    "triangle_inequality",
]
