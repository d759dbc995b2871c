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
    name = " ".join(case["argv"]) if "argv" in case else case["code"].replace("\n", "; ")
    return pytest.param(case, marks=marks, id=name[:80])


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_corpus_case(case):
    outcome = run_corpus.run_case(case)
    OUTCOMES.append(outcome)
    assert not outcome.problems, outcome.problems


def test_a_success_where_an_error_is_due_counts_as_silent_wrong():
    # the corpus' own bookkeeping: exit 0 for a bad input, a failed `check` and a failed
    # `assert` of a statement each count as a silent wrong result, not as right
    wrong = [
        {"category": "x", "code": "synth.errors", "expect": "error"},
        {"category": "x", "code": "assert 1 + 1 == 3", "expect": "ok"},
        {"category": "x", "argv": ["presets"], "expect": "ok", "check": "out.stat().st_size == 0"},
    ]
    outcomes = [run_corpus.run_case(c) for c in wrong]
    assert [o.silent_wrong for o in outcomes] == [True, True, True]
    f = run_corpus.figures(outcomes)
    assert (f["silent_wrong"], f["right"], f["clean_errors"], f["tracebacks"]) == (3, 0, 0, 0)


@pytest.mark.slow
def test_closing_figures(capsys):
    # runs after the cases (same module, in order); the figures are printed with -s
    outcomes = OUTCOMES if len(OUTCOMES) == len(CASES) else [run_corpus.run_case(c) for c in CASES]
    f = run_corpus.figures(outcomes)
    with capsys.disabled():
        print("\nfuzz corpus:", run_corpus.format_figures(f))
        print(run_corpus.format_table(f))
    assert f["tracebacks"] == 0 and f["leftovers"] == 0 and f["data_loss"] == 0
    assert f["silent_wrong"] == 0
    assert f["hangs"] == 0
    assert f["inputs"] == len(CASES) and f["unexpected"] == 0
