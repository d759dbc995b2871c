"""First use of the compiled kernels: the options every kernel is compiled with
(:func:`compiled`), the groups whose compile takes seconds (:data:`GROUPS`), a note once
per process before a group missing from numba's disk cache compiles (:func:`announce`,
which first waits for a process compiling that group ahead, :data:`LOCKS`), one compile of
a kernel at a time among processes sharing a disk cache (:data:`KERNEL_LOCKS`), and the log
of every compile with its CPU time (:class:`CompileLog`, for ``synth warmup`` and
``synth bench cold``).
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numba

from synth import jitcache

jitcache.stamp_with_the_import_closure()
jitcache.keep_kernels_the_cache_cannot_hold()

#: This package's folder: the kernels whose compiles take :data:`KERNEL_LOCKS`.
_ROOT = os.path.dirname(os.path.realpath(__file__)) + os.sep

#: numba's fast-math flags of a kernel: none, or with ``sums=True`` (the modal bank's
#: loops over modes, whose sums must vectorise) :data:`FAST_SUMS`. Always given, never
#: left unset: a kernel whose flags are unset is compiled with the flags of the first
#: kernel that calls it (numba's ``inherit_if_not_set``) and keeps that code for every
#: later caller, so its bits would depend on which caller compiled it first.
FASTMATH = False
#: Sums may be reordered (``reassoc``, so that a loop that accumulates vectorises), the
#: sign of a zero ignored (``nsz``), a division taken as a multiplication by the reciprocal
#: (``arcp``). Not ``contract``: LLVM fuses multiplies and adds differently in the code
#: numba compiles in the process and in the code it loads from its disk cache, so a
#: render's bits would depend on whether its kernels were compiled in this run. Not
#: ``nnan`` or ``ninf``: the kernels test for non-finite values. A function that needs
#: its operations in their order (:func:`synth.vecmath.cis`'s argument reduction) is a
#: kernel of its own without them; inlined by LLVM, its operations keep their flags.
FAST_SUMS = frozenset({"reassoc", "nsz", "arcp"})


def compiled(*, sums: bool = False, **options):
    """``numba.njit`` with the package's fast-math flags (:data:`FAST_SUMS` with
    ``sums=True``), ``cache=True`` and no C-callable wrapper (no kernel is passed as a
    first-class function; the wrapper only adds to the first compile)."""
    if "fastmath" in options:
        raise TypeError("compiled(): the fast-math flags are the package's (sums=True or not)")
    fastmath = set(FAST_SUMS) if sums else FASTMATH
    return numba.njit(cache=True, no_cfunc_wrapper=True, fastmath=fastmath, **options)


#: The measured compile time (CPU s) of each group, written by ``synth warmup --record``.
COMPILE_TIMES = Path(__file__).with_name("compile_times.json")


@dataclass(frozen=True)
class KernelGroup:
    """Kernels compiled together on their first use: ``title`` names them in the note;
    ``probe`` (module, kernel) is the outermost kernel, compiled last, whose disk cache
    says the group is there; ``modules`` are prefixes of the ``module.qualname`` of the
    kernels that start the group's compiles (the longest wins)."""

    name: str
    title: str
    probe: tuple[str, str]
    modules: tuple[str, ...]


GROUPS = {
    g.name: g
    for g in (
        KernelGroup(
            "contact",
            "the contact kernels",
            ("synth.physics.contact_kernels", "impacts_explicit"),
            ("synth.physics.contact_kernels",),
        ),
        KernelGroup(
            "stiff-contact",
            "the stiff contact kernels (Radau IIA)",
            ("synth.physics.contact_kernels", "impact_implicit"),
            ("synth.physics.contact_kernels.impact_implicit",),
        ),
        KernelGroup(
            "modal-contact",
            "the plate-coupled contact kernels",
            ("synth.physics.modal_contact.kernels", "contact_kernel"),
            ("synth.physics.modal_contact",),
        ),
        KernelGroup(
            "modal-bank",
            "the modal-bank kernels",
            ("synth.sound.modal_bank.transform_kernels", "impact_transform"),
            ("synth.sound.modal_bank", "synth.vecmath"),
        ),
        KernelGroup(
            "radiation",
            "the radiation kernels",
            ("synth.sound.radiation.common", "_rows_fast"),
            ("synth.sound.radiation",),
        ),
        KernelGroup(
            "live",
            "the live engine's kernels",
            ("synth.live.native", "_callback"),
            ("synth.live",),
        ),
        KernelGroup(
            "live-rolling",
            "the live engine's rolling voices",
            ("synth.live.native", "_roll_body"),
            ("synth.live.native._roll_body",),
        ),
    )
}

_announced: set[str] = set()

#: Environment variable: a folder of lock files (``GROUP.lock``, :func:`lock_file`) that a
#: process compiling kernel groups ahead (:func:`synth.warmup.compile_ahead`) holds until
#: each group is in numba's disk cache. A process about to compile such a group waits for
#: it, then loads the kernels instead of compiling them a second time at once.
LOCKS = "SYNTH_COMPILE_LOCKS"


#: Environment variable: a folder in which processes that share numba's disk cache take a
#: lock per kernel (:func:`kernel_lock_file`) while they compile it or load it from the
#: cache: a process about to compile a kernel that another is compiling (the workers of a
#: run spread over processes, starting alike) waits for it, then loads its code from the
#: cache, rather than compile it a second time at once.
KERNEL_LOCKS = "SYNTH_KERNEL_LOCKS"
#: The lock files of the kernels this process holds (a kernel that calls itself).
_held_kernels: set[Path] = set()


def kernel_lock_file(folder: str | Path, dispatcher) -> Path | None:
    """The lock file in ``folder`` of the kernel ``dispatcher``'s entry in numba's disk
    cache (its index file, which names the cache folder: processes on other caches take
    other locks), in the subfolder ``kernels``; None for a kernel that is not cached."""
    index = getattr(
        getattr(getattr(dispatcher, "_cache", None), "_cache_file", None), "_index_path", None
    )
    if index is None:
        return None
    digest = hashlib.sha256(os.path.realpath(index).encode()).hexdigest()[:32]
    return Path(folder) / "kernels" / f"{digest}.lock"


@contextmanager
def kernel_lock(dispatcher):
    """Hold the lock of the kernel ``dispatcher`` in :data:`KERNEL_LOCKS` (waiting while
    another process holds it); nothing without that folder, without POSIX locks, for a
    kernel that is not cached, or one whose lock this process holds already."""
    folder = os.environ.get(KERNEL_LOCKS)
    path = kernel_lock_file(folder, dispatcher) if folder else None
    if path is None or path in _held_kernels:
        yield
        return
    try:
        import fcntl

        path.parent.mkdir(exist_ok=True)
        handle = open(path, "wb")
    except (ImportError, OSError):
        yield
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        _held_kernels.add(path)
        try:
            yield
        finally:
            _held_kernels.discard(path)


def _lock_kernel_compiles() -> None:
    """Compile (or load) each kernel of this package under its :func:`kernel_lock`, taken
    under numba's compiler lock (one compile at a time in a process, as numba does): numba
    looks in its disk cache first, so a process that waited loads what the other compiled.
    A kernel's callees compile inside its compile, each under its own lock, so locks are
    taken in the order of the calls, which never loop back."""
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.dispatcher import Dispatcher

    if getattr(Dispatcher, "synth_kernel_locks", False):
        return
    own_compile = Dispatcher.compile

    def compile(self, sig):
        if not os.environ.get(KERNEL_LOCKS) or not os.path.realpath(
            self.py_func.__code__.co_filename
        ).startswith(_ROOT):
            return own_compile(self, sig)
        with global_compiler_lock, kernel_lock(self):
            return own_compile(self, sig)

    Dispatcher.compile = compile
    Dispatcher.synth_kernel_locks = True


_lock_kernel_compiles()


def lock_file(folder: str | Path, name: str) -> Path:
    """The lock file of the kernel group ``name`` in the lock folder ``folder``."""
    return Path(folder) / f"{name}.lock"


def same_cache_file(folder: str | Path) -> Path:
    """The file of the lock folder ``folder`` that holds the ``NUMBA_CACHE_DIR`` of the
    process compiling ahead (empty: numba's default, beside the sources)."""
    return Path(folder) / "numba-cache-dir"


def wait_for_ahead(name: str) -> None:
    """Wait while a process compiling ahead into this process's numba cache holds the
    lock of the kernel group ``name`` (:data:`LOCKS`); return at once without such a
    process or without POSIX locks."""
    folder = os.environ.get(LOCKS)
    if not folder:
        return
    try:
        if same_cache_file(folder).read_text() != os.environ.get("NUMBA_CACHE_DIR", ""):
            return
    except OSError:
        return
    try:
        import fcntl

        handle = open(lock_file(folder, name), "rb")
    except (ImportError, OSError):  # no POSIX locks, or the group is not compiled ahead
        return
    with handle:
        fcntl.flock(handle, fcntl.LOCK_SH)


def announce(name: str, stream=None) -> None:
    """Before the first use of the kernel group ``name``: if it is not in numba's disk
    cache, wait for a process compiling it ahead (:func:`wait_for_ahead`), then, if it is
    still missing, one line on ``stream`` (stderr); once per process."""
    if name in _announced:
        return
    _announced.add(name)
    group = GROUPS[name]
    if is_cached(group):
        return
    wait_for_ahead(name)
    if is_cached(group):
        return
    seconds = recorded_seconds().get(name)
    about = f" (about {seconds:.0f} s of CPU)" if seconds else ""
    print(
        f"synth: compiling {group.title} for first use{about}; later runs start at once",
        file=sys.stderr if stream is None else stream,
        flush=True,
    )


def is_cached(group: KernelGroup) -> bool:
    """True if the group's probe kernel is compiled in this process or in numba's disk
    cache for this source; True too where the cache cannot be read (no note is better
    than a wrong one)."""
    module, kernel = group.probe
    function = getattr(importlib.import_module(module), kernel)
    if isinstance(function, numba.core.dispatcher.Dispatcher) and function.overloads:
        return True
    return in_disk_cache(function)


def in_disk_cache(function) -> bool:
    """True if the dispatcher ``function`` (or a ``cfunc``'s Python function) has an entry
    in numba's disk cache for this source, or where the cache cannot be read."""
    try:
        if isinstance(function, numba.core.dispatcher.Dispatcher):
            cache = function._cache
        else:
            from numba.core.caching import FunctionCache

            cache = FunctionCache(function)
        return bool(cache._cache_file._load_index())
    except Exception:
        return True


@contextmanager
def cfunc_compiling(function, signature):
    """numba's ``numba:compile`` event around the compile of a ``cfunc`` of ``function``
    (numba signals a dispatcher's only), for :class:`CompileLog`; nothing when cached."""
    if in_disk_cache(function):
        yield
        return
    from numba.core import event

    data = {
        "dispatcher": SimpleNamespace(py_func=function),
        "args": signature.args,
        "return_type": signature.return_type,
    }
    with event.trigger_event("numba:compile", data=data):
        yield


def recorded_seconds() -> dict[str, float]:
    """The compile time (CPU s) of each group from the last ``synth warmup --record``."""
    try:
        return {k: float(v) for k, v in json.loads(COMPILE_TIMES.read_text()).items()}
    except (OSError, ValueError, AttributeError):
        return {}


def group_of(kernel: str) -> str:
    """The :data:`GROUPS` name of the kernel ``module.qualname`` (longest prefix), or "other"."""
    best, length = "other", 0
    for g in GROUPS.values():
        for prefix in g.modules:
            if kernel.startswith(prefix) and len(prefix) > length:
                best, length = g.name, len(prefix)
    return best


@dataclass
class Compile:
    """One compile by numba: the kernel (``module.qualname``), its argument types, the CPU
    time (s) of the compile itself and with the kernels it compiled on the way, how deep it
    was nested in another compile (0: called from Python), and its group."""

    kernel: str
    signature: str
    own_seconds: float
    total_seconds: float
    depth: int
    group: str


@dataclass
class CompileLog:
    """The compiles numba makes while :meth:`recording` (CPU time; numba compiles one at a
    time, under a lock). A compile counts in the group of the outermost compile it was
    part of: a group's time includes the kernels and helpers it needed."""

    compiles: list[Compile] = field(default_factory=list)
    _open: list[list] = field(default_factory=list)

    def recording(self):
        """Context manager: listen to numba's compile events while inside."""
        from numba.core import event

        log = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                func = ev.data["dispatcher"].py_func
                name = f"{func.__module__}.{func.__qualname__}"
                group = log._open[0][3] if log._open else group_of(name)
                log._open.append([time.process_time(), 0.0, name, group])

            def on_end(self, ev):
                start, nested, name, group = log._open.pop()
                took = time.process_time() - start
                if log._open:
                    log._open[-1][1] += took
                signature = ", ".join(str(a) for a in ev.data["args"])
                log.compiles.append(
                    Compile(name, signature, took - nested, took, len(log._open), group)
                )

        return event.install_listener("numba:compile", _Listener())

    @property
    def seconds(self) -> float:
        """CPU time of all the compiles (s)."""
        return sum(c.own_seconds for c in self.compiles)

    def by_group(self) -> dict[str, float]:
        """CPU time of the compiles (s) by kernel group."""
        out: dict[str, float] = {}
        for c in self.compiles:
            out[c.group] = out.get(c.group, 0.0) + c.own_seconds
        return out

    def by_kernel(self) -> list[tuple[str, int, float]]:
        """``(kernel, compiles, CPU s)`` for each kernel of the package (numba's own
        helpers summed under their module), the longest first."""
        rows: dict[str, list] = {}
        for c in self.compiles:
            key = c.kernel if c.kernel.startswith("synth.") else c.kernel.split(".<locals>")[0]
            row = rows.setdefault(key, [0, 0.0])
            row[0] += 1
            row[1] += c.own_seconds
        return sorted(((k, n, s) for k, (n, s) in rows.items()), key=lambda r: -r[2])
