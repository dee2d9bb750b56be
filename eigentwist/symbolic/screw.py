"""Deprecated home of the screw algebra: it lives in :mod:`eigentwist.description.screw`.

Importing this module warns (``DeprecationWarning``) and gives the same names, so a
description file written against the old import keeps working.
"""

import warnings

from ..description.screw import *  # noqa: F401,F403
from ..description.screw import __all__  # noqa: F401

warnings.warn(
    "eigentwist.symbolic.screw is deprecated: import the screw algebra from eigentwist.description.screw",
    DeprecationWarning,
    stacklevel=2,
)
