"""The documentation in docs/ stays true to the code: generated parts equal their generators,
every command-line option is documented, links resolve, and measured figures live in one
place (the block their command writes)."""

import re
import shutil
from pathlib import Path

import pytest

import benchmarks as bench
import validation as thesis_bench
from benchmarks import cli as bench_cli
from benchmarks import docs
from synth.cli import build_parser, main
from synth.errors import SynthError

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PAGES = (
    "physics.md",
    "analysis.md",
    "validation.md",
    "benchmarks.md",
    "cli.md",
    "materials.md",
    "rolling.md",
    "live.md",
)

#: The sections of docs/physics.md that code and other pages link to.
PHYSICS_SECTIONS = [
    "Materials",
    "Plate impedance",
    "Hertz contact",
    "Bounces",
    "Plate modes",
    "Radiation",
    "Modal synthesis",
    "Levels",
    "Known limitations",
    "References",
]


def _read(name):
    return (DOCS / name).read_text()


def test_every_page_exists():
    for name in PAGES:
        assert (DOCS / name).is_file(), name


def test_physics_has_exactly_the_linked_sections():
    headings = re.findall(r"^## (.+)$", _read("physics.md"), flags=re.M)
    assert headings == PHYSICS_SECTIONS


def test_materials_page_is_generated_from_the_table():
    # docs/materials.md is exactly what `python -m benchmarks.docs` writes; regenerate it with
    # that command when the table changes.
    assert _read("materials.md") == docs.materials_page()


def _undocumented(parser, text):
    """``synth NAME OPTION`` for every subcommand and option string (and every choice of a
    positional argument) of ``parser`` that its section of ``text`` does not name; the
    options of ``synth bench`` are those of the checkout's benchmarks."""
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    missing = []
    for name, p in dict(sub.choices, bench=bench_cli.build_parser()).items():
        if f"## synth {name}" not in text:
            missing.append(f"synth {name}")
            continue
        section = text.split(f"## synth {name}", 1)[1].split("\n## ", 1)[0]
        words = [s for a in p._actions for s in a.option_strings if s not in ("-h", "--help")]
        words += [c for a in p._actions if not a.option_strings and a.choices for c in a.choices]
        missing += [f"synth {name} {w}" for w in words if f"`{w}" not in section]
    return missing


def test_cli_page_documents_every_subcommand_and_option():
    assert _undocumented(build_parser(), _read("cli.md")) == []


def test_cli_page_check_finds_an_undocumented_option():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    sub.choices["render"].add_argument("--not-documented")
    assert _undocumented(parser, _read("cli.md")) == ["synth render --not-documented"]


def _slug(heading):
    """GitHub's anchor of a Markdown heading."""
    s = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return s.replace(" ", "-")


def _anchors(path):
    return {_slug(h) for h in re.findall(r"^#+ (.+)$", path.read_text(), flags=re.M)}


@pytest.mark.parametrize(
    "path", [ROOT / "README.md"] + [DOCS / n for n in PAGES], ids=lambda p: p.name
)
def test_links_resolve(path):
    # Every relative link points at a file of the repository, and every #anchor at a heading.
    for target in re.findall(r"\]\(([^)\s]+)\)", path.read_text()):
        if re.match(r"[a-z]+://", target):
            continue
        file, _, anchor = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        assert dest.exists(), f"{path.name}: {target}"
        if anchor:
            assert anchor in _anchors(dest), f"{path.name}: {target}"


#: Names of files outside the repository that the project must not cite (built here so that
#: this test does not cite them itself).
_OUTSIDE = ("PHYSICS" + ".md", "DESIGN" + ".md", "../" + "shared")


def test_no_reference_outside_the_repository():
    # The physics reference of the project is docs/physics.md: no page, module, test, preset
    # or example points at a file that is not in the repository.
    paths = [ROOT / "README.md", *DOCS.glob("*.md")]
    for folder, pattern in (
        ("synth", "*.py"),
        ("tests", "*.py"),
        ("synth/presets", "*.toml"),
        ("examples", "*.py"),
    ):
        paths += sorted((ROOT / folder).rglob(pattern))
    for path in paths:
        text = path.read_text()
        for name in _OUTSIDE:
            assert name not in text, f"{path.relative_to(ROOT)} cites {name}"


# --- measured figures: in the block their command writes, nowhere else -------------------
def _all_blocks():
    blocks = {}
    for name in PAGES:
        for key, body in docs.bench_blocks(_read(name)).items():
            assert key not in blocks, f"bench:{key} appears twice"
            blocks[key] = (name, body)
    return blocks


def test_every_benchmark_has_one_block_in_its_page():
    blocks = _all_blocks()
    assert set(blocks) == set(docs.BENCH_PAGES)
    for key, (page, _) in blocks.items():
        assert page == docs.BENCH_PAGES[key]
        assert f"`synth bench {key}`" in _read(page)  # the command that writes it


def _significant(token):
    digits = re.sub(r"e[+-]?\d+$", "", token).replace(".", "").replace("-", "").lstrip("0")
    return len(digits)


#: A measured figure: a decimal or exponent number standing alone (not part of a name).
_NUMBER = r"(?<![\w.])(?P<number>-?(?:\d+\.\d+(?:e[+-]?\d+)?|\d+e[+-]?\d+))(?![\w.])"
#: A unit written after a figure in a table cell.
_UNIT = r"(?:\s?(?P<unit>%|(?:dB|Hz|kHz|ms|us|s|mm|um|m/s|m|N|Pa|kPa|MPa|GPa|kg|g|J)\b))?"
#: Headers of columns of run times, which vary from run to run (a coincidence with a number
#: of the prose would not be a pasted figure): left out of the check.
_TIMING = re.compile(
    r"\bus\b|us/|\(ms\)$|render \(ms\)|time per|factor|speed-up|ns per|\bs\b|seconds|sounds/s"
    r"|\bMB\b|% of|percentile|^max$"
)


def _block_figures(body):
    """Measured figures of a block: decimal numbers with three or more significant digits
    in its table cells, apart from the first column (the case or quantity measured), the
    columns of published values (a header naming the thesis) and of run times. A number
    written with its unit in the cell is the figure with that unit ("10.1 dB"): the same
    number of another quantity elsewhere (a modulus of 10.1 GPa) is not a copy of it."""
    figures = set()
    skip = set()
    for line in body.splitlines():
        if not line.startswith("|"):
            skip = set()  # a new table starts after any other line
            continue
        cells = line.strip().strip("|").split("|")
        if line.startswith("|---"):
            continue
        if not skip:  # the header row
            skip = {0} | {
                i
                for i, c in enumerate(cells)
                if "thesis" in c or (_TIMING.search(c.strip()) and "error" not in c)
            }
            continue
        for i, cell in enumerate(cells):
            if i in skip:
                continue
            for m in re.finditer(_NUMBER + _UNIT, cell):
                if _significant(m.group("number")) >= 3:
                    unit = f" {m.group('unit')}" if m.group("unit") else ""
                    figures.add(m.group("number").lstrip("-") + unit)
    return figures


def _outside_blocks(text):
    return re.sub(r"<!-- bench:([a-z]+) -->.*?<!-- /bench:\1 -->", "", text, flags=re.S)


#: The end of a text that a number of the thesis' numbering follows (equation, table, figure,
#: section, chapter).
_REFERENCE = re.compile(r"(?:\beqs?\.|\bTables?|\bFigs?\.|\bsections?|\bChapters?) $")


def test_measured_figures_are_not_pasted_outside_their_block():
    # A figure a benchmark prints is written by `synth bench NAME --update-docs` into its
    # block; prose refers to the block rather than repeating the figure (which would go
    # stale at the next run).
    figures = set()
    for _, body in _all_blocks().values():
        figures |= _block_figures(body)
    for path in [ROOT / "README.md"] + [DOCS / n for n in PAGES]:
        text = _outside_blocks(path.read_text())
        for fig in figures:
            number, _, unit = fig.partition(" ")
            after = rf"\s?{re.escape(unit)}(?![\w])" if unit else r"(?![\d])"
            for m in re.finditer(rf"(?<![\d.]){re.escape(number)}{after}", text):
                # a reference's number (thesis eq. 2.42, Table 3.3) is not a figure
                assert _REFERENCE.search(text[: m.start()]), (
                    f"{path.name} repeats the measured figure {fig} outside its block"
                )


def test_block_figures_are_found():
    body = (
        "Printed by `synth bench thesis --markdown` on ...\n\n"
        "| quantity | engine | thesis (measured) | error | render (ms) | onset error, RMS (ms) |\n"
        "|---|---|---|---|---|---|\n"
        "| steel 12.55 mm | 0.871 | 0.87 | 3.4e-07 | 12.6 | 0.013 |\n"
        "| time (us) | 103.7 | 110.0 | 3.41e-07 | 12.7 | 0.0291 |\n"
        "| DOP853 | 1e-03 | 5148 / 7137 | -86.6 | 13.8 | 0.068 |\n"
        "| level | +10.1 dB | 1.0 | 2.50 | 1.0 | 1.0 |\n"
    )
    assert _block_figures(body) == {
        "0.871",
        "103.7",
        "3.41e-07",
        "86.6",
        "0.0291",
        "10.1 dB",
        "2.50",
    }


def test_replace_bench_block():
    text = (
        "a\n<!-- bench:thesis -->\nold\n<!-- /bench:thesis -->\n"
        "b\n<!-- bench:render -->\nx\n<!-- /bench:render -->\n"
    )
    new = docs.replace_bench_block(text, "thesis", "new figures")
    assert docs.bench_blocks(new) == {"thesis": "new figures\n", "render": "x\n"}
    assert docs.replace_bench_block(new, "thesis", "new figures") == new
    with pytest.raises(SynthError, match="bench='contact'"):
        docs.replace_bench_block(text, "contact", "y")


def test_markdown_block_names_its_command():
    block = bench.markdown_block("synth bench thesis --markdown", "| a | b |\n|---|---|")
    assert block.startswith("Printed by `synth bench thesis --markdown` on ")
    assert block.endswith("| a | b |\n|---|---|\n")


def test_bench_update_docs_writes_the_block(tmp_path, monkeypatch, capsys):
    # `synth bench thesis --update-docs` replaces the block of a copy of docs/ and nothing
    # else of the page. The modal plate's rows (minutes of plate modes on a cold cache) are
    # left out here: tests/test_fidelity_modal.py, tests/test_fidelity_lowspeed.py,
    # tests/test_fidelity_shear.py, tests/test_fidelity_edge.py and
    # tests/test_fidelity_losses.py check them.
    copy = tmp_path / "docs"
    shutil.copytree(DOCS, copy)
    monkeypatch.setattr(docs, "docs_dir", lambda: copy)
    monkeypatch.setattr(
        thesis_bench.modal, "thesis_modal_rows", lambda pairs=None, samplerate=48000: []
    )
    monkeypatch.setattr(thesis_bench.surface, "surface_fit", lambda rounds=4: None)
    monkeypatch.setattr(thesis_bench.series, "thesis_lowspeed_rows", lambda samplerate=48000: [])
    monkeypatch.setattr(thesis_bench.shear, "thesis_transverse_shear_rows", lambda pairs=None: [])
    monkeypatch.setattr(thesis_bench.shear, "transverse_shear_sensitivity", lambda: None)
    monkeypatch.setattr(thesis_bench.edge, "edge_study", lambda: [])
    monkeypatch.setattr(thesis_bench.losses, "loss_law_study", lambda: None)
    before = (copy / "validation.md").read_text()
    assert main(["bench", "thesis", "--update-docs"]) == 0
    after = (copy / "validation.md").read_text()
    assert _outside_blocks(after) == _outside_blocks(before)
    body = docs.bench_blocks(after)["thesis"]
    assert body.startswith("Printed by `synth bench thesis --markdown` on ")
    assert "| restitution, steel 10.0 mm on 18 mm, first impact (1.4 m/s) |" in body
    assert "bench:thesis updated" in capsys.readouterr().out


def test_bench_rejects_json_with_markdown(capsys):
    assert main(["bench", "thesis", "--json", "--markdown"]) == 2
    assert "--json cannot be combined" in capsys.readouterr().err
