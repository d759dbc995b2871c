"""Atomic file writing: content written to a temporary sibling (one file system), fsynced
and renamed onto the target (``os.replace``, atomic on POSIX and Windows), so a reader
never sees a partial file and a failure leaves the target untouched. Once a stop is asked
(:func:`refuse_commits`), no later rename happens.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
import secrets
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from synth.errors import SynthError

#: Prefix of the engine's temporaries, ``.synth-<pid>-<hex>.part<suffix>``: the name does
#: not grow with the target's, and the writer's pid lets a dead writer's be removed.
TEMPORARY_PREFIX = ".synth-"


class _Commits:
    """The stop that every later commit raises rather than rename (None: commits go on)."""

    refused_by: BaseException | None = None


def refuse_commits(stop: BaseException | None) -> None:
    """From now on raise ``stop`` where a finished temporary would be renamed onto its target
    (``None`` allows commits again). A command asked to stop (SIGTERM) sets it, so the stop
    holds even where Python swallowed the exception that carried it (a finalizer, a weakref
    callback): every target keeps its old content."""
    _Commits.refused_by = stop


def commits_refused_by() -> BaseException | None:
    """The stop given to :func:`refuse_commits`, or None."""
    return _Commits.refused_by


def _allow_commit() -> None:
    if _Commits.refused_by is not None:
        raise _Commits.refused_by


def temporary_name(suffix: str) -> str:
    """A fresh temporary file name of this process, ending in ``.part<suffix>``."""
    return f"{TEMPORARY_PREFIX}{os.getpid()}-{secrets.token_hex(6)}.part{suffix}"


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        pass
    return True


def remove_stale_temporaries(folder) -> None:
    """Remove the temporaries in ``folder`` whose writer process no longer runs."""
    try:
        entries = list(Path(folder).glob(f"{TEMPORARY_PREFIX}*.part*"))
    except OSError:
        return
    for tmp in entries:
        pid_text = tmp.name[len(TEMPORARY_PREFIX) :].split("-", 1)[0]
        if pid_text.isdigit() and not _process_alive(int(pid_text)):
            with contextlib.suppress(OSError):  # removed meanwhile, or not removable
                tmp.unlink()


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
            tmp.unlink(missing_ok=True)  # renamed onto its target, or never created


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
        _allow_commit()
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
        _allow_commit()
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


class Outputs(contextlib.AbstractContextManager):
    """The output files of one command, written all or none: each path checked before any
    work (:func:`synth.store.audio.check_output_path`; two outputs on one file refused);
    inside ``with outputs:`` each file is written to a temporary beside its target
    (:meth:`staged`), renamed onto it only when the block ends without an error."""

    def __init__(self, paths: dict, suffixes: dict | None = None):
        from synth.store.audio import check_output_path

        self.paths = {k: Path(v) for k, v in paths.items() if v}
        seen: dict = {}
        for field, path in self.paths.items():
            other = seen.setdefault(path.resolve(), field)
            if other != field:
                raise SynthError(
                    f"{other}={str(self.paths[other])!r} and {field}={str(path)!r} are the same "
                    f"file; give each output its own path (nothing was written)"
                )
        for field, path in self.paths.items():
            check_output_path(path, field, (suffixes or {}).get(field))
        self.temporaries: dict = {}

    def staged(self, field: str) -> Path:
        target = self.paths[field]
        self.temporaries[field] = target.with_name(temporary_name(target.suffix))
        return self.temporaries[field]

    def __exit__(self, kind, exc, tb):
        try:
            if kind is None:
                _allow_commit()
                for field, tmp in self.temporaries.items():
                    os.replace(tmp, self.paths[field])
            elif exc is not None:
                self._name_the_targets(exc)
        finally:
            for tmp in self.temporaries.values():
                tmp.unlink(missing_ok=True)

    def _name_the_targets(self, exc: BaseException) -> None:
        """Put the user's paths where ``exc`` names a temporary (any engine temporary in a
        target's folder with its suffix: a writer may stage its own beside ours)."""
        for target in map(self.paths.get, self.temporaries):
            hidden = re.compile(
                re.escape(str(target.with_name(TEMPORARY_PREFIX)))
                + r"\d+-[0-9a-f]+\.part"
                + re.escape(target.suffix)
            )
            named = functools.partial(hidden.sub, lambda _, path=str(target): path)
            if isinstance(exc, OSError) and exc.filename is not None:
                exc.filename = named(str(exc.filename))
            exc.args = tuple(named(a) if isinstance(a, str) else a for a in exc.args)
