"""``synth bench bank``: sounds per second of a sound bank of the default scene.

Measured in one run on this machine: an example bank (``count`` variations of the
default preset: drop height, impact point, ball radius; FLAC at 48 kHz, physical level)
rendered

* the way it is done without banks, one ``synth render`` process per file (timed on a few
  files, and the rate extrapolated to the bank: each process is independent);
* by ``synth.bank.run`` with ``jobs=1`` (in this process) and ``jobs=2`` (two workers):
  wall time of the whole call, of which the workers' start-up (spawn, import, one warm
  render), and the rate once they are warm, on which the two-core target is judged; each
  after a dry run of it into the same folder, whose estimate of the time
  (:class:`synth.bank.runner.Estimate`) is printed against the run's;
* on a Dask ``LocalCluster`` of two worker processes (started before the clock), whose
  overhead per sound is its time per sound less that of ``jobs=2``, both once warm;

and the peak resident memory of a worker; then the bank-gain pass
(:func:`synth.bank.gain.apply_gain`, the loudest true peak to -1 dBTP) over the
``jobs=2`` bank, in files per second. The disk caches are warmed first, as they are
after a bank's first sound.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

from benchmarks.common import target_verdict
from synth.bank import run as run_bank_spec
from synth.bank import spec as bank_spec
from synth.bank.gain import apply_gain

#: The example bank's spec, with the count left to the benchmark.
SPEC = """\
preset = "default"
count = {count}
seed = 7
name = "{{preset}}-{{index:04d}}"
format = "flac"
[vary]
"drop.height" = {{ min = 0.05, max = 0.3 }}
"drop.position" = {{ min = [0.2, 0.1], max = [1.0, 0.4] }}
"ball.radius" = [0.004, 0.005, 0.006]
[render]
samplerate = 48000
normalize = "physical"
"""

#: Targets: jobs=1 against one process per file, jobs=2 against jobs=1 (two cores).
TARGETS = {"jobs1_over_process": 30.0, "jobs2_over_jobs1": 1.8}


def _render_command(item, out: Path) -> list[str]:
    cmd = [
        sys.executable,
        "-m",
        "synth",
        "render",
        "default",
        "-o",
        str(out / item.file),
        "--samplerate",
        "48000",
        "--normalize",
        "physical",
    ]
    for key, value in item.values.items():
        cmd += ["--set", f"{key}={value}"]
    return cmd


def _process_per_file(items, out: Path, files: int) -> float:
    """Seconds per file of one ``synth render`` process per file (mean over ``files``)."""
    t0 = time.perf_counter()
    for item in items[:files]:
        subprocess.run(_render_command(item, out), check=True, capture_output=True)
    return (time.perf_counter() - t0) / files


def _timed_run(spec, out: Path, **kw):
    t0 = time.perf_counter()
    result = run_bank_spec(spec, out, **kw)
    return time.perf_counter() - t0, result


def run_bank(count: int = 200, process_files: int = 5, dask: bool = True) -> dict:
    """Measure the bank benchmark (see the module docstring); a dict of figures."""
    spec = bank_spec.from_dict(tomllib.loads(SPEC.format(count=count)))
    items = bank_spec.plan(spec)
    from synth.bank.row import warm

    warm(spec)
    out = {"count": count, "process_files": process_files}
    with tempfile.TemporaryDirectory(prefix="synth-bench-bank-") as tmp:
        tmp = Path(tmp)
        (tmp / "process").mkdir()
        per_file = _process_per_file(items, tmp / "process", process_files)
        out["process_per_file"] = {"seconds_per_sound": per_file, "rate": 1.0 / per_file}
        for jobs in (1, 2):
            dry = run_bank_spec(spec, tmp / f"jobs{jobs}", jobs=jobs, dry_run=True)
            seconds, result = _timed_run(spec, tmp / f"jobs{jobs}", jobs=jobs)
            assert result.ok, result.summary()
            out[f"jobs{jobs}"] = _figures(seconds, result, count)
            out[f"jobs{jobs}"]["estimate"] = dry.estimate
        gained = apply_gain(tmp / "jobs2", tmp / "gain")
        out["gain"] = {"seconds": gained.elapsed, "rate": gained.rate, "gain_db": gained.gain_db}
        if dask:
            out["dask"] = _dask(spec, tmp / "dask", count, out["jobs2"])
    out["ratios"] = {
        "jobs1_over_process": out["jobs1"]["rate"] / out["process_per_file"]["rate"],
        "jobs2_over_jobs1": out["jobs2"]["render_rate"] / out["jobs1"]["render_rate"],
        "jobs2_over_jobs1_with_startup": out["jobs2"]["rate"] / out["jobs1"]["rate"],
    }
    out["targets"] = TARGETS
    return out


def _figures(seconds: float, result, count: int) -> dict:
    return {
        "seconds": seconds,
        "startup": result.startup,
        "rate": count / seconds,
        "render_rate": result.render_rate,
        "peak_worker_rss": result.peak_worker_rss,
    }


def _dask(spec, folder: Path, count: int, pool: dict) -> dict:
    try:
        from dask.distributed import LocalCluster
    except ImportError:
        return {"skipped": "dask.distributed is not installed"}
    t0 = time.perf_counter()
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        start = time.perf_counter() - t0
        seconds, result = _timed_run(spec, folder, scheduler=cluster.scheduler_address)
    assert result.ok, result.summary()
    figures = _figures(seconds, result, count)
    figures["cluster_start"] = start
    figures["overhead_per_sound"] = 1.0 / figures["render_rate"] - 1.0 / pool["render_rate"]
    return figures


def format_bank(r: dict) -> str:
    """The bank benchmark as a Markdown table, with the targets and whether they are met."""
    n = r["count"]
    title = (
        f"{n}-sound bank of the default scene (an example bank: height, impact point, "
        f"ball radius; FLAC 48 kHz, physical level); wall time of each way, worker "
        f"start-up included (`--jobs 1` renders in the benchmark's process, warmed "
        f"before the clock as the caches are)"
    )
    header = (
        "| way | seconds | of which start-up (s) | sounds/s | sounds/s once warm | "
        "peak memory per worker (MB) |"
    )
    lines = [title, header, "|---|---|---|---|---|---|"]
    p = r["process_per_file"]
    lines.append(
        f"| one `synth render` process per file (timed on {r['process_files']} files, "
        f"extrapolated to {n}) | {p['seconds_per_sound'] * n:.1f} | - | "
        f"{p['rate']:.2f} | - | - |"
    )
    rows = [(f"`synth bank --jobs {j}`", r[f"jobs{j}"]) for j in (1, 2)]
    d = r.get("dask")
    if d and "skipped" not in d:
        way = (
            f"Dask LocalCluster, 2 worker processes (cluster started in "
            f"{d['cluster_start']:.1f} s, not counted)"
        )
        rows.append((way, d))
    for way, f in rows:
        lines.append(
            f"| {way} | {f['seconds']:.1f} | {f['startup']:.1f} | {f['rate']:.1f} | "
            f"{f['render_rate']:.1f} | {f['peak_worker_rss'] / 1e6:.0f} |"
        )
    g = r.get("gain")
    if g:
        lines.append(
            f"| `synth bank-gain` of the `--jobs 2` bank (one process; gain "
            f"{g['gain_db']:+.1f} dB to -1 dBTP) | {g['seconds']:.1f} | - | {g['rate']:.1f} | "
            f"- | - |"
        )
    ratios, targets = r["ratios"], r["targets"]

    def verdict(name):
        return target_verdict(ratios[name] >= targets[name])

    lines += [
        "",
        (
            f"- `--jobs 1` / process per file: {ratios['jobs1_over_process']:.1f}x "
            f"(target >= {targets['jobs1_over_process']:.0f}x): "
            f"{verdict('jobs1_over_process')}"
        ),
        (
            f"- `--jobs 2` / `--jobs 1` once warm: {ratios['jobs2_over_jobs1']:.2f}x "
            f"(target >= {targets['jobs2_over_jobs1']}x on two cores): "
            f"{verdict('jobs2_over_jobs1')}; with the start-up: "
            f"{ratios['jobs2_over_jobs1_with_startup']:.2f}x"
        ),
    ]
    lines.append(
        "- `--dry-run` estimate against the run's wall time: "
        + "; ".join(
            f"`--jobs {j}` {r[f'jobs{j}']['estimate']:.1f} s estimated, "
            f"{r[f'jobs{j}']['seconds']:.1f} s run "
            f"({r[f'jobs{j}']['estimate'] / r[f'jobs{j}']['seconds']:.2f}x)"
            for j in (1, 2)
        )
    )
    if d and "skipped" not in d:
        lines.append(
            f"- Dask overhead per sound against `--jobs 2`: {d['overhead_per_sound'] * 1e3:+.1f} ms"
        )
    elif d:
        lines.append(f"- Dask: {d['skipped']}")
    return "\n".join(lines)
