"""Whole settings that do not belong: one setting (pose x k_a) written with the
wrong k_a, or the wrong pose, is flagged by its CSV lines, set aside, and the true payload
recovered within 3 sigma; clean campaigns flag nothing.

Data from synth with a 0.3 kg payload; the mislabelling is done here (the rows measured at
k_a = 1000 N m/rad at the central pose written as 1500, or at another pose).
"""

from __future__ import annotations

import dataclasses
import importlib

import numpy as np
import pytest

import eigentwist
from eigentwist.description import resolve_model
from eigentwist.diagnose import diagnose, synth
from eigentwist.diagnose.answer import answer_text
from eigentwist.diagnose.fit import fit
from eigentwist.diagnose.settings import find_setting_anomalies
from eigentwist.diagnose.stats import ALPHA

fitmod = importlib.import_module("eigentwist.diagnose.fit")
KA = (250, 500, 1000, 2000, 4000)
POSES = ((0.0, 0.0, -0.625), (0.06, -0.04, -0.6))
M_P = 0.3


@pytest.fixture(scope="session")
def ev_cd():
    mp = pytest.MonkeyPatch()
    mp.setattr(fitmod, "EXACT_JACOBIAN", False)  # central differences
    yield eigentwist.load("heli4", backend="auto")
    mp.undo()


def campaign(ev, seed):
    return synth(f"paper+payload_mass:m_p={M_P}", KA, POSES, ("x", "y", "z"), 0.005, seed=seed, ev=ev)


def mislabelled(meas, what):
    rows = np.flatnonzero(np.isclose(meas.k_a, 1000) & np.all(np.isclose(meas.poses, POSES[0]), axis=1))
    if what == "k_a":
        k = meas.k_a.copy()
        k[rows] = 1500.0
        return dataclasses.replace(meas, k_a=k), rows
    p = meas.poses.copy()
    p[rows] = (0.03, -0.02, -0.61)
    return dataclasses.replace(meas, poses=p), rows


def test_clean_campaigns_flag_nothing(ev_cd):
    model = resolve_model("paper,payload_mass", ev_cd.robot)
    flagged = []
    for seed in range(20):
        meas = campaign(ev_cd, 100 + seed)
        f = fit(meas, model, ev_cd, ("m_p",))
        flagged += [(seed, a.lines) for a in find_setting_anomalies(meas, ev_cd, f, ALPHA)]
    assert flagged == []


@pytest.mark.slow
@pytest.mark.parametrize("what", ["k_a", "pose"])
def test_mislabelled_setting_is_flagged_and_the_payload_recovered(ev_cd, what):
    for seed in range(3):
        meas, rows = mislabelled(campaign(ev_cd, seed), what)
        d = diagnose(meas, "paper", ev=ev_cd)
        assert [a.lines for a in d.setting_anomalies] == [[int(x) for x in meas.lines[rows]]], seed
        a = d.setting_anomalies[0]
        assert a.what == what
        if what == "k_a":
            assert a.k_a == 1500.0 and abs(a.best_k_a / 1000.0 - 1) < 0.02
        else:
            assert np.allclose(a.best_pose, POSES[0])
        assert d.selected == ["payload_mass"] and abs(d.final.values["m_p"] - M_P) < 3 * d.final.std["m_p"]
        j = d.to_json()["setting_anomalies"][0]
        assert (
            j["lines"] == a.lines
            and j["best_k_a"] == a.best_k_a
            and j["evidence"]["chi2_best"] < j["evidence"]["chi2_written"]
        )
        assert len(d.meas) == len(meas) - len(rows) and d.all_rows is not None
        # the answer block names the setting by its lines and the label that fits
        text = answer_text(d, ev_cd)
        assert f"Setting set aside: lines {', '.join(str(x) for x in a.lines)} ({what} written" in text, text


def test_a_two_row_setting_written_with_another_k_a_is_left_out_and_flagged(ev_cd):
    """Modes x and y at k_a = 1000 written as 3000 (two rows, below MIN_ROWS): the model refitted
    without them predicts them far off, the measured k_a = 1000 fits them; without them the true
    k_t = 8000 N m/rad is within 3 sigma."""
    meas = synth("paper+transmission_compliance:k_t=8000", KA, POSES, ("x", "y"), 0.005, seed=4, ev=ev_cd)
    rows = np.flatnonzero(np.isclose(meas.k_a, 1000) & np.all(np.isclose(meas.poses, POSES[0]), axis=1))
    k = meas.k_a.copy()
    k[rows] = 3000.0
    meas = dataclasses.replace(meas, k_a=k)
    model = resolve_model("paper,transmission_compliance", ev_cd.robot)
    f = fit(meas, model, ev_cd, ("k_t",))
    found = find_setting_anomalies(meas, ev_cd, f, ALPHA)
    assert [a.lines for a in found] == [[int(x) for x in meas.lines[rows]]]
    assert found[0].n_rows == 2 and found[0].best_k_a == 1000.0 and found[0].what == "k_a"
    keep = ~np.isin(meas.lines, found[0].lines)
    g = fit(meas.subset(keep), model, ev_cd, ("k_t",))
    assert abs(g.values["k_t"] - 8000.0) < 3 * g.std["k_t"]
