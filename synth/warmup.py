"""``synth warmup``: compile every kernel ahead of time (for images and installers).

numba compiles for the argument types of a kernel's first call, so the warm-up runs what
calls the kernels on real inputs (the presets' renders, the live engine offline, a rolling
voice, an analysis), recording each step's compiles and their CPU time. A second process
can compile some kernel groups ahead while this one works (:func:`start_ahead`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from synth.compilation import (
    COMPILE_TIMES,
    GROUPS,
    KERNEL_LOCKS,
    LOCKS,
    CompileLog,
    is_cached,
    lock_file,
    same_cache_file,
)

#: Sample rate of the warm-up's renders (Hz): the presets' own rate, which sets no type.
SAMPLERATE = 48000


@dataclass
class Step:
    """One warm-up step: its name, action, and (after :func:`run`) its compiles and CPU s."""

    name: str
    action: Callable[[], object]
    log: CompileLog = field(default_factory=CompileLog)
    seconds: float = 0.0


def _render_presets():
    from synth.io.presets import available, render_preset

    return [render_preset(name) for name in available()]


def _stiff_contact():
    """A contact integrated by Radau IIA (the method named: the automatic choice takes
    it above Zener's lam = 20), which the presets may not reach."""
    from synth.physics.contact import solve_contact

    return solve_contact(mass=4e-3, stiffness=1e9, admittance=1e-3, speed=1.0, method="Radau")


def live_table(samplerate: float = SAMPLERATE):
    """The engine and the table of the README's live example ("Live, from UI and game
    code"), the ball's hit queued; ``engine.process`` plays it offline."""
    import synth

    engine = synth.Engine(samplerate=samplerate, blocksize=256)
    table = engine.add(synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6))
    table.hit(synth.Ball("steel", radius=0.005), 1.5, position=(0.3, 0.2))
    return engine, table


def _live():
    """The README's live example offline (4800 samples), then its table silenced
    (``stop_all``'s kernel compiles on its first use)."""
    engine, table = live_table()
    audio = engine.process(4800)
    table.stop_all()
    return audio


def _live_rolling():
    """A ball rolled for 0.1 s on the README's live table (``max_rolls=1``), offline: the
    rolling voices' block and what :meth:`synth.live.Body.roll` runs on the calling
    thread, on the docs' example roughness (RMS 1 um, correlation length 0.2 mm, Hurst
    0.8; the caller's value, docs/rolling.md)."""
    import synth
    from synth.physics import surface

    engine = synth.Engine(samplerate=SAMPLERATE, blocksize=256, max_rolls=1)
    table = engine.add(synth.Plate("mdf-18", thickness=0.018, length=1.2, width=0.6))
    ball = synth.Ball("steel", radius=0.01)
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=2e-4, hurst=0.8)
    profile = surface.rough_profile(spec, length=0.05, spacing=5e-6, seed=1)
    envelope = surface.contact_envelope(profile, ball.radius)
    voice = table.roll(ball, (0.3, 0.2), (0.2, 0.0), envelope=envelope, start=0.01)
    audio = engine.process(2400)
    voice.update((0.301, 0.2), (0.2, 0.0))
    return engine.process(2400), audio


def _analysis():
    from synth.analysis import analyze
    from synth.io.presets import render_preset
    from synth.stimuli.alter import alter_restitution

    rendered = render_preset("default")
    analyze(rendered.audio, rendered.samplerate)
    return alter_restitution(rendered.audio, rendered.samplerate, 0.5)


def steps() -> list[Step]:
    """The warm-up's steps, in order."""
    return [
        Step("render every preset", _render_presets),
        Step("stiff contact (Radau IIA)", _stiff_contact),
        Step("live example (offline)", _live),
        Step("analysis and restitution change", _analysis),
        Step("live rolling voice (offline)", _live_rolling),
    ]


def run(selected: list[Step] | None = None) -> list[Step]:
    """Run the steps (default: all), recording what each compiles."""
    done = steps() if selected is None else selected
    for step in done:
        start = time.process_time()
        with step.log.recording():
            step.action()
        step.seconds = time.process_time() - start
    return done


def format_steps(done: list[Step]) -> str:
    """What each step compiled (kernel, specialisations, CPU s), the longest first, and the
    totals."""
    lines = []
    for step in done:
        rows = step.log.by_kernel()
        lines.append(
            f"{step.name}: {len(step.log.compiles)} compiles, "
            f"{step.log.seconds:.1f} s of {step.seconds:.1f} s CPU"
            + ("" if rows else " (all kernels already compiled)")
        )
        for kernel, count, seconds in rows:
            lines.append(f"  {seconds:7.2f} s  {kernel}" + (f" (x{count})" if count > 1 else ""))
    total = _total(done)
    groups = ", ".join(f"{g} {s:.1f} s" for g, s in sorted(total.by_group().items()))
    lines.append(
        f"total: {len(total.compiles)} compiles, {total.seconds:.1f} s CPU"
        + (f" ({groups})" if groups else "")
    )
    return "\n".join(lines)


def record(done: list[Step]) -> str:
    """Write each kernel group's compile time (CPU s) for the first-use note
    (:data:`synth.compilation.COMPILE_TIMES`), from a warm-up on an empty cache; its path."""
    import json

    by_group = _total(done).by_group()
    times = {g: round(s, 1) for g, s in sorted(by_group.items()) if g != "other"}
    COMPILE_TIMES.write_text(json.dumps(times, indent=1) + "\n")
    return str(COMPILE_TIMES)


def _total(done: list[Step]) -> CompileLog:
    return CompileLog([c for step in done for c in step.log.compiles])


#: The action that compiles each kernel group a second process can compile ahead
#: (:func:`compile_ahead`): the groups the presets' renders do not reach.
AHEAD = {"live": _live, "live-rolling": _live_rolling, "stiff-contact": _stiff_contact}

#: The line :func:`compile_ahead` prints once it holds every lock.
HOLDING = "holding"


def compile_ahead(folder: str, names: list[str], stream=None) -> None:
    """Compile the kernel groups ``names`` (keys of :data:`AHEAD`) in this order, each
    under its lock in ``folder`` (:data:`synth.compilation.LOCKS`): every lock is taken
    before the first compile (then :data:`HOLDING` on ``stream``, stdout), and each is
    given back once its group is in numba's disk cache."""
    import fcntl

    handles = []
    for name in names:
        handle = open(lock_file(folder, name), "wb")
        fcntl.flock(handle, fcntl.LOCK_EX)
        handles.append(handle)
    print(HOLDING, file=sys.stdout if stream is None else stream, flush=True)
    for name, handle in zip(names, handles, strict=True):
        AHEAD[name]()
        handle.close()


@dataclass
class Ahead:
    """A child process compiling kernel groups ahead (:func:`start_ahead`): the process,
    the groups, its lock folder, the file its stderr goes to, and (after :meth:`finish`)
    its CPU time (s, user + system) and whether it was stopped before the end."""

    process: subprocess.Popen
    names: list[str]
    folder: Path
    errors: object  # the temporary file of the child's stderr
    cpu_seconds: float = 0.0
    stopped: bool = False

    def finish(self) -> str | None:
        """Stop the child if it still runs (what it compiled stays in the cache), remove
        its locks; its error output if it failed, else None."""
        if self.process.returncode is None:
            pid, status, usage = os.wait4(self.process.pid, os.WNOHANG)
            self.stopped = pid == 0
            if self.stopped:
                self.process.terminate()
                _, status, usage = os.wait4(self.process.pid, 0)
            self.process.returncode = os.waitstatus_to_exitcode(status)
            self.cpu_seconds = usage.ru_utime + usage.ru_stime
        status = self.process.returncode
        self.process.stdout.close()
        os.environ.pop(LOCKS, None)
        os.environ.pop(KERNEL_LOCKS, None)
        shutil.rmtree(self.folder / "kernels", ignore_errors=True)
        for name in self.names:
            lock_file(self.folder, name).unlink(missing_ok=True)
        same_cache_file(self.folder).unlink(missing_ok=True)
        self.folder.rmdir()
        self.errors.seek(0)
        text = self.errors.read().decode(errors="replace")
        self.errors.close()
        return text if status > 0 else None


def start_ahead(names: list[str], folder: Path | None = None) -> Ahead | None:
    """Start a child process that compiles those of the kernel groups ``names`` that are
    not in numba's disk cache (:func:`compile_ahead`), while this one goes on, and return
    once it holds their locks; this process and its children (:data:`LOCKS` in the
    environment) then wait for a group it holds rather than compile it too, and all take
    each kernel's lock while they compile it (:data:`KERNEL_LOCKS`, the same folder). The
    locks go in ``folder`` (an empty folder; default: a new temporary one), which processes
    started before may already have as :data:`LOCKS` and :data:`KERNEL_LOCKS`. None if
    every group is cached, or the child ended before it held the locks (POSIX locks
    missing)."""
    missing = [name for name in names if not is_cached(GROUPS[name])]
    if not missing:
        return None
    folder = Path(tempfile.mkdtemp(prefix="synth-compile-locks-")) if folder is None else folder
    same_cache_file(folder).write_text(os.environ.get("NUMBA_CACHE_DIR", ""))
    env = {k: v for k, v in os.environ.items() if k != LOCKS}
    env[KERNEL_LOCKS] = str(folder)
    code = "import sys; from synth import warmup; warmup.compile_ahead(sys.argv[1], sys.argv[2:])"
    errors = tempfile.TemporaryFile()
    process = subprocess.Popen(
        [sys.executable, "-c", code, str(folder), *missing],
        env=env,
        stdout=subprocess.PIPE,
        stderr=errors,
    )
    ahead = Ahead(process, missing, folder, errors)
    if process.stdout.readline().decode().strip() != HOLDING:
        ahead.finish()
        return None
    os.environ[LOCKS] = str(folder)
    os.environ[KERNEL_LOCKS] = str(folder)
    return ahead
