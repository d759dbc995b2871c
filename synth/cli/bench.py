"""The ``warmup`` and ``bench`` subcommands: kernels compiled ahead of time, and the benchmarks of
the source checkout around the current folder (``benchmarks.cli.main``), never installed."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from synth.errors import SynthError

#: The project's name in the ``pyproject.toml`` of its source repository.
PROJECT = "impact-synth"

#: What ``synth bench`` says outside a checkout of the source repository.
NO_CHECKOUT = (
    "synth bench runs the project's benchmarks and validation studies (the figures of "
    "docs/benchmarks.md and docs/validation.md: error against run time, the engine beside "
    "the thesis' measurements); they are not installed with the package but live in the "
    "benchmarks/ and validation/ folders of its source repository. Run `synth bench NAME` "
    "(or `python -m benchmarks NAME`) in a checkout of that repository, with the package "
    "installed (pip install -e '.[test]'); no checkout holds {cwd}"
)


def _cmd_warmup(args):
    from synth import warmup

    chosen = warmup.steps()
    if args.steps:
        chosen = [chosen[i - 1] for i in args.steps]
    done = warmup.run(chosen)
    print(warmup.format_steps(done))
    if args.record:
        print(f"{warmup.record(done)}: compile times recorded")
    return 0


def add_warmup_parser(sub) -> None:
    p = sub.add_parser(
        "warmup",
        help="compile every kernel ahead of time (images, installers); print what "
        "compiled and how long each took",
    )
    p.add_argument(
        "--step",
        dest="steps",
        type=int,
        action="append",
        choices=range(1, 6),
        metavar="N",
        help="run only step N (repeatable): 1 the presets' renders, 2 a stiff contact, "
        "3 the live example, 4 the analysis, 5 a live rolling voice",
    )
    p.add_argument(
        "--record",
        action="store_true",
        help="keep each kernel group's compile time for the first-use note (run on an empty cache)",
    )
    p.set_defaults(func=_cmd_warmup)


def find_checkout(start: Path) -> Path | None:
    """The nearest of ``start`` and its parents with a ``benchmarks`` package and a readable
    ``pyproject.toml`` naming this project, or None."""
    import tomllib

    for folder in (start := start.resolve(), *start.parents):
        if not (folder / "benchmarks" / "__init__.py").is_file():
            continue
        try:
            if tomllib.loads((folder / "pyproject.toml").read_text())["project"]["name"] == PROJECT:
                return folder
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, KeyError, TypeError):
            continue
    return None


def checkout_benchmarks(root: Path):
    """``benchmarks.cli`` of the checkout ``root``, imported with ``root`` last on
    ``sys.path`` (``synth`` stays the installed package the benchmarks measure)."""
    import importlib

    if str(root) not in sys.path:
        sys.path.append(str(root))
    cli = importlib.import_module("benchmarks.cli")
    where = Path(cli.__file__).resolve().parent
    if where != (root / "benchmarks").resolve():
        raise SynthError(
            f"benchmarks={str(where)!r}: another package named benchmarks is imported "
            f"before the checkout's ({root / 'benchmarks'})"
        )
    return cli


def _cmd_bench(args) -> int:
    root = find_checkout(Path.cwd())
    if root is None:
        raise SynthError(NO_CHECKOUT.format(cwd=Path.cwd()))
    return checkout_benchmarks(root).main(args.argv, prog="synth bench")


def add_bench_parser(sub) -> None:
    """The bench subcommand: the rest of the command line is the benchmarks' own."""
    p = sub.add_parser(
        "bench",
        add_help=False,
        help="error against run time: the benchmarks of a source checkout (synth bench --help)",
    )
    p.add_argument("argv", nargs=argparse.REMAINDER, help="a benchmark's name and options")
    p.set_defaults(func=_cmd_bench)


def bench_arguments(argv: list[str]):
    """``synth bench ARGV``: all of ``argv`` for the benchmarks' parser (argparse's remainder
    would take no option before the benchmark's name)."""
    return argparse.Namespace(command="bench", argv=list(argv), func=_cmd_bench)
