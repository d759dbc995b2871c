"""Atomic file writing: content written to a temporary sibling (one file system), fsynced
and renamed onto the target (``os.replace``, atomic on POSIX and Windows), so a reader
never sees a partial file and a failure leaves the target untouched.
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

#: Prefix of the engine's temporaries, ``.synth-<pid>-<hex>.part<suffix>``: the name does
#: not grow with the target's, and the writer's pid lets a dead writer's be removed.
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
    """Remove the temporaries in ``folder`` whose writer process no longer runs; the paths
    removed."""
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
    """Create (exclusively) an empty temporary beside ``path`` with its suffix (or
    ``suffix``: writers choose the format by it) and yield it; it is removed on every way
    out unless renamed away. ``error``, naming ``field``, when no file can be created."""
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
    """Call ``write(tmp)`` on a temporary sibling of ``path`` (existing, empty), then move it
    onto ``path``; on any failure the temporary is removed and the error raised again
    (``error`` when no temporary can be created)."""
    path = Path(path)
    with temporary_sibling(path, error) as tmp:
        write(tmp)
        _fsync(tmp)
        os.replace(tmp, path)
    return path


def write_once(path: str | os.PathLike, data: bytes) -> bool:
    """Publish ``data`` as ``path`` unless it exists; True if this call wrote it. The
    temporary is hard-linked onto ``path`` (``os.link`` fails atomically when the target
    exists: of racing writers exactly one wins); without hard links, a check and
    ``os.replace`` (atomic for the reader, racy between writers)."""
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
    """Write ``obj`` as JSON (other numbers as floats) atomically."""

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(obj, fh, indent=1, default=float)
            fh.write("\n")

    return write_atomically(path, write, error=error)
