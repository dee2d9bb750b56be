"""``symbolic/`` has no branch on a robot or a chain type.

One derivation serves every robot: what differs between the Heli4, the Delta and the
hexapod comes from their descriptions' data and the objects they provide (the pose
space, each leg's joint list and kinematics). This test reads the source of every module
in ``eigentwist/symbolic/`` (an ``ast`` scan, docstrings excluded) and asserts:

* no ``isinstance``/``issubclass`` test on a class imported from
  :mod:`eigentwist.description` (a robot or leg class), nor a comparison of ``type(...)``
  with one or with a class name;
* no robot name (``heli4``, ``delta``, ``hexapod``) in code, as a string or an identifier;
* no joint kind (``R``, ``P``, ``Pi``, ``U``, ``S``, ``virtual``) as a string except as a
  key of the table ``TWISTS`` that maps a joint kind to its unit twists, and no
  ``.kind`` read outside the function that looks that table up (``joint_twists``).

The scanner is shown to catch each kind of branch on small sources written here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from eigentwist.description.chain import JOINT_FREEDOMS

SYMBOLIC = Path(__file__).resolve().parent.parent / "eigentwist" / "symbolic"
ROBOT_NAMES = ("heli4", "delta", "hexapod")
JOINT_KINDS = set(JOINT_FREEDOMS)
KIND_READERS = {"joint_twists"}  # the table look-up


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
            ):
                out.add(id(first.value))
    return out


def _description_names(tree: ast.AST) -> set[str]:
    """Names the module imports from ``eigentwist.description`` (relative or absolute)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and "description" in (node.module or ""):
            names |= {a.asname or a.name for a in node.names}
    return names


def _parents(tree: ast.AST) -> dict:
    return {id(child): node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}


def _enclosing_function(node, parents) -> str | None:
    while id(node) in parents:
        node = parents[id(node)]
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            return node.name
    return None


def _in_twists_table(node, parents) -> bool:
    parent = parents.get(id(node))
    if not isinstance(parent, ast.Dict) or not any(k is node for k in parent.keys):
        return False
    owner = parents.get(id(parent))
    return isinstance(owner, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "TWISTS" for t in owner.targets)


def branches(source: str) -> list[str]:
    """Every branch on a robot or a chain type in ``source``, as readable lines."""
    tree = ast.parse(source)
    docs, described, parents = _docstrings(tree), _description_names(tree), _parents(tree)
    out = []
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("isinstance", "issubclass")
        ):
            used = {n.id for a in node.args[1:] for n in ast.walk(a) if isinstance(n, ast.Name)}
            used |= {n.attr for a in node.args[1:] for n in ast.walk(a) if isinstance(n, ast.Attribute)}
            if used & described:
                out.append(f"line {node.lineno}: {ast.unparse(node)} (a test of the description's class)")
        elif isinstance(node, ast.Compare) and any(
            isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "type" for n in ast.walk(node)
        ):
            other = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} & described
            named = [n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)]
            if other or named:
                out.append(f"line {node.lineno}: {ast.unparse(node)} (a test of the description's class)")
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            low = node.value.lower()
            if any(r in low for r in ROBOT_NAMES):
                out.append(f"line {node.lineno}: {node.value!r} (a robot name)")
            if node.value in JOINT_KINDS and not _in_twists_table(node, parents):
                out.append(f"line {node.lineno}: {node.value!r} (a joint kind outside the TWISTS table)")
        elif isinstance(node, (ast.Name, ast.Attribute, ast.FunctionDef, ast.arg)):
            name = getattr(node, "id", None) or getattr(node, "attr", None) or getattr(node, "name", None) or node.arg
            if any(r in name.lower() for r in ROBOT_NAMES):
                out.append(f"line {node.lineno}: {name} (a robot name)")
            if (
                isinstance(node, ast.Attribute)
                and node.attr == "kind"
                and _enclosing_function(node, parents) not in KIND_READERS
            ):
                out.append(f"line {node.lineno}: {ast.unparse(node)} (a kind read outside the joint-twist table)")
    return out


@pytest.mark.parametrize("path", sorted(SYMBOLIC.glob("*.py")), ids=lambda p: p.name)
def test_symbolic_has_no_branch_on_a_robot_or_a_chain(path):
    found = branches(path.read_text())
    assert not found, f"{path.name}: " + "; ".join(found)


def test_the_twist_table_covers_every_joint_kind():
    from eigentwist.symbolic.leg import TWISTS

    assert set(TWISTS) == JOINT_KINDS


@pytest.mark.parametrize(
    "source",
    [
        "from ..description.chain import ChainRobot\ndef f(r):\n    return 1 if isinstance(r, ChainRobot) else 2\n",
        "from ..description import RobotDescription\ndef f(r):\n    return isinstance(r, (int, RobotDescription))\n",
        "def f(r):\n    return type(r).__name__ == 'ChainRobot'\n",
        "from ..description.chain import ChainRobot\ndef f(r):\n    return type(r) is ChainRobot\n",
        "def f(robot):\n    return robot.name == 'hexapod'\n",
        "def derive_heli4(robot):\n    return robot\n",
        "def f(joint):\n    return joint.kind in ('P', 'Pi')\n",
        "def f(joint):\n    return joint.virtual or joint.kind\n",
        "OTHER = {'R': 1}\n",
    ],
)
def test_the_scan_catches_each_kind_of_branch(source):
    assert branches(source)


def test_the_scan_passes_a_table_lookup():
    source = (
        '"""A module about the Heli4."""\nTWISTS = {"R": 1, "P": 2}\n'
        'def joint_twists(joint):\n    """For the hexapod too."""\n    return TWISTS[joint.kind]\n'
    )
    assert branches(source) == []
