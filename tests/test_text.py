"""Plain-text helpers shared by the core and the command line (eigentwist/text.py)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from eigentwist.text import format_estimate, format_table, json_safe


@pytest.mark.parametrize(
    "value, std, unit, expected",
    [
        (373.6, 37.72, "N m/rad", "374 ± 38 N m/rad"),
        (164072.4, 30643.8, "N/m", "(1.64 ± 0.31)·10⁵ N/m"),
        (0.34931, 0.0031, "kg", "0.3493 ± 0.0031 kg"),
        (0.82, 0.031, "-", "0.820 ± 0.031"),
        (2.5e-5, 1.1e-6, "m", "(2.50 ± 0.11)·10⁻⁵ m"),
        (170e9, math.inf, "Pa", "1.7·10¹¹ (± undetermined) Pa"),
        (129870.13, None, "N/m", "1.2987·10⁵ N/m"),
        (None, 1.0, "kg", "(undetermined) kg"),
    ],
)
def test_format_estimate(value, std, unit, expected):
    assert format_estimate(value, std, unit) == expected


def test_json_safe_and_format_table():
    out = json_safe(
        {"a": np.float64(1.5), "b": [np.int64(2), float("nan")], 3: np.array([1.0, np.inf]), "ok": np.bool_(True)}
    )
    assert out == {"a": 1.5, "b": [2, None], "3": [1.0, None], "ok": True}
    json.dumps(out, allow_nan=False)
    table = format_table(["name", "x"], [["a", 1.23456], ["bb", 2.0]], ".3g")
    assert table.splitlines() == ["name     x", "----  ----", "   a  1.23", "  bb     2"]


def test_cli_common_reexports_format_table():
    from eigentwist.cli.common import format_table as cli_format_table

    assert cli_format_table is format_table
