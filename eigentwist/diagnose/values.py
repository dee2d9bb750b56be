"""The parameter values a run actually used, beside the robot's defaults.

Precedence (highest first): a measurement file's parameter column, values given for the
run (``--set``, ``--model NAME:PARAM=VALUE``, the ``values`` argument of
:func:`~eigentwist.diagnose.compare.compare`), the robot's default. Fitted values (a
diagnosis) start from the given value and replace it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["used_parameters", "changed_text"]

SOURCES = ("default", "given", "data column", "fitted")


def _base(name: str) -> str:
    return name.partition("@")[0]


def _row(p, name: str, value, source: str, effects) -> dict:
    row = {
        "name": name,
        "unit": p.unit,
        "default": float(p.default),
        "source": source,
        "effect": p.effect or "",
        "active": p.effect is None or p.effect in effects,
        "doc": p.doc,
    }
    arr = np.unique(np.asarray(value, dtype=float))
    row["value"] = float(arr[0]) if arr.size == 1 else None
    row["range"] = [float(arr.min()), float(arr.max())]
    row["differs"] = bool(np.any(arr != float(p.default)))
    return row


def used_parameters(ev, effects=(), values: dict | None = None, meas=None, fitted: dict | None = None) -> list[dict]:
    """One row per parameter of ``ev``'s robot (and per per-leg value ``NAME@N`` given).

    Each row: ``name``, ``value`` (SI; None when a data column varies it per row),
    ``range`` [min, max], ``unit``, ``default``, ``differs`` (from the default),
    ``source`` (``default``, ``given``, ``data column`` or ``fitted``), ``effect``,
    ``active`` (its effect is in ``effects``, or it belongs to the base model), ``doc``.
    """
    values = dict(values or {})
    fitted = dict(fitted or {})
    columns = dict(getattr(meas, "params", {}) or {})
    rows = []
    for p in ev.robot.parameters:
        names = [p.name] + sorted(
            (k for k in {**values, **columns} if "@" in k and _base(k) == p.name),
            key=lambda k: int(k.partition("@")[2]),
        )
        for name in names:
            if name in columns:
                value, source = columns[name], "data column"
            elif name in fitted:
                value, source = fitted[name], "fitted"
            elif name in values:
                value, source = values[name], "given"
            else:
                value, source = p.default, "default"
            rows.append(_row(p, name, value, source, effects))
    return rows


def _value_text(row: dict) -> str:
    if row["value"] is not None:
        return f"{row['value']:.6g}"
    return f"{row['range'][0]:.6g} ... {row['range'][1]:.6g} (per row)"


def changed_text(rows: list[dict], robot: str) -> str:
    """One line: the used values that differ from ``robot``'s defaults, or that none do."""
    changed = [r for r in rows if r["differs"]]
    if not changed:
        return f"parameters: {robot}'s defaults (none changed)"
    items = []
    for r in changed:
        off = "" if r["active"] else f", {r['effect']} is off"
        items.append(f"{r['name']} = {_value_text(r)} {r['unit']} (default {r['default']:.6g}, {r['source']}{off})")
    return f"parameters changed from {robot}'s defaults: " + "; ".join(items)
