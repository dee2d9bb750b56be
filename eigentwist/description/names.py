"""Suggestions for mistyped names (effects, presets, parameters, robots, modes, columns)."""

from __future__ import annotations

import difflib

__all__ = ["did_you_mean"]


def did_you_mean(name, choices) -> str:
    """``" (did you mean rod_compliance?)"`` for the closest of ``choices``, or ``""``.

    Appended to the one-line error that rejects ``name``; case is ignored.
    """
    choices = [str(c) for c in choices]
    lowered = {c.lower(): c for c in choices}
    close = difflib.get_close_matches(str(name).lower(), list(lowered), n=1, cutoff=0.5)
    return f" (did you mean {lowered[close[0]]}?)" if close else ""
