"""Atomic file writing: a file is either left as it was or replaced by a complete one.

The content is written to a temporary sibling (same directory, so the rename stays on
one file system), flushed to disk with ``fsync`` and renamed onto the target with
``os.replace``, which POSIX and Windows make atomic. A reader therefore never sees a
partial file, and a crash or an exception during the write leaves the target
untouched. The temporary file gets the usual permissions (``0o666`` less the umask).
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "remove_stale_temporaries",
    "temporary_name",
    "temporary_sibling",
    "write_atomically",
    "write_json_atomically",
    "write_once",
]


#: Prefix of the engine's temporary files: ``.synth-<pid>-<hex>.part<suffix>``. The name
#: does not grow with the target's (a 255-byte output name still has a temporary name),
#: and it carries the writer's process id, so that a temporary left by a killed process
#: is recognised and removed (:func:`remove_stale_temporaries`).
TEMPORARY_PREFIX = ".synth-"


def temporary_name(suffix: str) -> str:
    """A fresh temporary file name of this process, ending in ``.part<suffix>``."""
    return f"{TEMPORARY_PREFIX}{os.getpid()}-{secrets.token_hex(6)}.part{suffix}"


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True
    return True


def remove_stale_temporaries(folder) -> list[Path]:
    """Remove the temporaries (:func:`temporary_name`) in ``folder`` whose writer process
    no longer runs (it was killed mid-write); return the paths removed. A live process's
    temporaries, and every other file, are left alone."""
    removed = []
    try:
        entries = list(Path(folder).glob(f"{TEMPORARY_PREFIX}*.part*"))
    except OSError:
        return removed
    for tmp in entries:
        pid_text = tmp.name[len(TEMPORARY_PREFIX) :].split("-", 1)[0]
        if not pid_text.isdigit() or _process_alive(int(pid_text)):
            continue
        try:
            tmp.unlink()
            removed.append(tmp)
        except OSError:
            pass
    return removed


@contextmanager
def temporary_sibling(
    path: str | os.PathLike,
    error: type[Exception] = OSError,
    field: str = "path",
    suffix: str | None = None,
) -> Iterator[Path]:
    """Create (exclusively) an empty hidden file beside ``path`` and yield its path; on leaving,
    remove it unless it was renamed away, on every way out (the name carries this process's id
    and a random part, :func:`temporary_name`). It keeps ``path``'s suffix (or ``suffix``) for
    writers that choose the format by suffix; stale temporaries of killed writers there are
    removed first. ``error``, naming ``field`` and ``path``, is raised when no file can be
    created there."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    remove_stale_temporaries(folder)
    tmp = None
    try:
        for _ in range(100):
            tmp = folder / temporary_name(path.suffix if suffix is None else suffix)
            try:
                os.close(os.open(tmp, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
                break
            except FileExistsError:
                tmp = None
            except OSError as exc:
                tmp = None
                raise error(
                    f"{field}={str(path)!r}: cannot create a file in {str(folder)!r} "
                    f"({exc.strerror})"
                ) from None
        else:
            raise error(f"{field}={str(path)!r}: no free temporary name beside it")
        yield tmp
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except FileNotFoundError:  # renamed onto its target, or never created
                pass


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomically(
    path: str | os.PathLike, write: Callable[[Path], None], *, error: type[Exception] = OSError
) -> Path:
    """Call ``write(tmp)`` on a temporary sibling of ``path``, then move it onto ``path``.

    ``write`` receives the temporary file's path (it exists, empty) and must write the
    whole content there. On any failure (an exception, or a signal's at any point) the
    temporary file is removed and the exception re-raised. ``error`` is the exception
    class for a temporary file that cannot be created. Returns ``path`` as a
    :class:`~pathlib.Path`.
    """
    path = Path(path)
    with temporary_sibling(path, error) as tmp:
        write(tmp)
        _fsync(tmp)
        os.replace(tmp, path)
    return path


def write_once(path: str | os.PathLike, data: bytes) -> bool:
    """Publish ``data`` as ``path`` unless ``path`` exists: written whole to a temporary
    sibling, fsynced, then hard-linked onto ``path`` (``os.link`` fails when the target
    exists, atomically, so of several writers racing for one name exactly one wins and
    the file is never rewritten). Returns True if this call wrote the file, False if it
    was there already. Where hard links are not supported, ``os.replace`` is used when no
    file is there (a check and a rename: atomic for the reader, racy between writers)."""
    path = Path(path)
    with temporary_sibling(path) as tmp:
        tmp.write_bytes(data)
        _fsync(tmp)
        try:
            os.link(tmp, path)
        except FileExistsError:
            return False
        except OSError:  # no hard links on this file system
            if path.exists():
                return False
            os.replace(tmp, path)
    return True


def write_json_atomically(
    path: str | os.PathLike, obj, *, error: type[Exception] = OSError
) -> Path:
    """Write ``obj`` as JSON (numbers that are not JSON types as floats) plus a newline,
    atomically (see :func:`write_atomically`)."""

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(obj, fh, indent=1, default=float)
            fh.write("\n")

    return write_atomically(path, write, error=error)
