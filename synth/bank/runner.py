"""Running a bank (docs/banks.md): the rows of a plan rendered by long-lived workers
(:mod:`.executors`), each file written atomically and its row appended to the manifest here;
a rerun resumes. A row that fails is recorded ``failed``; a file that cannot be written
stops the bank cleanly."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from synth.bank import manifest as mf
from synth.bank import spec as bank_spec
from synth.bank.executors import BankRunError, Dask, Pool, Serial, connect, hold_lock
from synth.bank.options import OPTIONS
from synth.bank.row import base_row, described
from synth.bank.spec import BankSpec, BankSpecError
from synth.bank.spec.model import spec_integer

#: Rows a dry run times, spread over the plan: at least this many and the square root of the
#: rows (the sampled mean's error falls as one over the root of the sample), a whole number
#: per worker, at least :data:`ESTIMATE_ROWS_PER_WORKER`.
ESTIMATE_RENDERS = 5
ESTIMATE_ROWS_PER_WORKER = 2


@dataclass(frozen=True)
class Estimate:
    """A dry run's estimate of a run of ``rows`` rows on ``jobs`` workers, s: ``before`` the
    plan and checks, ``startup`` of the workers, ``per_row`` wall time per row (timed on
    ``sampled`` rows in a scratch folder in ``scratch_in``), ``finish`` the final check."""

    rows: int
    jobs: int
    sampled: int
    before: float
    startup: float
    per_row: float
    finish: float
    scratch_in: str

    @property
    def seconds(self) -> float:
        return self.before + self.startup + self.rows * self.per_row + self.finish

    def describe(self) -> str:
        workers = "this process" if self.jobs == 1 else f"{self.jobs} workers"
        return (
            f"{self.before:.1f} s plan and checks + {self.startup:.1f} s start-up of "
            f"{workers} + {self.rows} rows x {self.per_row:.3f} s (wall time per row on "
            f"{workers}: rendering, encoding, hashing, files and manifest written and "
            f"fsynced) + {self.finish:.1f} s end (workers stopped, final check); timed on "
            f"{self.sampled} rows run in {self.scratch_in}"
        )


@dataclass(kw_only=True)
class BankResult(mf.Outcome):
    """The outcome of :func:`run` (:class:`~synth.bank.manifest.Outcome`): of ``planned``
    rows, ``failed`` (``failures``); ``stopped`` why it stopped early; times in s, memory in
    bytes; for a dry run ``estimated`` and ``planned_rows``."""

    planned: int
    failed: int = 0
    failures: list = field(default_factory=list)
    stopped: str | None = None
    startup: float = 0.0
    peak_worker_rss: int = 0
    rendering: float = 0.0
    finishing: float = 0.0
    estimated: Estimate | None = None
    planned_rows: list = field(default_factory=list)

    @property
    def estimate(self) -> float | None:
        return None if self.estimated is None else self.estimated.seconds

    @property
    def render_rate(self) -> float:
        """Sounds rendered per second once the workers were warm."""
        busy = self.elapsed - self.startup
        return self.done / busy if busy > 0 else 0.0

    @property
    def ok(self) -> bool:
        return self.failed == 0 and self.stopped is None

    def summary(self) -> str:
        if self.estimate is not None:
            text = (
                f"{self.out_dir}: dry run, nothing written: {len(self.planned_rows)} of "
                f"{self.planned} sounds to render ({self.skipped} already done); estimated "
                f"time of the run {self.estimate:.1f} s"
            )
            if self.planned_rows:
                text += f" = {self.estimated.describe()}"
            return text + self.files_note()
        text = (
            f"{self.out_dir}: {self.done} done, {self.skipped} skipped, {self.failed} failed "
            f"of {self.planned} in {self.elapsed:.1f} s ({self.rate:.1f} sounds/s; "
            f"{self.startup:.1f} s of worker start-up, then {self.render_rate:.1f} sounds/s)"
        )
        text += self.files_note()
        for index, error in self.failures[:5]:
            text += f"\n  row {index} failed: {error}"
        if len(self.failures) > 5:
            text += f"\n  ... {len(self.failures) - 5} more failures in the manifest"
        return text + (f"\nstopped: {self.stopped}" if self.stopped else "")


@contextmanager
def _locked(out_dir: Path):
    """Hold the folder's lock file (``flock``: a killed run holds nothing) for the run, taken
    again if the run that held it removed it meanwhile; removed while held at the end."""
    try:
        import fcntl
    except ImportError:  # no advisory locks on this platform
        yield
        return
    path = out_dir / mf.LOCK
    for _ in range(100):
        fh = open(path, "a")  # noqa: SIM115 - held for the run
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            raise BankRunError(
                f"out_dir={str(out_dir)!r} is in use by another synth bank"
            ) from None
        with contextlib.suppress(FileNotFoundError):
            if os.stat(path).st_ino == os.fstat(fh.fileno()).st_ino:
                break
        fh.close()
    else:
        raise BankRunError(f"out_dir={str(out_dir)!r}: its lock file {mf.LOCK} keeps changing")
    hold_lock(fh)
    try:
        yield
    finally:
        hold_lock(None)
        with contextlib.suppress(OSError):
            path.unlink(missing_ok=True)
        fh.close()


def _as_spec(spec) -> BankSpec:
    if isinstance(spec, BankSpec):
        return spec
    if isinstance(spec, dict):
        return bank_spec.from_dict(spec)
    if isinstance(spec, (str, os.PathLike)):
        return bank_spec.load(spec)
    raise BankSpecError(f"spec={spec!r} must be a spec file, a dict or a BankSpec")


def engine_problem(what: str, recorded: dict | None, advice: str) -> str | None:
    """The error of ``what`` (a folder's ``bank.json`` or ``gain.json``, ``recorded``; None:
    a new folder) made by another :data:`synth.bank.spec.ENGINE` than this one, or by one
    that recorded none, with ``advice``; None if this engine made it. Another engine may
    make other bytes of the same spec, so resuming would mix two engines' files."""
    import synth

    if recorded is None or recorded.get(bank_spec.ENGINE) == synth.__version__:
        return None
    made_by = recorded.get(bank_spec.ENGINE)
    by = f"synth {made_by}" if isinstance(made_by, str) else "a synth that recorded no version"
    return (
        f"{what} was made by {by}, and this is synth {synth.__version__}: another engine "
        f"may render other bytes, so resuming would mix the two engines' files; {advice}"
    )


def _resume_problem(out_dir: Path, spec: BankSpec) -> str | None:
    """Why this run cannot resume the bank in ``out_dir`` (None if it can): another engine
    made it, or another spec (in :func:`synth.bank.spec.compared_form`, where a renamed
    preset, an edited label, name template or tag do not count), unless only ``count``
    grew (rows are drawn per index, so the rows done stay)."""
    raw = mf.read_spec(out_dir) if out_dir.is_dir() else None
    problem = engine_problem(
        f"out_dir={str(out_dir)!r} ({mf.SPEC})",
        raw,
        "use --force (force=True) to start over and render the bank again with this "
        "engine, or another folder",
    )
    if problem is not None or raw is None:
        return problem
    stored = bank_spec.compared_form(raw)
    new = bank_spec.compared_form(spec.stored_form())
    diff = bank_spec.differences(stored, new)
    old_count, new_count = stored.get("count"), new.get("count")
    grows = diff == ["count"] and isinstance(old_count, int) and isinstance(new_count, int)
    if stored == new or (grows and new_count > old_count):
        return None
    rules = (
        f"; the folder's rows were drawn by the drawing rules of plan {stored.get('plan')}, "
        f"this version's are those of plan {new.get('plan')}"
        if "plan" in diff
        else ""
    )
    return (
        f"out_dir={str(out_dir)!r} holds a bank of another spec (differing keys: "
        f"{', '.join(diff)}{rules}): use the same spec to resume, another folder, or "
        f"--force to start over"
    )


def _check_stored(out_dir: Path, spec: BankSpec, force: bool) -> None:
    """Refuse a folder this run cannot resume (:func:`_resume_problem`), or with ``force``
    delete its files and manifest to start over."""
    problem = _resume_problem(out_dir, spec)
    if problem is not None:
        if not force:
            raise BankSpecError(problem)
        for row in mf.read_rows(out_dir):
            f = out_dir / str(row.get("file", ""))
            if mf.inside(out_dir, f) and f.is_file():
                f.unlink()
        for name in (mf.JSONL, mf.CSV):
            (out_dir / name).unlink(missing_ok=True)
    mf.write_spec(out_dir, spec.stored_form())


def _verified(out_dir: Path, rows: list[dict], plan) -> list[dict]:
    """The complete rows: ``ok``, in the plan, their file with the recorded SHA-256."""
    ok = [r for r in rows if r.get("index") in plan and r.get("status") == "ok"]
    return [r for r in ok if mf.intact(out_dir, r)]


def _final_check(out_dir: Path, rows: list[dict], result: BankResult, recorded: set) -> list[dict]:
    """The rows whose record holds (every ``ok`` file hashed again); one that does not is
    dropped from the manifest, redone by the next run, and the bank is not complete."""
    good = [row.get("status") != "ok" or mf.intact(out_dir, row) for row in rows]
    kept = [row for row, ok in zip(rows, good) if ok]
    bad = [row["index"] for row, ok in zip(rows, good) if not ok]
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


def _estimate_sample(items, jobs: int) -> list:
    """The rows a dry run times (:data:`ESTIMATE_RENDERS`), spread over ``items`` (the first
    rows may all be alike: one grid corner)."""
    renders = max(ESTIMATE_RENDERS, math.ceil(math.sqrt(len(items))))
    per_worker = max(ESTIMATE_ROWS_PER_WORKER, math.ceil(renders / jobs))
    n = min(len(items), per_worker * jobs)
    picks = np.unique(np.linspace(0, len(items) - 1, n).round().astype(int))
    return [items[int(i)] for i in picks]


def _estimate(job: _Job, before: float) -> Estimate:
    """The :class:`Estimate` of ``job``: a sample of its rows run as the run runs them, in a
    scratch folder; the bank's folder is not touched."""
    import tempfile

    scratch_in = tempfile.gettempdir()
    if not job.items:
        return Estimate(0, job.jobs, 0, before, 0.0, 0.0, 0.0, scratch_in)
    sample = _estimate_sample(job.items, job.jobs)
    with tempfile.TemporaryDirectory(prefix="synth-bank-estimate-") as scratch:
        probe = _run(_Job(job.spec, tuple(sample), Path(scratch), job.jobs), progress=False)
    per_row = probe.rendering / len(sample)
    return Estimate(
        len(job.items), job.jobs, len(sample), before, probe.startup, per_row, probe.finishing,
        scratch_in,
    )  # fmt: skip


def _progress(total: int):
    """A progress bar on a terminal's stderr (optional ``tqdm``), or None."""
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, file=sys.stderr, unit="sound") if sys.stderr.isatty() else None


def _jobs(jobs) -> int:
    if jobs is None:
        return os.cpu_count() or 1
    return spec_integer("jobs", jobs, 1, "must be an integer >= 1 (worker processes)")


@dataclass(frozen=True)
class _Job:
    """A run's work: the checked ``spec``, the plan's ``items`` to render into ``out`` on
    ``jobs`` workers or a Dask ``connection``, from scratch with ``force``, and the rows
    ``again`` to render although complete."""

    spec: BankSpec
    items: tuple
    out: Path
    jobs: int
    connection: object = None
    force: bool = False
    again: frozenset = frozenset()


def _executor(spec, out_dir: Path, jobs: int, connection):
    if connection is not None:
        return Dask(spec, str(out_dir), connection.client)
    return Serial(spec, str(out_dir)) if jobs == 1 else Pool(spec, str(out_dir), jobs)


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
    t0 = time.perf_counter()
    spec = _as_spec(spec)
    n_jobs = _jobs(jobs)
    items = bank_spec.plan(spec)
    again = frozenset() if redo is None else bank_spec.parse_rows(redo, len(items))
    out = Path(out_dir)
    if not isinstance(prune, bool):
        raise BankSpecError(f"prune={prune!r} must be True or False")
    if dry_run:
        job = _Job(spec, items, out, n_jobs if scheduler is None else 1, None, force, again)
        return _dry_run(job, t0)
    connection = connect(scheduler) if scheduler is not None else None
    try:
        return _run_in(_Job(spec, items, out, n_jobs, connection, force, again), prune)
    finally:
        if connection is not None:
            connection.close()


run.__doc__ = (
    "Render the bank ``spec`` (a spec file, a dict, or a :class:`BankSpec`) into ``out_dir``\n"
    "(created if needed), resuming what an earlier run left.\n\n"
    + "\n".join(f"``{name}``: {text}." for name, (_, text) in OPTIONS.items())
    + "\n\nA bad spec raises :class:`~synth.bank.spec.BankSpecError` before any work, an\n"
    "unreachable scheduler a :class:`BankRunError` within :data:`CONNECT_TIMEOUT` s."
)


def _run_in(job: _Job, prune: bool) -> BankResult:
    out = job.out
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BankRunError(f"out_dir={str(out)!r} cannot be created: {exc}") from None
    try:
        with _locked(out):
            result = _run(job)
            recorded = [str(r.get("file")) for r in mf.read_rows(out)]
            result.prune([item.file for item in job.items] + recorded, prune)
            return result
    except OSError as exc:  # the folder cannot be written (full, read-only) before rendering
        raise BankRunError(
            f"out_dir={str(out)!r}: {exc}; nothing finished was lost: run "
            f"again once it can be written"
        ) from None


def _dry_run(job: _Job, t0: float) -> BankResult:
    """What a run would do, writing nothing: the rows to render (status ``planned``), the
    rows complete and the :class:`Estimate`; with ``force`` every row is to render."""
    spec, items, out = job.spec, job.items, job.out
    problem = _resume_problem(out, spec)
    if problem is not None and not job.force:
        raise BankSpecError(problem)
    here = problem is None and out.is_dir()
    verified = _verified(out, mf.read_rows(out), {item.index for item in items}) if here else []
    kept = [r for r in verified if r["index"] not in job.again]
    todo = _todo(items, kept)
    result = BankResult(out, planned=len(items), skipped=len(kept))
    result.planned_rows = [base_row(spec, item, "planned") for item in todo]
    if here:
        result.prune([item.file for item in items] + [r["file"] for r in verified], False)
    job = dataclasses.replace(job, items=tuple(todo))
    result.estimated = _estimate(job, before=time.perf_counter() - t0)
    result.elapsed = time.perf_counter() - t0
    return result


def _todo(items, kept: list[dict]) -> list:
    done = {r["index"] for r in kept}
    return [item for item in items if item.index not in done]


def _run(job: _Job, progress: bool = True) -> BankResult:
    spec, items, out = job.spec, job.items, job.out
    _check_stored(out, spec, job.force)
    mf.clean_temporaries(out)
    plan = {item.index: item for item in items}
    book = mf.Manifest(out, mf.columns(spec.keys))
    verified = _verified(out, mf.read_rows(out), plan)
    names = {index: item.file for index, item in plan.items()}
    moved, renamed = mf.renamed(out, spec.format, verified, names)
    kept = [described(spec, plan[r["index"]], r) for r in moved if r["index"] not in job.again]
    result = BankResult(out, planned=len(items), skipped=len(kept), renamed=renamed)
    todo = _todo(items, kept)
    book.rewrite(kept)
    for item in todo:  # a killed run's or a damaged file: published again, once
        (out / item.file).unlink(missing_ok=True)
    rows = list(kept)
    recorded = set()
    t_start = time.perf_counter()
    executor = _executor(spec, out, job.jobs, job.connection) if todo else None
    result.startup = time.perf_counter() - t_start
    bar = _progress(len(todo)) if progress else None
    try:
        for res in executor.results(todo) if executor else ():
            result.peak_worker_rss = max(result.peak_worker_rss, res.max_rss)
            if res.fatal is not None:
                result.stopped = f"{res.fatal}; the finished rows are kept: run again to resume"
                break
            if res.row["index"] in recorded:  # a second attempt of a row (a lost worker's)
                continue
            recorded.add(res.row["index"])
            if not _record(res.row, book, rows, result):
                break
            if bar is not None:
                bar.update()
    finally:
        t_rows = time.perf_counter()
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
    result.rendering = t_rows - t_start - result.startup
    result.finishing = time.perf_counter() - t_rows
    return result


def _record(row: dict, book, rows: list, result: BankResult) -> bool:
    """Append a finished ``row`` to the manifest, ``rows`` and ``result``; False when the
    manifest cannot take it (``result.stopped`` says why)."""
    try:
        book.append(row)
    except OSError as exc:
        result.stopped = (
            f"cannot append to the manifest: {exc}; the finished rows are kept: run again to resume"
        )
        return False
    rows.append(row)
    if row["status"] == "ok":
        result.done += 1
    else:
        result.failed += 1
        result.failures.append((row["index"], row.get("error")))
    return True
