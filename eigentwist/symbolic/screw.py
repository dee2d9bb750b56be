"""Screw algebra: moved to :mod:`eigentwist.description.screw` (descriptions and effects use it,
the derivation receives their results); these names stay importable from here."""
from ..description.screw import *  # noqa: F401,F403
from ..description.screw import __all__  # noqa: F401
