"""Warm caches and no derivation at run time.

* One content hash (:mod:`eigentwist.hashing`): the same in every process and under every
  ``PYTHONHASHSEED``, a function hashed by its code (two lambdas with one body hash alike,
  a changed body or closure value differently).
* A second ``diagnose`` process on one cache generates nothing: no new file in the cache,
  and it runs with ``eigentwist.codegen`` and ``eigentwist.symbolic`` made unimportable.
* The shipped robots' commands (catalogue effects and per-leg scopes included) run in a
  process where importing ``eigentwist.codegen`` or ``eigentwist.symbolic`` fails.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from eigentwist.hashing import canonical, content_hash

ROOT = Path(__file__).resolve().parents[1]
#: runs eigentwist's command line with the derivation and code generation unimportable
BLOCKED = """
import sys
BLOCK = ("eigentwist.codegen", "eigentwist.symbolic")
class Blocker:
    def find_spec(self, name, path=None, target=None):
        if any(name == b or name.startswith(b + ".") for b in BLOCK):
            raise ImportError(f"{name} is blocked: this command must not derive or generate code")
        return None
sys.meta_path.insert(0, Blocker())
from eigentwist.cli.main import main
for argv in [line.split("\\t") for line in sys.argv[1].split("\\n") if line]:
    code = main(argv)
    if code:
        sys.exit(f"eigentwist {' '.join(argv)} exited with {code}")
"""


def _env(cache: Path, **extra) -> dict:
    # a fresh cache per test: the commands run on NumPy (EIGENTWIST_BACKEND), as compiling the
    # checked-in C source derives nothing either (tests/test_cli.py: the first compile)
    return dict(
        os.environ,
        EIGENTWIST_CACHE=str(cache),
        OMP_NUM_THREADS="1",
        EIGENTWIST_BACKEND="numpy",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
        **extra,
    )


def _run(commands, cache: Path, blocked: bool = True):
    """Run eigentwist ``commands`` (lists of arguments) in one fresh process; its stdout."""
    script = BLOCKED if blocked else BLOCKED.replace("sys.meta_path.insert(0, Blocker())", "")
    res = subprocess.run(
        [sys.executable, "-c", script, "\n".join("\t".join(c) for c in commands)],
        env=_env(cache),
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    return res.stdout


def _files(directory: Path) -> set:
    return {p.relative_to(directory) for p in directory.rglob("*") if p.is_file()}


# ------------------------------------------------------------ the hash
def test_a_function_is_hashed_by_its_code_not_its_address():
    def make(k):
        return lambda ctx: ctx * k

    a, b = (lambda ctx: 2 * ctx), (lambda ctx: 2 * ctx)
    assert a is not b and content_hash(a) == content_hash(b)
    assert content_hash(lambda ctx: 3 * ctx) != content_hash(a)
    assert content_hash(make(2)) == content_hash(make(2)) != content_hash(make(3))  # closure values
    assert "0x" not in canonical(make(2))


def test_sympy_expressions_hash_by_their_tree():
    import sympy as sp

    x, y = sp.Symbol("x", real=True), sp.Symbol("y", real=True)
    assert content_hash(x * y + sp.sin(x)) == content_hash(sp.sin(x) + y * x)  # built in another order
    assert content_hash(x) != content_hash(sp.Symbol("x"))  # assumptions count
    assert content_hash(x / y) != content_hash(y / x) and content_hash(sp.Float(0.5) * x) != content_hash(x / 2)


def test_containers_hash_by_content_not_order():
    assert content_hash({"b": 1, "a": {2, 1}}) == content_hash({"a": {1, 2}, "b": 1})
    assert content_hash((1, 2)) != content_hash((2, 1)) and content_hash(1.0) != content_hash(1)


def test_a_description_hashes_alike_in_processes_with_different_hash_seeds(tmp_path):
    code = (
        "import eigentwist; from eigentwist.runtime.sensitivity import cache_key; "
        "from eigentwist.runtime.userfile import description_key; "
        "ev = eigentwist.load('heli4', backend='numpy'); "
        "print(cache_key(ev, ('k_a', 'eta_a@3')), description_key(ev.robot))"
    )
    keys = {
        subprocess.run(
            [sys.executable, "-c", code],
            env=_env(tmp_path, PYTHONHASHSEED=seed),
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        for seed in ("1", "2")
    }
    assert len(keys) == 1 and len(next(iter(keys)).split()) == 2


# ------------------------------------------------------------ warm processes
@pytest.mark.slow
def test_a_second_diagnose_process_generates_nothing(tmp_path):
    # the run's cache: the exact Jacobian's kernel (all the catalogue's fitted parameters, NumPy)
    # is the one tests/test_diagnose_jacobian.py generates, run before this test on the same
    # worker (tests/conftest.py: GROUPS["exact_kernel"]); the first process generates it where
    # it is missing, the second runs with the derivation and code generation unimportable
    from .conftest import c_cache_dir

    cache = c_cache_dir()
    csv = str(tmp_path / "m.csv")
    synth = [
        "synth",
        "--truth",
        "paper+payload_mass:m_p=0.35",
        "--k-a",
        "250,4000",
        "--pose",
        "0",
        "0",
        "-0.625",
        "--modes",
        "x,y,z",
        "--noise",
        "0.5%",
        "--seed",
        "3",
        "-o",
        csv,
    ]
    diagnose = ["diagnose", csv, "--baseline", "paper", "--add", "payload_mass", "--jacobian", "exact", "--json"]
    first = _run([synth, diagnose], cache, blocked=False)
    assert any(str(p).startswith("sensitivities") for p in _files(cache))  # the kernel is in the cache
    second = _run([diagnose], cache, blocked=True)
    assert first.endswith(second)  # the same diagnosis


@pytest.mark.slow
def test_shipped_robots_run_every_command_without_derivation(tmp_path):
    heli4_csv, hexapod_csv = str(tmp_path / "h.csv"), str(tmp_path / "x.csv")
    hexapod_poses = "0,0,0.8,0,0,0;0.05,0,0.78,0,0.05,0.1"
    out = _run(
        [
            ["matrices", "--model", "paper,actuator_loss@3,payload_mass", "--set", "eta_a@3=0.5", "--json"],
            ["matrices", "--robot", "delta", "--model", "paper", "--json"],
            ["matrices", "--robot", "hexapod", "--pose", "0.02", "-0.03", "0.78", "0.05", "-0.04", "0.1", "--json"],
            ["compare", "paper", "--model", "paper,rod_compliance@2"],
            [
                "synth",
                "--truth",
                "paper+actuator_loss@3:eta_a@3=0.5",
                "--k-a",
                "250,1000,4000",
                "--pose",
                "0",
                "0",
                "-0.625",
                "--pose",
                "0.06",
                "-0.04",
                "-0.6",
                "--modes",
                "x,y,z",
                "--noise",
                "0.5%",
                "--seed",
                "3",
                "-o",
                heli4_csv,
            ],
            ["diagnose", heli4_csv, "--baseline", "paper", "--add", "actuator_loss@3"],
            [
                "synth",
                "--robot",
                "hexapod",
                "--truth",
                "paper+payload_mass:m_p=8",
                "--k-a",
                "1e7,2e7",
                "--poses",
                hexapod_poses,
                "--modes",
                "1,2,3",
                "--noise",
                "0.2%",
                "-o",
                hexapod_csv,
            ],
            ["diagnose", hexapod_csv, "--robot", "hexapod", "--baseline", "paper", "--add", "payload_mass"],
            ["sweep", "--grid", "2", "2", "2", "--model", "paper,actuator_loss@2", "-o", str(tmp_path / "s.npz")],
            ["sensitivity", "--model", "paper,rod_compliance@2", "--json"],
            ["sensitivity", "--robot", "delta", "--wrt", "l2,k_a,E_rod@2", "--json"],
            ["sensitivity", "--robot", "hexapod", "--wrt", "k_a,m_p", "--model", "paper,payload_mass", "--json"],
            [
                "optimize",
                "--vary",
                "l2=0.5:0.6",
                "--grid",
                "2",
                "--maxiter",
                "3",
                "--constraint",
                "moving-mass<=1.2",
                "--backend",
                "numpy",
                "--json",
            ],
        ],
        tmp_path / "cache",
    )
    assert out.count('"freq_hz"') == 6 and "actuator_loss@3" in out and '"dlnf1_dlnp"' in out


@pytest.mark.slow
@pytest.mark.compiled
def test_a_cached_c_sensitivity_kernel_loads_without_the_code_generator():
    # the run's cache: the Delta's C kernel for p_x is the one tests/test_sensitivity.py's
    # test_c_equals_numpy compiles before this test on the same worker (tests/conftest.py:
    # GROUPS["sensitivity"]); the first process generates it where it is missing, the second
    # loads it (its compiler flags are the runtime's own) with the derivation and code
    # generation unimportable
    from .conftest import c_cache_dir

    cache = c_cache_dir()
    command = ["sensitivity", "--robot", "delta", "--backend", "c", "--jacobian", "exact", "--wrt", "p_x", "--json"]
    first = _run([command], cache, blocked=False)
    assert _run([command], cache) == first
