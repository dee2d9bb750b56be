"""Writing output files safely: never over an input, never half-written, never over a file of another kind.

* :func:`check_output` refuses an output path that is one of the inputs (the same file,
  by :func:`os.path.samefile`, hard and symbolic links included) and, unless ``force``,
  an existing file of another kind than the one to be written (HTML over a CSV, a CSV
  over a PNG): the kind of the existing file is read from its first bytes
  (:func:`file_kind`), not from its name.
* :func:`write_atomic` and :func:`atomic_path` write into a temporary file in the
  output's directory and rename it into place (:func:`os.replace`), so a reader sees the
  old file or the new one, never a partial one, and a failed write leaves the old file.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from pathlib import Path

from .errors import InputError

__all__ = ["OutputError", "KINDS", "file_kind", "same_file", "check_output", "write_atomic", "atomic_path"]


class OutputError(InputError):
    """An output path is refused: it is an input, or replacing it needs ``--force``."""


#: what a command writes -> the kinds of existing file it may replace without ``force``
KINDS = {
    "html": ("html", "empty"),
    "csv": ("text", "empty"),
    "image": ("png", "gif", "svg", "pdf", "jpeg", "empty"),
    "directory": ("directory",),
}

_MAGIC = (
    (b"\x89PNG", "png"),
    (b"GIF8", "gif"),
    (b"%PDF", "pdf"),
    (b"\xff\xd8\xff", "jpeg"),
    (b"PK\x03\x04", "zip"),
    (b"PAR1", "parquet"),
)


def file_kind(path) -> str:
    """The kind of an existing path from its first bytes: ``directory``, ``empty``, ``png``,
    ``gif``, ``pdf``, ``jpeg``, ``zip``, ``parquet``, ``html``, ``svg``, ``text`` (any other
    UTF-8 text: CSV, UFF) or ``binary``."""
    path = Path(path)
    if path.is_dir():
        return "directory"
    with open(path, "rb") as f:
        head = f.read(4096)
    if not head:
        return "empty"
    for magic, kind in _MAGIC:
        if head.startswith(magic):
            return kind
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.reason != "unexpected end of data":  # not a multi-byte character cut at byte 4096
            return "binary"
        text = head[: exc.start].decode("utf-8")
    text = text.lstrip("\ufeff \t\r\n").lower()
    if "\x00" in text:
        return "binary"
    if text.startswith(("<!doctype html", "<html")):
        return "html"
    if text.startswith("<svg") or (text.startswith("<?xml") and "<svg" in text):
        return "svg"
    return "text"


def same_file(a, b) -> bool:
    """True when the paths ``a`` and ``b`` name one file (links followed; a missing path
    is compared by its resolved name)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def check_output(path, kind: str, inputs=(), force: bool = False, option: str = "-o") -> Path:
    """Check that ``path`` may receive an output of ``kind`` (a key of :data:`KINDS`).

    Raises :class:`OutputError` when ``path`` is one of ``inputs`` (whatever ``force``
    says: the input would be lost) or, unless ``force``, when it exists and is of a kind
    that ``kind`` does not replace (:func:`file_kind`). Returns ``path`` as a Path.
    """
    path = Path(path)
    for source in inputs:
        if source is not None and same_file(path, source):
            raise OutputError(
                f"{option} {str(path)!r} is the input {str(source)!r}: writing there would destroy "
                "it; choose another output path"
            )
    if kind not in KINDS:
        raise InputError(f"unknown output kind {kind!r}: expected one of {', '.join(KINDS)}")
    if not os.path.lexists(path) or force:
        return path
    try:
        found = file_kind(path)
    except OSError as exc:
        raise OutputError(
            f"{option} {str(path)!r} exists and cannot be read ({exc.strerror}); choose another output path"
        ) from None
    if found not in KINDS[kind]:
        what = "a directory" if found == "directory" else f"a {found} file"
        raise OutputError(
            f"{option} {str(path)!r} exists and is {what}, not {'an' if kind == 'html' else 'a'} "
            f"{kind} output: choose another path or pass --force to replace it"
        )
    return path


def _new_file_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path):
    """``with atomic_path(path) as tmp:`` write the file ``tmp`` (same directory, same
    suffix, so writers that read the format from the name keep it); on success it is
    renamed to ``path`` with the mode of the file it replaces (else the umask's); on an
    exception it is removed and ``path`` is left as it was. A file object (``io.BytesIO``)
    is yielded as it is."""
    if not isinstance(path, (str, os.PathLike)):
        yield path
        return
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=directory)
    os.close(fd)
    try:
        yield Path(tmp)
        try:
            mode = stat.S_IMODE(os.stat(path).st_mode)
        except OSError:
            mode = _new_file_mode()
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_atomic(path, data, encoding: str = "utf-8") -> Path:
    """Write ``data`` (str or bytes) to ``path`` through :func:`atomic_path`; return ``path``."""
    path = Path(path)
    with atomic_path(path) as tmp:
        if isinstance(data, str):
            tmp.write_text(data, encoding=encoding)
        else:
            tmp.write_bytes(data)
    return path
