"""Robot descriptions in the user's own Python files, generated on first use.

``describe_file(path)`` imports a file that defines ``describe()`` and returns its
:class:`~eigentwist.description.RobotDescription`; ``generated_modules(description)``
renders its evaluators (the NumPy module, and the C source when a C backend asks) on first use into
``<cache>/descriptions/<name>_<key>/``, where ``key`` hashes the description's content
(its data, its effects' ``build`` functions by their code: :mod:`eigentwist.hashing`) and eigentwist's
derivation and code generation, so an unchanged description is not derived again for a backend
already rendered, and a changed one (or a new eigentwist) regenerates. The cache is the C library's
(``$EIGENTWIST_CACHE``, see :mod:`eigentwist.runtime.ccompile`) and may be deleted; its
files are trusted as the library is (:func:`~eigentwist.runtime.ccompile.read_verified`):
created private, each checked against its recorded SHA-256 before it is imported or
compiled, regenerated when missing, truncated or altered.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import time
import types
from pathlib import Path

from ..generated import generated_name
from ..hashing import canonical, content_hash, package_digest
from .ccompile import private_directory, read_verified, write_verified
from .errors import InputError
from .memo import NewestKept

# render_robot's stages (derived model, CSE'd kernels) of the descriptions whose C source
# is not rendered yet, by description key, the newest last
STAGES_KEPT = 16  # 4-8 MB each (the gallery's 6-RUS 7.7 MB): a test session's or a study's robots
_STAGES = NewestKept(STAGES_KEPT)

__all__ = [
    "describe_file",
    "is_description_file",
    "is_description",
    "description_kinds",
    "description_key",
    "generated_modules",
    "import_numpy_module",
]


def is_description_file(robot) -> bool:
    """True when ``robot`` names a Python file (``*.py``) rather than a shipped robot."""
    return isinstance(robot, (str, os.PathLike)) and str(robot).endswith(".py")


def description_kinds() -> tuple:
    """The description classes a robot may be built from: RR(Pi)RR legs
    (:class:`~eigentwist.description.RobotDescription`) and joint lists
    (:class:`~eigentwist.description.chain.ChainRobot`, as ``robots/hexapod.py``)."""
    from ..description import RobotDescription
    from ..description.chain import ChainRobot

    return (RobotDescription, ChainRobot)


def is_description(obj) -> bool:
    """True when ``obj`` is a robot description of any kind (:func:`description_kinds`)."""
    return isinstance(obj, description_kinds())


def describe_file(path) -> "RobotDescription":  # noqa: F821
    """Import ``path`` and return what its ``describe()`` returns (any description kind a
    shipped robot is built from: :data:`DESCRIPTION_KINDS`); one-line errors."""

    path = Path(path)
    if not path.is_file():
        raise InputError(f"robot description file {str(path)!r} does not exist")
    name = "eigentwist_user_" + content_hash(str(path.resolve()), length=12)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except (SystemExit, KeyboardInterrupt) as exc:
        raise InputError(
            f"robot description file {str(path)!r} {_ended(exc)} while it was imported: a description "
            "file must define describe() and return"
        ) from None
    except Exception as exc:
        raise InputError(
            f"robot description file {str(path)!r} failed to import: {type(exc).__name__}: {exc}"
        ) from None
    describe = getattr(module, "describe", None)
    if not callable(describe):
        raise InputError(
            f"robot description file {str(path)!r} does not define describe() "
            "(it must return an eigentwist.description.RobotDescription or a joint-list ChainRobot)"
        )
    try:
        desc = describe()
    except (SystemExit, KeyboardInterrupt) as exc:
        raise InputError(f"describe() in {str(path)!r} {_ended(exc)}: expected it to return a description") from None
    except Exception as exc:
        raise InputError(f"describe() in {str(path)!r} raised {type(exc).__name__}: {exc}") from None
    if not is_description(desc):
        raise InputError(
            f"describe() in {str(path)!r} returned {type(desc).__name__}: expected one of "
            f"{', '.join(k.__name__ for k in description_kinds())}"
        )
    return desc


def _ended(exc: BaseException) -> str:
    """``called sys.exit(0)`` or ``was interrupted (KeyboardInterrupt)``."""
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})"
    return f"was interrupted ({type(exc).__name__})"


def description_key(description, extra: bytes = b"") -> str:
    """Content hash of ``description`` (its functions by their code) and of eigentwist's
    derivation and code generation, 24 hex digits (:func:`eigentwist.hashing.content_hash`)."""
    return content_hash(canonical(description), extra, package_digest())


def generated_modules(description, key: str, progress=None, backends=("numpy", "c")) -> tuple[Path, dict[str, str]]:
    """The directory and the verified texts ``{file name: text}`` of ``description``'s
    evaluators of ``backends`` (``"numpy"``: ``<name>_numpy.py``, ``"c"``: ``<name>_c.c``),
    each rendered on first use, or again when its cached file is missing, truncated or
    altered (``progress(message)`` is told each step).

    A C source asked for after the NumPy module in the same process reuses that render's
    derivation and CSE (kept for the last :data:`STAGES_KEPT` descriptions).
    """
    from ..codegen.generate import render_robot

    names = {b: generated_name(description.name, b) for b in backends}
    directory = private_directory("descriptions", f"{description.name}_{key}")
    found = {b: read_verified(directory / name) for b, name in names.items()}
    missing = tuple(b for b, data in found.items() if data is None)
    if missing:
        say = progress or (lambda message: None)
        t0 = time.perf_counter()
        what = "the evaluators" if "numpy" in missing else "the C source"
        say(f"generating {what} of {description.name!r} (first use; cached in {directory})")
        stages = _STAGES.pop(key, {})
        files = render_robot(description, progress=lambda m: say(f"  {m}"), backends=missing, stages=stages)
        for b in missing:
            found[b] = files[names[b]].encode("utf-8")
            write_verified(directory / names[b], found[b])
        if "fused" not in stages:  # the C source not rendered yet: keep the stages for it
            _STAGES.put(key, stages)
        say(f"generated {description.name!r} in {time.perf_counter() - t0:.1f} s")
    return directory, {names[b]: data.decode("utf-8") for b, data in found.items()}


def import_numpy_module(text: str, path: Path) -> types.ModuleType:
    """Import a generated NumPy module from its verified ``text`` (read from ``path``, a file
    outside the package: the file is not read again, so what runs is what was checked)."""
    name = f"eigentwist_generated_{path.parent.name}"
    if name in sys.modules:
        return sys.modules[name]
    module = types.ModuleType(name)
    module.__file__ = str(path)
    exec(compile(text, str(path), "exec"), module.__dict__)
    sys.modules[name] = module
    return module
