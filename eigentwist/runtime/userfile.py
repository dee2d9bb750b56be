"""Robot descriptions in the user's own Python files, generated on first use.

``describe_file(path)`` imports a file that defines ``describe()`` and returns its
:class:`~eigentwist.description.RobotDescription`; ``generated_modules(description)``
renders its evaluators (NumPy module and C source) on first use into
``<cache>/descriptions/<name>_<key>/``, where ``key`` hashes the description's content
(its data, the source of its effects' ``build`` functions, the file) and eigentwist's
derivation and code generation, so an unchanged description is never derived twice
and a changed one (or a new eigentwist) regenerates. The cache is the C library's
(``$EIGENTWIST_CACHE``, see :mod:`eigentwist.runtime.ccompile`) and may be deleted.
"""
from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import re
import sys
import tempfile
import time
import types
from functools import lru_cache
from pathlib import Path

from .ccompile import cache_dir
from .errors import InputError

__all__ = ["describe_file", "is_description_file", "description_key", "generated_modules", "import_numpy_module"]

PACKAGE = Path(__file__).resolve().parent.parent


def is_description_file(robot) -> bool:
    """True when ``robot`` names a Python file (``*.py``) rather than a shipped robot."""
    return isinstance(robot, (str, os.PathLike)) and str(robot).endswith(".py")


def describe_file(path) -> "RobotDescription":  # noqa: F821
    """Import ``path`` and return what its ``describe()`` returns; one-line errors."""
    from ..description import RobotDescription

    path = Path(path)
    if not path.is_file():
        raise InputError(f"robot description file {str(path)!r} does not exist")
    name = "eigentwist_user_" + hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:
        raise InputError(f"robot description file {str(path)!r} failed to import: {type(exc).__name__}: {exc}") from None
    describe = getattr(module, "describe", None)
    if not callable(describe):
        raise InputError(f"robot description file {str(path)!r} does not define describe() "
                         "(it must return an eigentwist.description.RobotDescription)")
    try:
        desc = describe()
    except Exception as exc:
        raise InputError(f"describe() in {str(path)!r} raised {type(exc).__name__}: {exc}") from None
    if not isinstance(desc, RobotDescription):
        raise InputError(f"describe() in {str(path)!r} returned {type(desc).__name__}: expected a RobotDescription")
    return desc


@lru_cache(maxsize=1)
def _package_digest() -> str:
    """Hash of the code that turns a description into generated code."""
    h = hashlib.sha256()
    for sub in ("description", "symbolic", "codegen"):
        for f in sorted((PACKAGE / sub).rglob("*")):
            if f.is_file() and f.suffix in (".py", ".jinja"):
                h.update(f.relative_to(PACKAGE).as_posix().encode())
                h.update(f.read_bytes())
    return h.hexdigest()


def _content(obj) -> str:
    """A deterministic text of ``obj``: its repr without memory addresses, plus the
    source of every function its effects build with."""
    text = re.sub(r" at 0x[0-9a-fA-F]+", "", repr(obj))
    sources = []
    for e in (t for effect in getattr(obj, "custom_effects", ()) for t in effect.parts()):
        if e.build is not None:
            try:
                sources.append(inspect.getsource(e.build))
            except (OSError, TypeError):
                sources.append(getattr(e.build, "__qualname__", repr(e.build)))
    return text + "\0".join(sources)


def description_key(description, extra: bytes = b"") -> str:
    """Content hash of ``description`` (and eigentwist's code generation), 24 hex digits."""
    h = hashlib.sha256()
    for part in (_content(description).encode(), extra, _package_digest().encode()):
        h.update(part)
        h.update(b"\0")
    return h.hexdigest()[:24]


def generated_modules(description, key: str, progress=None) -> Path:
    """Directory holding ``<name>_numpy.py`` and ``<name>_c.c`` of ``description``,
    rendered on first use (``progress(message)`` is told each step)."""
    from ..codegen.generate import render_robot, write

    directory = cache_dir() / "descriptions" / f"{description.name}_{key}"
    if (directory / f"{description.name}_numpy.py").exists():
        return directory
    say = progress or (lambda message: None)
    t0 = time.perf_counter()
    say(f"generating the evaluators of {description.name!r} (first use; cached in {directory})")
    files = render_robot(description, progress=lambda m: say(f"  {m}"))
    directory.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{description.name}_", dir=directory.parent))
    write(files, tmp)
    try:
        os.replace(tmp, directory)          # atomic: a concurrent first use keeps one copy
    except OSError:
        for f in tmp.iterdir():
            f.unlink()
        tmp.rmdir()
    say(f"generated {description.name!r} in {time.perf_counter() - t0:.1f} s")
    return directory


def import_numpy_module(path: Path) -> types.ModuleType:
    """Import a generated NumPy module from a file outside the package."""
    name = f"eigentwist_generated_{path.parent.name}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules[name] = module
    return module
