"""The README's two opening commands and the CI script stay in step."""

import re
import subprocess
from pathlib import Path

from conftest import python_blocks

ROOT = Path(__file__).resolve().parent.parent


def _commands():
    text = (ROOT / "README.md").read_text()
    block = text.split("```", 2)[1]
    return [line for line in block.splitlines()[1:] if line.strip()]


def test_readme_opens_with_exactly_two_commands():
    # The README's first code block holds exactly the install+main-job and install+tests lines.
    cmds = _commands()
    assert len(cmds) == 2
    assert "pip install ." in cmds[0] and "synth " in cmds[0]
    assert "pip install '.[test]'" in cmds[1] and "pytest" in cmds[1]


def test_ci_runs_both_readme_commands():
    # .ci/run reads both commands from the README rather than repeating them, and runs each in
    # a fresh copy of the repository (so the environment it creates is new).
    out = subprocess.run(
        ["bash", str(ROOT / ".ci" / "run"), "--print-commands"],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    assert out.splitlines() == [c.strip() for c in _commands()]
    ci = (ROOT / ".ci" / "run").read_text()
    assert "mktemp -d" in ci and "git -C" in ci and "ls-files" in ci


def test_main_job_renders_a_shipped_preset():
    # The first command renders a preset installed with the package to a WAV in renders/.
    from synth.io.presets import find

    words = _commands()[0].split("synth render ")[1].split()
    assert find(words[0]).is_file()
    assert words[1] == "-o" and words[2].startswith("renders/") and words[2].endswith(".wav")


def _api_example():
    return python_blocks("README.md")[0]


def test_readme_is_short():
    # A newcomer reads it in five minutes; the rest is in docs/.
    assert len((ROOT / "README.md").read_bytes()) < 12_000


def test_readme_api_example_runs(tmp_path, monkeypatch):
    # The Python example of the README runs as printed (it writes tick.wav in the current
    # folder, here a temporary one) and is about fifteen lines.
    code = _api_example()
    assert 12 <= len([line for line in code.splitlines() if line.strip()]) <= 17
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "readme_example"})
    assert (tmp_path / "tick.wav").is_file()


def _layout_entries(layout: str) -> list[list[str]]:
    """The words of each entry of the layout map: an entry starts at the line's start and
    goes on over the indented lines below it."""
    entries: list[list[str]] = []
    for line in layout.splitlines():
        if not line.strip():
            continue
        if line[0].isspace() and entries:
            entries[-1] += line.split()
        else:
            entries.append(line.split())
    return entries


#: The packages of the repository the layout maps: the engine, and the benchmarks and the
#: thesis study beside it.
PACKAGES = ("synth", "benchmarks", "validation")


def _listed_modules(entry: list[str]) -> set[str]:
    """A module's own entry names it; a package's (``synth/.../``, ``benchmarks/``, ...)
    names its modules, each ``name.py`` in its text."""
    head = entry[0]
    if not (head.startswith(tuple(f"{p}/" for p in PACKAGES)) and head.endswith("/")):
        return {head}
    names = (word.strip(",;:()") for word in entry[1:])
    return {head + name for name in names if re.fullmatch(r"\w+\.py", name)}


def test_readme_layout_lists_every_module():
    # The layout map names every module of the package and of the benchmarks beside it: a
    # line each, or a package's line naming its modules.
    text = (ROOT / "README.md").read_text()
    layout = text.split("## Layout", 1)[1].split("```")[1]
    listed = set().union(*(_listed_modules(e) for e in _layout_entries(layout)))
    files = {
        p.relative_to(ROOT).as_posix()
        for package in PACKAGES
        for p in (ROOT / package).rglob("*.py")
    }
    required = {f for f in files if not f.endswith(("/__init__.py", "/__main__.py"))}
    assert required - listed == set()
    assert {m for m in listed if m.endswith(".py")} - files == set()


def test_readme_shows_a_reference_render():
    text = (ROOT / "README.md").read_text()
    assert "](renders/default.png)" in text and (ROOT / "renders" / "default.png").is_file()
