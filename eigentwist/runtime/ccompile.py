"""Find the system C compiler and build shared libraries cached by content hash.

Render, write and load are separate steps: this module only compiles a C source text
into ``<cache>/<name>_<key>.so``, where ``key`` hashes the source, the flags, the
compiler's path and its version, so a changed source or compiler rebuilds and an
unchanged one reuses the library. The cache directory is ``$EIGENTWIST_CACHE``,
``$XDG_CACHE_HOME/eigentwist`` or ``~/.cache/eigentwist``; it may be deleted at any time.
"""
from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from .errors import BackendUnavailableError

__all__ = ["CompilerNotFoundError", "find_compiler", "compiler_version", "flag_sets", "cache_dir", "build_library"]


class CompilerNotFoundError(BackendUnavailableError):
    """No C compiler: ``$CC`` is not an executable, or neither ``cc`` nor ``gcc`` is on PATH."""


def find_compiler() -> str:
    """Path of the C compiler: ``$CC`` if set, else ``cc`` or ``gcc`` on ``PATH``."""
    cc = os.environ.get("CC")
    if cc:
        path = shutil.which(cc)
        if path is None:
            raise CompilerNotFoundError(f"no C compiler found: CC={cc!r} is not an executable; "
                                        "set CC to a C compiler or install gcc")
        return path
    for name in ("cc", "gcc"):
        path = shutil.which(name)
        if path:
            return path
    raise CompilerNotFoundError("no C compiler found: set CC or install gcc (neither cc nor gcc is on PATH)")


def compiler_version(cc: str) -> str:
    """``cc --version`` output: part of the cache key, so a new compiler rebuilds."""
    res = subprocess.run([cc, "--version"], check=True, capture_output=True, text=True)
    return res.stdout.strip()


def _glibc_version() -> tuple[int, int]:
    try:
        name, version = os.confstr("CS_GNU_LIBC_VERSION").split()
        major, minor = version.split(".")[:2]
        return int(major), int(minor)
    except (AttributeError, ValueError, OSError):
        return (0, 0)


def flag_sets() -> list[tuple[str, list[str]]]:
    """Compiler flag sets to try, fastest first: ``[(name, flags), ...]``.

    ``native`` vectorises the pose loops (AVX-512 or AVX2 where present) and, on x86-64
    glibc, calls libmvec's vector sin/cos (glibc >= 2.22) and asin/acos/atan2 (>= 2.35);
    ``portable`` is plain C99 at ``-O3``.
    """
    base = ["-O3", "-fPIC", "-shared", "-std=gnu99"]
    native = base + ["-march=native", "-fopenmp-simd", "-fno-math-errno", "-fdisable-tree-sincos"]
    glibc = _glibc_version()
    if sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64"):
        if glibc >= (2, 22):
            native.append("-DET_SIMD_MATH")
        if glibc >= (2, 35):
            native.append("-DET_SIMD_MATH_INVERSE")
    return [("native", native), ("portable", base)]


def cache_dir() -> Path:
    """``$EIGENTWIST_CACHE``, ``$XDG_CACHE_HOME/eigentwist`` or ``~/.cache/eigentwist``."""
    if os.environ.get("EIGENTWIST_CACHE"):
        return Path(os.environ["EIGENTWIST_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "eigentwist"


def build_library(source: str, name: str, cc: str, flags: list[str], directory: Path | None = None) -> Path:
    """Compile ``source`` into ``<directory>/<name>_<key>.so``, or reuse it if present.

    ``key`` hashes the source, the flags, the compiler path and its version. The library
    is written to a temporary file in the same directory and renamed into place, so a
    concurrent build or an interrupted one never leaves a partial library behind.
    Raises :class:`subprocess.CalledProcessError` when the compiler fails.
    """
    directory = cache_dir() if directory is None else Path(directory)
    h = hashlib.sha256()
    for part in (source, "\0".join(flags), cc, compiler_version(cc)):
        h.update(part.encode())
        h.update(b"\0")
    target = directory / f"{name}_{h.hexdigest()[:24]}.so"
    if target.exists():
        return target
    directory.mkdir(parents=True, exist_ok=True)
    fd, src = tempfile.mkstemp(prefix=f".{name}_", suffix=".c", dir=directory)
    tmp = src[:-2] + ".so.tmp"
    try:
        with os.fdopen(fd, "w") as f:
            f.write(source)
        print(f"eigentwist: compiling {name} with {cc} (once; cached in {directory})", file=sys.stderr, flush=True)
        subprocess.run([cc, *flags, "-o", tmp, src, "-lm"], check=True, capture_output=True, text=True)
        os.replace(tmp, target)
    finally:
        for path in (src, tmp):
            if os.path.exists(path):
                os.unlink(path)
    return target
