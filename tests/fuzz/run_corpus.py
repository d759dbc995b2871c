"""Run the fuzz corpus (tests/fuzz/corpus.toml) through ``synth.cli.main`` and count the
outcomes: ``python tests/fuzz/run_corpus.py`` prints the closing figures, in all and by
category (inputs, right results, clean errors, tracebacks, hangs, leftovers, data loss).

A case with ``timeout`` (s) runs as ``python -m synth`` in a subprocess killed after that
long: a hang is counted, never waited for. ``env`` sets environment variables for the
case; ``wav_frames`` writes a silent mono 48 kHz WAV of that many frames at ``{wav}``.

Other kinds of case:

* ``code`` (instead of ``argv``): Python statements run in this process with ``synth``,
  ``np``, ``out`` and ``folder`` (the run's paths), ``scene()`` (a small scene, cheap to
  render) and ``engine()`` (a live engine, offline, with that scene's plate added: its
  ``body``); ``expect = "error"``: a :class:`synth.ParameterError` (any other exception
  is a traceback) whose message holds ``words``; ``"ok"``: no exception.
* ``signal`` (``"SIGTERM"`` or ``"SIGKILL"``) with ``after`` (s) or ``when`` (a glob under
  the run's folder): the command runs in a subprocess sent that signal ``after`` seconds
  in, or as soon as a path matches ``when`` (work done, more to do: the moment does not
  hang on the machine's speed); expected: it ends within ``timeout``,
  no traceback, the existing output unchanged (``expect = "killed"``). A SIGKILL cannot
  be cleaned up after: the next run of the command (``then``, an argv run to the end)
  must finish the work and leave no temporary.
* ``check``: a Python expression on ``out`` and ``folder`` that must hold after an
  ``"ok"`` case (the output is what was asked for).

A *silent wrong* result is a case that succeeded where it must fail, or whose ``check``
does not hold."""

from __future__ import annotations

import contextlib
import functools
import io
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

CORPUS = Path(__file__).with_name("corpus.toml")
#: The note a first use prints before compiling a kernel group (synth.compilation.announce):
#: it depends on numba's disk cache (what ran before in the process), not on the case, so an
#: error's one line of stderr is counted without it.
COMPILE_NOTE = re.compile(r"synth: compiling .* for first use")
PRECIOUS = b"an output that existed before the run"


@dataclass
class Outcome:
    """What one case did and what was wrong with it (``problems`` empty: as expected)."""

    case: dict
    code: int | None
    stderr: str
    problems: list = field(default_factory=list)
    traceback: bool = False
    partial: bool = False
    lost: bool = False
    hang: bool = False
    silent_wrong: bool = False


def load_corpus() -> list[dict]:
    return tomllib.loads(CORPUS.read_text())["case"]


@contextlib.contextmanager
def _environment(values: dict):
    """``os.environ`` with ``values`` set, restored afterwards."""
    saved = {k: os.environ.get(k) for k in values}
    os.environ.update({k: str(v) for k, v in values.items()})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _in_process(argv: list[str], env: dict) -> tuple[int | None, str, bool]:
    """(exit status, stderr, traceback) of ``synth.cli.main(argv)`` in this process."""
    from synth.cli import main

    err, std = io.StringIO(), io.StringIO()
    code, tb = None, False
    with _environment(env), contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own usage errors
            code = exc.code
        except Exception:  # noqa: BLE001 - a traceback is what we count
            tb = True
            traceback.print_exc(file=err)
    return code, err.getvalue(), tb


def _in_subprocess(argv: list[str], env: dict, timeout: float) -> tuple[int | None, str, bool]:
    """(exit status, stderr, hang) of ``python -m synth argv``, killed (with the processes
    it started) after ``timeout`` s."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "synth", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **{k: str(v) for k, v in env.items()}},
        start_new_session=True,
    )
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate()
        return None, err, True
    return proc.returncode, err, False


#: A steel ball on a small MDF plate, cheap to render (shared with tests/test_bank.py).
SMALL_SCENE = (Path(__file__).resolve().parents[1] / "data" / "small-scene.toml").read_text()


def _scene():
    """The small scene of :data:`SMALL_SCENE`."""
    import tomllib

    from synth.io.presets import scene_from_dict

    return scene_from_dict(tomllib.loads(SMALL_SCENE), "small")[0]


def _engine():
    """A live engine (offline, 16 kHz) with the small scene's plate added: ``(engine,
    body, ball)``."""
    import synth

    scene = _scene()
    engine = synth.Engine(samplerate=16000)
    return engine, engine.add(scene.plate), scene.ball


#: The status of a ``code`` case whose own ``assert`` failed: a wrong result, no error.
SILENT_WRONG = 3


def audio_ok(path) -> bool:
    """True if ``path`` is an audio file of at least one frame whose samples are finite
    and within full scale (the ``check`` of a render)."""
    import numpy as np
    import soundfile

    data, _ = soundfile.read(str(path), dtype="float64")
    return data.size > 0 and bool(np.all(np.isfinite(data))) and float(np.max(np.abs(data))) <= 1


def _in_code(code: str, folder: Path, out: Path) -> tuple[int | None, str, bool]:
    """(0, "", False) if ``code`` runs, (2, the message, False) for a ParameterError,
    (1, the traceback, True) for any other exception."""
    import numpy as np

    import synth

    names = {"synth": synth, "np": np, "out": out, "folder": folder}
    names.update(scene=_scene, engine=_engine)
    try:
        exec(code, names)  # noqa: S102 - the corpus' own statements
    except synth.ParameterError as exc:
        return 2, f"ParameterError: {exc}", False
    except AssertionError as exc:  # the statements ran and checked a wrong result
        return SILENT_WRONG, f"AssertionError: {exc}", False
    except Exception:  # noqa: BLE001 - a traceback is what we count
        return 1, traceback.format_exc(), True
    return 0, "", False


def _signalled(argv, env, name: str, moment, timeout: float):
    """(exit status, stderr, hang) of ``python -m synth argv`` sent signal ``name`` at
    ``moment`` (a number of seconds, or a callable true once the signal is due; polled every
    10 ms for at most ``timeout`` s), waited for at most ``timeout`` s more. Its stderr goes
    to a file, which no amount of it can block as a pipe would while it is polled."""
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "synth", *argv],
            stdout=subprocess.DEVNULL,
            stderr=err,
            text=True,
            env={**os.environ, **{k: str(v) for k, v in env.items()}},
            start_new_session=True,
        )
        due = moment if callable(moment) else None
        deadline = time.monotonic() + (timeout if due else moment)
        while proc.poll() is None and time.monotonic() < deadline and not (due and due()):
            time.sleep(0.01)
        signalled = proc.poll() is None  # else it ended before the signal
        if signalled:
            os.killpg(proc.pid, getattr(signal, name))
        try:
            proc.wait(timeout=timeout)
            hang = False
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            hang = True
        err.seek(0)
        return (None if hang else proc.returncode), err.read(), hang


def _any_match(folder: Path, pattern: str) -> bool:
    """Whether any path under ``folder`` matches the glob ``pattern``."""
    return next(folder.glob(pattern), None) is not None


def _write_wav(path: Path, frames: int) -> None:
    import numpy as np
    import soundfile as sf

    sf.write(path, np.zeros((frames, 1)), 48000, subtype="PCM_16")


@dataclass(frozen=True)
class CasePaths:
    """The paths a case runs with, in its own temporary folder: the output that exists
    before the run, the case's preset and WAV input (where it has them)."""

    folder: Path
    out: Path
    preset: Path
    wav: Path

    @classmethod
    def prepared(cls, folder: Path, case: dict) -> CasePaths:
        paths = cls(folder, folder / "existing.wav", folder / "preset.toml", folder / "input.wav")
        paths.out.write_bytes(PRECIOUS)
        if "preset" in case:
            paths.preset.write_text(case["preset"])
        if "wav_frames" in case:
            _write_wav(paths.wav, case["wav_frames"])
        return paths

    def substituted(self, args: list[str]) -> list[str]:
        """``args`` with ``{out}``, ``{dir}``, ``{preset}`` and ``{wav}`` replaced."""
        names = {"{out}": self.out, "{dir}": self.folder, "{preset}": self.preset}
        names["{wav}"] = self.wav
        for key, value in names.items():
            args = [a.replace(key, str(value)) for a in args]
        return args


@dataclass
class Run:
    """How a case's command ended: exit status (None: hung), stderr, whether it printed a
    traceback, and for a signal case whether the signal came before the command's end."""

    code: int | None
    stderr: str
    traceback: bool = False
    hang: bool = False
    signalled: bool = True


def _has_traceback(stderr: str) -> bool:
    return "Traceback (most recent call last)" in stderr


def _run_signalled(case: dict, paths: CasePaths, env: dict) -> Run:
    """A signal case: the command sent its signal, then (``then``) the next run to its end."""
    moment = case.get("after")
    if "when" in case:
        moment = functools.partial(_any_match, paths.folder, case["when"])
    argv = paths.substituted(case.get("argv", []))
    code, stderr, hang = _signalled(argv, env, case["signal"], moment, case["timeout"])
    run = Run(code, stderr, _has_traceback(stderr), hang, signalled=code != 0)
    if "then" in case and not hang:
        code2, stderr2, run.hang = _in_subprocess(
            paths.substituted(case["then"]), env, case["timeout"]
        )
        run.traceback = run.traceback or _has_traceback(stderr2)
        run.stderr += stderr2 if code2 != 0 else ""
        run.code = code2  # the killed run's status is the signal's
    return run


def _run(case: dict, paths: CasePaths) -> Run:
    """Run the case's code or command in the way it asks for."""
    env = case.get("env", {})
    if "code" in case:
        return Run(*_in_code(case["code"], paths.folder, paths.out))
    if "signal" in case:
        return _run_signalled(case, paths, env)
    argv = paths.substituted(case.get("argv", []))
    if "timeout" in case:
        code, stderr, hang = _in_subprocess(argv, env, case["timeout"])
        return Run(code, stderr, _has_traceback(stderr), hang)
    return Run(*_in_process(argv, env))


def _check_held(case: dict, paths: CasePaths) -> bool:
    """Whether the case's ``check`` expression holds on its output."""
    try:
        names = {"out": paths.out, "folder": paths.folder, "audio_ok": audio_ok}
        return bool(eval(case["check"], names))  # noqa: S307
    except Exception:  # noqa: BLE001 - a check that cannot be made does not hold
        return False


def _outcome(case: dict, paths: CasePaths, run: Run, before: set) -> Outcome:
    """What the run left in the folder and whether its result was silently wrong."""
    o = Outcome(case, run.code, run.stderr, traceback=run.traceback, hang=run.hang)
    new = {p.name for p in paths.folder.rglob("*")} - before
    o.partial = any(n.startswith(".") for n in new)
    o.lost = paths.out.read_bytes() != PRECIOUS and case["expect"] in ("error", "killed")
    ran_clean = run.code == 0 and not run.hang and not run.traceback
    if case.get("check") and case["expect"] == "ok" and ran_clean:
        o.silent_wrong = not _check_held(case, paths)
    if (case["expect"] == "error" and run.code == 0) or run.code == SILENT_WRONG:
        o.silent_wrong = True
    return o


def _error_problems(o: Outcome, case: dict) -> list[str]:
    """What is wrong with an expected error: its status, its one line, its words."""
    lines = [
        x
        for x in o.stderr.strip().splitlines()
        if not x.startswith("usage:") and not x.startswith("  ") and not COMPILE_NOTE.match(x)
    ]
    problems = []
    if o.code not in (1, 2):
        problems.append(f"exit {o.code}, expected 1 or 2")
    if len(lines) != 1:
        problems.append(f"{len(lines)} lines on stderr, expected 1: {o.stderr!r}")
    missing = [w for w in case.get("words", ()) if w not in o.stderr]
    if missing:
        problems.append(f"message lacks {missing}: {o.stderr.strip()!r}")
    return problems


def _problems(o: Outcome, case: dict) -> list[str]:
    """What differs from the case's expectation, in words."""
    problems = []
    if o.hang:
        problems.append(f"no end within {case['timeout']} s")
    elif o.traceback:
        problems.append("traceback")
    elif case["expect"] == "ok":
        if o.code != 0:
            problems.append(f"exit {o.code}, expected 0: {o.stderr.strip()[-300:]}")
        if o.silent_wrong:
            problems.append(f"the result does not hold: {case.get('check', o.stderr)}")
    elif case["expect"] == "killed":
        if "then" in case and o.code != 0:
            problems.append(f"the next run failed (exit {o.code}): {o.stderr.strip()[-300:]}")
    else:
        problems += _error_problems(o, case)
    if o.partial:
        problems.append("temporary file left")
    if o.lost:
        problems.append("existing output replaced although the command failed")
    return problems


def run_case(case: dict) -> Outcome:
    """Run one corpus case in a fresh folder and say what went wrong with it."""
    with tempfile.TemporaryDirectory() as tmp:
        paths = CasePaths.prepared(Path(tmp), case)
        before = {p.name for p in paths.folder.iterdir()}
        run = _run(case, paths)
        o = _outcome(case, paths, run, before)
    if "signal" in case and not run.hang and not run.signalled:
        o.problems.append("ended before the signal: make `after` shorter")
    o.problems += _problems(o, case)
    return o


#: The columns of the figures, in order.
COLUMNS = (
    "inputs",
    "right",
    "clean_errors",
    "tracebacks",
    "hangs",
    "leftovers",
    "data_loss",
    "silent_wrong",
)


def _counts(outcomes: list[Outcome]) -> dict:
    return {
        "inputs": len(outcomes),
        "right": sum(o.case["expect"] in ("ok", "killed") and not o.problems for o in outcomes),
        "clean_errors": sum(o.case["expect"] == "error" and not o.problems for o in outcomes),
        "tracebacks": sum(o.traceback for o in outcomes),
        "hangs": sum(o.hang for o in outcomes),
        "leftovers": sum(o.partial for o in outcomes),
        "data_loss": sum(o.lost for o in outcomes),
        "silent_wrong": sum(o.silent_wrong for o in outcomes),
        "unexpected": sum(bool(o.problems) for o in outcomes),
    }


def figures(outcomes: list[Outcome]) -> dict:
    """The counts in all, with ``by_category`` (inputs per category) and ``categories``
    (the counts of each)."""
    by_cat = Counter(o.case["category"] for o in outcomes)
    f = _counts(outcomes)
    f["by_category"] = dict(sorted(by_cat.items()))
    f["categories"] = {
        c: _counts([o for o in outcomes if o.case["category"] == c]) for c in sorted(by_cat)
    }
    # the earlier names of two columns
    f["successes"], f["partial_files"] = f["right"], f["leftovers"]
    return f


def format_figures(f: dict) -> str:
    cats = ", ".join(f"{k} {v}" for k, v in f["by_category"].items())
    return (
        f"{f['inputs']} inputs ({cats}): {f['clean_errors']} clean errors, "
        f"{f['right']} right, {f['tracebacks']} tracebacks, {f['hangs']} hangs, "
        f"{f['leftovers']} leftovers, {f['data_loss']} data loss, "
        f"{f['silent_wrong']} silent wrong, "
        f"{f['unexpected']} not as expected"
    )


def format_table(f: dict) -> str:
    """The figures by category, one row each and the total."""
    head = f"{'category':<22}" + "".join(f"{c.replace('_', ' '):>13}" for c in COLUMNS)
    rows = [head]
    for name, counts in [*f["categories"].items(), ("all", f)]:
        rows.append(f"{name:<22}" + "".join(f"{counts[c]:>13}" for c in COLUMNS))
    return "\n".join(rows)


if __name__ == "__main__":  # pragma: no cover
    results = [run_case(c) for c in load_corpus()]
    for r in results:
        if r.problems:
            print(f"{r.case['argv']}: {'; '.join(r.problems)}")
    f = figures(results)
    print(format_table(f))
    print(format_figures(f))
