"""Where a bank's rows render: in this process, in a pool of long-lived worker processes
that die with their parent, or on a Dask cluster; each returns the rows'
:class:`~synth.bank.row.RowResult` to the parent, which alone writes the manifest
(:mod:`synth.bank.run`)."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass

from synth.bank.row import RowResult, render_item, warm
from synth.bank.spec import BankSpec, PlanItem
from synth.errors import SynthError


class BankRunError(SynthError):
    """A bank that cannot go on: its folder is in use, or a file cannot be written."""


#: Threads of the numerical libraries in each pool worker: the pool is the parallelism.
_WORKER_THREADS = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}

_WORKER_SPEC: BankSpec | None = None
_WORKER_DIR: str | None = None


#: The bank folder's lock file held by this process (:func:`hold_lock`); a forked worker
#: closes its copy so that only the parent holds the lock.
_HELD_LOCK = None


def hold_lock(lock) -> None:
    """Remember the bank folder's lock file this process holds (an open file; None once
    released), for the workers it forks to close their copies."""
    global _HELD_LOCK
    _HELD_LOCK = lock


#: Period of a worker's watch on its parent, s (the fallback of PR_SET_PDEATHSIG).
PARENT_WATCH_PERIOD = 0.5


def _die_with_parent(parent: int) -> None:
    """Make this worker end when the process ``parent`` does (killed with -9 too), so a
    killed bank leaves no worker behind (nor its hold on the folder's lock): on Linux the
    kernel sends SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``, prctl(2));
    everywhere a daemon thread checks every :data:`PARENT_WATCH_PERIOD` s that the
    parent is still this process's parent, and kills this process otherwise."""
    import signal
    import threading

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            pr_set_pdeathsig = 1
            libc.prctl(pr_set_pdeathsig, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):  # no prctl: the watch below does it
            pass
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)

    def watch():
        while os.getppid() == parent:
            time.sleep(PARENT_WATCH_PERIOD)
        os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=watch, name="synth-bank-parent-watch", daemon=True).start()


def _pool_init(spec: BankSpec, out_dir: str, parent: int) -> None:
    """A worker's start: it dies with its parent (:func:`_die_with_parent`), drops its
    copy of the folder's lock, and SIGTERM takes its default action (the pool stops its
    workers with SIGTERM when one dies; a forked worker would otherwise inherit the
    command line's handler, which raises inside whatever library callback is running,
    where it is swallowed and printed). A temporary left by a stopped worker is removed
    by the next write in that folder (:func:`synth.store.atomic.remove_stale_temporaries`)."""
    import signal

    global _WORKER_SPEC, _WORKER_DIR
    _die_with_parent(parent)
    if _HELD_LOCK is not None:  # forked: closing the copy leaves the parent's lock held
        _HELD_LOCK.close()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _WORKER_SPEC, _WORKER_DIR = spec, out_dir
    warm(spec)


def _pool_ready() -> int:
    """A no-op task: its result tells that a worker has started and warmed the engine."""
    return os.getpid()


def _pool_task(item: PlanItem) -> RowResult:
    return render_item(_WORKER_SPEC, item, _WORKER_DIR)


class Serial:
    def __init__(self, spec, out_dir):
        self.spec, self.out_dir = spec, out_dir
        warm(spec)

    def results(self, items):
        for item in items:
            yield render_item(self.spec, item, self.out_dir)

    def close(self):
        pass


def _start_method() -> str:
    """``fork`` where it is safe and available (Linux, no other thread in this process
    that could hold a lock across the fork): the workers then start with the engine this
    process has imported and warmed. Else ``spawn``: each worker imports and warms it."""
    import threading

    if sys.platform.startswith("linux") and threading.active_count() == 1:
        return "fork"
    return "spawn"


class Pool:
    """Long-lived worker processes, one thread of numerics each; returns once every
    worker has warmed the engine. A worker that dies (killed, crashed) stops the run with
    a :class:`BankRunError` instead of waiting for its row forever: the rows done are in
    the manifest, and running the same bank again resumes."""

    def __init__(self, spec, out_dir, jobs):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        method = _start_method()
        if method == "fork":
            warm(spec)
        ctx = multiprocessing.get_context(method)
        saved = {k: os.environ.get(k) for k in _WORKER_THREADS}
        os.environ.update({k: v for k, v in _WORKER_THREADS.items() if saved[k] is None})
        try:
            self.executor = ProcessPoolExecutor(
                jobs,
                mp_context=ctx,
                initializer=_pool_init,
                initargs=(spec, out_dir, os.getpid()),
            )
            # one no-op per worker: each submit starts a worker, each result is a warm one
            for ready in [self.executor.submit(_pool_ready) for _ in range(jobs)]:
                self._result(ready)
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)

    @staticmethod
    def _result(future):
        from concurrent.futures.process import BrokenProcessPool

        try:
            return future.result()
        except BrokenProcessPool:
            raise BankRunError(
                "a worker process died (killed or crashed): the sounds finished are kept in "
                "the manifest; run the same bank again to resume"
            ) from None

    def results(self, items):
        from concurrent.futures import as_completed

        futures = [self.executor.submit(_pool_task, item) for item in items]
        for future in as_completed(futures):
            yield self._result(future)

    def close(self):
        self.executor.shutdown(wait=True, cancel_futures=True)


#: Time to reach a Dask scheduler before the bank is refused, s.
CONNECT_TIMEOUT = 5.0


@dataclass
class Connection:
    """A Dask client for the run, and whether the run made it (and so closes it)."""

    client: object
    own: bool

    def close(self) -> None:
        if self.own:
            self.client.close()


def connect(scheduler) -> Connection:
    """A client of the Dask scheduler ``scheduler`` (an address or a Client), reached
    within :data:`CONNECT_TIMEOUT` s, before the bank's folder is touched."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise BankRunError(
            "scheduler= needs the optional package dask.distributed: "
            "pip install 'impact-synth[dask]'"
        ) from None
    if isinstance(scheduler, Client):
        return Connection(scheduler, own=False)
    try:
        return Connection(Client(scheduler, timeout=CONNECT_TIMEOUT), own=True)
    except (OSError, ValueError, TypeError, TimeoutError) as exc:
        raise BankRunError(
            f"scheduler={scheduler!r}: cannot connect within {CONNECT_TIMEOUT:g} s ({exc}); "
            f"nothing was written"
        ) from None


class Dask:
    """The same task function on a Dask cluster, through ``client``."""

    def __init__(self, spec, out_dir, client):
        self.client = client
        self.spec, self.out_dir = spec, out_dir
        self.client.run(warm, spec)

    def results(self, items):
        """Each row's result as it finishes. A result read is released at once: the
        scheduler then has no reason to recompute a finished task when the worker that
        holds it is lost (only the rows still running or queued there are redone)."""
        from dask.distributed import as_completed

        spec = self.client.scatter(self.spec, broadcast=True)
        futures = [
            self.client.submit(render_item, spec, item, self.out_dir, pure=False) for item in items
        ]
        self._futures = futures
        for fut in as_completed(futures):
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 - a task the cluster lost (KilledWorker ...)
                res = RowResult(
                    None,
                    fatal=f"the Dask cluster lost a row ({type(exc).__name__}: {exc})",
                )
            fut.release()
            yield res

    def close(self):
        for fut in getattr(self, "_futures", ()):
            fut.cancel()
