"""Comparing a model with measurements: the paper's numbers, mode matching, residual patterns."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.diagnose import ModeMatchError, compare, load_measurements, paper_measurements
from eigentwist.diagnose.patterns import classify, hints
from eigentwist.paper import MEASURED, TABLE_KA


@pytest.fixture(scope="module")
def paper_data(ev):
    return paper_measurements(ev)


def test_rigid_model_on_the_paper_measurements(ev, paper_data):
    # facts file: the rigid model (K_R) errs by 13.6 % RMS and 32.9 % at most
    c = compare(paper_data, "rigid", ev)
    assert round(c.rms_pct, 1) == 13.6 and round(c.max_pct, 1) == 32.9
    # independent: the paper's own error formula on K_R frequencies matched by rank (x = omega_1, y = omega_2)
    f = ev.frequencies(np.tile(ev.robot.x_ref, (8, 1)), "rigid", k_a=np.array(TABLE_KA, float))
    err = np.concatenate([(f[:, 0] - MEASURED["x"]) / MEASURED["x"], (f[:, 1] - MEASURED["y"]) / MEASURED["y"]])
    assert np.allclose(np.sort(np.abs(c.error_pct)), np.sort(100 * np.abs(err)))
    assert (c.mode_index == np.repeat([0, 1], 8)).all()


def test_paper_model_on_the_paper_measurements(ev, paper_data):
    # facts file: 4.2 % RMS, 9.0 % max, and 6.0 % for omega_1 at k_a = 4000 (paper Sec. 5: 33 % -> 6 %)
    c = compare(paper_data, "paper", ev)
    assert round(c.rms_pct, 1) == 4.2 and round(c.max_pct, 1) == 9.0
    last_x = (np.asarray(paper_data.mode) == "x") & (paper_data.k_a == 4000)
    assert float(c.error_pct[last_x][0]) == pytest.approx(6.0, abs=0.05)
    assert c.chi2 == pytest.approx(np.sum(c.error_sigma**2))
    fails = {w["mode"]: w for w in c.where_it_fails()}
    assert fails["x"]["predicted"] == "too high" and 4000 in fails["x"]["k_a_range"]


def test_direction_matching_survives_a_mode_swap(tmp_path, ev):
    # Lowering the EE linear stiffness along Y (k_E_lin) lowers the Y mode below the X mode
    # at x_ref: rank 1 changes from the X mode to the Y mode, the directions do not.
    path = tmp_path / "swap.csv"
    path.write_text(
        "k_a,mode,freq_hz,k_E_lin\n"
        "2000,x,20,1.3e5\n2000,x,20,2e4\n2000,y,20,1.3e5\n2000,y,20,2e4\n2000,1,20,1.3e5\n2000,1,20,2e4\n"
    )
    c = compare(load_measurements(path, ev=ev), "paper", ev)
    modes = ev.modes(np.tile(ev.robot.x_ref, (2, 1)), "paper", k_a=2000.0, k_E_lin=np.array([1.3e5, 2e4]))
    assert [modes.axes[a] for a in np.argmax(np.abs(modes.eigentwists[:, :, 0]), axis=1)] == ["x", "y"]  # swapped
    x_pred, y_pred, rank1 = c.predicted[:2], c.predicted[2:4], c.predicted[4:]
    # k_E_lin acts along Y only, so at this symmetric pose the X mode does not move at all
    assert x_pred[0] == pytest.approx(x_pred[1], rel=1e-6)
    assert y_pred[1] < x_pred[1] < y_pred[0]
    assert rank1[0] == pytest.approx(x_pred[0]) and rank1[1] == pytest.approx(y_pred[1])
    assert c.mode_index.tolist() == [0, 1, 1, 0, 0, 0]


def test_direction_absent_from_the_model_is_a_clear_error(tmp_path, ev):
    path = tmp_path / "rot.csv"
    path.write_text("k_a,mode,freq_hz\n2000,x,20\n2000,rx,200\n")
    meas = load_measurements(path, ev=ev)
    with pytest.raises(ModeMatchError, match=r"line 3: mode 'rx': the rigid model has no mode along rx"):
        compare(meas, "rigid", ev)
    assert compare(meas, "paper", ev).mode_index[1] >= 3  # the flexible model has rotation modes
    path.write_text("k_a,mode,freq_hz\n2000,4,60\n")
    with pytest.raises(ModeMatchError, match=r"line 2: mode rank 4 does not exist.*3 modes"):
        compare(load_measurements(path, ev=ev), "rigid", ev)


def test_classify_recognises_the_three_shapes():
    k = np.array([125, 250, 500, 1000, 2000, 4000.0])
    w = np.full(6, 1e6)
    assert classify(k, -0.5 * np.log1p(k / 3000.0), w)["shape"] == "series"
    assert classify(k, 0.5 * np.log1p(20.0 / k), w)["shape"] == "parallel"
    res = classify(k, np.full(6, np.log(0.9)), w)
    assert res["shape"] == "constant" and res["ratio"] == pytest.approx(0.9)
    assert classify(k, np.zeros(6), w)["shape"] is None
    noise = np.random.default_rng(0).normal(0, 1e-3, 6)
    assert classify(k, noise, w)["shape"] is None  # pure noise at sigma = 1e-3: no pattern


def test_hints_on_the_paper_data_point_to_a_series_compliance(ev, paper_data):
    text = " ".join(hints(compare(paper_data, "rigid", ev)))
    assert "compliance in series" in text and "mode x" in text and "mode y" in text
