"""The fuzz corpus (tests/fuzz/corpus.toml): every bad input gives a one-line error naming
what is wrong, every good one succeeds; no traceback, no partial file, no output lost."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
import run_corpus

CASES = run_corpus.load_corpus()
OUTCOMES = []


@pytest.mark.parametrize("case", CASES, ids=[" ".join(c["argv"])[:80] for c in CASES])
def test_corpus_case(case):
    outcome = run_corpus.run_case(case)
    OUTCOMES.append(outcome)
    assert not outcome.problems, outcome.problems


def test_closing_figures(capsys):
    # runs after the cases (same module, in order); the figures are printed with -s
    outcomes = OUTCOMES if len(OUTCOMES) == len(CASES) else [run_corpus.run_case(c) for c in CASES]
    f = run_corpus.figures(outcomes)
    with capsys.disabled():
        print("\nfuzz corpus:", run_corpus.format_figures(f))
    assert f["tracebacks"] == 0 and f["leftovers"] == 0 and f["data_loss"] == 0
    assert f["hangs"] == 0
    assert f["inputs"] == len(CASES) and f["unexpected"] == 0
