"""Running a bank: the sounds of a plan rendered by long-lived workers, each file written
atomically, each finished row appended to the manifest; a rerun resumes.

Workers: a pool of ``jobs`` processes (default: the machine's cores) that import the
engine and render the base scene once (loading the compiled kernels and filling the
plate-mode and radiation caches), then render rows until the plan is done; on Linux they
are forked from this process once it has warmed the engine itself (when no other thread
runs here), elsewhere spawned. ``jobs=1`` renders in this process. With ``scheduler``,
the same task function runs on a Dask
cluster (``dask.distributed.Client(scheduler)``; the optional extra ``dask``), whose
workers must see the bank's folder.

The parent alone writes the manifest (see :mod:`synth.bank.manifest`). A row whose scene
cannot be rendered is recorded ``failed`` with its error and the others go on; a file that
cannot be written (a full disk) stops the bank cleanly: the finished rows and files stay,
and running the bank again completes it.
"""

from __future__ import annotations

import io
import math
import os
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.bank import manifest as mf
from synth.bank import spec as bank_spec
from synth.bank.spec import RESTITUTION_SCALE, BankSpec, BankSpecError, PlanItem
from synth.errors import SynthError
from synth.io.reproducible import reproducible

#: Threads of the numerical libraries in each pool worker: the pool is the parallelism.
_WORKER_THREADS = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}

#: Renders timed by a dry run to estimate the bank's time (rows spread over the plan).
ESTIMATE_RENDERS = 5


class BankRunError(SynthError):
    """A bank that cannot go on: its folder is in use, or a file cannot be written."""


@dataclass
class RowResult:
    """What a worker returns for a row: the manifest ``row``, or ``fatal`` (a file that
    could not be written; the row is not recorded), and the worker's peak memory."""

    row: dict | None
    fatal: str | None = None
    max_rss: int = 0


@dataclass
class BankResult:
    """The outcome of :func:`run`.

    ``planned`` rows in the plan; ``done`` rendered now (ok), ``skipped`` found complete,
    ``failed`` recorded with their error (``failures``: index and error), ``renamed``
    of the complete rows moved to a new name (the preset renamed, a label or the name
    template edited), ``orphans`` the audio files in the folder that are in neither
    the manifest nor the plan (:func:`synth.bank.manifest.orphans`; removed if
    ``pruned``), ``stopped`` the
    reason the bank stopped early (None if it ran through), ``elapsed`` s of the run,
    ``startup`` s of it spent starting and warming the workers, ``peak_worker_rss`` the
    largest resident memory of a worker, bytes; for a dry run, ``estimate`` the time the
    bank would take, s, and ``planned_rows`` the manifest rows it would render.
    """

    out_dir: Path
    planned: int
    done: int = 0
    skipped: int = 0
    failed: int = 0
    failures: list = field(default_factory=list)
    renamed: int = 0
    orphans: list = field(default_factory=list)
    pruned: bool = False
    stopped: str | None = None
    elapsed: float = 0.0
    startup: float = 0.0
    peak_worker_rss: int = 0
    estimate: float | None = None
    planned_rows: list = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Sounds rendered per second of the run."""
        return self.done / self.elapsed if self.elapsed > 0 else 0.0

    @property
    def render_rate(self) -> float:
        """Sounds rendered per second once the workers were warm."""
        busy = self.elapsed - self.startup
        return self.done / busy if busy > 0 else 0.0

    @property
    def ok(self) -> bool:
        return self.failed == 0 and self.stopped is None

    def summary(self) -> str:
        """The summary printed at the end of ``synth bank``."""
        if self.estimate is not None:
            text = (
                f"{self.out_dir}: dry run, nothing written: {len(self.planned_rows)} of "
                f"{self.planned} sounds to render ({self.skipped} already done); estimated "
                f"{self.estimate:.1f} s to render them"
            )
            if self.orphans:
                text += "\n  " + mf.orphans_note(self.orphans, removed=False)
            return text
        text = (
            f"{self.out_dir}: {self.done} done, {self.skipped} skipped, {self.failed} failed "
            f"of {self.planned} in {self.elapsed:.1f} s ({self.rate:.1f} sounds/s; "
            f"{self.startup:.1f} s of worker start-up, then {self.render_rate:.1f} sounds/s)"
        )
        if self.renamed:
            text += f"\n  {self.renamed} files renamed (same sounds, new names)"
        if self.orphans:
            text += "\n  " + mf.orphans_note(self.orphans, removed=self.pruned)
        for index, error in self.failures[:5]:
            text += f"\n  row {index} failed: {error}"
        if len(self.failures) > 5:
            text += f"\n  ... {len(self.failures) - 5} more failures in the manifest"
        if self.stopped:
            text += f"\nstopped: {self.stopped}"
        return text


# ------------------------------------------------------------------------ one row


def _max_rss() -> int:
    """Peak resident memory of this process, bytes."""
    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(r if sys.platform == "darwin" else r * 1024)


def _loudness(audio: np.ndarray, samplerate: int) -> float | None:
    """Integrated loudness (ITU-R BS.1770, LUFS) of ``audio`` zero-padded to one 400 ms
    gating block, or None without pyloudnorm or below the -70 LUFS gate."""
    try:
        import pyloudnorm
    except ImportError:
        return None
    from synth.io.audio import LOUDNESS_BLOCK

    x = np.asarray(audio, dtype=np.float64)
    need = math.ceil(LOUDNESS_BLOCK * samplerate)
    if x.shape[0] < need:
        x = np.pad(x, [(0, need - x.shape[0])] + [(0, 0)] * (x.ndim - 1))
    value = float(pyloudnorm.Meter(samplerate, block_size=LOUDNESS_BLOCK).integrated_loudness(x))
    return round(value, 6) if math.isfinite(value) else None


#: What to change when a row's PCM audio would clip.
CLIP_ADVICE = "use render.normalize = 'peak', or format = 'wav' with render.subtype = 'FLOAT'"


def encode(
    audio: np.ndarray, samplerate: int, fmt: str, subtype: str, identity: str, advice: str
) -> bytes:
    """The bytes of a bank's file: ``audio`` (``samplerate`` Hz) in format ``fmt`` (a key
    of :data:`synth.bank.spec.FORMATS`) and ``subtype``, a function of the samples and
    ``identity`` (the file's name in the bank) alone
    (:func:`synth.io.reproducible.reproducible`: an Ogg stream's serial, a float WAV's
    PEAK timestamp). PCM that would clip is refused, naming the file, its peak (dBFS)
    and ``advice`` (what to change); the files of a render and of the bank-gain pass
    are made here alike."""
    import soundfile

    from synth.io.audio import FLOAT_SUBTYPES

    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    if subtype not in FLOAT_SUBTYPES and peak > 1.0:
        raise BankSpecError(
            f"{identity!r} peaks at {20 * math.log10(peak):+.2f} dBFS, above full scale, "
            f"and subtype {subtype!r} would clip it: {advice}"
        )
    buf = io.BytesIO()
    soundfile.write(buf, audio, samplerate, subtype=subtype, format=bank_spec.FORMATS[fmt][1])
    return reproducible(buf.getvalue(), fmt, identity)


def _render(spec: BankSpec, item: PlanItem):
    """Render row ``item``: the Render, the file's bytes, and the row's figures."""
    from synth.io.presets import scene_from_dict
    from synth.sound.render import render
    from synth.stimuli.sequences import scaled_sequence

    scene, options = scene_from_dict(bank_spec.scene_data(spec, item.values), f"row {item.index}")
    subtype = str(options.pop("subtype", spec.subtype)).upper()
    k = item.values.get(RESTITUTION_SCALE)
    sequence = (
        None
        if k is None
        else scaled_sequence(scene, k, max_duration=options.get("max_duration", 30.0))
    )
    rendered = render(scene, sequence=sequence, **options)
    audio, length_reason = trim_tail(rendered.audio, rendered.samplerate, spec.trim)
    data = encode(audio, rendered.samplerate, spec.format, subtype, item.file, CLIP_ADVICE)
    peak = float(np.max(np.abs(audio))) if audio.size else 0.0
    first = rendered.impacts[0] if len(rendered.impacts) else None
    figures = {
        "duration": audio.shape[0] / rendered.samplerate,
        "stop_reason": rendered.impacts.stop_reason,
        "length_reason": length_reason,
        "audible_duration": _audible_duration(audio, rendered.samplerate),
        "ticks": len(rendered.impacts),
        "first_restitution": first.restitution if first is not None else None,
        "first_speed": first.speed if first is not None else None,
        "first_contact_time": first.result.contact_time if first is not None else None,
        "first_peak_force": first.result.peak_force if first is not None else None,
        "peak_dbfs": round(20 * math.log10(peak), 6) if peak > 0 else None,
        "true_peak_dbtp": _true_peak_db(audio),
        "loudness_lufs": _loudness(audio, rendered.samplerate),
        "spectral_centroid": _spectral_centroid(audio, rendered.samplerate),
        "scene": bank_spec.scene_data(spec, item.values),
    }
    return rendered, data, figures


#: Level below the peak that ends the audible part of a sound (the manifest's
#: ``audible_duration``), dB.
AUDIBLE_BELOW_DB = -60.0


def _last_above(audio: np.ndarray, below_db: float) -> int:
    """Index after the last sample whose magnitude reaches ``below_db`` dB re the peak
    (0 for silence)."""
    mag = np.abs(audio) if audio.ndim == 1 else np.max(np.abs(audio), axis=1)
    peak = float(mag.max()) if mag.size else 0.0
    if not peak > 0:
        return 0
    above = np.flatnonzero(mag >= peak * 10.0 ** (below_db / 20.0))
    return int(above[-1]) + 1


def _audible_duration(audio: np.ndarray, samplerate: int) -> float:
    """Time to the last sample within :data:`AUDIBLE_BELOW_DB` of the peak, s."""
    return _last_above(audio, AUDIBLE_BELOW_DB) / samplerate


def trim_tail(audio: np.ndarray, samplerate: int, trim: dict | None):
    """``audio`` cut after its last sample within ``trim["below_db"]`` dB of its peak
    (and at ``trim["max_length"]`` s), its last ``trim["fade"]`` s faded out with a
    raised cosine; with the reason: "tail-cut", "max-length", or "whole" (nothing cut,
    also without ``trim``)."""
    if trim is None:
        return audio, "whole"
    n = audio.shape[0]
    end, reason = min(n, _last_above(audio, trim["below_db"])), "tail-cut"
    if trim["max_length"] is not None and end > round(trim["max_length"] * samplerate):
        end, reason = round(trim["max_length"] * samplerate), "max-length"
    if end >= n:
        return audio, "whole"
    out = np.array(audio[:end], dtype=np.float64)
    k = min(end, round(trim["fade"] * samplerate))
    if k > 0:
        ramp = 0.5 * (1.0 + np.cos(np.pi * (np.arange(1, k + 1) / k)))
        out[end - k :] *= ramp if out.ndim == 1 else ramp[:, None]
    return out, reason


#: Oversampling of the true-peak estimate (ITU-R BS.1770-4, Annex 2: 4 at 48 kHz).
TRUE_PEAK_OVERSAMPLING = 4


def _true_peak_db(audio: np.ndarray) -> float | None:
    """True peak, dBTP: the largest magnitude of ``audio`` upsampled
    :data:`TRUE_PEAK_OVERSAMPLING` times (polyphase windowed-sinc interpolation,
    scipy.signal.resample_poly), as ITU-R BS.1770-4 Annex 2 estimates it."""
    from scipy.signal import resample_poly

    x = np.asarray(audio, dtype=np.float64)
    if not x.size:
        return None
    peak = float(np.max(np.abs(resample_poly(x, TRUE_PEAK_OVERSAMPLING, 1, axis=0))))
    peak = max(peak, float(np.max(np.abs(x))))
    return round(20 * math.log10(peak), 6) if peak > 0 else None


def _spectral_centroid(audio: np.ndarray, samplerate: int) -> float | None:
    """Spectral centroid of the whole sound, Hz: the mean frequency of its power
    spectrum, sum f |X(f)|^2 / sum |X(f)|^2 (channels summed; the sound zero-padded to
    a length the FFT factors well, scipy.fft.next_fast_len, which samples the same
    spectrum more finely)."""
    from scipy import fft

    x = np.asarray(audio, dtype=np.float64)
    if x.ndim > 1:
        x = x.sum(axis=1)
    n = fft.next_fast_len(max(x.size, 1), real=True)
    power = np.abs(fft.rfft(x, n)) ** 2
    total = float(power.sum())
    if not total > 0:
        return None
    f = fft.rfftfreq(n, 1.0 / samplerate)
    return round(float(np.dot(f, power) / total), 6)


def _base_row(spec: BankSpec, item: PlanItem, status: str) -> dict:
    row = {"index": item.index, "file": item.file, "seed": spec.seed, "status": status}
    for k, v in item.values.items():
        row[k] = list(v) if isinstance(v, tuple) else v
    return _described(spec, item, row)


def _described(spec: BankSpec, item: PlanItem, row: dict) -> dict:
    """``row`` with the columns that describe its sound without changing it, as the
    spec gives them now: its values' labels and the spec's tags."""
    return dict(row, labels=bank_spec.row_labels(spec, item.values), tags=spec.tags)


def render_item(spec: BankSpec, item: PlanItem, out_dir: str) -> RowResult:
    """Render row ``item`` of ``spec`` and publish its file in ``out_dir`` once
    (:func:`synth.bank.manifest.write_once`: atomically, never over a file already
    there; the run removes the stale files of the rows it renders before it starts):
    the task function of every worker (pool or Dask). A scene that fails gives a
    ``failed`` row with its error; a file that cannot be written gives ``fatal``."""
    try:
        _, data, figures = _render(spec, item)
    except Exception as exc:  # noqa: BLE001 - any error of one scene is recorded, the rest go on
        row = _base_row(spec, item, "failed")
        row["error"] = f"{type(exc).__name__}: {exc}"
        return RowResult(row, max_rss=_max_rss())
    target = Path(out_dir) / item.file
    try:
        target.parent.mkdir(parents=True, exist_ok=True)  # a subfolder of the template
        if not mf.write_once(target, data):
            # A file already there was published by another attempt of this row in this
            # run (a Dask task recomputed after its worker was lost): it is kept, never
            # rewritten, and the row records its bytes.
            data = target.read_bytes()
    except OSError as exc:
        return RowResult(None, fatal=f"cannot write {item.file!r}: {exc}", max_rss=_max_rss())
    row = _base_row(spec, item, "ok")
    row.update(figures, **mf.file_hashes(data))
    return RowResult(row, max_rss=_max_rss())


def warm(spec: BankSpec) -> None:
    """Load the engine in this process: render the base scene once (compiled kernels,
    plate modes and radiation gains into the caches). Errors are left to the rows."""
    try:
        _render(spec, PlanItem(-1, "warm", {}))
    except Exception:  # noqa: BLE001, S110 - a base scene that fails is reported by its rows
        pass


# ------------------------------------------------------------------------ executors

_WORKER_SPEC: BankSpec | None = None
_WORKER_DIR: str | None = None


#: The bank folder's lock file held by this process (see :func:`_lock`); a forked worker
#: closes its copy so that only the parent holds the lock.
_HELD_LOCK = None

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
    by the next write in that folder (:func:`synth.io.atomic.remove_stale_temporaries`)."""
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


class _Serial:
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


class _Pool:
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
class _Connection:
    """A Dask client for the run, and whether the run made it (and so closes it)."""

    client: object
    own: bool

    def close(self) -> None:
        if self.own:
            self.client.close()


def _connect(scheduler) -> _Connection:
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
        return _Connection(scheduler, own=False)
    try:
        return _Connection(Client(scheduler, timeout=CONNECT_TIMEOUT), own=True)
    except (OSError, ValueError, TypeError, TimeoutError) as exc:
        raise BankRunError(
            f"scheduler={scheduler!r}: cannot connect within {CONNECT_TIMEOUT:g} s ({exc}); "
            f"nothing was written"
        ) from None


class _Dask:
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


# ------------------------------------------------------------------------ the run


def _lock(out_dir: Path):
    """Hold the folder's lock file for the run (another run into it is refused). The
    lock is the ``flock`` on the open file, so a run that was killed holds nothing; the
    file is removed by :func:`_unlock`. A lock taken on a file that was removed meanwhile
    (by the run that held it) is taken again on the new file."""
    try:
        import fcntl
    except ImportError:  # no advisory locks on this platform
        return None
    path = out_dir / mf.LOCK
    for _ in range(100):
        fh = open(path, "a")  # noqa: SIM115 - held for the run, closed by _unlock()
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            raise BankRunError(
                f"out_dir={str(out_dir)!r} is in use by another synth bank"
            ) from None
        try:
            if os.stat(path).st_ino == os.fstat(fh.fileno()).st_ino:
                return fh
        except FileNotFoundError:
            pass
        fh.close()
    raise BankRunError(f"out_dir={str(out_dir)!r}: its lock file {mf.LOCK} keeps changing")


def _unlock(out_dir: Path, fh) -> None:
    """Remove the lock file (still holding its lock, so no other run holds it) and
    release it: a finished bank's folder holds only its files and manifests."""
    if fh is None:
        return
    try:
        (out_dir / mf.LOCK).unlink(missing_ok=True)
    except OSError:
        pass
    fh.close()


def _as_spec(spec) -> BankSpec:
    if isinstance(spec, BankSpec):
        return spec
    if isinstance(spec, dict):
        return bank_spec.from_dict(spec)
    if isinstance(spec, (str, os.PathLike)):
        return bank_spec.load(spec)
    raise BankSpecError(f"spec={spec!r} must be a spec file, a dict or a BankSpec")


def _grows(stored: dict, new: dict) -> bool:
    """True if ``new`` is the stored spec with a larger ``count`` (both in the compared
    form, :func:`synth.bank.spec.compared_form`): rows are drawn per
    index (:func:`synth.bank.spec.variations`), so the rows done stay and the new ones
    are added."""
    old_count, new_count = stored.get("count"), new.get("count")
    return (
        isinstance(old_count, int)
        and isinstance(new_count, int)
        and new_count > old_count
        and bank_spec.differences(stored, new) == ["count"]
    )


def _refuse_other_spec(out_dir: Path, stored: dict, new: dict) -> None:
    diff = bank_spec.differences(stored, new)
    raise BankSpecError(
        f"out_dir={str(out_dir)!r} holds a bank of another spec (differing keys: "
        f"{', '.join(diff)}): use the same spec to resume, another folder, or "
        f"--force to start over"
    )


def _stored(out_dir: Path) -> dict | None:
    """The part of the spec stored in the folder that makes its sounds (None if none):
    :func:`synth.bank.spec.compared_form`, in which a folder of an earlier version (which
    stored the spec as written) compares as the same spec, and a renamed preset, an
    edited label, name template or tag do not count."""
    stored = mf.read_spec(out_dir) if out_dir.is_dir() else None
    return None if stored is None else bank_spec.compared_form(stored)


def _of_another_spec(stored: dict | None, new: dict) -> bool:
    """True if the folder's stored spec makes other sounds than ``new`` (both in the
    compared form) and ``new`` does not just grow it."""
    return stored is not None and stored != new and not _grows(stored, new)


def _check_stored(out_dir: Path, spec: BankSpec, force: bool) -> None:
    """Refuse a folder made by another spec (naming the keys that differ), or with
    ``force`` delete its files and manifest to start over."""
    stored, new = _stored(out_dir), bank_spec.compared_form(spec.stored_form())
    if _of_another_spec(stored, new):
        if not force:
            _refuse_other_spec(out_dir, stored, new)
        for row in mf.read_rows(out_dir):
            f = out_dir / str(row.get("file", ""))
            if _inside(out_dir, f) and f.is_file():
                f.unlink()
        for name in (mf.JSONL, mf.CSV):
            (out_dir / name).unlink(missing_ok=True)
    mf.write_spec(out_dir, spec.stored_form())


def _verified(out_dir: Path, rows: list[dict], plan: dict) -> list[dict]:
    """The rows that are complete: ``ok``, in the plan, and their file (in the folder,
    under the name recorded, which :func:`_renamed` moves to the plan's) present with
    the recorded SHA-256; their labels and tags as the spec gives them now
    (:func:`_described`). ``failed`` and ``planned`` rows are redone."""
    out = []
    for row in rows:
        item = plan.get(row.get("index"))
        if item is None or row.get("status") != "ok" or not isinstance(row.get("file"), str):
            continue
        path = out_dir / row["file"]
        if _inside(out_dir, path) and path.is_file() and mf.sha256_file(path) == row.get("sha256"):
            out.append(row)
    return out


def _renamed(out_dir: Path, spec: BankSpec, rows: list[dict], plan: dict) -> list[dict]:
    """``rows`` (complete, :func:`_verified`) with their files moved to the plan's names
    where these changed (a renamed preset, an edited label or name template: the sounds
    are the same), and their labels and tags as the spec gives them now. The files are
    first moved aside to temporaries (a new name may be another row's old one), then
    published under their new names as the bytes a render would give there
    (:func:`synth.io.reproducible.reproducible`: an Ogg stream's serial follows the name).
    A run killed meanwhile leaves rows whose recorded file is missing: they are redone."""
    moves = {r["index"]: (r["file"], plan[r["index"]].file) for r in rows}
    moved = move_files(out_dir, spec.format, moves)
    out = []
    for row in rows:
        item = plan[row["index"]]
        if row["index"] in moved:
            row = dict(row, file=item.file, **mf.file_hashes(moved[row["index"]]))
        out.append(_described(spec, item, row))
    return out


def move_files(out_dir: Path, fmt: str, moves: dict) -> dict:
    """Move the files ``moves`` (index: (old name, new name), relative to ``out_dir``;
    those whose names are equal stay) to their new names, each published as the bytes a
    render would give under that name (:func:`synth.io.reproducible.reproducible`: an Ogg
    stream's serial follows the name). The files are first moved aside to temporaries (a
    new name may be another file's old one; a run killed meanwhile leaves only
    temporaries, cleaned up by the next). Returns index: the moved file's bytes."""
    from synth.io.atomic import temporary_name

    aside = {}
    for index, (old_name, new_name) in moves.items():
        if old_name == new_name:
            continue
        old = out_dir / old_name
        aside[index] = out_dir / temporary_name(old.suffix)
        os.replace(old, aside[index])
        _remove_empty_folders(out_dir, old.parent)
    moved = {}
    for index, temporary in aside.items():
        new_name = moves[index][1]
        data = reproducible(temporary.read_bytes(), fmt, new_name)
        target = out_dir / new_name
        target.parent.mkdir(parents=True, exist_ok=True)
        mf.write_atomic(target, data)
        temporary.unlink()
        moved[index] = data
    return moved


def _remove_empty_folders(out_dir: Path, folder: Path) -> None:
    """Remove ``folder`` and its parents up to ``out_dir`` (excluded) while empty (a
    subfolder of an earlier name template)."""
    while _inside(out_dir, folder):
        try:
            folder.rmdir()
        except OSError:  # not empty
            return
        folder = folder.parent


def _inside(folder: Path, path: Path) -> bool:
    """True if ``path`` lies in ``folder`` or one of its subfolders (a manifest's file
    name is trusted no further than that)."""
    try:
        return (
            path.resolve().is_relative_to(folder.resolve()) and path.resolve() != folder.resolve()
        )
    except OSError:
        return False


def _remove_stale_files(out_dir: Path, todo) -> None:
    """Delete the files of the rows about to be rendered (left by a run that was killed
    before recording them, or damaged since): a row's file is then published once, by
    the first attempt that finishes (:func:`render_item`)."""
    for item in todo:
        (out_dir / item.file).unlink(missing_ok=True)


def _final_check(out_dir: Path, rows: list[dict], result: BankResult, recorded: set) -> list[dict]:
    """The rows whose record holds: every ``ok`` row's file hashed again against its
    recorded SHA-256. A row that does not match is dropped from the manifest (the next
    run redoes it) and the bank is not reported complete."""
    kept, bad = [], []
    for row in rows:
        path = out_dir / str(row.get("file", ""))
        if row.get("status") == "ok" and not (
            path.is_file() and mf.sha256_file(path) == row.get("sha256")
        ):
            bad.append(row["index"])
            continue
        kept.append(row)
    if bad:
        now = sum(1 for i in bad if i in recorded)  # rendered in this run, else skipped
        result.done -= now
        result.skipped -= len(bad) - now
        result.stopped = result.stopped or (
            f"{len(bad)} file(s) do not match their recorded SHA-256 (rows "
            f"{', '.join(map(str, bad[:10]))}{' ...' if len(bad) > 10 else ''}): they are left "
            f"out of the manifest; run again to redo them"
        )
    return kept


def _estimate(spec: BankSpec, items, jobs: int) -> float:
    """Time to render ``items`` on ``jobs`` workers, from a few renders timed here."""
    if not items:
        return 0.0
    warm(spec)
    # rows spread over the plan (its first rows may all be alike: one grid corner)
    picks = np.unique(np.linspace(0, len(items) - 1, min(ESTIMATE_RENDERS, len(items))).round())
    sample = [items[int(i)] for i in picks]
    t0 = time.perf_counter()
    for item in sample:
        try:
            _render(spec, item)
        except Exception:  # noqa: BLE001, S110 - a failing row costs about as much as a render
            pass
    per = (time.perf_counter() - t0) / len(sample)
    return per * len(items) / max(1, jobs)


def _progress(total: int):
    if not sys.stderr.isatty():
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, file=sys.stderr, unit="sound")


def _executor(spec, out_dir: Path, jobs: int, connection):
    if connection is not None:
        return _Dask(spec, str(out_dir), connection.client)
    if jobs == 1:
        return _Serial(spec, str(out_dir))
    return _Pool(spec, str(out_dir), jobs)


def _jobs(jobs) -> int:
    if jobs is None:
        return os.cpu_count() or 1
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise BankSpecError(f"jobs={jobs!r} must be an integer >= 1 (worker processes)")
    return jobs


def run(
    spec,
    out_dir,
    *,
    jobs: int | None = None,
    scheduler=None,
    dry_run: bool = False,
    force: bool = False,
    redo=None,
    prune: bool = False,
) -> BankResult:
    """Render the bank ``spec`` (a spec file, a dict, or a :class:`BankSpec`) into the
    folder ``out_dir`` (created if needed), resuming what an earlier run left.

    Parameters
    ----------
    jobs : int >= 1, optional
        Worker processes (default: ``os.cpu_count()``); 1 renders in this process.
    scheduler : str or dask.distributed.Client, optional
        A Dask scheduler's address (``"tcp://host:8786"``) or a client: the rows run on
        that cluster instead of the pool.
    dry_run : bool
        Change nothing (no folder, file, manifest or lock written or deleted, also with
        ``force``): the rows that would be rendered (``result.planned_rows``) and an
        estimate of the time from a few renders.
    force : bool
        Start over in a folder made by another spec (its files and manifest deleted).
    redo : str or set of int, optional
        Rows to render again although complete (``"17,40-45"``): their files are
        replaced.
    prune : bool
        Delete the audio files in the folder that are in neither the manifest nor the
        plan (``result.orphans``: left by an earlier name template, a run stopped before
        recording them, or put there by hand). Without it they are only reported; a dry
        run reports them and deletes nothing.

    Returns the :class:`BankResult`; the bank is complete when ``result.ok``. A bad spec
    raises :class:`~synth.bank.spec.BankSpecError` before any work (every row's scene is
    checked), a scheduler that cannot be reached a :class:`BankRunError` within
    :data:`CONNECT_TIMEOUT` s; neither writes anything.
    """
    spec = _as_spec(spec)
    n_jobs = _jobs(jobs)
    items = bank_spec.plan(spec)
    again = frozenset() if redo is None else bank_spec.parse_rows(redo, len(items))
    out = Path(out_dir)
    if not isinstance(prune, bool):
        raise BankSpecError(f"prune={prune!r} must be True or False")
    if dry_run:
        return _dry_run(spec, items, out, n_jobs if scheduler is None else 1, force, again)
    connection = _connect(scheduler) if scheduler is not None else None
    try:
        return _run_in(spec, items, out, n_jobs, connection, force, again, prune)
    finally:
        if connection is not None:
            connection.close()


def _run_in(
    spec, items, out: Path, n_jobs: int, connection, force: bool, again, prune: bool
) -> BankResult:
    """:func:`run` once the plan is checked and the cluster (if any) reached."""
    global _HELD_LOCK
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BankRunError(f"out_dir={str(out)!r} cannot be created: {exc}") from None
    try:
        lock = _lock(out)
        _HELD_LOCK = lock
        try:
            result = _run(spec, items, out, n_jobs, connection, force, again)
            _find_orphans(out, items, result, prune)
            return result
        finally:
            _HELD_LOCK = None
            _unlock(out, lock)
    except OSError as exc:  # the folder cannot be written (full, read-only) before rendering
        raise BankRunError(
            f"out_dir={str(out)!r}: {exc}; nothing finished was lost: run "
            f"again once it can be written"
        ) from None


def _dry_run(spec, items, out: Path, jobs: int, force: bool, again=frozenset()) -> BankResult:
    """What a run would do, without writing or deleting anything: the rows it would
    render (``result.planned_rows``, status ``planned``), the rows already complete, and
    an estimate of the time from a few renders done here. A folder of another spec is
    refused as a run refuses it; with ``force`` every row counts as to be rendered."""
    t0 = time.perf_counter()
    plan = {item.index: item for item in items}
    stored, new = _stored(out), bank_spec.compared_form(spec.stored_form())
    other = _of_another_spec(stored, new)
    if other and not force:
        _refuse_other_spec(out, stored, new)
    kept = [] if other or not out.is_dir() else _verified(out, mf.read_rows(out), plan)
    kept = [r for r in kept if r["index"] not in again]
    done_ids = {r["index"] for r in kept}
    todo = [item for item in items if item.index not in done_ids]
    result = BankResult(out, len(items), skipped=len(kept))
    result.planned_rows = [_base_row(spec, item, "planned") for item in todo]
    if out.is_dir() and not other:
        recorded = [r["file"] for r in _verified(out, mf.read_rows(out), plan)]
        result.orphans = mf.orphans(out, [item.file for item in items] + recorded)
    result.estimate = _estimate(spec, todo, jobs)
    result.elapsed = time.perf_counter() - t0
    return result


def _find_orphans(out: Path, items, result: BankResult, prune: bool) -> None:
    """``result.orphans``: the audio files in ``out`` in neither the manifest nor the
    plan; deleted if ``prune`` (``result.pruned``)."""
    recorded = [str(r.get("file")) for r in mf.read_rows(out)]
    result.orphans = mf.orphans(out, [item.file for item in items] + recorded)
    if prune and result.orphans:
        mf.remove_files(out, result.orphans)
        result.pruned = True


def _run(spec, items, out, n_jobs, connection, force, again=frozenset()) -> BankResult:
    _check_stored(out, spec, force)
    mf.clean_temporaries(out)
    plan = {item.index: item for item in items}
    book = mf.Manifest(out, mf.columns(spec.keys))
    verified = _verified(out, mf.read_rows(out), plan)
    kept = [r for r in _renamed(out, spec, verified, plan) if r["index"] not in again]
    result = BankResult(out, len(items), skipped=len(kept))
    result.renamed = sum(1 for r in verified if r["file"] != plan[r["index"]].file)
    done_ids = {r["index"] for r in kept}
    todo = [item for item in items if item.index not in done_ids]
    book.rewrite(kept)
    _remove_stale_files(out, todo)
    rows = list(kept)
    recorded = set()
    t_start = time.perf_counter()
    executor = _executor(spec, out, n_jobs, connection) if todo else None
    result.startup = time.perf_counter() - t_start
    bar = _progress(len(todo))
    try:
        for res in executor.results(todo) if executor else ():
            result.peak_worker_rss = max(result.peak_worker_rss, res.max_rss)
            if res.fatal is not None:
                result.stopped = f"{res.fatal}; the finished rows are kept: run again to resume"
                break
            if res.row["index"] in recorded:  # a second attempt of a row (a lost worker's)
                continue
            recorded.add(res.row["index"])
            try:
                book.append(res.row)
            except OSError as exc:
                result.stopped = (
                    f"cannot append to the manifest: {exc}; the finished rows "
                    f"are kept: run again to resume"
                )
                break
            rows.append(res.row)
            if res.row["status"] == "ok":
                result.done += 1
            else:
                result.failed += 1
                result.failures.append((res.row["index"], res.row.get("error")))
            if bar is not None:
                bar.update()
    finally:
        if executor is not None:
            executor.close()
        if bar is not None:
            bar.close()
        book.close()
    result.elapsed = time.perf_counter() - t_start
    rows = _final_check(out, rows, result, recorded)
    try:
        book.rewrite(rows)
    except OSError as exc:  # the appended rows stay; the next run rewrites them
        result.stopped = result.stopped or f"cannot rewrite the manifest: {exc}"
    return result
