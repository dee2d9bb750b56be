"""Synthetic measurements: truth specs, seeded noise, the effect outside the catalogue."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.diagnose import compare, load_measurements, parse_truth, synth
from eigentwist.diagnose.synth import parse_noise
from eigentwist.runtime import InputError

KA = [125.0, 500.0, 2000.0]


def test_parse_truth(ev):
    t = parse_truth("paper+transmission_compliance:k_t=8000+payload_mass:m_p=0.5,p_z=0.02", ev)
    assert t.effects == ("actuator_loss", "rod_compliance", "ee_compliance", "transmission_compliance", "payload_mass")
    assert t.values == {"k_t": 8000.0, "m_p": 0.5, "p_z": 0.02}
    assert parse_truth("rigid:m_e=0.7", ev).values == {"m_e": 0.7}
    assert parse_truth("none", ev).effects == ()


@pytest.mark.parametrize(
    "spec, words",
    [
        ("paper+warp_drive", "warp_drive"),
        ("paper+payload_mass:mass=3", "unknown parameter 'mass'"),
        ("paper+payload_mass:m_p=heavy", "not a number"),
        ("paper+payload_mass:m_p", "PARAM=VALUE"),
        ("paper+payload_mass:m_p=-1", "m_p"),
        ("", "empty"),
    ],
)
def test_bad_truth_specs(ev, spec, words):
    with pytest.raises(InputError, match=words):
        parse_truth(spec, ev)


def test_noise_parsing():
    assert parse_noise("0.5%") == pytest.approx(0.005) and parse_noise("0.01") == 0.01
    for bad in ("lots", "-1%", "150%"):
        with pytest.raises(InputError):
            parse_noise(bad)


def test_noise_free_data_is_the_truth_model(ev):
    poses = [ev.robot.x_ref, [-0.1, 0.0, -0.55]]
    m = synth("paper+payload_mass:m_p=0.5", KA, poses, ("x", "y", "z"), noise=0, ev=ev)
    assert len(m) == 2 * 3 * 3
    assert np.allclose(m.sigma_hz, 0.02 * m.freq_hz)  # no noise: default sigma
    pred = compare(m, "paper", ev).predicted
    assert not np.allclose(pred, m.freq_hz)  # payload not in "paper"
    pred = compare(m, "paper,payload_mass", ev, {"m_p": 0.5}).predicted
    assert np.allclose(pred, m.freq_hz, rtol=1e-12)


def test_seeded_noise_has_the_stated_size(ev):
    k_a = np.geomspace(100, 4000, 50)
    a = synth("rigid", k_a, None, ("x", "y", "z"), "0.5%", seed=7, ev=ev)
    b = synth("rigid", k_a, None, ("x", "y", "z"), "0.5%", seed=7, ev=ev)
    c = synth("rigid", k_a, None, ("x", "y", "z"), "0.5%", seed=8, ev=ev)
    assert np.array_equal(a.freq_hz, b.freq_hz) and not np.array_equal(a.freq_hz, c.freq_hz)
    truth = synth("rigid", k_a, None, ("x", "y", "z"), 0, ev=ev).freq_hz
    rel = a.freq_hz / truth - 1
    # 150 draws: the sample std of N(0, 0.005) lies within 20 % of 0.005 with overwhelming probability
    assert np.std(rel) == pytest.approx(0.005, rel=0.2) and abs(np.mean(rel)) < 0.005 * 4 / np.sqrt(150)
    assert np.allclose(a.sigma_hz, 0.005 * a.freq_hz)


def test_extra_stiffness_is_a_spring_on_the_x_axis(ev):
    # rigid model at x_ref: M and K_R (translational 3x3) are diagonal, so the X mode is
    # sqrt((K_xx + k) / M_xx) / 2 pi exactly
    m = synth("rigid", [1000.0], None, ("x", "y"), noise=0, ev=ev, extra_stiffness={"x": 300.0})
    mats = ev.matrices(ev.robot.x_ref, "rigid", k_a=1000.0)
    K, M = mats["K_R"][0], mats["M"][0]
    assert m.freq_hz[0] == pytest.approx(np.sqrt((K[3, 3] + 300.0) / M[3, 3]) / (2 * np.pi), rel=1e-9)
    assert m.freq_hz[1] == pytest.approx(np.sqrt(K[4, 4] / M[4, 4]) / (2 * np.pi), rel=1e-9)
    with pytest.raises(InputError, match="rx"):
        synth("rigid", [1000.0], None, ("x",), noise=0, ev=ev, extra_stiffness={"rx": 1.0})


def test_synth_cli_writes_a_loadable_file(tmp_path, ev, capsys):
    from eigentwist.cli.main import main

    out = tmp_path / "d.csv"
    assert (
        main(
            [
                "synth",
                "--truth",
                "paper+transmission_compliance:k_t=8000",
                "--k-a",
                "125,500",
                "2000",
                "--poses",
                "0,0,-0.625 -0.1,0,-0.55",
                "--pose",
                "0.05",
                "0",
                "-0.6",
                "--modes",
                "x,y",
                "--noise",
                "0.5%",
                "--seed",
                "3",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    m = load_measurements(out, ev=ev)
    assert len(m) == 3 * 3 * 2 and len(np.unique(m.poses, axis=0)) == 3
    assert "wrote 18 rows" in capsys.readouterr().out
    assert main(["synth", "--truth", "paper+nothing", "--k-a", "100"]) == 2
    assert "nothing" in capsys.readouterr().err


def test_stated_sigma_is_apart_from_the_noise_drawn(ev):
    k_a = np.geomspace(100, 4000, 40)
    a = synth("rigid", k_a, None, ("x", "y", "z"), "3%", seed=5, ev=ev, sigma="1%")
    b = synth("rigid", k_a, None, ("x", "y", "z"), "3%", seed=5, ev=ev)
    assert np.array_equal(a.freq_hz, b.freq_hz)  # same draws: sigma changes only the column
    assert np.allclose(a.sigma_hz, 0.01 * a.freq_hz) and np.allclose(b.sigma_hz, 0.03 * b.freq_hz)
    truth = synth("rigid", k_a, None, ("x", "y", "z"), 0, ev=ev).freq_hz
    assert np.std(a.freq_hz / truth - 1) == pytest.approx(0.03, rel=0.2)  # 120 draws of N(0, 3 %)
    exact = synth("rigid", k_a, None, ("x",), 0, ev=ev, sigma="5%")
    assert np.allclose(exact.sigma_hz, 0.05 * exact.freq_hz)  # noise-free data, stated sigma
    with pytest.raises(InputError, match="sigma"):
        synth("rigid", k_a, None, ("x",), 0, ev=ev, sigma="lots")


def test_noise_levels_draw_independently(ev):
    k_a = np.geomspace(100, 4000, 100)
    truth = synth("rigid", k_a, None, ("x", "y", "z"), 0, ev=ev).freq_hz
    z = {
        level: (synth("rigid", k_a, None, ("x", "y", "z"), f"{level}%", seed=11, ev=ev).freq_hz / truth - 1)
        / (level / 100)
        for level in (0.5, 2.0)
    }
    # one draw scaled would give identical standardised deviations (correlation 1); independent draws
    # of 300 have |correlation| < 4/sqrt(300) = 0.23 with overwhelming probability
    assert abs(np.corrcoef(z[0.5], z[2.0])[0, 1]) < 0.23
    again = synth("rigid", k_a, None, ("x", "y", "z"), "2%", seed=11, ev=ev).freq_hz / truth - 1
    assert np.allclose(again / 0.02, z[2.0], rtol=1e-12)  # the same (seed, level): the same draws


def test_synth_cli_sigma_option(tmp_path, ev):
    from eigentwist.cli.main import main

    out = tmp_path / "d.csv"
    assert (
        main(
            [
                "synth",
                "--truth",
                "rigid",
                "--k-a",
                "500,2000",
                "--modes",
                "x,y",
                "--noise",
                "3%",
                "--sigma",
                "1%",
                "--seed",
                "2",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    m = load_measurements(out, ev=ev)
    assert np.allclose(m.sigma_hz, 0.01 * m.freq_hz, rtol=1e-9)
