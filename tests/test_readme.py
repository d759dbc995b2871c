"""The README's two opening commands and the CI script stay in step."""

import subprocess
from pathlib import Path

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


def test_ci_runs_the_readme_test_command():
    # .ci/run extracts the second command from the README rather than repeating it, and
    # runs it in a fresh copy of the repository (so the environment it creates is new).
    out = subprocess.run(["bash", str(ROOT / ".ci" / "run"), "--print-command"],
                         capture_output=True, text=True, check=True).stdout
    assert out.strip() == _commands()[1].strip()
    ci = (ROOT / ".ci" / "run").read_text()
    assert "mktemp -d" in ci and "--exclude=./.venv" in ci


def test_main_job_renders_a_preset_of_the_repository():
    # The first command renders a preset file of the repository to a WAV in renders/.
    words = _commands()[0].split("synth render ")[1].split()
    assert (ROOT / words[0]).is_file()
    assert words[1] == "-o" and words[2].startswith("renders/") and words[2].endswith(".wav")
