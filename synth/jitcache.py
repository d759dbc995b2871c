"""Where numba keeps the compiled kernels (``cache=True``), chosen before numba loads.

With neither the package's ``__pycache__`` nor the user's cache folder writable (numba then
refuses to compile a cached function), the cache goes to a folder of this user in the
system's temporary directory, or caching is turned off; a user's ``NUMBA_CACHE_DIR`` stays.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
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


#: This package's folder; its name is the top of every module name it holds.
_ROOT = Path(__file__).resolve().parent


def _digest(root: Path, files) -> str:
    """SHA-256 (hex) of ``files`` (under ``root``): each one's relative path and bytes."""
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def _module_file(root: Path, name: str) -> Path | None:
    """The source of the module ``name`` (dotted, starting with ``root``'s name) under
    ``root``: ``a/b.py`` or ``a/b/__init__.py``; None if it is no module of the package."""
    parts = name.split(".")
    if parts[0] != root.name:
        return None
    base = root.joinpath(*parts[1:])
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _module_name(root: Path, path: Path) -> str:
    """The dotted name of the module whose source is ``path`` under ``root``."""
    parts = [root.name, *path.relative_to(root).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


#: ``from X import names`` (names in parentheses over several lines, or to the line's end).
_FROM = re.compile(r"^[ \t]*from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)", re.M)
#: ``import X, Y as Z``.
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([^\n]*)", re.M)
#: A module-level ``__getattr__`` (PEP 562: names imported on first use).
_LAZY = re.compile(r"^(def[ \t]+)?__getattr__\b", re.M)


def _names(text: str) -> list[str]:
    """The imported names of an import's tail (``a as b, (c,\n d)  # note``): a, c, d."""
    text = re.sub(r"#[^\n]*", "", text).replace("(", " ").replace(")", " ")
    return [part.split()[0] for part in text.split(",") if part.split()]


@functools.cache
def _imported_files(root: Path, path: Path) -> frozenset[Path]:
    """The package's modules that ``path`` imports anywhere in its text (at the top, in a
    function, relative or absolute; a line of a docstring that reads as an import counts
    too, which only widens the set): ``from p import name`` counts the submodule
    ``p.name`` where there is one, else ``p`` itself. A package whose ``__init__`` has a
    ``__getattr__`` (names imported on first use, PEP 562) brings all its modules."""
    text = path.read_text(encoding="utf-8")
    package = _module_name(root, path)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    found: set[Path] = set()

    def add(name: str) -> bool:
        source = _module_file(root, name)
        if source is not None:
            found.add(source)
        return source is not None

    for match in _IMPORT.finditer(text):
        for name in _names(match[1]):
            add(name)
    for match in _FROM.finditer(text):
        base = match[1]
        level = len(base) - len(base.lstrip("."))
        if level:
            anchor = package.rsplit(".", level - 1)[0] if level > 1 else package
            base = f"{anchor}.{base[level:]}" if base[level:] else anchor
        for name in _names(match[2]):
            if name == "*" or not add(f"{base}.{name}"):
                add(base)
    if path.name == "__init__.py" and _LAZY.search(text):
        found.update(path.parent.rglob("*.py"))
    return frozenset(found)


def import_closure(path: Path, root: Path | None = None) -> list[Path]:
    """The package's sources that the module at ``path`` depends on: itself and, in turn,
    every module of the package it imports (:func:`_imported_files`), in path order. A
    compiled kernel can only use code and constants of these files."""
    root = _ROOT if root is None else Path(root)
    seen = {Path(path).resolve()}
    todo = list(seen)
    while todo:
        for found in _imported_files(root, todo.pop()):
            found = found.resolve()
            if found not in seen:
                seen.add(found)
                todo.append(found)
    return sorted(seen)


def closure_digest(path: Path, root: Path | None = None) -> str:
    """SHA-256 (hex) of the sources of :func:`import_closure` of ``path``."""
    root = _ROOT if root is None else Path(root)
    return _digest(root, import_closure(path, root))


@functools.cache
def source_digest(path: str) -> str:
    """:func:`closure_digest` of the module at ``path`` (a file of this package), once per
    process: a disk cache's key names the code that computed its entries, so an entry
    written by an edited or other revision of that code is recomputed, not served."""
    return closure_digest(Path(path))


def stamp_with_the_import_closure() -> None:
    """Key every kernel of this package in numba's disk cache on the sources its module
    depends on (:func:`closure_digest`), not on its own file alone (numba's stamp, its
    modification time and size): a change in a module the kernel's module imports,
    directly or not, recompiles the kernel (a callee inlined from another file is never
    served stale), a change anywhere else keeps its cache. Must run before the first
    kernel is defined; other packages keep numba's stamp."""
    from numba.core import caching

    mixin = caching._SourceFileBackedLocatorMixin
    if getattr(mixin, "synth_stamp", False):
        return
    own_stamp = mixin.get_source_stamp
    root = str(_ROOT) + os.sep
    digest = functools.cache(closure_digest)

    def get_source_stamp(self):
        path = os.path.realpath(self._py_file)
        if path.startswith(root):
            return ("synth import closure", digest(Path(path)))
        return own_stamp(self)

    mixin.get_source_stamp = get_source_stamp
    mixin.synth_stamp = True


def _disable_caching() -> None:
    """Make ``cache=True`` a no-op: numba then compiles in memory only."""
    from numba.core import dispatcher

    dispatcher.Dispatcher.enable_caching = lambda self: None


configure()


def keep_kernels_the_cache_cannot_hold() -> None:
    """A kernel of this package whose cache entry cannot be written (a full disk, a file
    size limit, ``ulimit -f``) runs all the same from memory, with one note on stderr per
    process; numba would raise the OSError out of the compile and fail the call. numba
    writes each cache file to a temporary name and renames it, so nothing partial is left."""
    from numba.core import caching

    cache = caching.Cache
    if getattr(cache, "synth_keeps", False):
        return
    own_save = cache.save_overload
    root = str(_ROOT) + os.sep
    noted = []

    def save_overload(self, sig, data):
        try:
            own_save(self, sig, data)
        except OSError as exc:
            if not os.path.realpath(self._py_func.__code__.co_filename).startswith(root):
                raise
            if not noted:
                noted.append(exc)
                print(
                    f"synth: note: numba's cache could not be written ({exc.strerror or exc});"
                    " the compiled code is kept for this run only",
                    file=sys.stderr,
                    flush=True,
                )

    cache.save_overload = save_overload
    cache.synth_keeps = True
