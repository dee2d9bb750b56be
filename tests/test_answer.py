"""The answer first: a diagnosis opens with at most 8 lines (4 more for a damping part) of at
most 100 characters holding the verdict, the effect added with its value, and the next
measurement; candidates that are mirror images at the measured poses are one row.

Mirror images are checked against the robot's geometry, independently of the fits: two legs
are mirror images at the measured poses when an isometry of the base frame that keeps the
vertical axis (a rotation about it or a reflection in a plane through it) maps every leg's
base joint and platform attachment onto another leg's at every measured pose, and leg i onto
leg j.
"""

from __future__ import annotations

import itertools
import re

import numpy as np
import pytest
from scipy import stats

import eigentwist
from eigentwist.cli.main import main
from eigentwist.description.effects import split_scope
from eigentwist.diagnose import diagnose, synth
from eigentwist.diagnose.answer import DAMPING_LINES, MAX_LINES, WIDTH, answer
from eigentwist.diagnose.matching import DIRECTIONS
from eigentwist.diagnose.mirror import mirror_groups
from eigentwist.plots import robot_geometry

# their fixtures are diagnoses of 7-11 s: make test, not make test-fast
pytestmark = pytest.mark.slow

KA = (250, 500, 1000, 2000, 4000)


@pytest.fixture(scope="module")
def heli4():
    return eigentwist.load("heli4", backend="numpy")


@pytest.fixture(scope="module")
def cases(heli4, paper_rigid_diagnosis):
    """name -> (diagnosis, evaluator, the effect that must be named, its parameter, true value or None)."""
    out = {}
    # the README walkthrough: 30 rows, a hidden 0.35 kg payload, 0.5 % noise (seed 3)
    meas = synth(
        "paper+payload_mass:m_p=0.35",
        KA,
        [[0, 0, -0.625], [0.06, -0.04, -0.6]],
        ["x", "y", "z"],
        "0.5%",
        seed=3,
        ev=heli4,
    )
    out["walkthrough"] = (diagnose(meas, "paper", ev=heli4), heli4, "payload_mass", "m_p", 0.35)
    # the paper's measurements from the rigid model: ee_compliance (the paper's static test: 500 N m/rad)
    # (conftest's paper_rigid_diagnosis: diagnose(parse_csv(paper_csv("heli4"), ...), "rigid") on NumPy)
    out["paper"] = (paper_rigid_diagnosis, heli4, "ee_compliance", "k_E_rot", None)
    # one weak actuator, leg 3, measured at the central pose only: legs 3 and 4 are mirror images
    meas = synth("paper+actuator_loss@3:eta_a@3=0.55", KA, [[0, 0, -0.625]], ["x", "y", "z"], 0.005, 0, ev=heli4)
    out["per-leg"] = (diagnose(meas, "paper", ev=heli4), heli4, "actuator_loss@3", "eta_a@3", 0.55)
    return out


@pytest.fixture(scope="module")
def hexapod_case():
    ev = eigentwist.load("hexapod", backend="numpy")
    poses = [[0, 0, 0.8, 0, 0, 0], [0.05, 0, 0.78, 0, 0.05, 0.1]]
    meas = synth("paper+payload_mass:m_p=8", [1e7, 2e7], poses, [str(k) for k in range(1, 7)], "0.2%", seed=1, ev=ev)
    return diagnose(meas, baseline="paper", ev=ev), ev, "payload_mass", "m_p", 8.0


def _check_answer(d, ev, effect, name, truth):
    a = answer(d, ev)
    lines = a["lines"]
    assert 1 <= len(lines) <= MAX_LINES + (DAMPING_LINES if a["damping"] else 0), lines
    assert not lines[-1].endswith("(the rest: --details)"), lines
    assert all(len(line) <= WIDTH for line in lines), [len(line) for line in lines]
    text = "\n".join(lines)
    assert lines[0].startswith("Explained" if d.explained else "NOT explained"), lines[0]
    assert re.search(r"chi2/nu = [\d.e+]+/\d+", lines[0])
    # the effect and its value, with the error and the unit the parameter has
    assert re.search(rf"{re.escape(effect)}( or @\d)?\b", text), text
    unit = ev.parameter(name).unit
    m = re.search(
        rf"{re.escape(name)} = \(?([\d.]+) ± ([\d.]+)\)?(·10\S+)? ?{re.escape(unit) if unit != '-' else ''}", text
    )
    assert m, (name, text)
    value, std = d.final.values[name], d.final.std[name]
    if truth is not None:
        assert abs(value - truth) < 3 * std + 1e-12, (value, std, truth)
    assert any(line.startswith("Next:") for line in lines), text


@pytest.mark.parametrize("case", ["walkthrough", "paper", "per-leg"])
def test_the_answer_block_holds_verdict_effect_value_and_next_measurement(cases, case):
    _check_answer(*cases[case])


@pytest.mark.slow
def test_the_answer_block_of_a_hexapod_diagnosis(hexapod_case):
    _check_answer(*hexapod_case)


def test_the_paper_answer_names_the_tie_and_the_measurement_that_separates_it(cases):
    d, ev, *_ = cases["paper"]
    a = answer(d, ev)
    assert a["apart"].startswith("Cannot tell apart: ee_compliance or ee_coupling")
    # subsets the search found as good (|dAICc| < 2 from the selection) are named beside it
    for t in d.search.ties[:2]:
        assert abs(t.fit.aicc - d.final.aicc) < 2 and " + ".join(t.effects) in a["apart"]
    assert "none needed" not in a["next"]
    # the paper measured modes x and y only (14-40 Hz): the proposal is one of them, inside that band
    m = re.search(r"measure mode (\w+) at .*: ee_compliance ([\d.]+) Hz, ee_coupling ([\d.]+) Hz", a["next"])
    assert m and m.group(1) in set(d.meas.mode), a["next"]
    lo, hi = d.meas.freq_hz.min() / 1.25, d.meas.freq_hz.max() * 1.25
    assert all(lo <= float(m.group(k)) <= hi for k in (2, 3)), a["next"]


def test_the_paper_answer_says_which_damping_the_data_support_and_what_separates_them(cases):
    """Servo damping is supported; a torque lag is not (its F test on top of the final model,
    computed here) but fits as well; the measurement that separates them lies in the measured
    k_a range, where both models are stable, and its values are the models' own there."""
    d, ev, *_ = cases["paper"]
    a = answer(d, ev)
    s = a["damping_support"]
    assert [x["effect"] for x in s["supported"]] == ["servo_damping"]
    no = {x["effect"]: x for x in s["not_supported"]}
    assert set(no) == {"servo_delay", "structural_loss"}
    final = d.final
    lag = next(c for c in d.steps[-1].ranking if c.effect == "servo_delay")
    dk, dof = lag.fit.k - final.k, lag.fit.n - lag.fit.k
    p = stats.f.sf((final.chi2 - lag.fit.chi2) / dk / (lag.fit.chi2 / dof), dk, dof)
    assert no["servo_delay"]["p_value"] == pytest.approx(p, rel=1e-6) and d.alpha < p
    assert f"servo_delay (p = {p:.2g}, fits as well with t_d = " in a["damping"]
    assert no["servo_delay"]["fits_alike"] and abs(lag.fit.aicc - final.aicc) < 2
    m = s["measurement"]
    assert m["between"] == ["servo_damping", "servo_damping + servo_delay"] and m["mode"] in set(d.meas.mode)
    assert d.meas.k_a.min() <= m["k_a"] <= d.meas.k_a.max()
    values = []
    for f in (final, lag.fit):
        modes = ev.modes(np.array([m["pose"]]), f.effects, k_a=np.array([m["k_a"]]), **f.fixed)
        zeta = modes.damping_ratio[0]
        assert np.all(zeta >= 0.0)  # stable: a step response decays there
        k = int(np.flatnonzero(modes.direction[0] == DIRECTIONS.index(m["mode"]))[0])
        values.append(zeta[k] if m["quantity"] == "damping_ratio" else getattr(modes, m["quantity"])[0, k])
    assert [m["predicted"][x] for x in m["between"]] == pytest.approx(values, rel=1e-6)
    if m["quantity"] == "damping_ratio":  # a lag takes damping away; sigma: 20 % of the value, >= 0.005
        assert values[1] < values[0]
        sigma = max(0.2 * (values[0] + values[1]) / 2, 0.005)
        assert m["separation_sigma"] == pytest.approx(abs(values[0] - values[1]) / sigma, rel=1e-6)
    assert m["separation_sigma"] > 3.0 and "To tell them apart, measure" in a["damping"]


# ------------------------------------------------------------------ mirror images
def _legs_symmetric(ev, poses, i: int, j: int) -> bool:
    """An isometry keeping the vertical axis maps legs onto legs (base and attachment) at every
    pose and leg i onto leg j (0-based): rotations about z and reflections in vertical planes,
    tried at the angles that send leg i's base joint onto leg j's."""
    geo = [robot_geometry(ev, p) for p in poses]
    b = geo[0].base
    ti, tj = (np.arctan2(b[k, 1], b[k, 0]) for k in (i, j))
    maps = []
    for phi in (tj - ti,):  # rotation about z by phi
        c, s = np.cos(phi), np.sin(phi)
        maps.append(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]))
    theta = (ti + tj) / 2  # reflection in the vertical plane at theta
    for t in (theta, theta + np.pi / 2):
        c, s = np.cos(2 * t), np.sin(2 * t)
        maps.append(np.array([[c, s, 0], [s, -c, 0], [0, 0, 1]]))
    for T in maps:
        ok = True
        for g in geo:
            for pts in (g.base, g.attachment):
                moved = pts @ T.T
                d = np.linalg.norm(moved[:, None, :] - pts[None, :, :], axis=-1)
                perm = np.argmin(d, axis=1)
                if np.max(np.min(d, axis=1)) > 1e-9 or len(set(perm)) != len(perm) or perm[i] != j:
                    ok = False
        if ok:
            return True
    return False


@pytest.mark.parametrize("case", ["paper", "per-leg", "walkthrough"])
def test_mirror_images_are_grouped_exactly_when_the_robot_is_symmetric(cases, case):
    """Each group of the ranking is the same effect on legs the geometry maps onto each other;
    every pair of legs the geometry maps onto each other is grouped for every per-leg effect
    whose fit is determined (the walkthrough's off-centre pose: no group at all)."""
    d, ev, *_ = cases[case]
    poses = np.unique(np.round(d.meas.poses, 9), axis=0)
    groups = mirror_groups(d.ranking, d.meas.sigma_hz)
    grouped = set()
    for g in groups:
        names = {split_scope(c.effect)[0] for c in g}
        assert len(names) == 1
        legs = [split_scope(c.effect)[1] for c in g]
        for a, b in itertools.combinations(legs, 2):
            assert _legs_symmetric(ev, poses, a - 1, b - 1), (case, [c.effect for c in g])
            grouped.add((names.pop() if len(names) else split_scope(g[0].effect)[0], a, b))
    symmetric = [
        (a, b)
        for a, b in itertools.combinations(range(1, ev.n_legs + 1), 2)
        if _legs_symmetric(ev, poses, a - 1, b - 1)
    ]
    if case == "walkthrough":
        assert symmetric == [] and all(len(g) == 1 for g in groups)
    else:
        assert (1, 2) in symmetric and (3, 4) in symmetric and (1, 3) not in symmetric
        per_leg = {split_scope(c.effect)[0] for c in d.ranking if split_scope(c.effect)[1]}
        for effect in per_leg:
            for a, b in symmetric:
                ca = next(c for c in d.ranking if c.effect == f"{effect}@{a}")
                cb = next(c for c in d.ranking if c.effect == f"{effect}@{b}")
                if all(np.isfinite(list(ca.param_std.values()))) and ca.fit.success:
                    assert any({ca.effect, cb.effect} <= {c.effect for c in g} for g in groups), (effect, a, b)


def test_the_per_leg_answer_is_one_row_for_two_mirror_legs(cases):
    d, ev, *_ = cases["per-leg"]
    a = answer(d, ev)
    assert "actuator_loss@3 or @4 (leg 3 or 4)" in a["added"]
    assert ["actuator_loss@3", "actuator_loss@4"] in a["mirror_images"]


def test_the_cli_opens_with_the_answer_and_details_hold_the_rest(capsys):
    assert main(["diagnose", "paper", "--details"]) == 0
    out = capsys.readouterr().out
    head, _, rest = out.partition("\n\n")
    # the paper's step responses are damped frequencies: the servo damping explains them
    assert 1 <= len(head.splitlines()) <= MAX_LINES + DAMPING_LINES and head.startswith("Explained")
    assert "servo_damping" in head and "Damping supported: servo_damping" in head
    assert "2. Candidate effects" in rest and "criteria:" in rest
    assert "transmission_compliance@1 or @2" in rest  # one row for the mirror images
    assert not re.search(r"^\s+\d+\s+transmission_compliance@2\b", rest, re.M)
    assert max(len(line) for line in head.splitlines()) <= WIDTH
