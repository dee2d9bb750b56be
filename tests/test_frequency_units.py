"""The unit check's ratio skips every row it cannot use, each on its own, and names a unit only
strictly within ``UNIT_TOL`` of its factor.

Each bad row is paired with one good row of ratio 2: the median of two logarithms is their
mean, so a bad row that slipped in would move the ratio (or make it inf/nan).
"""

from __future__ import annotations

import math
import warnings

import pytest

from eigentwist.diagnose import units


@pytest.mark.parametrize(
    "measured, predicted",
    [
        (5.0, 0.0),  # no prediction (zero)
        (5.0, -5.0),  # a negative prediction
        (5.0, math.nan),  # no prediction (nan)
        (5.0, None),  # no prediction (None)
        (5.0, math.inf),
        (0.0, 10.0),  # a zero measurement
        (-5.0, 10.0),
        (math.nan, 10.0),
        (None, 10.0),
        (math.inf, 10.0),
    ],
)
def test_a_row_without_a_finite_positive_pair_is_left_out_of_the_ratio(measured, predicted):
    assert units.frequency_ratio([20.0, measured], [10.0, predicted]) == pytest.approx(2.0, rel=1e-12)


def test_predictions_below_one_hertz_count():
    assert units.frequency_ratio([1.0, 0.6], [0.5, 0.3]) == pytest.approx(2.0, rel=1e-12)


def test_no_usable_row_gives_nan_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert math.isnan(units.frequency_ratio([0.0, math.nan], [10.0, 10.0]))
        assert units.unit_note([0.0], [10.0]) is None


def test_a_ratio_exactly_unit_tol_from_a_factor_names_no_unit(monkeypatch):
    # 1.5e3 / 1e3 is exactly UNIT_TOL in binary: the boundary itself is outside
    assert units.UNIT_TOL == 1.5 and dict(units.UNITS)["mHz"] == 1e3
    monkeypatch.setattr(units, "frequency_ratio", lambda m, p: 1.5e3)
    assert units.unit_note(None, None) is None
    monkeypatch.setattr(units, "frequency_ratio", lambda m, p: math.nextafter(1.5e3, 0.0))
    assert "mHz" in units.unit_note(None, None)
