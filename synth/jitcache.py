"""Where numba keeps the compiled kernels (``cache=True``), chosen before numba loads.

With neither the package's ``__pycache__`` nor the user's cache folder writable (numba then
refuses to compile a cached function), the cache goes to a folder of this user in the
system's temporary directory, or caching is turned off; a user's ``NUMBA_CACHE_DIR`` stays.
"""

from __future__ import annotations

import functools
import hashlib
import os
import sys
import tempfile
from pathlib import Path


def _writable(folder: Path) -> bool:
    """True if a file can be created in ``folder`` (made if missing), as numba tests it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def _source_dirs() -> list[Path]:
    """The package's folders: numba caches a kernel in the ``__pycache__`` beside it."""
    root = Path(__file__).resolve().parent
    return [root] + sorted(p.parent for p in root.rglob("*/__init__.py"))


def _user_cache_dir(environ) -> Path | None:
    base = environ.get("XDG_CACHE_HOME") or (
        os.path.join(environ["HOME"], ".cache") if environ.get("HOME") else None
    )
    return Path(base) / "numba" if base else None


def configure(environ=None, source_dirs=None, stream=None) -> str | None:
    """Set ``NUMBA_CACHE_DIR`` in ``environ`` when numba would find no writable cache
    folder; the folder chosen, or None. Must run before numba is imported."""
    environ = os.environ if environ is None else environ
    stream = sys.stderr if stream is None else stream
    if environ.get("NUMBA_CACHE_DIR") or environ.get("NUMBA_DISABLE_JIT") == "1":
        return None
    dirs = _source_dirs() if source_dirs is None else source_dirs
    if all(_writable(Path(d) / "__pycache__") for d in dirs):
        return None
    user = _user_cache_dir(environ)
    if user is not None and _writable(user):
        return None
    fallback = Path(tempfile.gettempdir()) / f"synth-numba-cache-{os.getuid()}"
    if _writable(fallback):
        environ["NUMBA_CACHE_DIR"] = str(fallback)
        print(
            f"synth: note: no writable numba cache folder (the package's __pycache__, "
            f"{user or '~/.cache/numba'}); caching compiled code in {fallback}",
            file=stream,
        )
        return str(fallback)
    _disable_caching()
    print(
        "synth: note: no writable folder for numba's cache; compiled code is not cached "
        "(every start compiles again, about a minute)",
        file=stream,
    )
    return None


def package_digest(root: Path | None = None) -> str:
    """SHA-256 (hex) of the Python sources under ``root`` (default: this package): each
    file's relative path and bytes, in path order."""
    root = Path(__file__).resolve().parent if root is None else Path(root)
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def stamp_with_the_package() -> None:
    """Make every kernel of this package's numba cache entry valid for the package's sources
    as a whole (:func:`package_digest`): a change anywhere recompiles every kernel once.
    Must run before the first kernel is defined; other packages keep numba's stamp."""
    from numba.core import caching

    mixin = caching._SourceFileBackedLocatorMixin
    if getattr(mixin, "synth_stamp", False):
        return
    own_stamp = mixin.get_source_stamp
    root = str(Path(__file__).resolve().parent) + os.sep
    digest = functools.cache(package_digest)

    def get_source_stamp(self):
        if os.path.realpath(self._py_file).startswith(root):
            return ("synth package", digest())
        return own_stamp(self)

    mixin.get_source_stamp = get_source_stamp
    mixin.synth_stamp = True


def _disable_caching() -> None:
    """Make ``cache=True`` a no-op: numba then compiles in memory only."""
    from numba.core import dispatcher

    dispatcher.Dispatcher.enable_caching = lambda self: None


configure()
