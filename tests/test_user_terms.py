"""An effect of several parts: the README's cable chain, a mass on the tool and a
spring to ground under one switch, fitted jointly; and the same chain written as two
effects, whose mass half is the catalogue's payload under another name.

Expectations from physics: the chain adds m_chain to the platform's translational inertia
(as a point payload at the EE origin does) and k_chain to K_F(5, 5), the y stiffness.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import numpy as np
import pytest

import eigentwist
from eigentwist.description import resolve_model
from eigentwist.diagnose import diagnose, synth
from eigentwist.diagnose.fit import fit
from eigentwist.diagnose.separate import equivalent

pytestmark = pytest.mark.slow
fitmod = importlib.import_module("eigentwist.diagnose.fit")

ROOT = Path(__file__).resolve().parent
README = (ROOT.parent / "README.md").read_text()
KA = (250, 500, 1000, 2000, 4000)
POSES = ((0.0, 0.0, -0.625), (0.06, -0.04, -0.6))
M_TRUE, K_TRUE = 0.3, 2500.0


def readme_chain_file() -> str:
    m = re.search(r"`my_chain\.py`:\n\n```python\n(.*?)```", README, re.S)
    assert m, "the README shows my_chain.py"
    return m.group(1)


@pytest.fixture(scope="module")
def robots(tmp_path_factory, ev):  # ``ev`` first: the session's Heli4 is loaded from the run's cache
    directory = tmp_path_factory.mktemp("terms")
    (directory / "my_chain.py").write_text(readme_chain_file())
    mp = pytest.MonkeyPatch()
    mp.setenv("EIGENTWIST_CACHE", str(directory / "cache"))
    mp.setattr(fitmod, "EXACT_JACOBIAN", False)  # central differences: no sensitivity kernel to generate
    chain = eigentwist.load(str(directory / "my_chain.py"), backend="numpy")
    two = eigentwist.load(str(ROOT / "data" / "user" / "heli4_two_part.py"), backend="numpy")
    yield chain, two
    mp.undo()


@pytest.fixture(scope="module")
def chain_data(ev):
    # the session's Heli4 (``robots`` asks for it before it points the cache at its own directory)
    return synth(
        f"paper+payload_mass:m_p={M_TRUE}",
        KA,
        POSES,
        ("x", "y", "z"),
        0.005,
        seed=2,
        ev=ev,
        extra_stiffness={"y": K_TRUE},
    )


def test_one_switch_adds_the_mass_and_the_spring(robots):
    chain, _ = robots
    pose = np.array([[0.05, -0.03, -0.61]])
    on = chain.matrices(pose, "paper,cable_chain", m_chain=M_TRUE, k_chain=K_TRUE)
    off = chain.matrices(pose, "paper", m_chain=M_TRUE, k_chain=K_TRUE)
    dM, dK = on["M"][0] - off["M"][0], on["K_F"][0] - off["K_F"][0]
    np.testing.assert_allclose(dM, np.diag([0, 0, 0, M_TRUE, M_TRUE, M_TRUE]), atol=1e-12)
    np.testing.assert_allclose(dK, np.diag([0, 0, 0, 0, K_TRUE, 0]), atol=1e-8 * K_TRUE)
    assert chain.robot.effect("cable_chain").primitives == ("added_inertia", "ground_spring")


def test_cable_chain_found_as_one_effect_with_both_values(robots, chain_data):
    chain, _ = robots
    d = diagnose(chain_data, "paper", ev=chain)
    assert d.selected == ["cable_chain"] and d.explained
    for name, truth in (("m_chain", M_TRUE), ("k_chain", K_TRUE)):
        assert abs(d.final.values[name] - truth) < 3 * d.final.std[name], (name, d.final.values, d.final.std)


def test_chain_mass_is_the_payload_under_another_name(robots, chain_data):
    _, two = robots
    base = resolve_model("paper", two.robot)
    payload = fit(chain_data, resolve_model(base + ("payload_mass",), two.robot), two, ("m_p",))
    mass = fit(chain_data, resolve_model(base + ("chain_mass",), two.robot), two, ("m_chain",))
    spring = fit(chain_data, resolve_model(base + ("chain_spring",), two.robot), two, ("k_chain",))
    assert payload.values["m_p"] == pytest.approx(mass.values["m_chain"], rel=1e-5)
    same = equivalent(two, chain_data, payload, mass)
    assert same is not None and same["max_separation_sigma"] < 0.05 and same["poses"] > 40
    assert min(same["k_a"]) < min(KA) and max(same["k_a"]) > max(KA)  # beyond the measured rows
    assert equivalent(two, chain_data, payload, spring) is None
    from eigentwist.diagnose.select import _between

    assert _between(two, chain_data, payload, mass, True) is None  # never a separating measurement
    assert _between(two, chain_data, payload, spring, True) is not None
