"""Shared fixtures: one canonical model for all tests (style: pydy models.py)."""

from __future__ import annotations

import gc
import os
import tempfile

# Before NumPy loads OpenBLAS: the tests' linear algebra is on small matrices, and two
# workers share two cores; OpenBLAS's own threads would only spin between calls, on the
# other worker's core (the command line does the same for its process: cli.main)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import eigentwist  # noqa: E402


@pytest.fixture(scope="session")
def ev():
    """The Heli4 evaluator, ``backend="auto"``: the C library where a compiler exists (CI),
    the NumPy module under ``make test-fast`` (below). The backends agree to 1e-12
    (tests/test_c_backend.py); tests of one backend load it by name."""
    return eigentwist.load("heli4", backend="auto")


@pytest.fixture(scope="session")
def paper_rigid_diagnosis(ev):
    """The paper's measurements diagnosed from the rigid model (Heli4, NumPy), computed once
    for tests/test_diagnose.py and tests/test_answer.py (one scheduling group, below)."""
    from eigentwist.diagnose import diagnose, paper_measurements

    return diagnose(paper_measurements(ev), "rigid", ev=ev)


@pytest.fixture(scope="session")
def derived():
    """The symbolic Heli4 model (derivation only, no CSE)."""
    from eigentwist.robots import get
    from eigentwist.symbolic import derive

    return derive(get("heli4"))


@pytest.fixture(scope="session")
def rendered_with_progress():
    """Every robot's generated files (``render_all``: {filename: text}) and the progress
    messages, rendered once per run (tests/test_generated.py, test_c_backend.py, ...: the
    ``derive`` scheduling group below)."""
    from eigentwist.codegen.generate import render_all

    messages: list[str] = []
    return render_all(progress=messages.append), messages


@pytest.fixture(scope="session")
def rendered(rendered_with_progress):
    return rendered_with_progress[0]


def workspace_grid(robot, n=4) -> np.ndarray:
    """A grid of poses (m) over the robot's workspace box."""
    axes = [np.linspace(lo, hi, n) for lo, hi in robot.workspace]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(robot.workspace))


def random_poses(robot, n, seed) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = np.array([a for a, _ in robot.workspace])
    hi = np.array([b for _, b in robot.workspace])
    return lo + (hi - lo) * rng.random((n, len(robot.workspace)))


def effect_inputs(robot, p: dict, on, spread=None) -> dict:
    """Add the generated code's effect inputs to ``p`` (parameter values by name): each
    effect's switch (1 for the effects in ``on``), and for a leg-level effect each leg's
    switch and copy of its parameters (the shared value, times 1 + ``spread()`` if given)."""
    from eigentwist.description.effects import leg_input_name, leg_switch_name, switch_name

    for e in robot.effects:
        effect = robot.effect(e)
        flag = np.asarray(1.0 if e in on else 0.0)
        if not effect.leg_level:
            p[switch_name(e)] = flag
            continue
        for k in range(1, len(robot.legs) + 1):
            p[leg_switch_name(e, k)] = flag
            for q in effect.params:
                p[leg_input_name(q.name, k)] = np.asarray(p[q.name] * (1 + spread() if spread else 1.0))
    return p


# CI (.ci/run) sets EIGENTWIST_REQUIRE_TIERS=1: there a tier that cannot run (no compiler,
# no Chromium) fails instead of skipping, so a broken install cannot pass CI silently.
REQUIRE_TIERS_ENV = "EIGENTWIST_REQUIRE_TIERS"


def tiers_required() -> bool:
    return os.environ.get(REQUIRE_TIERS_ENV, "").strip() not in ("", "0")


def skip_tier(tier: str, reason: str):
    """Skip a test of an optional tier (``compiled``, ``browser``), or fail where CI requires it."""
    if tiers_required():
        pytest.fail(f"the {tier} tier cannot run here but {REQUIRE_TIERS_ENV}=1 requires it: {reason}", pytrace=False)
    pytest.skip(f"{tier} tier skipped: {reason}")


# ------------------------------------------------------------ tiers (make test-fast)
#: ``EIGENTWIST_TEST_BACKEND=numpy`` (``make test-fast``): evaluators asked for ``backend="auto"``
#: use the generated NumPy module, so the fast tier never starts the compiler
TEST_BACKEND_ENV = "EIGENTWIST_TEST_BACKEND"


def pytest_configure(config):
    _bytecode_cache_for_commands()
    _hypothesis_skips_generated_code()
    if os.environ.get(TEST_BACKEND_ENV, "").strip() != "numpy":
        return
    # the CLI's --backend default in the commands the tests start (subprocesses inherit it)
    os.environ["EIGENTWIST_BACKEND"] = "numpy"
    import eigentwist.runtime as runtime
    from eigentwist.runtime import loader

    original = loader.load

    def load_numpy(robot="heli4", backend="auto", *args, **kwargs):
        # a test that points CC somewhere tests the compiler lookup itself: leave it alone
        use = "numpy" if backend == "auto" and "CC" not in os.environ else backend
        return original(robot, use, *args, **kwargs)

    loader.load = runtime.load = load_numpy


#: the first line of every module eigentwist generates (checked-in evaluators, a description's
#: evaluators and sensitivity kernels in the cache): ``codegen.render``, ``codegen.sensitivity``
GENERATED_HEADER = b"# Generated by "


def _is_generated(path: str) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(len(GENERATED_HEADER)) == GENERATED_HEADER
    except OSError:
        return False


def _hypothesis_skips_generated_code() -> None:
    """Hypothesis draws constants from the source of the project's own modules, parsing each
    module loaded (``hypothesis.internal.conjecture.providers``, module by module as they
    appear); the generated evaluators are 0.2-0.7 MB of straight-line code each, with no
    constant a property test needs, and parsing them costs ~10 s of CPU a suite run (the two
    workers together). They are left out; the hand-written modules' constants are still drawn.
    Where Hypothesis has no such hook (another version), nothing changes."""
    try:
        from hypothesis.internal.conjecture import providers
    except ImportError:
        return
    local = getattr(providers, "is_local_module_file", None)
    if local is None or getattr(local, "skips_generated", False):
        return

    def hand_written(path: str) -> bool:
        return local(path) and not _is_generated(path)

    hand_written.skips_generated = True
    providers.is_local_module_file = hand_written


def _bytecode_cache_for_commands() -> None:
    """The commands the tests start import eigentwist afresh; where byte-code writing is off
    (``PYTHONDONTWRITEBYTECODE``) each would compile every eigentwist module again (~1.7 s of
    CPU a command). They share a byte-code cache outside the tree instead
    (``PYTHONPYCACHEPREFIX``, a temporary directory of this run), so the tree stays unwritten."""
    if os.environ.get("PYTHONDONTWRITEBYTECODE") and not os.environ.get("PYTHONPYCACHEPREFIX"):
        os.environ.pop("PYTHONDONTWRITEBYTECODE")
        os.environ["PYTHONPYCACHEPREFIX"] = tempfile.mkdtemp(prefix="eigentwist-bytecode-")


#: modules whose tests generate sensitivity kernels with SymPy (their session fixtures)
DERIVING_MODULES = {
    "test_diagnose_jacobian",
    "test_hexapod_sensitivity",
    "test_optimize",
    "test_sensitivity",
    "test_sensitivity_cli",
    "test_sensitivity_legs",
    "test_sensitivity_split",
}
#: fixtures that derive (``derived``: the symbolic Heli4), render every robot (``rendered``,
#: ``rendered_with_progress``) or generate description files' code on first use (``gallery``:
#: tests/test_gallery.py; ``numeric``: the URDF-form robots of tests/test_numeric_ik.py)
DERIVING_FIXTURES = {"derived", "rendered", "rendered_with_progress", "gallery", "numeric"}


def pytest_collection_finish(session):
    """The objects collection built (the modules, the items) live as long as the run: the
    cyclic garbage collector skips them in every later collection (the command line does
    the same after its start-up: cli.main)."""
    gc.freeze()


def pytest_collection_modifyitems(config, items):
    """A test parametrized on the C backend (``backend`` = ``"c"``) is a compiled test; a test
    that derives (module, fixture above) is marked ``derives`` (``make test-fast`` leaves both out)."""
    for item in items:
        module = getattr(item, "module", None)
        if (module is not None and module.__name__.rpartition(".")[2] in DERIVING_MODULES) or DERIVING_FIXTURES & set(
            getattr(item, "fixturenames", ())
        ):
            item.add_marker(pytest.mark.derives)
        params = getattr(getattr(item, "callspec", None), "params", {})
        if any(k in ("backend", "ev") and v == "c" for k, v in params.items()):
            item.add_marker(pytest.mark.compiled)


# ------------------------------------------------------------ xdist scheduling
# pytest-xdist 3.8's ``--dist loadgroup`` appends ``@group`` to ``item._nodeid``, which
# pytest 9 no longer reads (``Node.nodeid`` is ``str(item._id)``): ``xdist_group`` marks are
# ignored and a module's tests spread over every worker, each computing the module's
# fixtures again. ``make test`` therefore uses the scheduler below: a *unit* (the tests one
# worker runs together) is a whole test module, or a group of modules named in GROUPS
# (modules sharing a session fixture or a generated-code cache entry), except the modules in
# SPLIT, whose tests are independent units (cheap fixtures, expensive tests). Units are
# handed out most expensive first (COST, measured seconds on 2 workers) so the last ones
# are short and both workers finish together.

#: group name -> modules (or tests: ``module.py::test_name``) run on one worker, in this order
GROUPS = {
    # the symbolic Heli4 (``derived``, session-scoped) and every robot's rendered code
    # (the gallery's generated code: test_gallery_pinocchio reads what test_gallery generated into the cache)
    "derive": (
        "test_generated.py",
        "test_c_backend.py",
        "test_coupling.py",
        "test_gallery.py",
        "test_gallery_pinocchio.py",
        "test_urdf_lower_mobility.py",  # reads the gallery's 3-PRS from the cache
        "test_evaluator_c_rules.py",  # the gallery's 3-PRS, generated and compiled: from the cache
        "test_physics.py",
        "test_cli.py::test_generate_check_names_stale_files",
        "test_cli.py::test_generate_check_passes_on_fresh_tree",
        "test_hexapod.py::test_generation_renders_every_backend",
    ),
    # the Heli4's sensitivity kernel for WRT["heli4"]: generated by the first, read from the cache by the others
    "sensitivity": (
        "test_sensitivity.py",
        "test_warm.py::test_a_cached_c_sensitivity_kernel_loads_without_the_code_generator",
        "test_optimize.py",
        "test_sensitivity_cli.py",
    ),
    # the exact Jacobian's kernel of the Heli4 catalogue (NumPy): generated by the first, read by the second
    "exact_kernel": (
        "test_diagnose_jacobian.py",
        "test_sensitivity_legs.py",
        "test_warm.py::test_a_second_diagnose_process_generates_nothing",
    ),
    # the paper's measurements diagnosed from the rigid model (``paper_rigid_diagnosis``, session-scoped)
    "paper_diagnosis": ("test_diagnose.py", "test_answer.py"),
}
#: modules whose tests are scheduled one by one (cheap fixtures, expensive tests)
SPLIT = {"test_diagnose_seeds.py", "test_notebooks.py"}
#: estimated seconds of CPU per unit (measured, 2 workers): a group's name, a module (the whole
#: module, or each test of a SPLIT one) or a test's node id; unlisted modules count 1 s. Only
#: the order matters: the most expensive units first, so the last ones are short.
COST = {
    "test_readme.py": 210,
    "derive": 139,
    "paper_diagnosis": 110,
    "sensitivity": 80,
    "test_diagnose_seeds.py::test_right_in_three_of_four_seeds[payload_offset]": 18,
    "test_diagnose_seeds.py::test_right_in_three_of_four_seeds[two_effects]": 10,
    "test_diagnose_seeds.py": 5,
    "test_notebooks.py::test_notebook_runs[01_closed_form.ipynb]": 34,
    "test_notebooks.py::test_notebook_runs[03_find_the_missing_effect.ipynb]": 16,
    "test_notebooks.py::test_notebook_runs[04_design_space.ipynb]": 11,
    "test_notebooks.py::test_notebook_runs[02_reproduce_paper.ipynb]": 5,
    "test_user_terms.py": 39,
    "test_cli.py": 38,
    "test_report.py": 45,
    "test_user_effects.py": 31,
    "test_localise.py": 28,
    "test_warm.py": 24,
    "test_numeric_ik.py": 33,
    "test_backward.py": 23,
    "test_chain_equivalence.py": 21,
    "test_setting_anomalies.py": 19,
    "test_diagnose_cli.py": 17,
    "test_sets.py": 16,
    "test_sensitivity_split.py": 16,
    "test_delta.py": 15,
    "exact_kernel": 50,
    "test_hexapod_sensitivity.py": 14,
    "test_identify.py": 10,
    "test_csv_input.py": 10,
    "test_labels.py": 10,
    "test_hexapod.py": 9,
    "test_misfit.py": 7,
    "test_ccompile.py": 7,
    "test_hexapod_cli.py": 7,
    "test_layering.py": 7,
    "test_sweep.py": 7,
    "test_c_library.py": 5,
    "test_pose_status.py": 12,
    "test_urdf_leg.py": 3,
    "test_urdf_robot.py": 5,
}


def _module(nodeid: str) -> str:
    return nodeid.split("::", 1)[0].rpartition("/")[2]


def _member(nodeid: str, group: str) -> int | None:
    """Position in ``GROUPS[group]`` of the entry a test belongs to, or None."""
    name = _module(nodeid) + nodeid.partition("::")[1] + nodeid.partition("::")[2]
    for k, entry in enumerate(GROUPS[group]):
        if name == entry or name.startswith(entry + "::") or name.startswith(entry + "["):
            return k
    return None


def unit_of(nodeid: str) -> str:
    """The unit a test belongs to: its group's name, its module's path, or (SPLIT) itself."""
    nodeid = nodeid.rsplit("@", 1)[0] if nodeid.rfind("@") > nodeid.rfind("]") else nodeid
    for group in GROUPS:
        if _member(nodeid, group) is not None:
            return group
    return nodeid if _module(nodeid) in SPLIT else nodeid.split("::", 1)[0]


def unit_cost(unit: str) -> float:
    """COST of a unit: its group, its test (``module.py::test[id]``) or its module."""
    test = _module(unit) + unit.partition("::")[1] + unit.partition("::")[2]
    return COST.get(unit, COST.get(test, COST.get(_module(unit), 1.0)))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        """LoadScopeScheduling with ``unit_of`` as the scope, most expensive unit first."""

        def _split_scope(self, nodeid):
            return unit_of(nodeid)

        def _assign_work_unit(self, node):
            heaviest = max(self.workqueue, key=unit_cost)  # the first of equals: collection order
            self.workqueue.move_to_end(heaviest, last=False)
            if heaviest in GROUPS:  # the group's modules in the listed order
                tests = self.workqueue[heaviest]
                self.workqueue[heaviest] = dict(sorted(tests.items(), key=lambda t: _member(t[0], heaviest)))
            super()._assign_work_unit(node)

    return UnitScheduling(config, log)


def compiled_tier() -> pytest.MonkeyPatch:
    """For a module fixture of the ``compiled`` tier: skip (or fail, where CI requires the tier)
    without a C compiler; else a MonkeyPatch that points ``EIGENTWIST_CACHE`` at the run's one
    cache (:func:`c_cache_dir`), to ``undo()`` when the fixture ends."""
    from eigentwist.runtime import ccompile

    try:
        ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:  # the only reason to skip
        skip_tier("compiled", str(exc))
    mp = pytest.MonkeyPatch()
    mp.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    return mp


@pytest.fixture
def compiled():
    """The ``compiled`` tier for one test (:func:`compiled_tier`: skips without a compiler, fails
    where CI requires the tier; the run's one cache), undone after it."""
    mp = compiled_tier()
    yield
    mp.undo()


def c_cache_dir():
    """The run's one eigentwist cache (``$EIGENTWIST_CACHE``, ``$XDG_CACHE_HOME/eigentwist`` or
    ``~/.cache/eigentwist``), for the tests that compile into an explicit directory: the
    tests that load ``backend="auto"`` use it too, so each robot is compiled once per cache."""
    from eigentwist.runtime.ccompile import cache_dir

    directory = cache_dir()
    directory.mkdir(mode=0o700, parents=True, exist_ok=True)
    return directory
