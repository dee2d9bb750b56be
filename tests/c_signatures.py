"""The ctypes argument types a C function's declaration asks for, read from the C source text
(for the rules tests of the compiled drivers: what Python declares must be what C takes)."""

from __future__ import annotations

import ctypes
import re

SCALARS = {"int64_t": ctypes.c_int64, "int": ctypes.c_int, "double": ctypes.c_double}
POINTEES = {"double": ctypes.c_double, "int64_t": ctypes.c_int64, "int": ctypes.c_int, "int8_t": ctypes.c_int8}


def _declaration(source: str, function: str) -> re.Match:
    """``int function(...) {`` or ``void function(...) {`` in ``source``: groups (return type, parameters)."""
    match = re.search(r"\b(int|void)\s+" + function + r"\s*\(([^)]*)\)\s*\{", source)
    assert match, function
    return match


def parameters(source: str, function: str) -> list[str]:
    """The parameter types of ``int function(...)`` (or ``void``) in ``source`` (the names dropped)."""
    match = _declaration(source, function)
    types = []
    for p in match.group(2).split(","):
        p = " ".join(p.split())
        name = re.search(r"\w+$", p).group(0)
        types.append(p[: -len(name)].replace("const", "").replace(" ", ""))
    return types


def accepts(c_type: str, declared) -> bool:
    """Whether the ctypes type ``declared`` passes an argument of C type ``c_type``: a scalar
    its own type; a pointer (or a typedef'd function pointer) ``c_void_p`` or a pointer to its
    pointee (a pointer to pointers: ``POINTER(c_void_p)``)."""
    if c_type in SCALARS:
        return declared is SCALARS[c_type]
    if declared is ctypes.c_void_p:
        return True
    base, stars = c_type.rstrip("*"), len(c_type) - len(c_type.rstrip("*"))
    pointee = ctypes.c_void_p if stars == 2 else POINTEES.get(base)
    return declared is ctypes.POINTER(pointee)


def check(source: str, function: str, argtypes, restype) -> None:
    """Assert ``argtypes``/``restype`` match ``int function(...)`` (restype ``c_int``) or
    ``void function(...)`` (restype None) of ``source``."""
    types = parameters(source, function)
    assert restype is (ctypes.c_int if _declaration(source, function).group(1) == "int" else None), function
    assert len(argtypes) == len(types), (function, len(argtypes), len(types))
    for k, (c_type, declared) in enumerate(zip(types, argtypes)):
        assert accepts(c_type, declared), (function, k, c_type, declared)


def names(source: str, function: str) -> list[str]:
    """The parameter names of ``int function(...)`` in ``source``, in order."""
    match = _declaration(source, function)
    return [re.search(r"\w+$", " ".join(p.split())).group(0) for p in match.group(2).split(",")]


class Recorder:
    """A stand-in of a C function: each call's arguments by their C parameter names (a list of
    dicts in ``calls``); returns ``rc``."""

    def __init__(self, source: str, function: str, rc: int = 0, effect=None):
        self.names = names(source, function)
        self.calls = []
        self.rc = rc
        self.effect = effect

    def __call__(self, *args):
        assert len(args) == len(self.names), (len(args), self.names)
        call = dict(zip(self.names, args))
        self.calls.append(call)
        if self.effect is not None:
            self.effect(call)
        return self.rc
