"""Find the system C compiler and build shared libraries cached by content hash.

Render, write and load are separate steps: this module only compiles a C source text
into ``<cache>/<name>_<key>.so``, where ``key`` hashes the source, the flags, the
compiler's path and its version, so a changed source or compiler rebuilds and an
unchanged one reuses the library. The cache directory is ``$EIGENTWIST_CACHE``,
``$XDG_CACHE_HOME/eigentwist`` or ``~/.cache/eigentwist``; it may be deleted at any time.

Safe under concurrency and damage:

* processes building the same library take an exclusive ``fcntl.flock`` on
  ``<name>_<key>.lock``, so it is compiled once; the library is written to a temporary
  file and renamed into place, so nobody loads a half-written one;
* beside each library, ``<name>_<key>.so.sha256`` holds the SHA-256 of its bytes; a
  library whose bytes do not match (truncated, corrupted) is rebuilt before use;
* the cache directory is created private (0700); a directory (or library) that another
  user owns or that others may write to is refused with :class:`UnsafeCacheError`,
  since loading a library runs its code.

The same trust rule holds for every generated file cached beside the libraries (a user
description's NumPy module and C source, the sensitivity kernels): :func:`write_verified`
records its SHA-256 beside it, :func:`read_verified` returns its bytes only from private
directories (:func:`private_directory`) and only when they match, so a missing, truncated
or altered file is regenerated (one line on stderr says so) and never imported or compiled.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

from ..hashing import content_hash

try:
    import fcntl
except ImportError:  # not POSIX: no locking (the rename still keeps builds whole)
    fcntl = None

__all__ = [
    "BuildError",
    "CompilerNotFoundError",
    "UnsafeCacheError",
    "find_compiler",
    "compiler_version",
    "flag_sets",
    "GCC_COMPILE_TIME",
    "SIMD_SIN_COS",
    "cache_dir",
    "build_library",
    "check_private",
    "library_digest",
    "private_directory",
    "write_verified",
    "read_verified",
    "note",
    "read_shipped",
    "DamagedFileError",
    "load_library",
    "library_once",
]


class BuildError(RuntimeError):
    """The C backend cannot be built or loaded here (the command line prints it as one line)."""


class CompilerNotFoundError(BuildError):
    """No C compiler: ``$CC`` is not an executable, or neither ``cc`` nor ``gcc`` is on PATH."""


class UnsafeCacheError(BuildError):
    """The compiled-code cache (or a library in it) is writable by others or not ours."""


class DamagedFileError(BuildError):
    """A generated file shipped in ``eigentwist/generated`` differs from its recorded SHA-256."""


def find_compiler() -> str:
    """Path of the C compiler: ``$CC`` if set, else ``cc`` or ``gcc`` on ``PATH``."""
    cc = os.environ.get("CC")
    if cc:
        path = shutil.which(cc)
        if path is None:
            raise CompilerNotFoundError(
                f"no C compiler found: CC={cc!r} is not an executable; set CC to a C compiler or install gcc"
            )
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


#: gcc options of the ``native`` flag set that shorten the compile of long straight-line
#: code without changing its arithmetic (:func:`flag_sets`)
GCC_COMPILE_TIME = ("-fira-region=one", "-fno-gcse-after-reload")

#: C declaring glibc's vector sin and cos (libmvec) where the ``native`` flag set defines
#: ``ET_SIMD_MATH`` (:func:`flag_sets`), for the runtime's own C sources: a pose loop calling
#: them then vectorises (the generated libraries declare them in their template)
SIMD_SIN_COS = r"""
#ifdef ET_SIMD_MATH
#pragma omp declare simd notinbranch
double sin(double);
#pragma omp declare simd notinbranch
double cos(double);
#endif
"""


def flag_sets() -> list[tuple[str, list[str]]]:
    """Compiler flag sets to try, fastest first: ``[(name, flags), ...]``.

    ``native`` vectorises the pose loops (AVX-512 or AVX2 where present; ``-fno-trapping-math``
    lets a guarded division or square root run in every lane and be selected, which AVX2,
    without masked vector instructions, needs to vectorise the Jacobi sweeps) and, on x86-64
    glibc, calls libmvec's vector sin/cos (glibc >= 2.22) and asin/acos/atan2 (>= 2.35);
    ``native`` also gives gcc's register allocator one region per function and skips its CSE
    of loads after reload (:data:`GCC_COMPILE_TIME`): on the generated kernels' long
    straight-line blocks gcc's defaults there took 14 % more compile time for no speed (the
    same arithmetic; measured on AVX-512: ``benchmarks/README.md``);
    ``vector`` is the same without gcc's options (``-fdisable-tree-sincos``, those two) and the
    vector maths, for compilers that refuse them (clang): the loops without a sin or cos call
    still vectorise (the Jacobi sweeps, a pass without trigonometry); ``portable`` is plain C99
    at ``-O3``.
    """
    base = ["-O3", "-fPIC", "-shared", "-std=gnu99"]
    vector = base + ["-march=native", "-fopenmp-simd", "-fno-math-errno", "-fno-trapping-math"]
    native = vector + ["-fdisable-tree-sincos", *GCC_COMPILE_TIME]
    glibc = _glibc_version()
    if sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64"):
        if glibc >= (2, 22):
            native.append("-DET_SIMD_MATH")
        if glibc >= (2, 35):
            native.append("-DET_SIMD_MATH_INVERSE")
    return [("native", native), ("vector", vector), ("portable", base)]


def cache_dir() -> Path:
    """``$EIGENTWIST_CACHE``, ``$XDG_CACHE_HOME/eigentwist`` or ``~/.cache/eigentwist``."""
    if os.environ.get("EIGENTWIST_CACHE"):
        return Path(os.environ["EIGENTWIST_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "eigentwist"


def check_private(path: Path) -> None:
    """Raise :class:`UnsafeCacheError` unless ``path`` is owned by this user and not
    writable by group or others (a library loaded from there would run their code)."""
    st = os.stat(path)
    kind = "directory" if stat.S_ISDIR(st.st_mode) else "library" if Path(path).suffix == ".so" else "file"
    if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
        raise UnsafeCacheError(
            f"refusing the compiled-code cache {kind} {path}: it is owned by uid {st.st_uid}, "
            f"not by this user (uid {os.geteuid()}); set EIGENTWIST_CACHE to a private directory"
        )
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise UnsafeCacheError(
            f"refusing the compiled-code cache {kind} {path}: it is writable by others "
            f"(mode {stat.S_IMODE(st.st_mode):o}); run `chmod go-w {path}` or set EIGENTWIST_CACHE "
            "to a private directory"
        )


def library_digest(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _intact(target: Path) -> bool:
    """The library exists and its bytes match the digest stored beside it."""
    sidecar = target.with_name(target.name + ".sha256")
    try:
        want = sidecar.read_text().strip()
        return bool(want) and library_digest(target) == want
    except OSError:
        return False


def _cache_directory(directory: Path) -> Path:
    missing = []
    level = directory
    while not level.exists() and level != level.parent:
        missing.append(level)
        level = level.parent
    for level in reversed(missing):  # every level created here is private, not only the last
        level.mkdir(mode=0o700, exist_ok=True)
    check_private(directory)
    return directory


def private_directory(*parts: str) -> Path:
    """``cache_dir() / parts...``, each level created 0700 where missing and each level from
    the cache directory down checked by :func:`check_private` (a directory others may write
    could have its files swapped)."""
    root = cache_dir()
    directory = _cache_directory(root.joinpath(*parts))
    level = root
    check_private(level)
    for part in parts:
        level = level / part
        check_private(level)
    return directory


def note(message: str) -> None:
    """One line on stderr, ``eigentwist: message`` (cache events the user should know of)."""
    print(f"eigentwist: {message}", file=sys.stderr, flush=True)


def _digest_path(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


def write_verified(path: Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically and its SHA-256 beside it (``path.sha256``)."""
    path = Path(path)
    _write_atomic(path, data)
    _write_atomic(_digest_path(path), (hashlib.sha256(data).hexdigest() + "\n").encode())
    return path


_SHIPPED: dict = {}


def read_shipped(path: Path) -> bytes:
    """The bytes of a generated file shipped in ``eigentwist/generated`` (``<robot>_numpy.py``,
    ``<robot>_c.c``), checked against ``<robot>.sha256`` beside it (written by ``eigentwist
    generate``) before it is imported or compiled; once per process and file version.
    Raises :class:`DamagedFileError` when the digest is missing or differs."""
    path = Path(path)
    data = path.read_bytes()
    st = os.stat(path)
    key = (str(path), st.st_mtime_ns, st.st_size)
    if key in _SHIPPED:
        return data
    sums = path.with_name(path.name.rsplit("_", 1)[0] + ".sha256")
    try:
        recorded = dict(reversed(line.split(None, 1)) for line in sums.read_text().splitlines() if line.strip())
    except (OSError, ValueError):
        recorded = {}
    digest = hashlib.sha256(data).hexdigest()
    if recorded.get(path.name) != digest:
        why = "has no recorded SHA-256" if path.name not in recorded else "does not match its recorded SHA-256"
        raise DamagedFileError(
            f"the generated file {path} {why} ({sums.name}): the installation is damaged or "
            "edited; reinstall eigentwist, or run `eigentwist generate` in a source checkout"
        )
    _SHIPPED[key] = digest
    return data


def read_verified(path: Path) -> bytes | None:
    """The bytes of the cached file ``path`` when they match the SHA-256 recorded beside it,
    else None (missing, truncated or altered: a :func:`note` says which; regenerate it).
    Raises :class:`UnsafeCacheError` when ``path`` or its directory is not private."""
    path = Path(path)
    check_private(path.parent)
    if not path.exists():
        return None
    check_private(path)
    data = path.read_bytes()
    try:
        want = _digest_path(path).read_text().strip()
    except OSError:
        want = ""
    if hashlib.sha256(data).hexdigest() != want:
        why = "has no recorded SHA-256" if not want else "does not match its recorded SHA-256 (truncated or altered)"
        note(f"the cached file {path} {why}: regenerating it")
        return None
    return data


class _Lock:
    """An exclusive ``flock`` on ``path`` for the ``with`` block (no-op without fcntl)."""

    def __init__(self, path: Path):
        self.path = path
        self.fd = None

    def __enter__(self):
        if fcntl is not None:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)


def _write_atomic(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _compile(source: str, name: str, cc: str, flags: list[str], target: Path) -> None:
    """Compile into a temporary file, record its digest, rename it into place."""
    directory = target.parent
    fd, src = tempfile.mkstemp(prefix=f".{name}_", suffix=".c", dir=directory)
    tmp = src[:-2] + ".so.tmp"
    try:
        with os.fdopen(fd, "w") as f:
            f.write(source)
        print(f"eigentwist: compiling {name} with {cc} (once; cached in {target.parent})", file=sys.stderr, flush=True)
        subprocess.run([cc, *flags, "-o", tmp, src, "-lm"], check=True, capture_output=True, text=True)
        os.chmod(tmp, 0o700)
        _write_atomic(target.with_name(target.name + ".sha256"), (library_digest(Path(tmp)) + "\n").encode())
        os.replace(tmp, target)
    finally:
        for path in (src, tmp):
            if os.path.exists(path):
                os.unlink(path)


def load_library(source: str, name: str):
    """The library compiled from ``source`` (:func:`build_library`, on the first flag set of
    :func:`flag_sets` that builds it) and loaded with ctypes, or None where no compiler or no
    flag set builds it (the caller falls back to NumPy)."""
    import ctypes

    try:
        cc = find_compiler()
        for _, flags in flag_sets():
            try:
                return ctypes.CDLL(str(build_library(source, name, cc, flags)))
            except (subprocess.CalledProcessError, OSError):
                continue
    except (BuildError, OSError):
        pass
    return None


def library_once(kept: list, libraries: list, source: str, name: str, bind):
    """A hand-written helper library's bound function, built once per process: on the first
    call the library compiled from ``source`` (:func:`load_library`) is appended to
    ``libraries`` (the module's list: loaded for the process) and ``bind(library)`` (the
    function, its argument and return types declared) to ``kept``; where no compiler
    builds it, None is kept (the callers take their Python or NumPy way). Returns ``kept[0]``."""
    if not kept:
        library = load_library(source, name)
        if library is not None:
            libraries.append(library)
        kept.append(None if library is None else bind(library))
    return kept[0]


def build_library(source: str, name: str, cc: str, flags: list[str], directory: Path | None = None) -> Path:
    """Compile ``source`` into ``<directory>/<name>_<key>.so``, or reuse it if intact.

    ``key`` hashes the source, the flags, the compiler path and its version. Reuse checks
    the library's SHA-256 against the one recorded when it was built; a missing or
    damaged library is (re)built under an exclusive file lock, so concurrent processes
    compile it once, and renamed into place, so none loads a partial file.
    Raises :class:`subprocess.CalledProcessError` when the compiler fails and
    :class:`UnsafeCacheError` for a cache directory or library others may write to.
    """
    directory = _cache_directory(cache_dir() if directory is None else Path(directory))
    stem = f"{name}_{content_hash(source, tuple(flags), cc, compiler_version(cc))}"
    target = directory / f"{stem}.so"
    if not _intact(target):
        if target.exists():
            note(
                f"the cached library {target} does not match its recorded SHA-256 (truncated or altered): rebuilding it"
            )
        with _Lock(directory / f"{stem}.lock"):
            if not _intact(target):  # another process may have built it meanwhile
                _compile(source, name, cc, flags, target)
    check_private(target)
    return target
