"""Damping ratios as residuals (``diagnose/damping.py``) on hand-made rows: which rows count,
with which sigma, and the decay bound on both sides of zero (written out from the definitions:
a measured ratio's residual (zeta - measured) / sigma; a damped row's min(zeta_least, 0) /
DECAY_SIGMA)."""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.diagnose import damping as dmp

NAN = np.nan
S = dmp.DECAY_SIGMA


class Rows(NS):
    def __len__(self):
        return len(self.freq_hz)


def _meas(**cols):
    return Rows(freq_hz=np.ones(4), **cols)


# rows: 0 measured, 1 damped without a value, 2 neither, 3 measured and damped
MEAS = _meas(
    damping_ratio=np.array([0.02, NAN, NAN, 0.01]),
    sigma_damping_ratio=np.array([0.005, 0.5, 0.5, 0.002]),
    damped=np.array([False, True, False, True]),
)


def test_rows_with_a_measured_ratio_or_a_decay_count_with_their_sigma():
    rows, sigma, measured = dmp.zeta_rows(MEAS)
    assert rows.tolist() == [0, 1, 3] and sigma.tolist() == [0.005, S, 0.002]
    assert measured.tolist() == [True, False, True]
    rows, sigma, measured = dmp.zeta_rows(MEAS, damped_model=False)  # no decay bound: zeta = 0 there
    assert rows.tolist() == [0, 3] and sigma.tolist() == [0.005, 0.002] and measured.all()


def test_rows_without_damping_columns():
    assert dmp.zeta_rows(_meas()) is None
    assert dmp.zeta_rows(_meas(damped=np.zeros(4, bool))) is None
    rows, sigma, measured = dmp.zeta_rows(_meas(damped=np.array([0, 0, 1, 0])))
    assert rows.tolist() == [2] and sigma.tolist() == [S] and measured.tolist() == [False]
    rows, sigma, measured = dmp.zeta_rows(_meas(damping_ratio=np.array([NAN, 0.03, NAN, NAN])))
    assert rows.tolist() == [1] and sigma.tolist() == [1.0] and measured.tolist() == [True]  # sigma 1 unless given


def test_residuals_measured_and_the_decay_bound_on_both_sides_of_zero():
    spec = dmp.zeta_rows(MEAS)
    zeta = np.array([0.03, -2 * S, 5.0, 0.004])
    r = dmp.zeta_residuals(MEAS, zeta, spec)
    assert r == pytest.approx([(0.03 - 0.02) / 0.005, -2.0, (0.004 - 0.01) / 0.002], rel=1e-12)
    zeta[1] = 2 * S  # a decaying mode: no cost
    assert dmp.zeta_residuals(MEAS, zeta, spec)[1] == 0.0
    # the least damped mode of the row decides the bound, not the matched one
    least = np.array([0.0, -3 * S, 0.0, -1.0])
    r = dmp.zeta_residuals(MEAS, zeta, spec, least)
    assert r == pytest.approx([2.0, -3.0, -3.0], rel=1e-12)  # measured rows keep zeta - measured
    least[1] = 3 * S  # least above the matched one: the matched one's zeta
    assert dmp.zeta_residuals(MEAS, np.array([0.0, -S, 0.0, 0.0]), spec, least)[1] == pytest.approx(-1.0)


def test_residuals_of_many_parameter_sets_at_once():
    spec = dmp.zeta_rows(MEAS)
    zeta = np.array([[0.02, -S, 0.0, 0.01], [0.025, S, 0.0, 0.012]])
    assert dmp.zeta_residuals(MEAS, zeta, spec) == pytest.approx(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 1.0]]))


def test_least_damping_leaves_out_nan_modes():
    modes = NS(damping_ratio=np.array([[0.1, NAN, 0.05], [NAN, NAN, NAN], [-0.2, 0.3, 0.0]]))
    assert dmp.least_damping(modes).tolist() == [0.05, np.inf, -0.2]


@pytest.mark.parametrize(
    "cols, count, carries",
    [
        ({}, 0, False),
        ({"damped": np.zeros(4, bool), "damping_ratio": np.full(4, NAN)}, 0, False),
        ({"damped": np.array([0, 0, 0, 1])}, 0, True),
        ({"damping_ratio": np.array([NAN, 0.01, NAN, NAN])}, 1, True),
        ({"damping_ratio": np.array([NAN, 0.01, 0.02, NAN])}, 2, True),
    ],
)
def test_data_carry_damping_with_one_damped_row_or_one_ratio(cols, count, carries):
    meas = _meas(**cols)
    assert dmp.zeta_count(meas) == count and dmp.carries_damping(meas) is carries


def test_attach_damping_takes_each_rows_matched_mode():
    modes = NS(damping_ratio=np.array([[0.01, 0.02], [0.03, -S], [0.05, 0.06], [0.07, 0.08]]))
    comp = dmp.attach_damping(NS(), MEAS, modes, np.array([1, 0, 1, 0]), dmp.zeta_rows(MEAS))
    assert comp.zeta.tolist() == [0.02, 0.03, 0.06, 0.07]
    # row 1's least damped mode grows (-S): the bound counts it though the matched mode decays
    assert comp.zeta_residuals == pytest.approx([0.0, -1.0, (0.07 - 0.01) / 0.002], rel=1e-12)
    assert dmp.attach_damping(NS(), MEAS, modes, np.array([0, 0, 0, 0]), None).zeta_residuals is None
