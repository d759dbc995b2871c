"""``synth bench cold``: the first use on a fresh install, against the same warm.

Each case runs in child processes with an empty numba cache (``NUMBA_CACHE_DIR``) and an
empty plate-mode cache (``SYNTH_CACHE_DIR``), then again with the caches the first run
filled: ``import synth``; ``synth render default``; the README's live example up to its
first sound (offline, :func:`synth.warmup.live_table`: the engine's own mixing without
an audio device). Per run: CPU time (user + system, ``os.wait4``'s resource usage of the
child), wall time and peak resident memory of the child, and whether it said on stderr
that it was compiling (it must on an empty cache, never on a warm one). The cold runs'
CPU time is held against the targets of :data:`TARGETS`.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass

from benchmarks.common import markdown_table, target_verdict

#: Cold-start targets, CPU seconds (user + system) of the whole child process.
TARGETS = {"import": 0.5, "render": 15.0, "live": 15.0}

#: What each case runs: Python code, after :data:`PEAK_REPORT` (``{tmp}``: a scratch folder).
CASES = {
    "import": "import synth",
    "render": (
        "from synth.cli import main\n"
        "raise SystemExit(main(['render', 'default', '-o', '{tmp}/default.wav']))"
    ),
    "live": "from synth.warmup import live_table\nlive_table()[0].process(4800)",
}

#: The child's own peak resident memory, printed on stderr at exit: the kernel's
#: high-water mark of its address space (``VmHWM``), which starts at ``exec``, whereas
#: ``ru_maxrss`` keeps the forking parent's.
PEAK_REPORT = (
    "import atexit, sys\n"
    "def _peak():\n"
    "    for line in open('/proc/self/status'):\n"
    "        if line.startswith('VmHWM:'):\n"
    "            print('" + "{marker}" + "', line.split()[1], file=sys.stderr)\n"
    "atexit.register(_peak)\n"
)
PEAK_MARKER = "synth-bench-cold-peak-kB"

#: What each case is called in the table.
TITLES = {
    "import": "`import synth`",
    "render": "`synth render default`",
    "live": "README live example, first sound",
}

#: The start of the first-use note of :func:`synth.compilation.announce`.
NOTE = "synth: compiling "


@dataclass
class Run:
    """One child process: the case, ``cold`` (empty caches) or not, its CPU time (s, user
    + system), wall time (s), peak resident memory (MB), whether it printed the
    first-use note, and its exit status."""

    case: str
    cold: bool
    cpu_s: float
    wall_s: float
    peak_mb: float
    noted: bool
    status: int


def run_child(code: str, env: dict, timeout: float = 900.0) -> tuple:
    """Run ``python -c code`` and return (CPU s, wall s, peak MB, stderr, exit status) of
    that child alone (``os.wait4``; the peak from :data:`PEAK_REPORT` where the child
    printed it, else ``ru_maxrss``)."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(
            [sys.executable, "-c", PEAK_REPORT.replace("{marker}", PEAK_MARKER) + code],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        deadline = t0 + timeout
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                proc.kill()
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.02)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    cpu = usage.ru_utime + usage.ru_stime
    peak_kb = usage.ru_maxrss  # Linux: KiB
    for line in stderr.splitlines():
        if line.startswith(PEAK_MARKER):
            peak_kb = int(line.split()[1])
    return cpu, wall, peak_kb / 1024.0, stderr, proc.returncode


def run_cold(cases: tuple[str, ...] = tuple(CASES)) -> list[dict]:
    """Each case cold (new empty caches) and then warm (the caches it filled): the
    :class:`Run` fields of each run."""
    runs = []
    for case in cases:
        with tempfile.TemporaryDirectory(prefix="synth-cold-") as tmp:
            env = dict(
                os.environ,
                NUMBA_CACHE_DIR=os.path.join(tmp, "numba"),
                SYNTH_CACHE_DIR=os.path.join(tmp, "synth"),
            )
            code = CASES[case].replace("{tmp}", tmp)
            for cold in (True, False):
                cpu, wall, peak, stderr, status = run_child(code, env)
                if status != 0:
                    lines = stderr.strip().splitlines()
                    raise RuntimeError(f"{case}: {lines[-1] if lines else 'failed'}")
                runs.append(asdict(Run(case, cold, cpu, wall, peak, NOTE in stderr, status)))
    return runs


def format_cold(rows: list[dict]) -> str:
    """A Markdown table of :func:`run_cold`'s runs and a line per target."""
    runs = [Run(**row) for row in rows]
    header = ["first use", "caches", "CPU s", "wall s", "peak MB", "compile note"]
    cells = [
        [
            TITLES[r.case],
            "empty" if r.cold else "warm",
            f"{r.cpu_s:.2f}",
            f"{r.wall_s:.2f}",
            f"{r.peak_mb:.0f}",
            "yes" if r.noted else "no",
        ]
        for r in runs
    ]
    lines = markdown_table(header, cells)
    lines += [
        "",
        "CPU: user + system time of the child process (os.wait4); empty: new NUMBA_CACHE_DIR "
        "and SYNTH_CACHE_DIR; warm: a second process with the caches the first one filled. "
        "'compile note': the child said on stderr that it was compiling.",
        "",
    ]
    for r in runs:
        if r.cold and r.case in TARGETS:
            met = target_verdict(r.cpu_s < TARGETS[r.case])
            lines.append(
                f"- {TITLES[r.case]}, empty caches: {r.cpu_s:.1f} s of CPU, target under "
                f"{TARGETS[r.case]:g} s: {met}."
            )
    return "\n".join(lines)
