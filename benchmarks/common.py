"""Shared by the benchmarks: median timing, child processes, peak memory, Markdown blocks."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

#: The source checkout holding this package. A child process puts it last on ``sys.path``:
#: it imports these benchmarks, and ``synth`` as installed (as the parent does).
CHECKOUT = Path(__file__).resolve().parents[1]


def target_verdict(met: bool) -> str:
    """The word a benchmark's summary gives a target: met or not."""
    return "met" if met else "NOT met"


def markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    """The lines of a Markdown table: ``header``, its rule, then one line a row of cells
    (already formatted)."""
    return [
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
        *("| " + " | ".join(row) + " |" for row in rows),
    ]


def median_time(fn, repeat):
    ts = np.empty(repeat)
    for i in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts[i] = time.perf_counter() - t0
    return float(np.median(ts))


def markdown_block(command: str, table: str) -> str:
    """A benchmark's output as a block for docs/: one line naming the command, the date and
    the machine (CPUs, load average), then the benchmark's Markdown tables."""
    import datetime
    import os
    import platform

    import numba

    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    head = (
        f"Printed by `{command}` on {now} (Python {platform.python_version()}, "
        f"numba {numba.__version__}, {os.cpu_count()} CPUs, load average {load:.1f} "
        "at the end of the run)."
    )
    return f"{head}\n\n{table}\n"


def peak_rss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def child_json(code: str, argv: list, timeout: float, cache_dir=None) -> dict:
    """Run ``python -c code *argv`` in a new process (with ``SYNTH_CACHE_DIR=cache_dir``
    if given, and :data:`CHECKOUT` last on its path) and return the JSON object its last line of output prints, with
    ``process_s`` its wall time (s); or ``{"error": ...}`` saying why there is none (a
    timeout, a signal, or the last line of its error output)."""
    import json
    import os
    import subprocess
    import sys

    env = (
        dict(os.environ) if cache_dir is None else dict(os.environ, SYNTH_CACHE_DIR=str(cache_dir))
    )
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(
            [
                sys.executable,
                "-c",
                f"import sys; sys.path.append({str(CHECKOUT)!r})\n{code}",
                *argv,
            ],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return {"error": f"over {timeout:g} s"}
    wall = time.perf_counter() - t0
    if proc.returncode < 0:
        return {"error": f"stopped by signal {-proc.returncode} after {wall:.0f} s"}
    if proc.returncode != 0:
        lines = proc.stderr.strip().splitlines()
        return {"error": lines[-1] if lines else "failed"}
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    res["process_s"] = wall
    return res
