"""The README's two opening commands and the CI script stay in step."""

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
    # .ci/run extracts the second command from the README rather than repeating it.
    ci = (ROOT / ".ci" / "run").read_text()
    assert "README.md" in ci and "sed -n 2p" in ci


def test_main_job_preset_exists():
    # The first command's preset file is in the repository.
    preset = _commands()[0].split("synth info ")[1].split()[0]
    assert (ROOT / preset).is_file()
