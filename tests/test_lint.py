"""The code passes the project's linter and formatter (ruff, configured in pyproject.toml),
when ruff is installed (it is in the ``test`` extra)."""

import ast
import json
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from conftest import python_blocks

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


#: The Markdown pages whose Python blocks users copy.
DOC_PAGES = ["README.md", *sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", DOC_PAGES)
def test_the_python_blocks_of_the_docs_pass_ruff(page):
    # each block is checked and format-checked as a module of the repository would be (the
    # project's config; its name says where it is: PAGE.N.py, N from 0)
    findings = []
    for i, code in enumerate(python_blocks(page)):
        name = f"{page}.{i}.py"
        for args in (["check", "--output-format", "concise"], ["format", "--diff"]):
            done = subprocess.run(
                ruff() + args + ["--stdin-filename", name, "-"],
                input=code.lstrip("\n"),
                cwd=ROOT,
                capture_output=True,
                text=True,
                timeout=60,
            )
            if done.returncode != 0:
                findings.append(done.stdout + done.stderr)
    assert not findings, "\n".join(findings)


#: The rules on a function's size and arguments, whose stated exceptions are the kernels.
SIZE_RULES = ("C901", "PLR0912", "PLR0913", "PLR0915")


def _decorated_compiled(path: Path, line: int) -> bool:
    """Whether the function defined at ``line`` of ``path`` is a numba kernel (@compiled)."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.FunctionDef) and node.lineno == line:
            return any("compiled" in ast.unparse(d) for d in node.decorator_list)
    raise AssertionError(f"no function at {path}:{line}")


def test_size_rule_exceptions_are_kernels_or_pending():
    # A module listed in pyproject's per-file ignores of the size rules is exempt only where
    # every function the rules flag in it is a numba kernel (nopython code takes its arrays
    # by position), unless its line says "pending:" (a fold still to do, named there).
    text = (ROOT / "pyproject.toml").read_text()
    lint = tomllib.loads(text)["tool"]["ruff"]["lint"]
    kernel_modules = [
        path
        for path, codes in lint["per-file-ignores"].items()
        if set(SIZE_RULES) & set(codes)
        and not re.search(rf'^"{re.escape(path)}" = .*# pending:', text, re.M)
    ]
    limits = [
        f"lint.mccabe.max-complexity={lint['mccabe']['max-complexity']}",
        *(f"lint.pylint.{k}={v}" for k, v in lint["pylint"].items()),
    ]
    args = ["check", "--isolated", "--select", ",".join(SIZE_RULES), "--output-format", "json"]
    for limit in limits:
        args += ["--config", limit]
    done = subprocess.run(
        ruff() + args + kernel_modules, cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    findings = json.loads(done.stdout)
    assert findings, "the kernel modules' findings are what the list exempts"
    not_kernels = [
        f"{f['filename']}:{f['location']['row']} {f['code']}"
        for f in findings
        if not _decorated_compiled(Path(f["filename"]), f["location"]["row"])
    ]
    assert not not_kernels, not_kernels


#: The package's size limits: lines of a module, lines of a function (a numba kernel, the
#: stated exception, is one piece of numerics: an integrator's step, a transform's loop).
MODULE_LINES = 800
FUNCTION_LINES = 150


def test_no_module_or_function_over_the_size_limits():
    too_long = []
    for path in sorted((ROOT / "synth").rglob("*.py")):
        text = path.read_text()
        name = path.relative_to(ROOT)
        if text.count("\n") > MODULE_LINES:
            too_long.append(f"{name}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            lines = node.end_lineno - node.lineno + 1
            kernel = any("compiled" in ast.unparse(d) for d in node.decorator_list)
            if lines > FUNCTION_LINES and not kernel:
                too_long.append(f"{name}:{node.lineno} {node.name}: {lines} lines")
    assert too_long == [], too_long
