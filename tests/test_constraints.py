"""Parameters are checked together, not only one by one."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from eigentwist.runtime import InputError

X_REF = np.array([0.0, 0.0, -0.625])


@pytest.mark.parametrize(
    "params, fragment",
    [
        ({"r_i": 0.005}, "r_i < r_o"),  # equal radii: a tube with no wall
        ({"r_i": 0.006}, "r_i < r_o"),  # a negative area and mass before
        ({"r_o": 0.003}, "r_i < r_o"),
        ({"I_e_zz": 0.05}, "I_e_zz <= I_e_xx + I_e_yy"),
        ({"I1_yy": 0.01}, "I1_yy <= I1_xx + I1_zz"),
    ],
)
def test_joint_conditions_are_named(ev, params, fragment):
    with pytest.raises(InputError) as err:
        ev.frequencies(X_REF, **params)
    msg = str(err.value)
    assert fragment in msg and "\n" not in msg
    for name, value in params.items():
        assert f"{name} = {value:g}" in msg


def test_a_bad_row_is_found_in_a_batch(ev):
    with pytest.raises(InputError, match=r"\(row 2\)"):
        ev.frequencies(np.tile(X_REF, (3, 1)), r_i=np.array([0.003, 0.004, 0.0055]))


def test_effect_conditions_apply_when_the_effect_is_on(ev):
    ev.frequencies(X_REF, model="paper", r_i_l1=0.02)  # lower link tube not in the model
    with pytest.raises(InputError, match="r_i_l1 < r_o_l1"):
        ev.frequencies(X_REF, model="paper,lower_link_compliance", r_i_l1=0.02)


def test_valid_designs_pass_on_both_robots():
    import eigentwist

    for robot in ("heli4", "delta"):
        e = eigentwist.load(robot, backend="numpy")
        assert np.isfinite(e.frequencies(e.robot.x_ref, model="paper,lower_link_compliance")).all()


def test_cli_reports_one_line():
    r = subprocess.run(
        [sys.executable, "-m", "eigentwist", "matrices", "--set", "r_i=0.006"], capture_output=True, text=True
    )
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "r_i < r_o" in lines[0] and "Traceback" not in r.stderr
