"""One content hash for every cache: deterministic across processes and machines.

:func:`canonical` turns a value into a text that depends on its content only — never on a
memory address, ``PYTHONHASHSEED`` or the order a set or dict was filled in:

* numbers, strings, bytes: their ``repr``; SymPy expressions: their tree in SymPy's canonical
  argument order, atoms by ``srepr``;
  NumPy arrays: dtype, shape and bytes;
* dataclasses and plain objects: their class's qualified name and their fields;
  dicts and sets sorted by the canonical text of their keys or items;
* functions (``lambda`` included) by their code: bytecode, constants, names, free variables,
  nested code objects, default arguments, the values in their closure cells and the
  functions of their own module they call (recursively; a cycle is written once);
  ``functools.partial`` by its function and arguments; classes and modules by name.

:func:`content_hash` is SHA-256 over the canonical texts of its parts (24 hex digits by
default); :func:`files_digest` hashes the bytes of source files, keyed by their path
relative to the package, for the code that turns a description into generated code.
Used by the compiled libraries (:mod:`eigentwist.runtime.ccompile`), the user
descriptions (:mod:`eigentwist.runtime.userfile`) and the sensitivity kernels
(:mod:`eigentwist.runtime.sensitivity`). This module imports nothing of eigentwist.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import re
import types
from pathlib import Path

__all__ = ["canonical", "content_hash", "files_digest", "package_digest", "PACKAGE"]

PACKAGE = Path(__file__).resolve().parent
_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+|0x[0-9a-fA-F]{6,}")


def content_hash(*parts, length: int = 24) -> str:
    """SHA-256 (first ``length`` hex digits) of the canonical texts of ``parts`` (:func:`canonical`)."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part if isinstance(part, bytes) else canonical(part).encode())
        h.update(b"\0")
    return h.hexdigest()[:length]


def canonical(obj) -> str:
    """A text of ``obj`` that depends on its content only (see the module docstring)."""
    return _Canon().text(obj)


def files_digest(paths) -> str:
    """SHA-256 of the files ``paths`` (sorted), each keyed by its path relative to :data:`PACKAGE`."""
    h = hashlib.sha256()
    for f in sorted(Path(p) for p in paths):
        try:
            key = f.resolve().relative_to(PACKAGE).as_posix()
        except ValueError:
            key = f.name
        h.update(key.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def package_digest(subpackages: tuple = ("description", "symbolic", "codegen")) -> str:
    """:func:`files_digest` of every ``.py`` and ``.jinja`` file under ``subpackages`` of eigentwist:
    the code that derives and renders generated code (part of every generated file's cache key)."""
    files = [
        f for sub in subpackages for f in (PACKAGE / sub).rglob("*") if f.is_file() and f.suffix in (".py", ".jinja")
    ]
    return files_digest(files)


@functools.lru_cache(maxsize=65536)
def _symbol_text(symbol) -> str:
    import sympy

    if type(symbol) is not sympy.Symbol:  # Dummy, Wild: srepr names their identity
        return sympy.srepr(symbol)
    return f"Symbol({symbol.name!r},{sorted(symbol.assumptions0.items())})"


def _sympy_text(obj) -> str:
    """A SymPy object as unambiguous text: ``Class(arg,...)`` over an expression tree in
    SymPy's own argument order (canonical: set when the expression is built, the same in
    every process), symbols by name and assumptions, other atoms and non-expressions by ``srepr``. Like
    ``srepr`` without its printer's sorting of terms (most of its time on large programs)."""
    import sympy

    if not isinstance(obj, sympy.Basic):
        return sympy.srepr(obj)
    if obj.is_Symbol:
        return _symbol_text(obj)
    if not obj.args:
        return sympy.srepr(obj)
    return f"{type(obj).__name__}({','.join(_sympy_text(a) for a in obj.args)})"


class _Canon:
    """One canonicalisation: remembers the functions and objects on the current path (cycles)."""

    def __init__(self):
        self.active: set[int] = set()

    def text(self, obj) -> str:
        if obj is None or isinstance(obj, (bool, int, float, complex, str, bytes)):
            return repr(obj)
        if isinstance(obj, enum.Enum):
            return f"{_qualname(type(obj))}.{obj.name}"
        if isinstance(obj, Path):
            return f"Path({obj.as_posix()!r})"
        if isinstance(obj, (type, types.ModuleType)):
            return f"<{_qualname(obj) if isinstance(obj, type) else obj.__name__}>"
        if id(obj) in self.active:
            return "<cycle>"
        self.active.add(id(obj))
        try:
            return self._compound(obj)
        finally:
            self.active.discard(id(obj))

    def _compound(self, obj) -> str:
        module = type(obj).__module__ or ""
        if module.startswith("sympy"):
            return "sympy:" + _sympy_text(obj)
        if hasattr(obj, "dtype") and hasattr(obj, "tobytes") and hasattr(obj, "shape"):
            return f"array({obj.dtype.str},{tuple(obj.shape)},{obj.tobytes().hex()})"
        if isinstance(obj, dict):
            items = sorted((self.text(k), self.text(v)) for k, v in obj.items())
            return "{" + ",".join(f"{k}:{v}" for k, v in items) + "}"
        if isinstance(obj, (set, frozenset)):
            return "set{" + ",".join(sorted(self.text(v) for v in obj)) + "}"
        if isinstance(obj, (list, tuple)):
            inner = ",".join(self.text(v) for v in obj)
            return f"{type(obj).__name__}[{inner}]"
        if isinstance(obj, types.CodeType):
            return self._code(obj, {})
        if isinstance(obj, types.FunctionType):
            return self._function(obj)
        if isinstance(obj, types.MethodType):
            return f"method({self.text(obj.__func__)},{self.text(obj.__self__)})"
        if isinstance(obj, functools.partial):
            return f"partial({self.text(obj.func)},{self.text(obj.args)},{self.text(obj.keywords)})"
        if isinstance(obj, types.BuiltinFunctionType):
            return f"<builtin {getattr(obj, '__module__', '')}.{obj.__qualname__}>"
        if dataclasses.is_dataclass(obj):
            fields = ",".join(f"{f.name}={self.text(getattr(obj, f.name))}" for f in dataclasses.fields(obj))
            return f"{_qualname(type(obj))}({fields})"
        state = getattr(obj, "__dict__", None)
        if state is not None and type(obj).__repr__ is object.__repr__:
            return f"{_qualname(type(obj))}{self.text(dict(state))}"
        return f"{_qualname(type(obj))}:" + _ADDRESS.sub("", repr(obj))

    def _function(self, fn) -> str:
        globals_ = fn.__globals__
        cells = tuple(c.cell_contents if _filled(c) else "<empty>" for c in (fn.__closure__ or ()))
        return (
            f"function({fn.__qualname__};{self._code(fn.__code__, globals_, fn.__module__)};"
            f"defaults={self.text(fn.__defaults__)};kwdefaults={self.text(fn.__kwdefaults__)};"
            f"closure={self.text(cells)})"
        )

    def _code(self, code, globals_: dict, module: str | None = None) -> str:
        consts = ",".join(
            self._code(c, globals_, module) if isinstance(c, types.CodeType) else self.text(c) for c in code.co_consts
        )
        called = []
        for name in code.co_names:  # helper functions of the same module: by their code too
            value = globals_.get(name)
            if isinstance(value, types.FunctionType) and value.__module__ == module:
                called.append(f"{name}={self.text(value)}")
        return (
            f"code({code.co_name};{code.co_code.hex()};consts[{consts}];names{code.co_names};"
            f"vars{code.co_varnames};free{code.co_freevars};args{code.co_argcount},{code.co_kwonlyargcount};"
            f"calls[{','.join(called)}])"
        )


def _qualname(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _filled(cell) -> bool:
    try:
        cell.cell_contents
    except ValueError:
        return False
    return True
