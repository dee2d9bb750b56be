"""The selection's significance rule for one candidate effect (used by the selection and its report).

Its own module so that :mod:`.verdict` renders a diagnosis without importing :mod:`.select`.
"""

from __future__ import annotations

import math

__all__ = ["significant"]


def significant(c, current, m: int, alpha: float, plausible_only: bool = True) -> bool:
    """Whether adding ``c`` (one of ``m`` candidates) is significant and lowers AICc."""
    return (
        (c.plausible or not plausible_only)
        and c.p_value is not None
        and math.isfinite(c.p_value)
        and c.p_value < alpha / max(m, 1)
        and c.fit.aicc < current.aicc
    )
