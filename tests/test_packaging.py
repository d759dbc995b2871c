"""What a user installs: the wheel holds every module and preset and nothing of the studies
beside the package, the installed package is the one under test, and the project states one
version."""

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from conftest import REPOSITORY

import synth

SOURCE = REPOSITORY / "synth"
#: The packages beside synth/ in the repository, never installed.
BESIDE = ("benchmarks/", "validation/")


def _source_files() -> set[str]:
    """The package's modules and presets in the source tree, relative to the repository."""
    files = {p for p in SOURCE.rglob("*.py") if "__pycache__" not in p.parts}
    files |= set(SOURCE.rglob("*.toml"))
    return {p.relative_to(REPOSITORY).as_posix() for p in files}


@pytest.mark.slow
def test_wheel_holds_every_module_and_preset(tmp_path):
    # The wheel `pip install .` builds holds every module under synth/ and every preset: a
    # package left out of pyproject.toml breaks every installed copy while a suite importing
    # the source tree stays green; and it holds nothing of the benchmarks and the thesis
    # study beside the package. Built from a copy of the files a build reads, so the
    # repository is left as it was.
    tracked = subprocess.run(
        ["git", "-C", str(REPOSITORY), "ls-files", "pyproject.toml", "README.md", "LICENSE"],
        capture_output=True,
        text=True,
    ).stdout.split() or ["pyproject.toml", "README.md", "LICENSE"]
    build = tmp_path / "src"
    build.mkdir()
    for name in tracked:
        (build / name).write_bytes((REPOSITORY / name).read_bytes())
    beside = {
        p.relative_to(REPOSITORY).as_posix()
        for folder in BESIDE
        for p in (REPOSITORY / folder).rglob("*.py")
        if "__pycache__" not in p.parts
    }
    assert beside, "the benchmarks are beside the package"
    for rel in _source_files() | beside | {"synth/py.typed"}:
        (build / rel).parent.mkdir(parents=True, exist_ok=True)
        (build / rel).write_bytes((REPOSITORY / rel).read_bytes())
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(build)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    (wheel,) = tmp_path.glob("impact_synth-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = _source_files() - names
    assert not missing, f"the wheel lacks {sorted(missing)}"
    assert not [n for n in names if n.startswith(("tests/", "docs/"))]
    # the benchmarks and the thesis study stay in the source repository; of the modules
    # named bench, the wheel holds the command finding them (synth/cli/bench.py) alone
    studies = [
        n
        for n in names
        if n.startswith(BESIDE)
        or (re.search(r"(^|/)bench(/|\.py$)", n) and n != "synth/cli/bench.py")
    ]
    assert not studies, f"the wheel holds {studies}"


def test_installed_package_is_the_source_trees():
    # The package under test holds the same modules and presets as the source tree, so the
    # tests that read the repository's files speak of the code that runs.
    installed = Path(synth.__file__).resolve().parent
    files = {p for p in installed.rglob("*.py") if "__pycache__" not in p.parts}
    files |= set(installed.rglob("*.toml"))
    assert {"synth/" + p.relative_to(installed).as_posix() for p in files} == _source_files()


def test_one_version():
    # synth.__version__ is the package's version (pyproject.toml reads it), CITATION.cff
    # states it and the changelog's newest version is it (above it, the changes not yet
    # released, under "Unreleased").
    from importlib.metadata import version

    assert version("impact-synth") == synth.__version__
    citation = (REPOSITORY / "CITATION.cff").read_text()
    assert re.search(r'^version: "([^"]+)"$', citation, re.M).group(1) == synth.__version__
    changelog = (REPOSITORY / "CHANGELOG.md").read_text()
    assert re.search(r"^## (?!Unreleased$)(\S+)", changelog, re.M).group(1) == synth.__version__


def test_lowest_versions_are_the_declared_bounds():
    # .ci/lowest.txt pins each dependency at the lower bound pyproject.toml declares, so CI's
    # lowest-version run tests what the package admits.
    import tomllib

    project = tomllib.loads((REPOSITORY / "pyproject.toml").read_text())["project"]
    bounds = dict(re.fullmatch(r"([\w-]+)>=([\w.]+)", d).groups() for d in project["dependencies"])
    pins = dict(
        line.split("==")
        for line in (REPOSITORY / ".ci" / "lowest.txt").read_text().splitlines()
        if line and not line.startswith("#")
    )
    assert pins == bounds
