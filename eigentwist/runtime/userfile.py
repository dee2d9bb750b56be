"""Robot descriptions in the user's own Python files, generated on first use.

``describe_file(path)`` imports a file that defines ``describe()`` and returns its
:class:`~eigentwist.description.RobotDescription`; ``generated_modules(description)``
renders its evaluators (NumPy module and C source) on first use into
``<cache>/descriptions/<name>_<key>/``, where ``key`` hashes the description's content
(its data, its effects' ``build`` functions by their code: :mod:`eigentwist.hashing`) and eigentwist's
derivation and code generation, so an unchanged description is never derived twice
and a changed one (or a new eigentwist) regenerates. The cache is the C library's
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

from ..hashing import canonical, content_hash, package_digest
from .ccompile import private_directory, read_verified, write_verified
from .errors import InputError

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


def generated_modules(description, key: str, progress=None) -> tuple[Path, dict[str, str]]:
    """The directory and the verified texts ``{file name: text}`` of ``<name>_numpy.py`` and
    ``<name>_c.c`` of ``description``, rendered on first use, or again when a cached file is
    missing, truncated or altered (``progress(message)`` is told each step)."""
    from ..codegen.generate import render_robot

    names = [f"{description.name}_numpy.py", f"{description.name}_c.c"]
    directory = private_directory("descriptions", f"{description.name}_{key}")
    found = {name: read_verified(directory / name) for name in names}
    if all(data is not None for data in found.values()):
        return directory, {name: data.decode("utf-8") for name, data in found.items()}
    say = progress or (lambda message: None)
    t0 = time.perf_counter()
    say(f"generating the evaluators of {description.name!r} (first use; cached in {directory})")
    files = render_robot(description, progress=lambda m: say(f"  {m}"))
    for name in names:
        write_verified(directory / name, files[name].encode("utf-8"))
    say(f"generated {description.name!r} in {time.perf_counter() - t0:.1f} s")
    return directory, {name: files[name] for name in names}


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
