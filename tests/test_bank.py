"""Tests of synth.bank: sound banks rendered by workers, resumable, with a manifest.

Most tests use a cheap scene (a small simply supported MDF plate heard at 16 kHz up to
4 kHz, a bounce series cut at 0.3 s) so that a bank of a dozen sounds renders in seconds.
"""

from __future__ import annotations

import json
import math
import os
import random
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

from synth import bank
from synth.bank import manifest as mf
from synth.bank.spec import BankSpecError
from synth.cli import main

ROOT = Path(__file__).resolve().parents[1]

#: A steel ball on a small MDF plate, cheap to render (shared with the fuzz corpus).
SMALL_PRESET = (ROOT / "tests" / "data" / "small-scene.toml").read_text()

SMALL_SPEC = """
preset = "small.toml"
count = {count}
seed = 3
name = "{{preset}}-{{index:03d}}"
format = "wav"
[vary]
"drop.height" = {{ min = 0.01, max = 0.05 }}
"drop.position" = {{ min = [0.05, 0.05], max = [0.25, 0.15] }}
"ball.radius" = [0.004, 0.005]
"""


def _file_identity(path: Path):
    st = path.stat()
    return st.st_ino, st.st_mtime_ns, st.st_size


BANK_SPECS_BY_NAME = ["marble-on-glass-table-game", "restitution-stimuli"]

EXAMPLE_SPEC = """\
preset = "default"                  # a name or a file
count = 200                         # random variations; leave out for the full grid of lists
seed = 7
name = "{preset}-{index:04d}"
format = "flac"
[vary]
"drop.height" = { min = 0.05, max = 0.3 }
"drop.position" = { min = [0.2, 0.1], max = [1.0, 0.4] }
"ball.radius" = [0.004, 0.005, 0.006]
[render]
samplerate = 48000
normalize = "physical"
"""


@pytest.fixture(scope="module")
def cache_dir():
    """The disk cache the suite shares (``$SYNTH_CACHE_DIR``): the default plate's modes,
    solved once for the suite, are read from it; the bank's workers share it too (the
    cache's own tests, tests/test_cache.py, use private ones)."""
    from synth.store.cache import cache_dir as shared

    return shared()


def _write_spec(folder: Path, count: int = 12, extra: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "small.toml").write_text(SMALL_PRESET)
    path = folder / "bank.toml"
    path.write_text(SMALL_SPEC.format(count=count) + extra)
    return path


@pytest.fixture(scope="module")
def serial(tmp_path_factory, cache_dir):
    """The small bank rendered in this process (jobs=1): the reference of the others."""
    folder = tmp_path_factory.mktemp("serial")
    spec = _write_spec(folder / "spec")
    result = bank.run(spec, folder / "out", jobs=1)
    assert result.ok and result.done == 12
    return spec, folder / "out"


def _audio_files(folder: Path) -> dict:
    return {
        p.name: p.read_bytes()
        for p in sorted(folder.iterdir())
        if p.suffix in (".wav", ".flac", ".ogg")
    }


def _check_complete(folder: Path, n: int) -> None:
    """Every row once (JSONL and CSV), ok, its file present with its SHA-256, no
    temporary file, no file outside the manifest."""
    rows = [json.loads(line) for line in (folder / mf.JSONL).read_text().splitlines()]
    assert [r["index"] for r in rows] == list(range(n))
    assert all(r["status"] == "ok" for r in rows)
    for r in rows:
        assert mf.sha256_file(folder / r["file"]) == r["sha256"]
    csv_lines = (folder / mf.CSV).read_text().splitlines()
    assert len(csv_lines) == n + 1
    assert not [p for p in folder.iterdir() if mf.TEMPORARY.match(p.name)]
    assert not (folder / mf.LOCK).exists()  # removed when the run finished
    assert set(_audio_files(folder)) == {r["file"] for r in rows}


def test_serial_and_two_workers_identical(serial, tmp_path):
    # Each row's scene and draws depend on the spec and the row's index only, and the
    # manifest is rewritten by index at the end: the scheduling must not show.
    spec, ref = serial
    result = bank.run(spec, tmp_path / "pool", jobs=2)
    assert result.ok and result.done == 12 and result.peak_worker_rss > 0
    assert _audio_files(tmp_path / "pool") == _audio_files(ref)
    for name in (mf.JSONL, mf.CSV, mf.SPEC):
        assert (tmp_path / "pool" / name).read_bytes() == (ref / name).read_bytes()
    _check_complete(ref, 12)


def test_rerun_skips_everything(serial):
    # Every file is there with its hash: nothing to redo.
    spec, ref = serial
    before = _audio_files(ref)
    result = bank.run(spec, ref, jobs=1)
    assert (result.done, result.skipped, result.failed) == (0, 12, 0)
    assert _audio_files(ref) == before


def test_damaged_file_is_redone(serial, tmp_path):
    # A file whose bytes no longer match its row's hash is rendered again.
    spec, ref = serial
    out = tmp_path / "copy"
    out.mkdir()
    for p in ref.iterdir():
        (out / p.name).write_bytes(p.read_bytes())
    rows = mf.read_rows(out)
    victim = out / rows[4]["file"]
    victim.write_bytes(victim.read_bytes()[:-10])
    (out / rows[7]["file"]).unlink()
    (out / ".small-003.0123456789ab.part.wav").write_bytes(b"partial")
    result = bank.run(spec, out, jobs=1)
    assert (result.done, result.skipped) == (2, 10)
    _check_complete(out, 12)
    assert _audio_files(out) == _audio_files(ref)


@pytest.mark.slow
def test_dask_local_cluster_equals_pool(serial, tmp_path):
    # The same task function on a real distributed cluster (2 worker processes) writes the
    # same files as the local run.
    distributed = pytest.importorskip("dask.distributed")
    spec, ref = serial
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        result = bank.run(spec, tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert result.ok and result.done == 12
    assert _audio_files(tmp_path / "dask") == _audio_files(ref)
    assert (tmp_path / "dask" / mf.JSONL).read_bytes() == (ref / mf.JSONL).read_bytes()


@pytest.mark.slow
def test_kill_9_at_random_moments_then_resume(tmp_path, cache_dir):
    # SIGKILL to the whole bank (parent and workers) three times while it renders (after
    # a random 2-8 new rows, plus 0-20 ms; a warm worker renders a row in ~15 ms): every
    # finished row keeps its file, no partial file survives the next run, and the last run
    # completes with every row once and every hash right.
    spec = _write_spec(tmp_path / "spec", count=40)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "synth", "bank", str(spec), "-o", str(out), "--jobs", "2"]
    rng = random.Random(13)
    rows_seen = []
    for _ in range(3):
        proc = subprocess.Popen(
            cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        target = (rows_seen[-1] if rows_seen else 0) + rng.randint(2, 8)
        deadline = time.monotonic() + 120
        while (
            len(mf.read_rows(out)) < target and proc.poll() is None and time.monotonic() < deadline
        ):  # the workers are rendering
            time.sleep(0.002)
        time.sleep(rng.uniform(0.0, 0.02))
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        rows = mf.read_rows(out)
        rows_seen.append(len(rows))
        for r in rows:  # every recorded row has its whole file
            assert mf.sha256_file(out / r["file"]) == r["sha256"]
    assert rows_seen[-1] < 40  # the kills came before the end
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    _check_complete(out, 40)


def _children(pid: int) -> list[int]:
    """Process ids whose parent is ``pid`` (Linux /proc)."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_a_killed_worker_stops_the_bank_cleanly_and_resume_completes(tmp_path, cache_dir):
    # SIGKILL to one worker (not the parent) mid-run: the bank must not wait forever for
    # that worker's row; it stops with a one-line error (exit 2, as every error that stops a
    # bank), keeps every finished row with its file, and the same command then completes it.
    spec = _write_spec(tmp_path / "spec", count=40)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "synth", "bank", str(spec), "-o", str(out), "--jobs", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while len(mf.read_rows(out)) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.002)
    workers = _children(proc.pid)
    assert workers, "no worker process found"
    os.kill(workers[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    rows = mf.read_rows(out)
    if len(rows) < 40:  # the kill came before the end
        assert proc.returncode == 2, err
        assert "worker process died" in err and "Traceback" not in err, err
    for r in rows:
        assert mf.sha256_file(out / r["file"]) == r["sha256"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    _check_complete(out, 40)


@pytest.mark.slow
def test_pool_workers_take_sigterm_by_default(tmp_path, cache_dir):
    # The command line's SIGTERM handler raises to unwind; a forked worker must not inherit
    # it: the pool stops its workers with SIGTERM when one dies, and a raise inside a
    # library callback (soundfile's writer) is swallowed and printed as a traceback.

    from synth.bank import executors
    from synth.bank import spec as bank_spec
    from synth.cli import _on_sigterm

    spec = bank_spec.load(_write_spec(tmp_path / "spec", count=2))
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        pool = executors.Pool(spec, str(tmp_path / "out"), 2)
        try:
            futures = [pool.executor.submit(signal.getsignal, signal.SIGTERM) for _ in range(4)]
            assert all(f.result(timeout=60) == signal.SIG_DFL for f in futures)
        finally:
            pool.close()
    finally:
        signal.signal(signal.SIGTERM, previous)


def _mount_tmpfs(path: Path, size: str) -> bool:
    if not sys.platform.startswith("linux") or os.geteuid() != 0:
        return False
    path.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True,
        check=False,
    )
    return r.returncode == 0


def test_disk_that_fills(serial, tmp_path, monkeypatch):
    # A full disk stops the bank cleanly (no exception, not ok, the reason given), the
    # finished rows and files are intact, and once there is room the rerun completes.
    spec, ref = serial
    disk = tmp_path / "disk"
    mounted = _mount_tmpfs(disk, "120k")
    try:
        if not mounted:  # no tmpfs here: the writer fails with ENOSPC after 5 files
            disk.mkdir(exist_ok=True)
            real, calls = mf.write_atomic, []

            def full(target, data):
                if Path(target).suffix == ".wav":
                    calls.append(target)
                    if len(calls) > 5:
                        raise OSError(28, "No space left on device")
                return real(target, data)

            monkeypatch.setattr(mf, "write_atomic", full)
        result = bank.run(spec, disk / "out", jobs=1)
        assert not result.ok and result.stopped and "space" in result.stopped.lower()
        assert 0 < result.done < 12
        rows = mf.read_rows(disk / "out")
        assert all(r["status"] == "ok" for r in rows)
        for r in rows:
            assert mf.sha256_file(disk / "out" / r["file"]) == r["sha256"]
        assert not [p for p in (disk / "out").iterdir() if mf.TEMPORARY.match(p.name)]
        if mounted:
            subprocess.run(["mount", "-o", "remount,size=8m", str(disk)], check=True)
        else:
            monkeypatch.setattr(mf, "write_atomic", real)
        again = bank.run(spec, disk / "out", jobs=1)
        assert again.ok and again.skipped == len(rows) and again.done == 12 - len(rows)
        _check_complete(disk / "out", 12)
        assert _audio_files(disk / "out") == _audio_files(ref)
    finally:
        if mounted:
            subprocess.run(["umount", str(disk)], check=False)


def test_failed_scene_recorded_and_exit_status(tmp_path, cache_dir, capsys, monkeypatch):
    # A row whose render fails (here a solver error injected into row 1) is recorded with
    # its error; the other rows are rendered; the command exits with status 1.

    from synth.bank import row as bank_row

    render = bank_row.render_scene

    def failing(spec, item):
        if item.index == 1:
            raise FloatingPointError("the contact solver diverged")
        return render(spec, item)

    monkeypatch.setattr(bank_row, "render_scene", failing)
    spec = tmp_path / "bank.toml"
    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    spec.write_text(
        'preset = "small.toml"\nname = "p{index}"\nformat = "ogg"\n[vary]\n'
        '"drop.position" = [[0.1, 0.1], [0.15, 0.1], [0.2, 0.1]]\n'
    )
    assert main(["bank", str(spec), "-o", str(tmp_path / "out"), "--jobs", "1"]) == 1
    assert "1 failed" in capsys.readouterr().err
    rows = mf.read_rows(tmp_path / "out")
    assert [r["status"] for r in rows] == ["ok", "failed", "ok"]
    assert "diverged" in rows[1]["error"] and rows[1]["sha256"] is None
    assert sorted(_audio_files(tmp_path / "out")) == ["p0.ogg", "p2.ogg"]


def _tree(folder: Path) -> dict:
    """Every path under ``folder`` with its modification time and bytes (None: a folder)."""
    return {
        str(p.relative_to(folder)): (p.stat().st_mtime_ns, p.read_bytes() if p.is_file() else None)
        for p in sorted(folder.rglob("*"))
    }


def test_dry_run_changes_nothing(tmp_path, cache_dir):
    # The rows to render and an estimate of the time from a few renders; no folder made.
    spec = _write_spec(tmp_path / "spec")
    result = bank.run(spec, tmp_path / "out", jobs=2, dry_run=True)
    assert result.estimate is not None and result.estimate > 0
    assert [r["status"] for r in result.planned_rows] == ["planned"] * 12
    assert not (tmp_path / "out").exists()
    assert "estimated" in result.summary()


def test_dry_run_samples_more_rows_as_the_bank_grows():
    # rows differ in cost (ten times between impact points): the dry run times at least
    # the square root of the rows, spread from the first to the last, a whole number per
    # worker, so that the sampled mean's relative error falls with the bank's size
    from synth.bank.runner import _estimate_sample

    items = list(range(200))
    for jobs, want in ((1, 15), (2, 16)):
        sample = _estimate_sample(items, jobs)
        assert len(sample) == want and sample[0] == 0 and sample[-1] == 199
    assert len(_estimate_sample(list(range(12)), 1)) == 5
    assert len(_estimate_sample(list(range(10_000)), 2)) == 100


@pytest.mark.parametrize("jobs", [1, 2])
def test_dry_run_estimate_runs_rows_as_the_run_does(tmp_path, cache_dir, monkeypatch, jobs):
    # The estimate is made of what a run pays, each part measured by running a sample of
    # the rows as the run runs them: the workers started as the run starts them (jobs of
    # them), each sampled row's manifest row appended by this process, in a scratch
    # folder removed after; and its seconds are the sum of its parts.
    import importlib

    run_module = importlib.import_module("synth.bank.runner")
    started, appended = [], []
    real_executor, real_append = run_module._executor, mf.Manifest.append

    def executor(spec, out, n_jobs, connection):
        started.append((n_jobs, out))
        return real_executor(spec, out, n_jobs, connection)

    def append(book, row):
        appended.append(row["index"])
        real_append(book, row)

    monkeypatch.setattr(run_module, "_executor", executor)
    monkeypatch.setattr(mf.Manifest, "append", append)
    spec = _write_spec(tmp_path / "spec")
    result = bank.run(spec, tmp_path / "out", jobs=jobs, dry_run=True)
    e = result.estimated
    assert not (tmp_path / "out").exists()
    # 5 rows or more, a whole number per worker, spread over the 12 (first and last)
    assert (e.rows, e.jobs, e.sampled) == (12, jobs, {1: 5, 2: 6}[jobs])
    assert len(started) == 1 and started[0][0] == jobs
    scratch = started[0][1]
    assert not scratch.exists() and not scratch.is_relative_to(tmp_path)
    assert len(appended) == e.sampled and {0, 11} <= set(appended)
    assert min(e.before, e.startup, e.per_row, e.finish) > 0
    parts = e.before + e.startup + e.rows * e.per_row + e.finish
    assert result.estimate == e.seconds == pytest.approx(parts, rel=1e-12)
    text = result.summary()
    workers = "this process" if jobs == 1 else f"{jobs} workers"
    assert f"start-up of {workers}" in text and f"12 rows x {e.per_row:.3f} s" in text
    assert f"timed on {e.sampled} rows" in text


def test_force_dry_run_on_a_finished_bank_writes_and_deletes_nothing(tmp_path, cache_dir):
    # A finished bank, then --force --dry-run with a changed spec, and a plain --dry-run:
    # the folder's tree (names, mtimes, bytes) is the same before and after each.
    spec = _write_spec(tmp_path / "spec", count=3)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    before = _tree(out)
    assert main(["bank", str(spec), "-o", str(out), "--dry-run"]) == 0
    assert _tree(out) == before
    spec.write_text(spec.read_text().replace("seed = 3", "seed = 4"))
    assert main(["bank", str(spec), "-o", str(out), "--dry-run", "--force"]) == 0
    assert _tree(out) == before
    result = bank.run(spec, out, jobs=1, dry_run=True, force=True)
    assert len(result.planned_rows) == 3 and result.skipped == 0
    assert _tree(out) == before


def test_changed_spec_refused_naming_keys_then_force(tmp_path, cache_dir):
    spec = _write_spec(tmp_path / "spec", count=3)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    spec.write_text(
        spec.read_text().replace("seed = 3", "seed = 4").replace("[0.004, 0.005]", "[0.004, 0.006]")
    )
    with pytest.raises(BankSpecError, match=r"seed.*vary\.ball\.radius|vary\.ball\.radius.*seed"):
        bank.run(spec, out, jobs=1)
    result = bank.run(spec, out, jobs=1, force=True)
    assert result.ok and result.done == 3 and result.skipped == 0
    _check_complete(out, 3)


def _bad(tmp_path, text: str) -> str:
    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    path = tmp_path / "bad.toml"
    path.write_text(text)
    out = tmp_path / "out"
    with pytest.raises(BankSpecError) as info:
        bank.run(path, out, jobs=1)
    assert not out.exists()  # rejected before any work
    return str(info.value)


BASE = 'preset = "small.toml"\n'


@pytest.mark.parametrize(
    "text, key",
    [
        (BASE + "colour = 3\n", "colour"),
        (BASE + '[vary]\n"ball.radios" = [0.004]\n', "ball.radios"),
        (BASE + '[vary]\n"drop.height" = []\n', "vary.drop.height"),
        (BASE + '[vary]\n"drop.height" = { min = 0.3, max = 0.1 }\n', "vary.drop.height"),
        (
            BASE + '[vary]\n"drop.position" = { min = [0.1, 0.2], max = [0.2, 0.1] }\n',
            "vary.drop.position",
        ),
        (BASE + 'name = "{preset}-{ball_mass}"\n[vary]\n"drop.height" = [0.01, 0.02]\n', "name"),
        (BASE + 'name = "{preset}"\n[vary]\n"drop.height" = [0.01, 0.02]\n', "name"),
        (BASE + 'count = 0\n[vary]\n"drop.height" = [0.01, 0.02]\n', "count"),
        (BASE + '[render]\nsamplerate = "fast"\n', "samplerate"),
    ],
)
def test_bad_specs_rejected_naming_the_key(tmp_path, text, key):
    assert key in _bad(tmp_path, text)


@pytest.mark.parametrize(
    "axis, row, says",
    [
        ('"ball.material" = ["steel", "unobtainium"]', 1, "unobtainium"),
        ('"ball.radius" = [0.005, -0.004]', 1, "-0.004"),
        ('"drop.height" = { min = -0.05, max = 0.05 }', 2, "must be > 0"),
        ('"drop.position" = [[0.1, 0.1], [5.0, 5.0]]', 1, "off the plate"),
        ('"ball.radius" = ["5mm", 0.004]', 0, "'5mm'"),
        ("restitution_scale = [1.0, -1.0]", 1, ">= 0"),
        ('"render.max_frequency" = [4000.0, 9000.0]', 1, "Nyquist"),
    ],
)
def test_bad_row_values_refused_at_plan_time(tmp_path, axis, row, says):
    # Every row's scene is built and checked before anything is written (nothing solved):
    # the message names the rows, their values and what is wrong.
    text = _bad(tmp_path, BASE + f"count = 4\n[vary]\n{axis}\n")
    assert f"row {row} (" in text and says in text, text


def test_row_beyond_the_mode_budget_refused_at_plan_time(tmp_path, monkeypatch):
    # The rows' plates are held to the render's mode budget (synth.cost.estimate_render) when the
    # bank is planned, so a bank never starts a row that its renders would refuse: the 1 mm
    # board has about 130 modes below 4 kHz, over a budget of 100; the 18 mm one about 7.
    monkeypatch.setenv("SYNTH_MAX_MODES", "100")
    text = _bad(tmp_path, BASE + 'count = 2\n[vary]\n"plate.thickness" = [0.018, 0.001]\n')
    assert "row 1 (" in text and "SYNTH_MAX_MODES" in text and "row 0 (" not in text, text


def test_row_beyond_the_render_estimate_refused_at_plan_time(tmp_path):
    # The plan holds each row to the render's whole cost estimate (synth.cost.estimate_render
    # against the budget), not only its mode count, so no worker starts a row its render would
    # refuse: a ball of 999 to 1000 kg comes to rest on the small board, a contact of minutes
    # (longer than the preset's max_duration of 0.3 s, and a pulse grid beyond the budget).
    text = _bad(tmp_path, BASE + 'count = 2\n[vary]\n"ball.mass" = { min = 999.0, max = 1000.0 }\n')
    for row in (0, 1):
        assert f"row {row} (ball.mass=" in text, text
    assert "comes to rest" in text and "max_duration=0.3" in text and "lower ball.mass" in text
    assert "SYNTH_MAX_PULSE_POINTS" in text


def test_file_name_over_255_bytes_refused(tmp_path):
    text = _bad(
        tmp_path, BASE + 'name = "' + "x" * 260 + '{index}"\n[vary]\n"drop.height" = [0.01]\n'
    )
    assert "255 bytes" in text


def test_absurd_count_refused_before_anything(tmp_path):
    text = _bad(tmp_path, BASE + 'count = 2_000_000\n[vary]\n"drop.height" = [0.01, 0.02]\n')
    assert "count=2000000" in text and "100000" in text


def test_unreachable_scheduler_fails_leaving_nothing(tmp_path):
    pytest.importorskip("dask.distributed")
    spec = _write_spec(tmp_path / "spec", count=2)
    with pytest.raises(bank.BankRunError, match="cannot connect"):
        bank.run(spec, tmp_path / "out", scheduler="tcp://127.0.0.1:1")
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "address", ["tcp://127.0.0.1:1", "tcp://192.0.2.1:8786"], ids=["refused", "no-answer"]
)
def test_a_wrong_scheduler_address_is_given_up_within_the_connect_timeout(tmp_path, address):
    # `synth bank --scheduler` at a port that refuses and at an address that does not
    # answer (TEST-NET-1, RFC 5737), with Dask's own connect timeout set to 600 s in the
    # command's environment: the command gives up by its own CONNECT_TIMEOUT (5 s), so it
    # ends well within a subprocess limit of 120 s (which a wait for Dask's timeout would
    # pass), exit status 2, naming the address, with no folder made.
    pytest.importorskip("dask.distributed")
    from synth.bank.executors import CONNECT_TIMEOUT

    spec = _write_spec(tmp_path / "spec", count=2)
    out = tmp_path / "out"
    env = dict(os.environ, DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="600s")
    done = subprocess.run(
        [sys.executable, "-m", "synth", "bank", str(spec), "-o", str(out), "--scheduler", address],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert f"scheduler={address!r}: cannot connect within {CONNECT_TIMEOUT:g} s" in done.stderr
    assert "nothing was written" in done.stderr
    assert not out.exists()


def test_list_axes_drawn_without_replacement_block_by_block(tmp_path):
    # With count, a list of n values gives each value once in every n consecutive rows,
    # by the rule of plan 2 (a permutation of the list per block from
    # default_rng([seed, axis, block, 1])), which plan 3 keeps for one list axis; a count
    # above the 4 values (no range axis) repeats them, with a warning.
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    radii = [0.003, 0.004, 0.005, 0.006]
    s = S.from_dict(
        {"preset": "small.toml", "count": 10, "vary": {"ball.radius": radii}}, base_dir=tmp_path
    )
    with pytest.warns(S.RepeatedRowsWarning, match="4 distinct rows"):
        drawn = [item.values["ball.radius"] for item in S.plan(s)]
    assert sorted(drawn[:4]) == radii and sorted(drawn[4:8]) == radii
    assert set(drawn[8:]) <= set(radii) and len(set(drawn[8:])) == 2
    plan_2 = [
        radii[np.random.default_rng([0, 0, i // 4, 1]).permutation(4)[i % 4]] for i in range(10)
    ]
    assert drawn == plan_2


def _lists_spec(tmp_path, count: int, seed: int, vary: dict):
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    data = {"preset": "small.toml", "count": count, "seed": seed, "vary": vary}
    return S.from_dict(data, base_dir=tmp_path)


def _combos(items) -> list:
    return [json.dumps(item.values, sort_keys=True) for item in items]


TWO_BY_THREE = {"ball.radius": [0.004, 0.005], "drop.height": [0.01, 0.02, 0.03]}


def test_list_combinations_drawn_without_replacement(tmp_path):
    # Lists of 2 x 3 values with count = 6 give the 6 combinations once each, for every
    # seed (drawn per axis, 4 or 5 distinct rows were common); count = 12 gives each
    # twice, once per block of 6; a smaller count is a prefix of a larger one.
    from synth.bank import spec as S

    grid = {json.dumps({"ball.radius": r, "drop.height": h}, sort_keys=True)
            for r in TWO_BY_THREE["ball.radius"] for h in TWO_BY_THREE["drop.height"]}  # fmt: skip
    for seed in range(100):
        six = _combos(S.plan(_lists_spec(tmp_path, 6, seed, TWO_BY_THREE), check_scenes=False))
        assert set(six) == grid, seed
    with pytest.warns(S.RepeatedRowsWarning):
        twelve = _combos(S.plan(_lists_spec(tmp_path, 12, 5, TWO_BY_THREE), check_scenes=False))
    assert set(twelve[:6]) == set(twelve[6:]) == grid
    four = _combos(S.plan(_lists_spec(tmp_path, 4, 5, TWO_BY_THREE), check_scenes=False))
    assert four == twelve[:4]


def test_many_list_combinations_drawn_without_replacement(tmp_path):
    # 50 x 50 x 50 = 125000 combinations, more than a whole permutation is drawn for:
    # each row draws until it has a combination no earlier row has; still a prefix when
    # the count grows.
    from synth.bank import spec as S

    vary = {
        "ball.radius": [0.004 + 1e-5 * i for i in range(50)],
        "drop.height": [0.01 + 1e-4 * i for i in range(50)],
        "restitution_scale": [0.5 + 0.01 * i for i in range(50)],
    }
    assert math.prod(len(v) for v in vary.values()) > S.PERMUTED_COMBINATIONS
    rows = _combos(S.plan(_lists_spec(tmp_path, 3000, 2, vary), check_scenes=False))
    assert len(set(rows)) == 3000
    assert _combos(S.plan(_lists_spec(tmp_path, 1000, 2, vary), check_scenes=False)) == rows[:1000]


def test_count_above_the_distinct_rows_warns_once_naming_them(tmp_path, capsys):
    # Without a range axis, count = 7 over 2 x 3 lists repeats a row: one warning naming
    # the 6 distinct rows (on the command line one "synth: warning" line); with a range
    # axis the rows differ and nothing is said.
    import warnings

    from synth.bank import spec as S

    with pytest.warns(S.RepeatedRowsWarning, match=r"count=7 .* the 6 distinct rows") as caught:
        S.plan(_lists_spec(tmp_path, 7, 0, TWO_BY_THREE), check_scenes=False)
    assert len(caught) == 1
    spec = tmp_path / "seven.toml"
    spec.write_text(
        'preset = "small.toml"\ncount = 7\nname = "{index}"\n[vary]\n'
        '"ball.radius" = [0.004, 0.005]\n"drop.height" = [0.01, 0.02, 0.03]\n'
    )
    assert main(["bank", str(spec), "-o", str(tmp_path / "out"), "--dry-run", "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert err.count("synth: warning: count=7") == 1 and "6 distinct rows" in err
    ranged = dict(TWO_BY_THREE, **{"drop.position": {"min": [0.05, 0.05], "max": [0.25, 0.15]}})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(S.plan(_lists_spec(tmp_path, 20, 0, ranged), check_scenes=False)) == 20


def test_a_bank_of_plan_2_resumes_where_its_rows_are_drawn_alike(tmp_path, cache_dir):
    # Plan 3 changed the draws of specs with two or more list axes and count only: a
    # bank stored by plan 2 with one list axis resumes without rendering; one with two
    # list axes is refused naming the plan (its rows would differ), as any change.
    one = _write_spec(tmp_path / "one", count=3)
    out = tmp_path / "one-out"
    assert bank.run(one, out, jobs=1).ok
    before = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    mf.write_spec(out, dict(mf.read_spec(out), plan=2))
    result = bank.run(one, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (0, 3)
    assert {p.name: _file_identity(p) for p in out.glob("*.wav")} == before
    assert mf.read_spec(out)["plan"] == 3

    two = _write_spec(tmp_path / "two", count=2, extra='"drop.height" = [0.01, 0.02]\n')
    two.write_text(two.read_text().replace('"drop.height" = { min = 0.01, max = 0.05 }\n', ""))
    out = tmp_path / "two-out"
    assert bank.run(two, out, jobs=1).ok
    mf.write_spec(out, dict(mf.read_spec(out), plan=2))
    with pytest.raises(BankSpecError, match=r"differing keys: plan\b.*drawing rules"):
        bank.run(two, out, jobs=1)


def test_raising_count_adds_rows_keeping_the_first(tmp_path, cache_dir):
    # Rows are drawn per index: count 3 -> 5 keeps the three files (same inode, bytes)
    # and renders two more.
    spec = _write_spec(tmp_path / "spec", count=3)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    before = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    spec.write_text(spec.read_text().replace("count = 3", "count = 5"))
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (2, 3)
    assert {p.name: _file_identity(p) for p in out.glob("*.wav") if p.name in before} == before
    _check_complete(out, 5)


def _with_default_keys(spec: Path) -> None:
    """Spell out, in the spec and its preset, keys at the values they take by default
    (the render options, sampling, gravity, the contact model, its law, plate, surface,
    theory and accuracy), change the
    preset's description, and set the preset's radius, which the spec varies (every row
    sets it): the files stay the same."""
    spec.write_text(
        spec.read_text().replace('format = "wav"\n', 'format = "wav"\nsampling = "random"\n')
        + '[render]\nnormalize = "physical"\npeak_db = -1.0\nfade = 0.005\npulse_points = 65\n'
        + 'subtype = "pcm_24"\n'
    )
    preset = spec.parent / "small.toml"
    preset.write_text(
        "gravity = 9.81\n"
        + preset.read_text()
        .replace("cheap to render", "described otherwise")
        .replace("radius = 0.005", "radius = 0.006")
        + '[contact]\nmodel = "measured"\nlaw = "hertz"\nplate = "auto"\n'
        + 'surface = "auto"\ntheory = "kirchhoff"\nrtol = 1e-9\n'
    )


def test_default_valued_keys_resume_the_bank(tmp_path, cache_dir, capsys):
    # A bank, resumed first from the spec as the previous version stored it (as written),
    # then with keys spelled out at their default values: nothing is rendered, every
    # file keeps its inode and bytes, and the dry run agrees.
    from synth.bank import spec as bank_spec

    spec = _write_spec(tmp_path / "spec", count=3)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    before = {p.name: (_file_identity(p), p.read_bytes()) for p in out.glob("*.wav")}
    mf.write_spec(out, bank_spec.load(spec).as_dict())  # the earlier versions' bank.json
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (0, 3)
    _with_default_keys(spec)
    dry = bank.run(spec, out, jobs=1, dry_run=True)
    assert (len(dry.planned_rows), dry.skipped) == (0, 3)
    assert main(["bank", str(spec), "-o", str(out), "--dry-run"]) == 0
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (0, 3)
    assert {p.name: (_file_identity(p), p.read_bytes()) for p in out.glob("*.wav")} == before
    _check_complete(out, 3)


@pytest.mark.parametrize(
    "change, key",
    [
        (lambda spec: spec.write_text(spec.read_text() + "[render]\nmax_duration = 0.25\n"),
         "render.max_duration"),
        (lambda spec: (spec.parent / "small.toml").write_text(
            "gravity = 9.0\n" + (spec.parent / "small.toml").read_text()),
         "preset_data.gravity"),
        (lambda spec: (spec.parent / "small.toml").write_text(
            (spec.parent / "small.toml").read_text() + '[contact]\nmodel = "fitted"\n'),
         "preset_data.contact.model"),
    ],
    ids=["render.max_duration", "gravity", "contact.model"],
)  # fmt: skip
def test_a_changed_value_is_still_refused_naming_its_key(tmp_path, cache_dir, capsys, change, key):
    # A value other than the default changes the files: the run and the dry run refuse
    # the folder naming the key, and the folder is left as it was.
    spec = _write_spec(tmp_path / "spec", count=2)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    before = _tree(out)
    change(spec)
    with pytest.raises(BankSpecError, match=rf"another spec \(differing keys: .*{key}"):
        bank.run(spec, out, jobs=1)
    with pytest.raises(BankSpecError, match=rf"another spec \(differing keys: .*{key}"):
        bank.run(spec, out, jobs=1, dry_run=True)
    assert main(["bank", str(spec), "-o", str(out), "--dry-run"]) != 0
    assert key in capsys.readouterr().err
    assert _tree(out) == before


def test_a_default_derived_from_a_varied_key_is_not_filled(tmp_path):
    # With contact.model varied, a law, plate and surface spelled out in the preset pin
    # them for every row (an explicit key wins over the model's), so the spec makes other
    # files than the preset without them: the stored forms differ there. Without the
    # axis they are the default (measured) model's own and the stored forms are equal.
    from synth.bank import spec as bank_spec

    pinned = SMALL_PRESET + '[contact]\nlaw = "hertz"\nplate = "auto"\nsurface = "auto"\n'
    for folder, preset in (("plain", SMALL_PRESET), ("pinned", pinned)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "small.toml").write_text(preset)

    def stored(folder: str, vary: str) -> dict:
        text = f'preset = "small.toml"\nname = "{{index}}"\n[vary]\n{vary}\n'
        return bank_spec.from_dict(tomllib.loads(text), base_dir=tmp_path / folder).stored_form()

    models = '"contact.model" = ["thesis", "fitted"]'
    heights = '"drop.height" = [0.01, 0.02]'
    assert bank_spec.differences(stored("plain", models), stored("pinned", models)) == [
        "preset_data.contact.law",
        "preset_data.contact.plate",
        "preset_data.contact.surface",
    ]
    assert stored("plain", heights) == stored("pinned", heights)


def test_raising_count_with_a_default_valued_key_grows_the_bank(tmp_path, cache_dir):
    spec = _write_spec(tmp_path / "spec", count=3)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    before = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    _with_default_keys(spec)
    spec.write_text(spec.read_text().replace("count = 3", "count = 5"))
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (2, 3)
    assert {p.name: _file_identity(p) for p in out.glob("*.wav") if p.name in before} == before
    _check_complete(out, 5)


@pytest.mark.parametrize("name", BANK_SPECS_BY_NAME)
def test_example_specs_by_name(name):
    assert len(bank.plan(bank.load(name))) >= 10


def test_example_spec_as_written():
    # The example bank: 200 rows, every value within its range or list, reproducible.
    import tomllib

    from synth.bank import spec as S

    s = S.from_dict(tomllib.loads(EXAMPLE_SPEC))
    items = S.plan(s)
    assert len(items) == 200 and items[0].file == "default-0000.flac"
    assert s.render["normalize"] == "physical" and s.render["samplerate"] == 48000
    for it in items:
        assert 0.05 <= it.values["drop.height"] <= 0.3
        x, y = it.values["drop.position"]
        assert 0.2 <= x <= 1.0 and 0.1 <= y <= 0.4
        assert it.values["ball.radius"] in (0.004, 0.005, 0.006)
    assert S.plan(S.from_dict(tomllib.loads(EXAMPLE_SPEC))) == items
    # a row depends on its index only: a shorter bank is a prefix of the longer one
    shorter = S.plan(S.from_dict(tomllib.loads(EXAMPLE_SPEC.replace("200", "20"))))
    assert shorter == items[:20]
    # with 200 draws from 3 values each value comes up (binomial: P(missing one) < 1e-34)
    assert {it.values["ball.radius"] for it in items} == {0.004, 0.005, 0.006}


def test_grid_template_and_log_range(tmp_path):
    # Without count: the full grid of the lists, first axis slowest; a log range stays in
    # its bounds; dotted and underscored names both fill the template.
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    s = S.from_dict(
        {
            "preset": "small.toml",
            "name": "h{drop.height:.2f}-k{restitution_scale}-{plate_thickness:.4f}",
            "vary": {
                "drop.height": [0.01, 0.02],
                "restitution_scale": [0.5, 1.0, 1.5],
                "plate.thickness": {"min": 0.006, "max": 0.018, "log": True},
            },
        },
        base_dir=tmp_path,
    )
    items = S.plan(s)
    assert [(i.values["drop.height"], i.values["restitution_scale"]) for i in items] == [
        (h, k) for h in (0.01, 0.02) for k in (0.5, 1.0, 1.5)
    ]
    assert all(0.006 <= i.values["plate.thickness"] <= 0.018 for i in items)
    assert items[0].file.startswith("h0.01-k0.5-0.0")


BANK_SPECS = sorted(p.name for p in (ROOT / "synth" / "presets" / "banks").glob("*.toml"))


@pytest.mark.parametrize("name", BANK_SPECS)
def test_example_specs_plan(name):
    s = bank.load(ROOT / "synth" / "presets" / "banks" / name)
    assert len(bank.plan(s)) >= 10


def test_restitution_scale_changes_the_ticks(tmp_path, cache_dir):
    # k = 0 makes every impact perfectly elastic (1 - e' = 0): the first restitution is 1;
    # k = 1 leaves the physical sequence (the same first restitution as a plain render).
    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    spec = {
        "preset": str(tmp_path / "small.toml"),
        "name": "k{restitution_scale}",
        "format": "wav",
        "vary": {"restitution_scale": [0.0, 1.0]},
    }
    result = bank.run(spec, tmp_path / "out", jobs=1)
    assert result.ok
    rows = mf.read_rows(tmp_path / "out")
    from synth.io.presets import load_preset
    from synth.physics.bounces import simulate_scene

    e = simulate_scene(load_preset(tmp_path / "small.toml")).impacts[0].restitution
    assert rows[0]["first_restitution"] == pytest.approx(1.0, abs=1e-12)
    assert rows[1]["first_restitution"] == pytest.approx(e, rel=1e-12)


@pytest.mark.slow
def test_spawned_workers_identical(serial, tmp_path, monkeypatch):
    # Where the pool cannot fork (not Linux, or threads in this process) its workers are
    # spawned and import the engine themselves: the same files.
    from synth.bank import executors

    monkeypatch.setattr(executors, "_start_method", lambda: "spawn")
    spec, ref = serial
    result = bank.run(spec, tmp_path / "spawn", jobs=2)
    assert result.ok and result.done == 12
    assert _audio_files(tmp_path / "spawn") == _audio_files(ref)
    assert (tmp_path / "spawn" / mf.JSONL).read_bytes() == (ref / mf.JSONL).read_bytes()


@pytest.mark.slow
def test_example_spec_dry_run_from_the_command_line(tmp_path, cache_dir, capsys):
    # The example spec as written, through `synth bank --dry-run`: 200 planned rows with the
    # varied values, no audio, an estimate; a bad spec is exit status 2 naming the key.
    spec = tmp_path / "bank.toml"
    spec.write_text(EXAMPLE_SPEC)
    assert main(["bank", str(spec), "-o", str(tmp_path / "out"), "--dry-run", "--jobs", "2"]) == 0
    captured = capsys.readouterr()
    assert "estimated" in captured.err
    rows = [json.loads(line) for line in captured.out.splitlines()]
    assert len(rows) == 200 and rows[5]["file"] == "default-0005.flac"
    assert set(rows[0]) >= {"drop.height", "drop.position", "ball.radius", "seed", "status"}
    assert not (tmp_path / "out").exists()
    spec.write_text(EXAMPLE_SPEC.replace("count = 200", "count = 0"))
    assert main(["bank", str(spec), "-o", str(tmp_path / "out2")]) == 2
    assert "count=0" in capsys.readouterr().err


def test_unwritable_folder_is_a_clean_error(tmp_path, monkeypatch):
    # A folder that cannot be written before any sound (a disk already full) is one
    # BankRunError naming the folder, not a traceback.
    spec = _write_spec(tmp_path / "spec", count=2)

    def full(folder, spec):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(mf, "write_spec", full)
    with pytest.raises(bank.BankRunError, match="No space left"):
        bank.run(spec, tmp_path / "out", jobs=1)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="SIGKILL of a worker process")
def test_dask_worker_killed_mid_run_leaves_an_exact_manifest(tmp_path, cache_dir):
    # A real distributed cluster on loopback (two worker processes under nannies); one
    # worker is SIGKILLed once a few rows are recorded. Every row recorded in the
    # manifest keeps the very file it was recorded with (same inode, mtime and size: a
    # finished file is never rewritten by a recomputed task), and at the end every
    # manifest hash matches its file; a rerun completes the bank.
    import threading

    distributed = pytest.importorskip("dask.distributed")
    spec = _write_spec(tmp_path / "spec", count=40)
    out = tmp_path / "out"
    seen: dict = {}
    outcome: dict = {}
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        pids = client.run(os.getpid)

        def render():
            try:
                outcome["result"] = bank.run(spec, out, scheduler=client)
            except Exception as exc:  # noqa: BLE001 - reported by the assertion below
                outcome["error"] = exc

        thread = threading.Thread(target=render)
        thread.start()
        deadline = time.monotonic() + 180
        killed = 0
        while thread.is_alive() and time.monotonic() < deadline:
            for r in mf.read_rows(out) if (out / mf.JSONL).exists() else []:
                if r["index"] not in seen and r.get("status") == "ok":
                    seen[r["index"]] = _file_identity(out / r["file"])
            if not killed and len(seen) >= 12:
                os.kill(next(iter(pids.values())), signal.SIGKILL)
                killed = len(seen)
            time.sleep(0.002)
        thread.join(timeout=300)
    assert killed and "error" not in outcome, outcome
    assert killed < 40  # the kill came before the end
    rows = mf.read_rows(out)
    for r in rows:
        assert mf.sha256_file(out / r["file"]) == r["sha256"], r["index"]
    for index, identity in seen.items():
        f = out / bank.plan(bank.load(spec))[index].file
        assert _file_identity(f) == identity, f"row {index}'s file was rewritten"
    again = bank.run(spec, out, jobs=1)
    assert again.ok
    _check_complete(out, 40)


def _alive(pid: int) -> bool:
    """A process that exists and is not a zombie (Linux /proc)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
def test_workers_die_with_a_killed_parent_and_the_next_run_resumes(tmp_path, cache_dir):
    # SIGKILL to the bank's parent process alone: its pool workers end within a few
    # seconds (they would otherwise render on, holding the folder's lock), and the same
    # command then resumes and completes the bank.
    spec = _write_spec(tmp_path / "spec", count=400)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "synth", "bank", str(spec), "-o", str(out), "--jobs", "2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while len(mf.read_rows(out)) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.002)
    workers = _children(proc.pid)
    assert len(workers) >= 2, "no worker processes found"
    proc.kill()
    proc.wait()
    deadline = time.monotonic() + 5.0  # PR_SET_PDEATHSIG: at once; the watch: 0.5 s
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    orphans = [w for w in workers if _alive(w)]
    for w in orphans:  # leave no process of this test behind, whatever the outcome
        os.kill(w, signal.SIGKILL)
    assert not orphans, "workers outlived their parent"
    assert len(mf.read_rows(out)) < 400  # the kill came before the end
    assert (out / mf.LOCK).is_file()  # left by the killed parent, no longer locked
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    _check_complete(out, 400)  # the lock file and every temporary gone


HISTORY_SPEC = """
preset = "free.toml"
count = 8
seed = 5
name = "{{preset}}-{{index:02d}}"
format = "{fmt}"
[vary]
"render.max_frequency" = [2500.0, 4000.0]
"drop.height" = {{ min = 0.01, max = 0.04 }}
[render]
subtype = "{subtype}"
"""

#: Formats of the history test: WAV of 32-bit floats shows a change in the last bit of
#: a sample; FLAC's 24 bits and OGG's decoded audio are what banks ship. In this order in
#: each of its runs: the runs from a cold cache solve the plate's modes for the WAV bank,
#: FLAC and OGG render in the same run from those modes.
HISTORY_FORMATS = {"wav": "FLOAT", "flac": "PCM_24", "ogg": "VORBIS"}


def _clear_memory_caches() -> None:
    from synth.physics import modes
    from synth.physics.modal_contact import point
    from synth.sound import radiation

    modes.clear_memory_cache()
    radiation.clear_memory_cache()
    point.clear_memory_cache()


def test_plate_modes_depend_only_on_the_plate_and_band(tmp_path, monkeypatch):
    # The modes of a band, asked for after a wider band of the same plate was solved and
    # cached in a process of as many BLAS threads as cores, are the very arrays of a solve
    # of that band alone on one BLAS thread (a bank's pool worker): a wider band's larger
    # basis, or another thread count, moves their last bits.
    import tomllib

    from threadpoolctl import threadpool_limits

    from synth.io.presets import scene_from_dict
    from synth.physics import modes

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache"))
    _clear_memory_caches()
    free = tomllib.loads(SMALL_PRESET.replace('"simply-supported"', '"free"'))
    plate = scene_from_dict(free, "free plate")[0].plate
    modes.modes(plate, max_frequency=4000.0)
    after_wider = modes.modes(plate, max_frequency=2500.0)
    with threadpool_limits(1, user_api="blas"):
        alone = modes.modes(plate, max_frequency=2500.0, cache=False)
    points = [[0.05, 0.05], [0.2, 0.13]]
    assert np.array_equal(after_wider.frequencies, alone.frequencies)
    assert np.array_equal(after_wider.shapes(points), alone.shapes(points))
    _clear_memory_caches()


def _decoded(folder: Path) -> dict:
    import soundfile

    return {name: soundfile.read(folder / name)[0] for name in _audio_files(folder)}


def _assert_same_bank(folder: Path, ref: Path, fmt: str) -> None:
    """The same bytes (WAV, FLAC; and OGG once its stream serial is the row's) and the
    same decoded samples as the reference folder."""
    got, want = _decoded(folder), _decoded(ref)
    assert sorted(got) == sorted(want)
    for name in want:
        assert np.array_equal(got[name], want[name]), name
    assert _audio_files(folder) == _audio_files(ref)


@pytest.mark.slow
def test_bytes_depend_only_on_the_spec(tmp_path, monkeypatch):
    # A free plate (its modes from the Ritz solver and its cache), rows of two bands in
    # one bank per format: rendered from a cold cache with 1 worker, then in reversed row
    # order in one warm process, with 2 forked workers warm, with 2 spawned workers from
    # another cold cache, and on a Dask cluster from a third: every file the same (WAV,
    # FLAC: bytes; OGG: bytes and decoded samples). The three formats share each run's
    # cache and the one cluster (HISTORY_FORMATS): the samples do not depend on the format,
    # the encoding of each format is checked in every kind of process.

    from synth.bank import executors
    from synth.bank import row as bank_row

    distributed = pytest.importorskip("dask.distributed")
    folder = tmp_path / "spec"
    folder.mkdir()
    (folder / "free.toml").write_text(
        SMALL_PRESET.replace('boundary = "simply-supported"', 'boundary = "free"')
    )
    spec_paths = {}
    for fmt in HISTORY_FORMATS:
        spec_paths[fmt] = folder / f"bank-{fmt}.toml"
        spec_paths[fmt].write_text(HISTORY_SPEC.format(fmt=fmt, subtype=HISTORY_FORMATS[fmt]))

    def run_all(name: str, **how) -> None:  # each format's bank into name/fmt, as the ref
        for fmt in HISTORY_FORMATS:
            assert bank.run(spec_paths[fmt], tmp_path / name / fmt, **how).ok
            if name != "cold1":
                _assert_same_bank(tmp_path / name / fmt, tmp_path / "cold1" / fmt, fmt)

    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache1"))
    _clear_memory_caches()
    run_all("cold1", jobs=1)

    for fmt in HISTORY_FORMATS:  # this process is warm with every band now
        spec = bank.load(spec_paths[fmt])
        reversed_dir = tmp_path / "reversed" / fmt
        reversed_dir.mkdir(parents=True)
        for item in reversed(bank.plan(spec)):
            assert bank_row.render_item(spec, item, str(reversed_dir)).row["status"] == "ok"
        _assert_same_bank(reversed_dir, tmp_path / "cold1" / fmt, fmt)

    run_all("warm2", jobs=2)

    # spawned workers (one BLAS thread each, this process one per core) from another
    # cold cache: they solve the plate's modes themselves
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache2"))
    monkeypatch.setattr(executors, "_start_method", lambda: "spawn")
    _clear_memory_caches()
    run_all("cold2", jobs=2)

    # Dask's workers start with one BLAS thread (this process has one per core), from
    # another cold cache: they solve the plate's modes themselves
    monkeypatch.setenv("SYNTH_CACHE_DIR", str(tmp_path / "cache3"))
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        run_all("dask", scheduler=cluster.scheduler_address)


@pytest.mark.parametrize("fmt, subtype", [("ogg", "VORBIS"), ("wav", "FLOAT")])
def test_two_runs_write_the_same_bytes(tmp_path, cache_dir, fmt, subtype):
    # An Ogg stream's serial number is drawn at random by the encoder, a float WAV's PEAK
    # chunk carries the time of writing: both are set from the row, so two runs of one
    # spec write the same bytes; the manifest records the hash of the decoded samples too.
    import struct

    from synth.store.reproducible import decoded_sha256, ogg_serial_for

    spec = _write_spec(
        tmp_path / "spec",
        count=2,
        extra=f'[render]\nsubtype = "{subtype}"\n',
    )
    spec.write_text(spec.read_text().replace('format = "wav"', f'format = "{fmt}"'))
    assert bank.run(spec, tmp_path / "a", jobs=1).ok
    time.sleep(1.1)  # a timestamp in seconds would differ
    assert bank.run(spec, tmp_path / "b", jobs=1).ok
    assert _audio_files(tmp_path / "a") == _audio_files(tmp_path / "b")
    for row in mf.read_rows(tmp_path / "a"):
        data = (tmp_path / "a" / row["file"]).read_bytes()
        assert row["audio_sha256"] == decoded_sha256(data)
        if fmt == "ogg":
            assert struct.unpack_from("<I", data, 14)[0] == ogg_serial_for(row["file"])


def test_manifest_columns_and_a_row_rendered_again_from_its_scene(serial):
    # The first impact's speed is the free fall's sqrt(2 g h) (closed form); the true peak
    # is at least the sample peak (interpolation only adds points); the centroid lies in
    # (0, fs/2); and the row's `scene` column renders the very samples of its file.
    import io

    import soundfile

    from synth.io.presets import scene_from_dict
    from synth.sound.render import render
    from synth.store.reproducible import decoded_sha256

    _, ref = serial
    rows = mf.read_rows(ref)
    for row in rows:
        scene, options = scene_from_dict(row["scene"], f"row {row['index']}")
        h = row["drop.height"]
        assert row["first_speed"] == pytest.approx((2 * scene.gravity * h) ** 0.5, rel=1e-9)
        assert row["true_peak_dbtp"] >= row["peak_dbfs"]
        assert 0 < row["spectral_centroid"] < 8000.0
        assert row["first_contact_time"] > 0 and row["first_peak_force"] > 0
    row = rows[5]
    scene, options = scene_from_dict(row["scene"], "row 5")
    subtype = options.pop("subtype", "PCM_24")
    rendered = render(scene, **options)
    buf = io.BytesIO()
    soundfile.write(buf, rendered.audio, rendered.samplerate, subtype=subtype, format="WAV")
    assert decoded_sha256(buf.getvalue()) == row["audio_sha256"]


def test_redo_renders_chosen_rows_again(serial, tmp_path):
    # --redo 2,5-6: those three files are replaced (new inodes, same bytes: a row's bytes
    # depend on its inputs only), the other nine untouched; a bad range is refused.
    spec, ref = serial
    out = tmp_path / "copy"
    out.mkdir()
    for p in ref.iterdir():
        (out / p.name).write_bytes(p.read_bytes())
    before = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    assert main(["bank", str(spec), "-o", str(out), "--jobs", "1", "--redo", "2,5-6"]) == 0
    after = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    changed = sorted(name for name in before if after[name] != before[name])
    assert changed == ["small-002.wav", "small-005.wav", "small-006.wav"]
    assert _audio_files(out) == _audio_files(ref)
    with pytest.raises(BankSpecError, match="redo"):
        bank.run(spec, out, jobs=1, redo="10-20")


def test_bank_gain_keeps_relative_levels(serial, tmp_path):
    # One gain for the bank: the loudest true peak to -1 dBTP. Every file is the source
    # scaled by that gain (decoded samples within one 24-bit step of the exact product:
    # half a step of rounding, and at most half a step at full scale from libsndfile's
    # scaling, x (2^23 - 1) when writing, / 2^23 when reading), the relative levels
    # kept; a rerun skips every file; the source is untouched.
    import soundfile

    from synth.bank.gain import apply_gain

    _, ref = serial
    before = _tree(ref)
    out = tmp_path / "gained"
    assert main(["bank-gain", str(ref), "-o", str(out)]) == 0
    rows = mf.read_rows(out)
    src_rows = mf.read_rows(ref)
    gain = rows[0]["gain_db"]
    assert gain == pytest.approx(-1.0 - max(r["true_peak_dbtp"] for r in src_rows), abs=1e-6)
    assert max(r["true_peak_dbtp"] for r in rows) == pytest.approx(-1.0, abs=1e-6)
    step = 1.0 / 2**23
    for row, src in zip(rows, src_rows):
        assert row["gain_db"] == gain and row["file"] == src["file"]
        scaled, _ = soundfile.read(out / row["file"])
        source, _ = soundfile.read(ref / src["file"])
        assert np.max(np.abs(scaled - source * 10 ** (gain / 20))) <= step
        assert mf.sha256_file(out / row["file"]) == row["sha256"]
    again = apply_gain(ref, out)
    assert (again.done, again.skipped) == (0, len(rows))
    assert _tree(ref) == before


def test_bank_gain_resumes_over_a_bank_stored_by_an_earlier_version(tmp_path, cache_dir):
    # A bank whose bank.json holds the spec as written (earlier versions), scaled into a
    # folder; the bank resumed (its bank.json now canonical), then scaled again into the
    # same folder: the same bank and gain, so every file is skipped.
    from synth.bank import spec as bank_spec
    from synth.bank.gain import apply_gain

    spec = _write_spec(tmp_path / "spec", count=2)
    src, out = tmp_path / "bank", tmp_path / "gained"
    assert bank.run(spec, src, jobs=1).ok
    mf.write_spec(src, bank_spec.load(spec).as_dict())
    assert apply_gain(src, out).done == 2
    assert bank.run(spec, src, jobs=1).skipped == 2
    assert mf.read_spec(src) == bank_spec.load(spec).stored_form()
    again = apply_gain(src, out)
    assert (again.done, again.skipped) == (0, 2)


def test_trim_cuts_the_tail_with_a_fade(serial, tmp_path, cache_dir):
    # [trim] below_db = -40: each file is the untrimmed one up to 40 dB below its peak at
    # the end, the last 10 ms faded to 0 (raised cosine), and the manifest says so; the
    # stop reason of the bounces is recorded whatever the trim.
    import soundfile

    spec, ref = serial
    trimmed_spec = _write_spec(tmp_path / "spec", extra="[trim]\nbelow_db = -40.0\nfade = 0.01\n")
    out = tmp_path / "out"
    assert bank.run(trimmed_spec, out, jobs=1).ok
    fs = 16000
    fade = round(0.01 * fs)
    for row, whole in zip(mf.read_rows(out), mf.read_rows(ref)):
        assert row["length_reason"] == "tail-cut" and whole["length_reason"] == "whole"
        assert row["stop_reason"] == whole["stop_reason"] and row["stop_reason"]
        cut, _ = soundfile.read(out / row["file"])
        full, _ = soundfile.read(ref / whole["file"])
        n = cut.size
        assert n < full.size and row["duration"] == pytest.approx(n / fs)
        assert np.array_equal(cut[: n - fade], full[: n - fade]) and cut[-1] == 0.0
        # the cut is where the untrimmed sound stays 40 dB below its peak (decided on the
        # samples before their 24-bit quantization: within one step here)
        level, step = np.max(np.abs(full)) * 10 ** (-40 / 20), 2.0**-23
        assert np.max(np.abs(full[n:])) < level + step and abs(full[n - 1]) > level - step


def test_preview_and_contact_sheet_of_a_finished_bank(serial, tmp_path):
    # The preview is every file in index order with 0.25 s of silence between two (the
    # samples themselves, 32-bit float WAV); the sheet is a PNG of 3 rows of 4 sounds.
    import soundfile

    pytest.importorskip("matplotlib")
    _, ref = serial
    before = _tree(ref)
    wav, png = tmp_path / "preview.wav", tmp_path / "sheet.png"
    assert main(["bank", str(ref), "--preview", str(wav), "--sheet", str(png)]) == 0
    joined, fs = soundfile.read(wav)
    gap = round(0.25 * fs)
    at = 0
    for i, row in enumerate(mf.read_rows(ref)):
        audio, _ = soundfile.read(ref / row["file"])
        if i:
            assert not joined[at : at + gap].any()
            at += gap
        assert np.array_equal(joined[at : at + audio.size], audio)
        at += audio.size
    assert at == joined.size
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert _tree(ref) == before
    assert main(["bank", str(ref)]) == 2  # a bank's folder without --sheet or --preview


def test_sampling_lhs_and_grid(tmp_path):
    # lhs: in each block of LHS_BLOCK rows every range component has one row in each of
    # LHS_BLOCK equal strata (log strata for a log range); a row depends on its index
    # alone. grid: `steps` values per range, ends included (geometric with log).
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    vary = {
        "drop.height": {"min": 0.01, "max": 0.04, "log": True},
        "drop.position": {"min": [0.05, 0.05], "max": [0.25, 0.15]},
    }
    n = 2 * S.LHS_BLOCK + 5
    lhs = S.from_dict(
        {"preset": "small.toml", "count": n, "sampling": "lhs", "vary": vary}, base_dir=tmp_path
    )
    items = S.plan(lhs)
    for block in range(2):
        rows = items[block * S.LHS_BLOCK : (block + 1) * S.LHS_BLOCK]
        h = np.array([r.values["drop.height"] for r in rows])
        strata = np.floor(np.log(h / 0.01) / np.log(4.0) * S.LHS_BLOCK)
        assert sorted(strata) == list(range(S.LHS_BLOCK))
        for c, (lo, hi) in enumerate([(0.05, 0.25), (0.05, 0.15)]):
            x = np.array([r.values["drop.position"][c] for r in rows])
            assert sorted(np.floor((x - lo) / (hi - lo) * S.LHS_BLOCK)) == list(range(S.LHS_BLOCK))
    shorter = S.from_dict(
        {"preset": "small.toml", "count": 40, "sampling": "lhs", "vary": vary}, base_dir=tmp_path
    )
    assert S.plan(shorter) == items[:40]
    grid_vary = {k: dict(v, steps=3) for k, v in vary.items()}
    grid = S.from_dict(
        {"preset": "small.toml", "sampling": "grid", "vary": grid_vary}, base_dir=tmp_path
    )
    items = S.plan(grid)
    assert len(items) == 9
    assert sorted({i.values["drop.height"] for i in items}) == pytest.approx([0.01, 0.02, 0.04])
    with pytest.raises(BankSpecError, match="steps"):
        S.from_dict({"preset": "small.toml", "sampling": "grid", "vary": vary}, base_dir=tmp_path)


def test_subfolders_in_the_name_template(tmp_path, cache_dir):
    # "/" in the template makes subfolders (created as the files are written); a name
    # with "..", a hidden part or an absolute path is refused before any work.
    spec = _write_spec(tmp_path / "spec", count=4)
    spec.write_text(
        spec.read_text().replace(
            'name = "{preset}-{index:03d}"', 'name = "r{ball.radius:.3f}/{preset}-{index:03d}"'
        )
    )
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    rows = mf.read_rows(out)
    assert all(r["file"].startswith(("r0.004/", "r0.005/")) for r in rows)
    for r in rows:
        assert mf.sha256_file(out / r["file"]) == r["sha256"]
    assert bank.run(spec, out, jobs=1).skipped == 4
    for n, bad in enumerate(("../{index}", "/abs/{index}", "a/.hidden{index}", "a//{index}")):
        (tmp_path / f"bad{n}").mkdir()
        text = _bad(
            tmp_path / f"bad{n}",
            BASE + f'name = "{bad}"\n[vary]\n"drop.height" = [0.01, 0.02]\n',
        )
        assert "name=" in text


def test_value_labels_in_names(tmp_path):
    # {ball.radius:label} takes the label of the row's value from [labels]; a value
    # without a label is refused at plan time naming it.
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    data = {
        "preset": "small.toml",
        "name": "{ball.radius:label}-h{drop.height:.2f}",
        "vary": {"ball.radius": [0.004, 0.005], "drop.height": [0.01, 0.02]},
        "labels": {"ball.radius": {"0.004": "small", "0.005": "large"}},
    }
    names = [i.file for i in S.plan(S.from_dict(data, base_dir=tmp_path))]
    assert names == ["small-h0.01.flac", "small-h0.02.flac", "large-h0.01.flac", "large-h0.02.flac"]
    data["labels"] = {"ball.radius": {"0.004": "small"}}
    with pytest.raises(BankSpecError, match=r"labels\.ball\.radius.*0\.005"):
        S.plan(S.from_dict(data, base_dir=tmp_path))


def test_min_distance_between_rows(tmp_path):
    # Every two rows are at least min_distance apart in the unit cube of the ranges (log
    # ranges in log); a shorter bank is a prefix; a distance leaving no room is refused.
    from synth.bank import spec as S

    (tmp_path / "small.toml").write_text(SMALL_PRESET)
    data = {
        "preset": "small.toml",
        "count": 40,
        "min_distance": 0.1,
        "vary": {
            "drop.height": {"min": 0.01, "max": 0.04, "log": True},
            "drop.position": {"min": [0.05, 0.05], "max": [0.25, 0.15]},
        },
    }
    items = S.plan(S.from_dict(data, base_dir=tmp_path))
    s = S.from_dict(data, base_dir=tmp_path)
    pts = np.array([S.sampling._unit_point(s, i.values) for i in items])
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    assert d[~np.eye(len(pts), dtype=bool)].min() >= 0.1
    assert S.plan(S.from_dict(dict(data, count=20), base_dir=tmp_path)) == items[:20]
    with pytest.raises(BankSpecError, match="min_distance"):
        S.plan(S.from_dict(dict(data, min_distance=0.9), base_dir=tmp_path))


def test_final_check_drops_a_row_whose_file_changed(tmp_path, cache_dir, monkeypatch):
    # A file altered after its row was recorded (by anything: another writer, a disk)
    # is found by the end-of-run check: left out of the manifest, the bank not reported
    # complete, and the next run redoes it.
    spec = _write_spec(tmp_path / "spec", count=4)
    out = tmp_path / "out"
    append = mf.Manifest.append

    def append_then_alter(self, row):
        append(self, row)
        if row["index"] == 2:
            (out / row["file"]).write_bytes(b"altered")

    monkeypatch.setattr(mf.Manifest, "append", append_then_alter)
    result = bank.run(spec, out, jobs=1)
    assert not result.ok and "SHA-256" in result.stopped and result.done == 3
    assert [r["index"] for r in mf.read_rows(out)] == [0, 1, 3]
    monkeypatch.setattr(mf.Manifest, "append", append)
    again = bank.run(spec, out, jobs=1)
    assert again.ok and (again.done, again.skipped) == (1, 3)
    _check_complete(out, 4)


LABELLED_SPEC = """
preset = "{preset}"
count = 3
seed = 3
name = "{{preset}}-{{ball.radius:label}}-{{index:02d}}"
format = "{fmt}"
{tags}[vary]
"drop.height" = {{ min = 0.01, max = 0.05 }}
"ball.radius" = [0.004, 0.005]
[labels]
"ball.radius" = {{ "0.004" = "{small}", "0.005" = "large" }}
"""


def _labelled_spec(folder: Path, *, preset="small.toml", small="small", tags=None, fmt="ogg"):
    """The small bank with a labelled axis, its name from the preset and the labels."""
    folder.mkdir(parents=True, exist_ok=True)
    tags = "" if tags is None else f"tags = {tags}\n"
    (folder / preset).write_text(SMALL_PRESET)
    path = folder / "bank.toml"
    path.write_text(LABELLED_SPEC.format(preset=preset, small=small, tags=tags, fmt=fmt))
    return path


def test_free_tags_and_value_labels_in_every_manifest_row(tmp_path, cache_dir):
    # The spec's free tags (a list of keywords or a table of name = value) and each row's
    # value labels are columns of every row, in the JSON Lines and the CSV manifest;
    # editing a tag resumes the bank without rendering and rewrites the rows' tags.
    import csv

    spec = _labelled_spec(tmp_path / "spec", tags='{ category = "impact", take = 2 }', fmt="wav")
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    rows = mf.read_rows(out)
    assert [r["tags"] for r in rows] == [{"category": "impact", "take": 2}] * 3
    assert [r["labels"] for r in rows] == [
        {"ball.radius": "small" if r["ball.radius"] == 0.004 else "large"} for r in rows
    ]
    with open(out / mf.CSV, newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [json.loads(r["tags"]) for r in table] == [r["tags"] for r in rows]
    assert [json.loads(r["labels"]) for r in table] == [r["labels"] for r in rows]
    before = {p.name: _file_identity(p) for p in out.glob("*.wav")}
    spec.write_text(
        spec.read_text().replace(
            'tags = { category = "impact", take = 2 }', 'tags = ["impact", "glass"]'
        )
    )
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (0, 3)
    assert [r["tags"] for r in mf.read_rows(out)] == [["impact", "glass"]] * 3
    assert {p.name: _file_identity(p) for p in out.glob("*.wav")} == before
    _check_complete(out, 3)


@pytest.mark.parametrize(
    "bad, says",
    [("[1, 2]", "tags"), ("{ a = [1] }", "tags.a"), ('[""]', "tags"), ('"x"', "tags")],
)
def test_bad_tags_refused_naming_the_key(tmp_path, bad, says):
    from synth.bank import spec as S

    spec = _labelled_spec(tmp_path, tags=bad)
    with pytest.raises(BankSpecError, match=rf"{says}="):
        S.load(spec)


def test_renamed_preset_and_edited_label_resume_without_rendering(tmp_path, cache_dir):
    # Neither the preset's name nor a value's label changes a sound: the bank resumes
    # (nothing rendered), the files take their new names, and every file's bytes (OGG's
    # serial follows the name) equal those of the new spec rendered afresh.
    spec = _labelled_spec(tmp_path / "spec")
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    assert sorted(p.name for p in out.glob("*.ogg"))[0].startswith("small-large-")
    spec = _labelled_spec(tmp_path / "spec2", preset="tiny.toml", small="little")
    dry = bank.run(spec, out, jobs=1, dry_run=True)
    assert (len(dry.planned_rows), dry.skipped) == (0, 3)
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped, result.renamed) == (0, 3, 3)
    _check_complete(out, 3)
    fresh = tmp_path / "fresh"
    assert bank.run(spec, fresh, jobs=1).ok
    assert _audio_files(out) == _audio_files(fresh)
    assert all(name.startswith("tiny-") for name in _audio_files(out))
    assert "little" in "".join(_audio_files(out))
    for name in (mf.JSONL, mf.CSV, mf.SPEC):
        assert (out / name).read_bytes() == (fresh / name).read_bytes()


def test_bank_gain_that_would_clip_is_refused_naming_the_file(serial, tmp_path):
    # The gain pass encodes through the render's encoder (synth.bank.row.encode): a
    # gain that takes a PCM file above full scale is refused naming the file, its peak
    # and what to change, before that file is written.
    from synth.bank.gain import apply_gain
    from synth.bank.row import CLIP_ADVICE, encode

    _, ref = serial
    with pytest.raises(BankSpecError, match=r"'small-\d{3}\.wav' peaks at \+[\d.]+ dBFS.*lower"):
        apply_gain(ref, tmp_path / "loud", target="loudness", level=-1.0)
    assert not list((tmp_path / "loud").glob("*.wav"))
    over = np.array([0.5, -1.25, 0.0])
    with pytest.raises(BankSpecError, match=r"'x\.flac' peaks at \+1\.94 dBFS.*normalize"):
        encode(over, 16000, "flac", "PCM_24", "x.flac", CLIP_ADVICE)
    data = encode(over, 16000, "wav", "FLOAT", "x.wav", CLIP_ADVICE)  # floats hold it
    assert data == encode(over, 16000, "wav", "FLOAT", "x.wav", CLIP_ADVICE)


def test_bank_gain_follows_a_renamed_preset_without_scaling_again(tmp_path, cache_dir):
    # The source bank's preset renamed (the same sounds under new names, the bank
    # resumed): the gain pass into the same folder is not refused, scales nothing again,
    # moves its files to the new names, and its folder then equals a fresh pass's.
    from synth.bank.gain import apply_gain

    spec = _labelled_spec(tmp_path / "spec")
    src, out = tmp_path / "bank", tmp_path / "gained"
    assert bank.run(spec, src, jobs=1).ok
    assert apply_gain(src, out).done == 3
    renamed = _labelled_spec(tmp_path / "spec2", preset="tiny.toml", small="little")
    assert bank.run(renamed, src, jobs=1).renamed == 3
    again = apply_gain(src, out)
    assert (again.done, again.skipped, again.renamed, again.orphans) == (0, 3, 3, [])
    fresh = apply_gain(src, tmp_path / "fresh")
    assert fresh.done == 3
    assert _audio_files(out) == _audio_files(tmp_path / "fresh")
    assert all(name.startswith("tiny-") for name in _audio_files(out))
    for name in (mf.JSONL, mf.CSV):
        assert (out / name).read_bytes() == (tmp_path / "fresh" / name).read_bytes()


def test_files_outside_the_manifest_are_reported_and_removed_only_with_prune(
    tmp_path, cache_dir, capsys
):
    # Audio files that neither the manifest nor the plan names (an earlier template's
    # file a stopped run did not record, one copied there by hand, in a subfolder) are
    # named in the summary and left; a dry run with --prune deletes nothing; --prune
    # deletes exactly them (and the folder they leave empty), nothing of the bank. The
    # same in the gain pass' folder.
    from synth.bank.gain import apply_gain

    spec = _write_spec(tmp_path / "spec", count=2)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    stray = ["old-000.wav", "takes/old-001.flac"]
    (out / "takes").mkdir()
    for name in stray:
        (out / name).write_bytes((out / "small-000.wav").read_bytes())
    (out / "notes.txt").write_text("kept: not audio")
    assert main(["bank", str(spec), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "2 files in the folder are not in the manifest" in err and "--prune" in err
    assert all(name in err for name in stray)
    before = _tree(out)
    assert main(["bank", str(spec), "-o", str(out), "--dry-run", "--prune"]) == 0
    assert "2 files in the folder are not in the manifest" in capsys.readouterr().err
    assert _tree(out) == before
    result = bank.run(spec, out, jobs=1, prune=True)
    assert result.ok and result.pruned and result.orphans == stray
    assert not (out / "takes").exists() and (out / "notes.txt").is_file()
    _check_complete_files = {r["file"] for r in mf.read_rows(out)}
    assert set(_audio_files(out)) == _check_complete_files == {"small-000.wav", "small-001.wav"}
    assert bank.run(spec, out, jobs=1).orphans == []

    gained = tmp_path / "gained"
    assert apply_gain(out, gained).done == 2
    (gained / "extra.ogg").write_bytes(b"not ours")
    again = apply_gain(out, gained)
    assert again.orphans == ["extra.ogg"] and (gained / "extra.ogg").is_file()
    assert "--prune" in again.summary()
    assert main(["bank-gain", str(out), "-o", str(gained), "--prune"]) == 0
    assert not (gained / "extra.ogg").exists() and len(_audio_files(gained)) == 2


@pytest.mark.slow
def test_bench_bank_prints_the_rates_of_both_pools_and_the_gain_pass(cache_dir):
    # `synth bench bank` measures, in one run, sounds per second of --jobs 1 and
    # --jobs 2 and files per second of the bank-gain pass, and prints each in its table
    from benchmarks import bank as bench

    r = bench.run_bank(count=4, process_files=1, dask=False)
    assert all(r[k]["rate"] > 0 for k in ("jobs1", "jobs2", "gain"))
    table = bench.format_bank(r)
    rows = {line.split(" | ")[0]: line for line in table.splitlines() if line.startswith("| ")}
    assert {"| `synth bank --jobs 1`", "| `synth bank --jobs 2`"} <= set(rows)
    gain = [line for line in rows.values() if "bank-gain" in line]
    assert len(gain) == 1 and f"{r['gain']['rate']:.1f}" in gain[0]
    assert f"{r['jobs1']['rate']:.1f}" in rows["| `synth bank --jobs 1`"]
    assert f"{r['jobs2']['rate']:.1f}" in rows["| `synth bank --jobs 2`"]
    # and the dry run's estimate of each against its run's wall time
    estimate = [line for line in table.splitlines() if "`--dry-run` estimate" in line]
    assert len(estimate) == 1
    for j in (1, 2):
        f = r[f"jobs{j}"]
        said = f"`--jobs {j}` {f['estimate']:.1f} s estimated, {f['seconds']:.1f} s run"
        assert said in estimate[0]


#: Steel, rubber and ABS balls on the small plate with the thesis' lossless Hertz contact:
#: rubber and ABS then keep e near 0.99 and, unbounded, bounce on for tens of seconds.
MATERIALS_SPEC = """
preset = "small.toml"
name = "{{ball.material}}-h{{drop.height:.2f}}"
format = "wav"
[vary]
"ball.material" = ["steel", "rubber", "abs"]
"drop.height" = [0.02, 0.05]
[render]
max_duration = 30.0
{render}
"""


def _materials_spec(folder: Path, render: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "small.toml").write_text(SMALL_PRESET + '[contact]\nmodel = "thesis"\n')
    path = folder / "bank.toml"
    path.write_text(MATERIALS_SPEC.format(render=render))
    return path


@pytest.mark.slow
def test_near_elastic_balls_stop_at_the_banks_impact_limit(tmp_path, cache_dir):
    # Rubber and ABS keep the lossless contact (e > 0.97 at every impact): with the
    # render's own limits their series run for tens of seconds (rubber from 5 cm to the
    # 30 s max_duration). In a bank the documented impact limit stops every drop: each
    # row records why (max-impacts, or its own end before it) and its impact count, none
    # reaches max_duration, and the restitution of each impact is the physics' own (the
    # bound cuts the series, it changes no bounce).
    from synth.bank.spec import BANK_MAX_IMPACTS
    from synth.io.presets import scene_from_dict
    from synth.physics.bounces import simulate_scene

    spec = _materials_spec(tmp_path / "spec")
    out = tmp_path / "out"
    result = bank.run(spec, out, jobs=1)
    assert result.ok and result.done == 6
    _check_complete(out, 6)
    rows = mf.read_rows(out)
    for row in rows:
        assert row["stop_reason"] != "max-duration"
        assert 1 <= row["ticks"] <= BANK_MAX_IMPACTS
        assert row["scene"]["render"]["max_impacts"] == BANK_MAX_IMPACTS
        assert (row["stop_reason"] == "max-impacts") == (row["ticks"] == BANK_MAX_IMPACTS)
        scene, options = scene_from_dict(row["scene"], "row")
        unbounded = simulate_scene(scene, max_duration=options["max_duration"])
        bounded = simulate_scene(
            scene, max_duration=options["max_duration"], max_impacts=BANK_MAX_IMPACTS
        )
        assert [i.restitution for i in bounded] == [
            i.restitution for i in unbounded[: len(bounded)]
        ]
        assert row["first_restitution"] == unbounded[0].restitution
        if row["ball.material"] in ("rubber", "abs"):
            assert row["stop_reason"] == "max-impacts", row
            assert min(i.restitution for i in bounded) > 0.97
            # unbounded, the same drop lasts more than 5 s (the bank's row ends at the limit)
            assert unbounded.duration > 5.0 and len(unbounded) > BANK_MAX_IMPACTS
            if row["drop.height"] == 0.05 and row["ball.material"] == "rubber":
                assert unbounded.stop_reason == "max-duration"
    # the user's own bounds, from [render], are taken and recorded the same way: steel
    # (e about 0.89) falls 3 dB in kinetic energy within a few bounces and stops at the
    # level rule, after the first impact n whose rebound energy (e_1 ... e_n)^2 of the
    # first is below -3 dB; rubber (e about 0.99) at 5 impacts
    spec = _materials_spec(tmp_path / "own", "max_impacts = 5\nbounce_floor_db = -3.0\n")
    out = tmp_path / "own-out"
    assert bank.run(spec, out, jobs=1).ok
    for row in mf.read_rows(out):
        scene, options = scene_from_dict(row["scene"], "row")
        assert (options["max_impacts"], options["bounce_floor_db"]) == (5, -3.0)
        e = np.array([i.restitution for i in simulate_scene(scene)])
        below = np.flatnonzero(np.cumprod(e**2) < 10 ** (-3.0 / 10))
        if row["ball.material"] == "steel":
            assert row["stop_reason"] == "floor" and row["ticks"] == below[0] + 1 < 5, row
        else:
            assert row["stop_reason"] == "max-impacts" and row["ticks"] == 5, row
            assert below[0] + 1 > 5


@pytest.mark.parametrize(
    "render, says",
    [
        ("max_impacts = 0", "render.max_impacts=0 must be an integer in [1, 100000]"),
        ("max_impacts = 2.5", "render.max_impacts=2.5 must be an integer in [1, 100000]"),
        ("max_impacts = 100001", "render.max_impacts=100001 must be an integer in [1, 100000]"),
        ("bounce_floor_db = 0.0", "render.bounce_floor_db=0.0 must be < 0 (dB"),
        ('bounce_floor_db = "low"', "render.bounce_floor_db='low' must be a real number < 0"),
        ("bounce_floor_db = inf", "render.bounce_floor_db=inf must be finite and < 0"),
    ],
)
def test_bad_bounce_limits_refused_at_plan_time(tmp_path, render, says):
    # In the spec's [render] or as an axis: refused before any work, naming the key, its
    # value and the allowed range (and, for an axis, the row).
    assert says in _bad(tmp_path, BASE + f"[render]\n{render}\n")
    key, value = render.split(" = ")
    text = _bad(tmp_path, BASE + f'[vary]\n"render.{key}" = [{value}]\n')
    assert "row 0 (" in text and says.removeprefix("render.") in text, text


def _edit_json(path: Path, **changes) -> None:
    """Set (or, with None, remove) keys of a stored JSON record."""
    data = json.loads(path.read_text())
    for key, value in changes.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")


def test_a_bank_of_another_engine_is_refused_naming_both_versions(tmp_path, cache_dir, capsys):
    # bank.json records the engine that rendered the bank. Resumed by another engine (or
    # one whose bank.json records none), the run, its dry run and the command refuse it
    # naming both versions and --force, and write or delete nothing; --force starts over.
    import synth

    spec = _write_spec(tmp_path / "spec", count=2)
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    assert mf.read_spec(out)["engine"] == synth.__version__
    for recorded, says in (("0.0.1", "made by synth 0.0.1"), (None, "recorded no version")):
        _edit_json(out / mf.SPEC, engine=recorded)
        before = _tree(out)
        for dry_run in (False, True):
            with pytest.raises(BankSpecError) as info:
                bank.run(spec, out, jobs=1, dry_run=dry_run)
            text = str(info.value)
            assert says in text and f"this is synth {synth.__version__}" in text, text
            assert "--force" in text
        assert main(["bank", str(spec), "-o", str(out), "--jobs", "1"]) == 2
        assert says in capsys.readouterr().err
        assert _tree(out) == before
    result = bank.run(spec, out, jobs=1, force=True)
    assert result.ok and (result.done, result.skipped) == (2, 0)
    assert mf.read_spec(out)["engine"] == synth.__version__
    _check_complete(out, 2)


def test_a_gain_pass_of_another_engine_is_refused_naming_both_versions(serial, tmp_path):
    # gain.json records the engine of the pass and the source's (in its spec): a pass
    # resumed by another engine is refused, nothing in the folder changed.
    import synth
    from synth.bank.gain import GAIN_FILE, apply_gain

    _, ref = serial
    out = tmp_path / "gained"
    assert apply_gain(ref, out).done == 12
    record = json.loads((out / GAIN_FILE).read_text())
    assert record["engine"] == record["spec"]["engine"] == synth.__version__
    _edit_json(out / GAIN_FILE, engine="0.0.1")
    before = _tree(out)
    with pytest.raises(BankSpecError) as info:
        apply_gain(ref, out)
    text = str(info.value)
    assert "made by synth 0.0.1" in text and f"this is synth {synth.__version__}" in text, text
    assert _tree(out) == before


def _file_loudness(path: Path) -> float:
    """Integrated loudness of an audio file, LUFS (ITU-R BS.1770 by pyloudnorm), zero-padded
    to one 400 ms gating block as the manifest measures it."""
    import pyloudnorm
    import soundfile

    x, fs = soundfile.read(path, dtype="float64")
    x = np.pad(x, (0, max(0, round(0.4 * fs) - x.size)))
    return pyloudnorm.Meter(fs, block_size=0.4).integrated_loudness(x)


def test_bank_gain_brings_the_median_loudness_to_its_level(serial, tmp_path):
    # target = "loudness": the median loudness of the scaled files, measured again from
    # them, is the level asked for, within 0.01 LU (the pass stops within 0.001 LU of it,
    # measured on the samples before quantization; the files are within one 24-bit step of
    # them, which moves a loudness above -70 LUFS by far less). These quiet sounds (-70 to
    # -60 LUFS at the physical level) are the hard case: BS.1770's gates let more of their
    # blocks in once they are lifted, so their loudness does not rise dB for dB with the
    # gain, and the manifest's loudness of each scaled file is that of the file too.
    # The level is chosen 3 dB under the clip of the loudest true peak.
    import statistics

    pytest.importorskip("pyloudnorm")
    from synth.bank.gain import apply_gain

    _, ref = serial
    src_rows = mf.read_rows(ref)
    median = statistics.median(r["loudness_lufs"] for r in src_rows if r["loudness_lufs"])
    level = round(median + (-3.0 - max(r["true_peak_dbtp"] for r in src_rows)), 3)
    out = tmp_path / "gained"
    result = apply_gain(ref, out, target="loudness", level=level)
    assert result.done == len(src_rows) and result.reached == pytest.approx(level, abs=1e-3)
    rows = mf.read_rows(out)
    measured = [_file_loudness(out / r["file"]) for r in rows]
    assert statistics.median(measured) == pytest.approx(level, abs=0.01)
    for value, row in zip(measured, rows):
        assert row["loudness_lufs"] == pytest.approx(value, abs=0.01)
    again = apply_gain(ref, out, target="loudness", level=level)  # the same gain found
    assert (again.done, again.skipped, again.gain_db) == (0, len(rows), result.gain_db)


#: Runs a gain pass in a child process, each file's scaling slowed (so that the test can
#: kill it between two files): argv = source, out.
SLOW_GAIN = """
import sys, time
from synth.bank import gain
encode = gain.encode
def slow(*args):
    time.sleep(0.25)
    return encode(*args)
gain.encode = slow
gain.apply_gain(sys.argv[1], sys.argv[2])
"""


@pytest.mark.slow
def test_bank_gain_killed_mid_pass_resumes_scaling_each_file_once(serial, tmp_path):
    # A gain pass SIGKILLed after a few files: the rerun scales only the files not
    # recorded (those recorded keep their inode and mtime), no temporary is left, every
    # row is in the manifest once with its file's hash, and the folder equals that of a
    # pass never interrupted, byte for byte.
    from synth.bank.gain import apply_gain

    _, ref = serial
    out = tmp_path / "gained"
    child = subprocess.Popen([sys.executable, "-c", SLOW_GAIN, str(ref), str(out)])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and child.poll() is None:
        if (out / mf.JSONL).is_file() and len((out / mf.JSONL).read_text().splitlines()) >= 3:
            break
        time.sleep(0.01)
    child.send_signal(signal.SIGKILL)
    child.wait()
    recorded = [r for r in mf.read_rows(out) if r["status"] == "ok"]
    assert 3 <= len(recorded) < 12, "the pass was not killed mid-way"
    before = {r["file"]: _file_identity(out / r["file"]) for r in recorded}
    again = apply_gain(ref, out)
    assert (again.done, again.skipped) == (12 - len(recorded), len(recorded))
    assert {name: _file_identity(out / name) for name in before} == before
    rows = mf.read_rows(out)
    assert [r["index"] for r in rows] == list(range(12))
    for r in rows:
        assert mf.sha256_file(out / r["file"]) == r["sha256"]
    assert not [p for p in out.iterdir() if mf.TEMPORARY.match(p.name)]
    assert apply_gain(ref, tmp_path / "fresh").done == 12
    assert _audio_files(out) == _audio_files(tmp_path / "fresh")
    for name in (mf.JSONL, mf.CSV):
        assert (out / name).read_bytes() == (tmp_path / "fresh" / name).read_bytes()


def test_trim_max_length_and_audible_duration(serial, tmp_path, cache_dir):
    # [trim] max_length = 0.1 s (below_db so low that the tail is never cut first): every
    # file is the untrimmed one's first 0.1 s, its last 10 ms faded by a raised cosine,
    # and the manifest says "max-length". The audible duration of each untrimmed file is
    # the time to its last sample within 60 dB of its peak, found again in the decoded
    # file (to within the samples one 24-bit step either side of that level).
    import soundfile

    _, ref = serial
    spec = _write_spec(
        tmp_path / "spec", extra="[trim]\nbelow_db = -200.0\nfade = 0.01\nmax_length = 0.1\n"
    )
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    fs, step = 16000, 2.0**-23
    n, k = round(0.1 * fs), round(0.01 * fs)
    ramp = 0.5 * (1.0 + np.cos(np.pi * np.arange(1, k + 1) / k))
    for row, whole in zip(mf.read_rows(out), mf.read_rows(ref)):
        assert row["length_reason"] == "max-length" and row["duration"] == pytest.approx(0.1)
        cut, _ = soundfile.read(out / row["file"])
        full, _ = soundfile.read(ref / whole["file"])
        assert cut.size == n < full.size
        assert np.array_equal(cut[: n - k], full[: n - k])
        assert np.max(np.abs(cut[n - k :] - full[n - k : n] * ramp)) <= step
        assert row["audible_duration"] <= row["duration"]
        level = np.max(np.abs(full)) * 10 ** (-60 / 20)
        last = [np.flatnonzero(np.abs(full) >= level + d)[-1] + 1 for d in (step, -step)]
        assert last[0] <= round(whole["audible_duration"] * fs) <= last[1]


def test_the_next_run_cleans_what_a_killed_run_left(tmp_path, cache_dir):
    # After kill -9 of the parent, the folder holds its .bank.lock (no longer locked) and
    # the temporaries of the files being written (in subfolders too): the next run,
    # resumed or dry, takes the lock; the run (not the dry run) removes them all, and the
    # finished folder holds neither.
    from synth.store.atomic import temporary_name

    spec = _write_spec(tmp_path / "spec", count=2, extra="")
    spec.write_text(
        spec.read_text().replace(
            'name = "{preset}-{index:03d}"', 'name = "sub/{preset}-{index:03d}"'
        )
    )
    out = tmp_path / "out"
    assert bank.run(spec, out, jobs=1).ok
    (out / mf.LOCK).touch()
    left = [out / temporary_name(".wav"), out / "sub" / temporary_name(".wav")]
    for path in left:
        path.write_bytes(b"partial")
    assert all(mf.TEMPORARY.match(p.name) for p in left)
    before = _tree(out)
    assert bank.run(spec, out, jobs=1, dry_run=True).skipped == 2
    assert _tree(out) == before
    result = bank.run(spec, out, jobs=1)
    assert result.ok and (result.done, result.skipped) == (0, 2)
    assert not (out / mf.LOCK).exists() and not any(p.exists() for p in left)


def test_bank_run_stays_the_function_whatever_was_imported_first():
    # invariant: `synth.bank.run` is the public function in every import order; a submodule
    # of the same name would replace it on the package once anything imported it (the gain
    # pass imports the runner's helpers).
    code = (
        "import synth.bank.gain, synth.bank.spec.loading, synth.bank.runner\n"
        "from synth import bank\n"
        "assert callable(bank.run) and bank.run.__module__ == 'synth.bank.runner', bank.run\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=Path(__file__).parent)
