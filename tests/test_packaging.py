"""What a user installs: the wheel holds every module and preset, the installed package is the
one under test, and the project states one version."""

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from conftest import REPOSITORY

import synth

SOURCE = REPOSITORY / "synth"


def _source_files() -> set[str]:
    """The package's modules and presets in the source tree, relative to the repository."""
    files = {p for p in SOURCE.rglob("*.py") if "__pycache__" not in p.parts}
    files |= set((SOURCE / "presets").rglob("*.toml"))
    return {p.relative_to(REPOSITORY).as_posix() for p in files}


@pytest.mark.slow
def test_wheel_holds_every_module_and_preset(tmp_path):
    # The wheel `pip install .` builds holds every module under synth/ and every preset: a
    # package left out of pyproject.toml breaks every installed copy while a suite importing
    # the source tree stays green. Built from a copy of the files a build reads, so the
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
    for rel in _source_files() | {"synth/py.typed"}:
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


def test_installed_package_is_the_source_trees():
    # The package under test holds the same modules and presets as the source tree, so the
    # tests that read the repository's files speak of the code that runs.
    installed = Path(synth.__file__).resolve().parent
    files = {p for p in installed.rglob("*.py") if "__pycache__" not in p.parts}
    files |= set((installed / "presets").rglob("*.toml"))
    assert {"synth/" + p.relative_to(installed).as_posix() for p in files} == _source_files()


def test_one_version():
    # synth.__version__ is the package's version (pyproject.toml reads it), CITATION.cff
    # states it and the changelog's newest entry is it.
    from importlib.metadata import version

    assert version("impact-synth") == synth.__version__
    citation = (REPOSITORY / "CITATION.cff").read_text()
    assert re.search(r'^version: "([^"]+)"$', citation, re.M).group(1) == synth.__version__
    changelog = (REPOSITORY / "CHANGELOG.md").read_text()
    assert re.search(r"^## (\S+)", changelog, re.M).group(1) == synth.__version__


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
