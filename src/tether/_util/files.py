"""Output files: validate a path before computing, write it whole or not at all.

A user should not wait a minute to learn that ``--plot out/fig.png`` names a missing folder,
and an interrupted or failed write must never leave a half-written file behind. So commands
that write files

1. call :func:`check_output_path` (or :func:`check_output_dir`) on their arguments *before*
   any computation, and
2. write through :func:`atomic_output`, which yields a temporary path in the same folder with
   the same extension (so writers that pick the format from the extension still work) and
   renames it onto the real path only on success.

Every problem is an :class:`OutputPathError`: one line naming the path and what is wrong.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from tether.errors import OutputPathError

__all__ = [
    "ANIMATION_KINDS",
    "IMAGE_KINDS",
    "OutputPathError",
    "atomic_output",
    "check_output_dir",
    "check_output_path",
]

#: Extensions a figure can be saved with (matplotlib picks the format from the extension).
IMAGE_KINDS = (".png", ".pdf", ".svg", ".jpg")

#: Extensions an animation can be saved with.
ANIMATION_KINDS = (".gif", ".mp4", ".html")


def _writable_dir(folder: Path, shown: str) -> None:
    """Raise unless ``folder`` is an existing, writable directory (``shown`` names the path)."""
    if not folder.exists():
        # a path under a regular file: "file.txt/out.png"
        for parent in [folder, *folder.parents]:
            if parent.exists() and not parent.is_dir():
                raise OutputPathError(f"cannot write {shown}: {str(parent)!r} is a file, "
                                      "not a folder")
        raise OutputPathError(f"cannot write {shown}: folder {str(folder)!r} does not exist")
    if not folder.is_dir():
        raise OutputPathError(f"cannot write {shown}: {str(folder)!r} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputPathError(f"cannot write {shown}: folder {str(folder)!r} is not writable")


def check_output_path(path: str | os.PathLike, kinds: Iterable[str] = IMAGE_KINDS) -> Path:
    """Validate an output file path before any computation; return it as a :class:`Path`.

    ``kinds`` are the accepted extensions (lower case, with the dot). Raises
    :class:`OutputPathError` if the extension is missing or not one of ``kinds``, if the path is
    an existing folder or an existing file that cannot be overwritten, or if its folder is
    missing, is a file, or is not writable.
    """
    kinds = tuple(k.lower() for k in kinds)
    text = os.fspath(path)
    shown = repr(text)
    if not text or not text.strip():
        raise OutputPathError("output path is empty")
    if "\x00" in text:
        raise OutputPathError(f"cannot write {shown}: the path contains a NUL character")
    p = Path(text)
    if text.endswith(("/", os.sep)) or p.is_dir():
        raise OutputPathError(f"cannot write {shown}: it is a folder; give a file name "
                              f"ending in {', '.join(kinds)}")
    suffix = p.suffix.lower()
    if not suffix:
        raise OutputPathError(f"cannot write {shown}: no extension; use one of "
                              f"{', '.join(kinds)}")
    if suffix not in kinds:
        raise OutputPathError(f"cannot write {shown}: unknown extension {p.suffix!r}; use one "
                              f"of {', '.join(kinds)}")
    _writable_dir(p.parent if str(p.parent) else Path("."), shown)
    if p.exists() and not os.access(p, os.W_OK):
        raise OutputPathError(f"cannot write {shown}: the file exists and is read-only")
    return p


def check_output_dir(path: str | os.PathLike) -> Path:
    """Validate an output folder (created later if missing); return it as a :class:`Path`.

    The folder may not exist yet, but its nearest existing ancestor must be a writable folder;
    an existing path must be a writable folder, not a file.
    """
    text = os.fspath(path)
    if not text or not text.strip():
        raise OutputPathError("output folder is empty")
    if "\x00" in text:
        raise OutputPathError(f"cannot write {text!r}: the path contains a NUL character")
    p = Path(text)
    shown = repr(text)
    if p.exists():
        if not p.is_dir():
            raise OutputPathError(f"cannot write into {shown}: it is a file, not a folder")
        if not os.access(p, os.W_OK | os.X_OK):
            raise OutputPathError(f"cannot write into {shown}: the folder is not writable")
        return p
    for parent in p.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputPathError(f"cannot create folder {shown}: {str(parent)!r} is a "
                                      "file, not a folder")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise OutputPathError(f"cannot create folder {shown}: {str(parent)!r} is not "
                                      "writable")
            break
    return p


def make_output_dir(path: str | os.PathLike) -> Path:
    """Create an output folder checked by :func:`check_output_dir`; errors become one line."""
    p = check_output_dir(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"cannot create folder {os.fspath(path)!r}: "
                              f"{exc.strerror or exc}") from None
    return p


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` with the same extension; rename on success.

    If the body raises (or is interrupted), the temporary file is removed and ``path`` is left
    as it was. OS errors while writing become :class:`OutputPathError`.
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{p.stem}.", suffix=p.suffix, dir=folder)
    except OSError as exc:
        raise OutputPathError(f"cannot write {os.fspath(path)!r}: {exc.strerror or exc}") \
            from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        try:
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, p)
        except OSError as exc:
            raise OutputPathError(f"cannot write {os.fspath(path)!r}: "
                                  f"{exc.strerror or exc}") from None
    except OSError as exc:
        raise OutputPathError(f"cannot write {os.fspath(path)!r}: {exc.strerror or exc}") \
            from None
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
