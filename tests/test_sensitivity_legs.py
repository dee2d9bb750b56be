"""Sensitivities with respect to one leg's own value (``P@N``) and of per-leg models.

The derivative with respect to ``E_rod@2`` seeds only leg 2's input ``E_rod__2``; a model
may switch an effect on one leg (``lower_link_compliance@3``); a shared ``E_rod`` with leg 2
given its own value moves legs 1, 3, 4 only. Each is checked against central differences
of the evaluator (Richardson-extrapolated), varying exactly the value the name denotes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import eigentwist
from eigentwist.cli.main import main
from eigentwist.runtime import InputError

from .conftest import random_poses
from .test_sensitivity import _assert_close, _richardson

# leg copies of a modulus, an efficiency and a lower-link modulus, their shared parameters and
# the end-effector's stiffness: a subset of the diagnosis' exact kernel (every fitted parameter
# of the catalogue), which tests/test_diagnose_jacobian.py generates in the same worker first
# (tests/conftest.py: GROUPS["exact_kernel"]), so the suite generates one kernel for both
WRT = ("eta_a@3", "E_rod", "E_rod@2", "E_l1", "E_l1@3", "k_E_rot")


@pytest.fixture(scope="module")
def ev():
    ev = eigentwist.load("heli4", backend="numpy")
    ev.sensitivities(ev.robot.x_ref, WRT)
    return ev


def _fd(ev, poses, model, params, name):
    """Central difference of the frequencies in the value ``name`` denotes (P or P@N)."""
    base = name.partition("@")[0]
    value = params.get(name, params.get(base, ev.defaults[base]))
    return _richardson(lambda v: ev.frequencies(poses, model, **{**params, name: v}), value)


def test_one_legs_value_equals_central_differences(ev):
    poses = random_poses(ev.robot, 3, seed=31)
    model = "paper,lower_link_compliance@3"
    params = {"E_rod@2": 1.2e11, "eta_a@3": 0.8}
    got = ev.sensitivities(poses, WRT, model, **params)
    want = np.stack([_fd(ev, poses, model, params, n) for n in WRT], axis=-1)
    _assert_close(got, want)
    # the lower link is compliant on leg 3 only: E_l1 acts through leg 3's copy alone
    j, k = WRT.index("E_l1"), WRT.index("E_l1@3")
    assert np.allclose(got[..., j], got[..., k], rtol=1e-12, atol=0.0)
    assert np.abs(got[..., k]).max() > 0


def test_shared_parameter_moves_only_the_legs_without_their_own_value(ev):
    """d f / d E_rod with E_rod@2 given: legs 1, 3, 4 move, leg 2 keeps its own value."""
    poses = random_poses(ev.robot, 2, seed=32)
    own = {"E_rod@2": 0.7 * ev.defaults["E_rod"]}
    got = ev.sensitivities(poses, ("E_rod", "k_E_rot"), "paper", **own)
    want = _fd(ev, poses, "paper", own, "E_rod")
    _assert_close(got[..., :1], want[..., None])
    with_leg = ev.sensitivities(poses, ("E_rod", "E_rod@2"), "paper", **own)
    assert np.allclose(got[..., 0], with_leg[..., 0], rtol=1e-12, atol=0.0)
    # leg 2's share is material: moving all four copies would differ from the answer
    both = _richardson(lambda v: ev.frequencies(poses, "paper", E_rod=v, **{"E_rod@2": v * 0.7}), ev.defaults["E_rod"])
    assert not np.allclose(got[..., 0], both, rtol=1e-2, atol=0.0)
    _assert_close((with_leg[..., 0] + 0.7 * with_leg[..., 1])[..., None], both[..., None])


def test_bad_leg_names_are_one_line(ev):
    with pytest.raises(InputError, match=r"unknown parameter.*'E_rod@9'.*NAME@N"):
        ev.sensitivities(ev.robot.x_ref, ("E_rod@9",))
    with pytest.raises(InputError, match="l2@1"):
        ev.sensitivities(ev.robot.x_ref, ("l2@1",))


def test_cli_table_and_json_name_leg_values(ev, capsys):
    assert (
        main(
            [
                "sensitivity",
                "--backend",
                "numpy",
                "--wrt",
                "E_rod@2,eta_a@3",
                "--set",
                "E_rod@2=1.5e11",
                "--model",
                "paper,lower_link_compliance@3",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    rows = {r["name"]: r for r in out["parameters"]}
    assert set(rows) == {"E_rod@2", "eta_a@3"}
    assert rows["E_rod@2"]["value"] == 1.5e11 and rows["E_rod@2"]["unit"] == "Pa"
    s = ev.sensitivities(ev.robot.x_ref, ("E_rod@2",), "paper,lower_link_compliance@3", **{"E_rod@2": 1.5e11})
    f1 = ev.frequencies(ev.robot.x_ref, "paper,lower_link_compliance@3", **{"E_rod@2": 1.5e11})[0, 0]
    assert np.isclose(rows["E_rod@2"]["dlnf1_dlnp"], s[0, 0, 0] * 1.5e11 / f1, rtol=1e-9)
    assert main(["sensitivity", "--backend", "numpy", "--wrt", "eta_a@3"]) == 0
    assert "eta_a@3" in capsys.readouterr().out
