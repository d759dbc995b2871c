"""Where a bank's rows render: in this process, in a pool of long-lived workers that die
with their parent, or on a Dask cluster; the parent alone writes the manifest."""

from __future__ import annotations

import contextlib
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
_WORKER_THREADS = dict.fromkeys(
    ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"), "1"
)

#: A pool worker's spec and folder; the bank folder's lock file this process holds (a forked
#: worker closes its copy).
_WORKER_SPEC: BankSpec | None = None
_WORKER_DIR: str | None = None
_HELD_LOCK = None

#: Period of a worker's watch on its parent, s (the fallback of PR_SET_PDEATHSIG), and
#: prctl(2)'s option: the signal this process gets when its parent dies (linux/prctl.h).
PARENT_WATCH_PERIOD = 0.5
PR_SET_PDEATHSIG = 1


def hold_lock(lock) -> None:
    global _HELD_LOCK
    _HELD_LOCK = lock


def _die_with_parent(parent: int) -> None:
    """End this worker when ``parent`` ends (killed with -9 too): on Linux the kernel's
    ``prctl(PR_SET_PDEATHSIG)``, everywhere a daemon thread watching the parent."""
    import signal
    import threading

    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):  # no prctl: the watch below does it
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)

    def watch():
        while os.getppid() == parent:
            time.sleep(PARENT_WATCH_PERIOD)
        os.kill(os.getpid(), signal.SIGKILL)

    threading.Thread(target=watch, name="synth-bank-parent-watch", daemon=True).start()


def _pool_init(spec: BankSpec, out_dir: str, parent: int) -> None:
    """A worker's start: it dies with its parent, drops its copy of the folder's lock, and
    SIGTERM takes its default action (the pool stops workers with it; the command line's
    handler would raise inside a library callback, where it is swallowed)."""
    import signal

    global _WORKER_SPEC, _WORKER_DIR
    _die_with_parent(parent)
    if _HELD_LOCK is not None:  # forked: closing the copy leaves the parent's lock held
        _HELD_LOCK.close()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _WORKER_SPEC, _WORKER_DIR = spec, out_dir
    warm(spec)


def _pool_task(item: PlanItem) -> RowResult:
    return render_item(_WORKER_SPEC, item, _WORKER_DIR)


class Serial:
    """The rows rendered one by one in this process."""

    def __init__(self, spec, out_dir):
        self.spec, self.out_dir = spec, out_dir
        warm(spec)

    def results(self, items):
        return (render_item(self.spec, item, self.out_dir) for item in items)

    def close(self):
        pass


def _start_method() -> str:
    """``fork`` on Linux with no other thread (that could hold a lock across the fork): the
    workers start with this process's warm engine. Else ``spawn``."""
    import threading

    if sys.platform.startswith("linux") and threading.active_count() == 1:
        return "fork"
    return "spawn"


class Pool:
    """Long-lived worker processes, one thread of numerics each, ready once all are warm. A
    worker that dies stops the run with a :class:`BankRunError` (a rerun resumes)."""

    def __init__(self, spec, out_dir, jobs):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        method = _start_method()
        if method == "fork":
            warm(spec)
        ctx = multiprocessing.get_context(method)
        unset = [k for k in _WORKER_THREADS if k not in os.environ]
        os.environ.update({k: _WORKER_THREADS[k] for k in unset})
        try:
            init = (spec, out_dir, os.getpid())
            self.executor = ProcessPoolExecutor(
                jobs, mp_context=ctx, initializer=_pool_init, initargs=init
            )
            for ready in [self.executor.submit(os.getpid) for _ in range(jobs)]:  # all warm
                self._result(ready)
        finally:
            for k in unset:
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
    """A Dask client, and whether the run made it (and closes it)."""

    client: object
    own: bool

    def close(self) -> None:
        if self.own:
            self.client.close()


def connect(scheduler) -> Connection:
    """A client of ``scheduler`` (an address or a Client), within :data:`CONNECT_TIMEOUT` s."""
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
        self.client, self.spec, self.out_dir = client, spec, out_dir
        client.run(warm, spec)

    def results(self, items):
        """Each row's result as it finishes, released at once: a lost worker's finished
        tasks are then not recomputed."""
        from dask.distributed import as_completed

        spec = self.client.scatter(self.spec, broadcast=True)
        submit = self.client.submit
        self._futures = [submit(render_item, spec, i, self.out_dir, pure=False) for i in items]
        for fut in as_completed(self._futures):
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 - a task the cluster lost (KilledWorker ...)
                res = RowResult(None, f"the Dask cluster lost a row ({type(exc).__name__}: {exc})")
            fut.release()
            yield res

    def close(self):
        for fut in getattr(self, "_futures", ()):
            fut.cancel()
