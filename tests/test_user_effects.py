"""Effects the user adds without editing eigentwist.

The README's description file, copied verbatim into a temporary directory, is generated
on first use into a fresh cache, found there on the second use, and its hose is what
``diagnose`` finds in data with a spring to ground along x.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

import eigentwist
from eigentwist.diagnose import diagnose, synth
from eigentwist.runtime.errors import InputError

README = (Path(__file__).resolve().parent.parent / "README.md").read_text()
K_HOSE = 3000.0


def readme_user_file() -> str:
    m = re.search(r"`my_heli4\.py`:\n\n```python\n(.*?)```", README, re.S)
    assert m, "the README shows my_heli4.py"
    return m.group(1)


def test_the_readme_file_uses_public_imports_only():
    for line in readme_user_file().splitlines():
        if line.startswith(("from eigentwist", "import eigentwist")):
            module = line.split()[1]
            assert not any(part.startswith("_") for part in module.split(".")), line
            names = line.split(" import ")[1].split(", ") if " import " in line else []
            mod = __import__(module, fromlist=["*"])
            for name in names:
                assert name in getattr(mod, "__all__", ()), f"{module}.{name} is not in __all__"


@pytest.fixture(scope="module")
def user_robot(tmp_path_factory, ev):  # ``ev`` first: the session's Heli4 is loaded from the run's cache
    directory = tmp_path_factory.mktemp("user")
    path = directory / "my_heli4.py"
    path.write_text(readme_user_file())
    mp = pytest.MonkeyPatch()
    mp.setenv("EIGENTWIST_CACHE", str(directory / "cache"))
    messages = []
    ev = eigentwist.load(str(path), backend="c", progress=messages.append)
    yield path, ev, messages, directory / "cache"
    mp.undo()


@pytest.mark.compiled
@pytest.mark.slow
def test_generated_on_first_use_and_cached(user_robot):
    path, ev, messages, cache = user_robot
    assert any("first use" in m for m in messages) and any("generated" in m for m in messages)
    assert ev.robot.name == "heli4_hose" and "hose" in ev.effects and ev.backend == "c"
    assert list(cache.glob("descriptions/heli4_hose_*/heli4_hose_numpy.py"))
    again = []
    ev2 = eigentwist.load(str(path), backend="c", progress=again.append)
    assert again == [] and ev2.robot.name == "heli4_hose"
    # the hose adds K = k_hose along x at the EE origin, to K_F and K_R; off, the Heli4 is unchanged
    shipped = eigentwist.load("heli4", backend="numpy")
    pose = np.array([[0.05, -0.03, -0.61]])
    a, b = ev.matrices(pose, "paper,hose", k_hose=K_HOSE), shipped.matrices(pose, "paper")
    for key in ("K_F", "K_R"):
        d = a[key][0] - b[key][0]
        assert abs(d[3, 3] - K_HOSE) < 1e-8 * K_HOSE and np.abs(np.delete(d.ravel(), 21)).max() < 1e-8 * K_HOSE
    np.testing.assert_allclose(ev.frequencies(pose, "paper"), shipped.frequencies(pose, "paper"), rtol=1e-12)


@pytest.mark.compiled
@pytest.mark.slow
def test_diagnose_finds_the_users_hose(user_robot, ev):
    # the session's Heli4 (C where a compiler is; ``user_robot`` asks for it before it points
    # the cache at its own directory, where a load would compile the shipped library again)
    shipped, (_, ev, _, _) = ev, user_robot
    poses = [[0, 0, -0.625], [0.08, 0, -0.6], [0, 0.08, -0.65]]
    meas = synth(
        "paper", [250, 500, 1000, 2000], poses, ["x", "y", "z"], 0.005, 1, ev=shipped, extra_stiffness={"x": K_HOSE}
    )
    catalogue = diagnose(meas, "paper", ev=shipped)
    assert not catalogue.explained and "outside the catalogue" in catalogue.message
    d = diagnose(meas, "paper", ev=ev)
    assert d.selected == ["hose"] and d.explained
    value, std = d.final.values["k_hose"], d.final.std["k_hose"]
    assert abs(value - K_HOSE) < 3 * std
    assert d.final.rms_pct < 1.0 < catalogue.final.rms_pct


@pytest.mark.parametrize(
    "text, message",
    [
        (None, "does not exist"),
        ("X = 1\n", r"does not define describe\(\)"),
        (
            "def describe():\n    raise RuntimeError('no robot today')\n",
            r"describe\(\) in .* raised RuntimeError: no robot today",
        ),
        ("def describe():\n    return 42\n", "returned int: expected one of RobotDescription, ChainRobot"),
        ("import not_a_module_anywhere\n", "failed to import: ModuleNotFoundError"),
        ("import sys\ndef describe():\n    sys.exit(0)\n", r"describe\(\) in '.*robot\.py' called sys\.exit\(0\)"),
        ("def describe():\n    raise KeyboardInterrupt\n", r"describe\(\) in '.*robot\.py' was interrupted"),
        ("import sys\nsys.exit(3)\n", r"file '.*robot\.py' called sys\.exit\(3\) while it was imported"),
    ],
)
def test_bad_description_files_fail_with_one_line(tmp_path, capsys, text, message):
    path = tmp_path / "robot.py"
    if text is not None:
        path.write_text(text)
    with pytest.raises(InputError, match=message) as exc:
        eigentwist.load(str(path))
    assert "\n" not in str(exc.value)
    from eigentwist.cli.main import main

    assert main(["matrices", "--robot", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and re.search(message, err)


def test_effect_names_and_primitives_are_checked():
    from eigentwist.description import Effect, Term

    with pytest.raises(ValueError, match="primitive 'spring'"):
        Effect("hose", "", (), (), primitive="spring")
    with pytest.raises(ValueError, match="no '@'"):
        Effect("hose@2", "", (), (), primitive="ground_spring")
    # the primitive's old name still works, with a warning, and never beside the new one
    with pytest.warns(DeprecationWarning, match="primitive='ground_spring'"):
        old = Effect("hose", "", (), (), kind="ground_spring")
    assert old == Effect("hose", "", (), (), primitive="ground_spring")
    with pytest.warns(DeprecationWarning, match=r"\.primitive"):
        assert old.kind == "ground_spring"
    with pytest.warns(DeprecationWarning), pytest.raises(ValueError, match="not both"):
        Term(primitive="preload", kind="preload")
    assert sys.modules["eigentwist"].load is eigentwist.load
