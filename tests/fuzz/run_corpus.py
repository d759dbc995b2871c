"""Run the fuzz corpus (tests/fuzz/corpus.toml) through ``synth.cli.main`` and count the
outcomes: ``python tests/fuzz/run_corpus.py`` prints the closing figures, in all and by
category (inputs, right results, clean errors, tracebacks, hangs, leftovers, data loss).

A case with ``timeout`` (s) runs as ``python -m synth`` in a subprocess killed after that
long: a hang is counted, never waited for. ``env`` sets environment variables for the
case; ``wav_frames`` writes a silent mono 48 kHz WAV of that many frames at ``{wav}``."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import tempfile
import tomllib
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

CORPUS = Path(__file__).with_name("corpus.toml")
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


def _write_wav(path: Path, frames: int) -> None:
    import numpy as np
    import soundfile as sf

    sf.write(path, np.zeros((frames, 1)), 48000, subtype="PCM_16")


def run_case(case: dict) -> Outcome:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        out = folder / "existing.wav"
        out.write_bytes(PRECIOUS)
        preset = folder / "preset.toml"
        if "preset" in case:
            preset.write_text(case["preset"])
        wav = folder / "input.wav"
        if "wav_frames" in case:
            _write_wav(wav, case["wav_frames"])
        argv = [
            a.replace("{out}", str(out))
            .replace("{dir}", str(folder))
            .replace("{preset}", str(preset))
            .replace("{wav}", str(wav))
            for a in case["argv"]
        ]
        before = {p.name for p in folder.iterdir()}
        env = case.get("env", {})
        if "timeout" in case:
            code, stderr, hang = _in_subprocess(argv, env, case["timeout"])
            tb = "Traceback (most recent call last)" in stderr
        else:
            (code, stderr, tb), hang = _in_process(argv, env), False
        o = Outcome(case, code, stderr, traceback=tb, hang=hang)
        new = {p.name for p in folder.iterdir()} - before
        o.partial = any(n.startswith(".") for n in new)
        o.lost = out.read_bytes() != PRECIOUS and case["expect"] == "error"
    lines = [
        x
        for x in o.stderr.strip().splitlines()
        if not x.startswith("usage:") and not x.startswith("  ")
    ]
    if hang:
        o.problems.append(f"no end within {case['timeout']} s")
    elif tb:
        o.problems.append("traceback")
    elif case["expect"] == "ok":
        if code != 0:
            o.problems.append(f"exit {code}, expected 0: {o.stderr.strip()[-300:]}")
    else:
        if code not in (1, 2):
            o.problems.append(f"exit {code}, expected 1 or 2")
        if len(lines) != 1:
            o.problems.append(f"{len(lines)} lines on stderr, expected 1: {o.stderr!r}")
        missing = [w for w in case.get("words", ()) if w not in o.stderr]
        if missing:
            o.problems.append(f"message lacks {missing}: {o.stderr.strip()!r}")
    if o.partial:
        o.problems.append("temporary file left")
    if o.lost:
        o.problems.append("existing output replaced although the command failed")
    return o


#: The columns of the figures, in order.
COLUMNS = ("inputs", "right", "clean_errors", "tracebacks", "hangs", "leftovers", "data_loss")


def _counts(outcomes: list[Outcome]) -> dict:
    return {
        "inputs": len(outcomes),
        "right": sum(o.case["expect"] == "ok" and not o.problems for o in outcomes),
        "clean_errors": sum(o.case["expect"] == "error" and not o.problems for o in outcomes),
        "tracebacks": sum(o.traceback for o in outcomes),
        "hangs": sum(o.hang for o in outcomes),
        "leftovers": sum(o.partial for o in outcomes),
        "data_loss": sum(o.lost for o in outcomes),
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
