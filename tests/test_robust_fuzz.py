"""The fuzz corpus (tests/fuzz/corpus.toml): every bad input gives a one-line error naming
what is wrong, every good one succeeds; no traceback, no partial file, no output lost."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
import run_corpus

CASES = run_corpus.load_corpus()
OUTCOMES = []


def _param(case):
    """A case run in a subprocess (it has a ``timeout``: a former hang) is slow."""
    marks = [pytest.mark.slow] if "timeout" in case else []
    return pytest.param(case, marks=marks, id=" ".join(case["argv"])[:80])


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_corpus_case(case):
    outcome = run_corpus.run_case(case)
    OUTCOMES.append(outcome)
    assert not outcome.problems, outcome.problems


@pytest.mark.slow
def test_closing_figures(capsys):
    # runs after the cases (same module, in order); the figures are printed with -s
    outcomes = OUTCOMES if len(OUTCOMES) == len(CASES) else [run_corpus.run_case(c) for c in CASES]
    f = run_corpus.figures(outcomes)
    with capsys.disabled():
        print("\nfuzz corpus:", run_corpus.format_figures(f))
        print(run_corpus.format_table(f))
    assert f["tracebacks"] == 0 and f["leftovers"] == 0 and f["data_loss"] == 0
    assert f["hangs"] == 0
    assert f["inputs"] == len(CASES) and f["unexpected"] == 0
