"""``eigentwist sensitivity`` and ``eigentwist optimize``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import eigentwist
from eigentwist.cli.main import main

from .test_sensitivity import WRT


@pytest.fixture(scope="module")
def ev():
    ev = eigentwist.load("heli4", backend="numpy")
    ev.sensitivities(ev.robot.x_ref, WRT["heli4"])  # loaded once: every subset below reuses it
    return ev


def test_sensitivity_table_ranks_by_relative_sensitivity(ev, capsys):
    assert main(["sensitivity", "--wrt", ",".join(WRT["heli4"]), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    rel = [abs(r["dlnf1_dlnp"]) for r in out["parameters"]]
    assert rel == sorted(rel, reverse=True) and len(rel) == len(WRT["heli4"])
    s = ev.sensitivities(ev.robot.x_ref, WRT["heli4"])[0]
    f1 = ev.frequencies(ev.robot.x_ref)[0, 0]
    for r in out["parameters"]:
        j = WRT["heli4"].index(r["name"])
        assert np.isclose(r["dlnf1_dlnp"], s[0, j] * ev.defaults[r["name"]] / f1, rtol=1e-9)
    assert main(["sensitivity", "--wrt", "k_a,l2", "--set", "l2=0.55"]) == 0
    text = capsys.readouterr().out
    assert "dlnf1/dlnp" in text and "Hz/(N m/rad)" in text


def test_sensitivity_errors_are_one_line(capsys):
    assert main(["sensitivity", "--wrt", "k_a,nope"]) == 2
    assert "unknown parameter" in capsys.readouterr().err
    assert main(["sensitivity", "--wrt", "k_a", "--model", "paper,gravity_preload"]) == 2
    assert "gravity_preload" in capsys.readouterr().err


def test_optimize_prints_design_map_and_active_constraints(ev, capsys):
    argv = [
        "optimize",
        "--backend",
        "numpy",
        "--vary",
        "l1=0.15:0.25",
        "--pose",
        "0",
        "0",
        "-0.625",
        "--pose",
        "0.05",
        "-0.03",
        "-0.6",
    ]
    assert main(argv + ["--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert 0.15 <= out["values"]["l1"] <= 0.25 and out["worst_hz"] >= out["start_worst_hz"]
    assert len(out["f1_hz"]) == 2 and out["active"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "worst-case f1" in text and "active constraints" in text
    assert main(["optimize", "--vary", "l1=0.3:0.2"]) == 2
    assert "--vary" in capsys.readouterr().err


def test_default_wrt_is_the_models_geometry_masses_moduli_and_k_a():
    """Without --wrt: k_a and the parameters in m, kg, Pa that act in the model."""
    from eigentwist.cli.sensitivity import default_wrt
    from eigentwist.description.effects import resolve_model

    ev = eigentwist.load("heli4", backend="numpy")
    paper = default_wrt(ev, resolve_model("paper", ev.robot))
    assert {"l1", "l2", "r_o", "m_e", "k_a", "E_rod"} <= set(paper)
    # inertias, a ratio, a switched-off effect's modulus and gravity are left to --wrt all
    assert not {"I1_xx", "eta_a", "E_l1", "k_t", "g"} & set(paper)
    assert all(ev.parameters[n].unit in ("m", "kg", "Pa") or n == "k_a" for n in paper)
    rigid = default_wrt(ev, resolve_model("rigid", ev.robot))
    assert "E_rod" not in rigid and "E_l1" in default_wrt(ev, resolve_model("paper,lower_link_compliance", ev.robot))
