"""The notebooks run top to bottom, are checked in without outputs, stay paired with their
jupytext scripts and use only the public API.

Every ``notebooks/*.ipynb`` is picked up (so a new notebook is tested without editing
this file). Execution uses nbclient with the ``python3`` kernel (the interpreter running
the tests), the notebook's own folder as working directory and the non-interactive
Matplotlib backend, and fails on the first cell that raises.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import time
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="notebook tests need the test extras: pip install -e '.[test]'")

NOTEBOOK_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
SCRIPTS = sorted(NOTEBOOK_DIR.glob("*.py"))
CELL_TIMEOUT_S = 300  # per cell; each notebook is meant to finish within two minutes in all
BUDGET_S = 120  # the goal: "runs top to bottom on a fresh install in under two minutes"


def _id(path: Path) -> str:
    return path.name


def test_notebooks_exist():
    assert NOTEBOOKS, f"no notebooks found in {NOTEBOOK_DIR}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_id)
def test_notebook_is_stripped(path):
    """Checked-in notebooks carry no outputs or execution counts, and name the python3 kernel."""
    nb = nbformat.read(path, as_version=4)
    dirty = [
        k
        for k, cell in enumerate(nb.cells)
        if cell.cell_type == "code" and (cell.get("outputs") or cell.get("execution_count") is not None)
    ]
    assert not dirty, f"{path.name}: cells {dirty} have outputs or execution counts: clear them before committing"
    assert nb.metadata.get("kernelspec", {}).get("name") == "python3", f"{path.name}: kernelspec must be python3"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=_id)
def test_notebook_runs(path, monkeypatch):
    """Execute the notebook in a fresh kernel; any cell error fails the test with its traceback."""
    nbclient = pytest.importorskip("nbclient", reason="notebook tests need the test extras: pip install -e '.[test]'")
    monkeypatch.setenv("MPLBACKEND", "Agg")  # inherited by the kernel process
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb, timeout=CELL_TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    )
    start = time.perf_counter()
    client.execute()
    elapsed = time.perf_counter() - start
    errors = [
        out
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors, f"{path.name}: {errors[0].get('ename')}: {errors[0].get('evalue')}"
    assert elapsed < 2 * BUDGET_S, f"{path.name} took {elapsed:.0f} s (budget {BUDGET_S} s on a fresh install)"


# ---------------------------------------------------------------- paired jupytext scripts
@pytest.mark.parametrize("path", NOTEBOOKS, ids=_id)
def test_notebook_is_paired_with_its_percent_script(path):
    """``NAME.ipynb`` and ``NAME.py`` hold the same cells (jupytext's own comparison)."""
    jupytext = pytest.importorskip("jupytext", reason="notebook tests need the test extras: pip install -e '.[test]'")
    from jupytext.compare import compare_notebooks

    script = path.with_suffix(".py")
    assert script.exists(), f"{path.name} has no paired script {script.name}: jupytext --set-formats ipynb,py:percent"
    nb = nbformat.read(path, as_version=4)
    assert nb.metadata.get("jupytext", {}).get("formats") == "ipynb,py:percent", (
        f"{path.name}: not paired (jupytext --set-formats ipynb,py:percent notebooks/{path.name})"
    )
    compare_notebooks(jupytext.read(script), nb, fmt="py:percent")


def test_every_script_has_its_notebook():
    assert SCRIPTS and all(p.with_suffix(".ipynb").exists() for p in SCRIPTS), (
        "a notebooks/*.py without its .ipynb: jupytext --to ipynb notebooks/NAME.py"
    )


# ---------------------------------------------------------------- public API only
def public_api() -> tuple[set, dict]:
    """``eigentwist.__all__`` and, per documented subpackage (docstring and ``__all__``), its ``__all__``."""
    import eigentwist

    subpackages = {}
    for info in pkgutil.iter_modules(eigentwist.__path__):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"eigentwist.{info.name}")
        if (mod.__doc__ or "").strip() and hasattr(mod, "__all__"):
            subpackages[info.name] = set(mod.__all__)
    return set(eigentwist.__all__), subpackages


def api_violations(code: str, top: set, subpackages: dict) -> list[str]:
    """Uses of eigentwist in ``code`` that go past the public API, as readable lines."""
    bound = {}  # local name -> "" (eigentwist) or a subpackage name
    bad = []

    def check(sub, name, line):
        if sub == "":
            if name not in top and name not in subpackages:
                bad.append(
                    f"line {line}: eigentwist.{name} is neither in eigentwist.__all__ nor a documented subpackage"
                )
        elif name not in subpackages[sub]:
            bad.append(f"line {line}: eigentwist.{sub}.{name} is not in eigentwist.{sub}.__all__")

    tree = ast.parse(code)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] != "eigentwist":
                    continue
                if len(parts) > 2 or (len(parts) == 2 and parts[1] not in subpackages):
                    bad.append(f"line {node.lineno}: import {a.name} (not a documented subpackage)")
                elif a.asname:
                    bound[a.asname] = parts[1] if len(parts) == 2 else ""
                else:
                    bound["eigentwist"] = ""
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "eigentwist":
            parts = node.module.split(".")
            if len(parts) > 2 or (len(parts) == 2 and parts[1] not in subpackages):
                bad.append(f"line {node.lineno}: from {node.module} import ... (not a documented subpackage)")
                continue
            sub = parts[1] if len(parts) == 2 else ""
            for a in node.names:
                check(sub, a.name, node.lineno)
                if sub == "" and a.name in subpackages:
                    bound[a.asname or a.name] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound:
            sub = bound[node.value.id]
            check(sub, node.attr, node.lineno)
        elif (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Attribute)
            and isinstance(node.value.value, ast.Name)
            and bound.get(node.value.value.id) == ""
            and node.value.attr in subpackages
        ):
            check(node.value.attr, node.attr, node.lineno)
    return sorted(set(bad))


@pytest.fixture(scope="module")
def api():
    return public_api()


@pytest.mark.parametrize("path", SCRIPTS, ids=_id)
def test_notebook_uses_the_public_api_only(path, api):
    bad = api_violations(path.read_text(encoding="utf-8"), *api)
    assert not bad, f"{path.name}:\n  " + "\n  ".join(bad)


@pytest.mark.parametrize(
    "code",
    [
        "from eigentwist.runtime.loader import evaluator_from_description",  # a private module
        "from eigentwist.codegen.generate import kernels_for",
        "from eigentwist.diagnose.plots import plot_comparison",  # a private module
        "from eigentwist import paper\npaper.EQ58_KF",  # 02: an unexported table
        "import eigentwist\neigentwist.runtime.loader.load_module('heli4')",
        "import eigentwist.runtime.loader",
        "from eigentwist.diagnose import select",
        "import eigentwist\neigentwist.diagnose.select",
    ],
)
def test_the_api_check_catches_private_uses(code, api):
    assert api_violations(code, *api)


@pytest.mark.parametrize(
    "code",
    [
        "import eigentwist\nev = eigentwist.load('heli4')\neigentwist.robots.get('heli4')",
        "from eigentwist import paper\npaper.TABLE_E1",
        "from eigentwist.plots import plot_modes",
        "import eigentwist.robots as robots\nrobots.get('delta')",
    ],
)
def test_the_api_check_allows_public_names(code, api):
    assert not api_violations(code, *api)
