"""Run the fuzz corpus (tests/fuzz/corpus.toml) through ``synth.cli.main`` and count the
outcomes: ``python tests/fuzz/run_corpus.py`` prints the closing figures (inputs by
category, clean errors, successes, tracebacks, partial files, data loss)."""

from __future__ import annotations

import contextlib
import io
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


def load_corpus() -> list[dict]:
    return tomllib.loads(CORPUS.read_text())["case"]


def run_case(case: dict) -> Outcome:
    from synth.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        out = folder / "existing.wav"
        out.write_bytes(PRECIOUS)
        preset = folder / "preset.toml"
        if "preset" in case:
            preset.write_text(case["preset"])
        argv = [
            a.replace("{out}", str(out))
            .replace("{dir}", str(folder))
            .replace("{preset}", str(preset))
            for a in case["argv"]
        ]
        before = {p.name for p in folder.iterdir()}
        err, std = io.StringIO(), io.StringIO()
        code, tb = None, False
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse's own usage errors
                code = exc.code
            except Exception:  # noqa: BLE001 - a traceback is what we count
                tb = True
                traceback.print_exc(file=err)
        o = Outcome(case, code, err.getvalue(), traceback=tb)
        new = {p.name for p in folder.iterdir()} - before
        o.partial = any(n.startswith(".") for n in new)
        o.lost = out.read_bytes() != PRECIOUS and case["expect"] == "error"
    lines = [
        x
        for x in o.stderr.strip().splitlines()
        if not x.startswith("usage:") and not x.startswith("  ")
    ]
    if tb:
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


def figures(outcomes: list[Outcome]) -> dict:
    by_cat = Counter(o.case["category"] for o in outcomes)
    return {
        "inputs": len(outcomes),
        "by_category": dict(sorted(by_cat.items())),
        "clean_errors": sum(o.case["expect"] == "error" and not o.problems for o in outcomes),
        "successes": sum(o.case["expect"] == "ok" and not o.problems for o in outcomes),
        "tracebacks": sum(o.traceback for o in outcomes),
        "partial_files": sum(o.partial for o in outcomes),
        "data_loss": sum(o.lost for o in outcomes),
        "unexpected": sum(bool(o.problems) for o in outcomes),
    }


def format_figures(f: dict) -> str:
    cats = ", ".join(f"{k} {v}" for k, v in f["by_category"].items())
    return (
        f"{f['inputs']} inputs ({cats}): {f['clean_errors']} clean errors, "
        f"{f['successes']} successes, {f['tracebacks']} tracebacks, "
        f"{f['partial_files']} partial files, {f['data_loss']} data loss, "
        f"{f['unexpected']} not as expected"
    )


if __name__ == "__main__":  # pragma: no cover
    results = [run_case(c) for c in load_corpus()]
    for r in results:
        if r.problems:
            print(f"{r.case['argv']}: {'; '.join(r.problems)}")
    print(format_figures(figures(results)))
