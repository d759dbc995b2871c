"""The code passes the project's linter and formatter (ruff, configured in pyproject.toml),
when ruff is installed (it is in the ``test`` extra)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def ruff() -> list[str]:
    exe = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    assert exe is not None, "ruff is part of the test extra: pip install '.[test]'"
    return [exe]


@pytest.mark.parametrize(
    "args",
    [
        ["check", "synth", "benchmarks", "validation", "tests", "examples"],
        ["format", "--check", "synth", "benchmarks", "validation", "tests", "examples"],
    ],
)
def test_ruff(args):
    done = subprocess.run(ruff() + args, cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
