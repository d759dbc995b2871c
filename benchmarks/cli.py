"""``synth bench NAME`` (also ``python -m benchmarks NAME``): run one benchmark and print its
figures as a table, as JSON, or as the Markdown block of docs/ that ``--update-docs`` writes
between its markers (:mod:`benchmarks.docs`).

``synth bench`` finds this package in the source checkout it runs in and hands it the rest
of its command line (:mod:`synth.cli.bench`); the benchmarks are not installed with the
package.
"""

from __future__ import annotations

import argparse
import json
import sys

from synth.errors import SynthError

#: The benchmarks, in the order ``--help`` lists them, with what each measures.
BENCHMARKS = {
    "contact": "solver error and time per impact against scipy",
    "render": "audio error against a reference and real-time factor",
    "thesis": "the engine beside the thesis' model and measurements",
    "analysis": "recovered restitution and onsets against noise",
    "long": "the analysis of long recordings: time and peak memory",
    "live": "the live engine's callback, hit() and add() costs, and underflows through a "
    "JACK dummy server",
    "scale": "cold and warm cost of modes, radiation gains and synthesis for a ladder of plates",
    "hires": "cold renders at 96, 192 and 384 kHz, and at 384 kHz with the previous paths",
    "bank": "sounds/s of a sound bank against one process per file",
    "cold": "CPU and wall time and peak memory of the first import synth, synth render "
    "default and live example on empty numba and plate-mode caches, and the same warm",
    "rolling": "the rolling contact's and its modal drive's time per second of audio, and "
    "the rolling presets' renders",
    "rollingcheck": "the rolling's contact-loss speed, energy balance and spectral centroid "
    "against speed and size, beside a published measurement of rolling balls",
    "hollow": "the hollow balls against their rule books' bounce tests",
    "materials": "solid balls of the material table against published bounces",
    "rules": "each radiation rule's estimated cost and the rule chosen on the presets, the "
    "scale benchmark's plates and the hires rates",
    "cost": "this machine's rates of the cost estimate's work (a cold mode solve, each "
    "radiation rule), which synth info --cost turns into seconds",
}


def _runs(args) -> dict:
    """Each benchmark's ``(run, format)``: ``run()`` measures and returns a JSON-clean
    result, ``format(result)`` its Markdown tables."""
    import benchmarks as bench
    from benchmarks import bank, live

    def repeat(default: int) -> int:
        return default if args.repeat is None else args.repeat

    tolerances = tuple(args.tolerances) if args.tolerances else (1e-3, 1e-4, 1e-6, 1e-8, 1e-10)
    return {
        "contact": (
            lambda: bench.run_contact(tolerances=tolerances, repeat=repeat(300), modal=True),
            bench.format_contact,
        ),
        "render": (lambda: bench.run_render(repeat=repeat(5)), bench.format_render),
        "thesis": (lambda: bench.thesis_comparison(modal=True), bench.format_thesis),
        "analysis": (
            (lambda: bench.run_random(args.random, args.seed, limit=args.limit))
            if args.random
            else bench.run_analysis,
            bench.format_random if args.random else bench.format_analysis,
        ),
        "long": (bench.run_long, bench.format_long),
        "live": (lambda: live.run_live(seconds=args.seconds), live.format_live),
        "scale": (bench.run_scale, bench.format_scale),
        "hires": (bench.run_hires, bench.format_hires),
        "cold": (bench.run_cold, bench.format_cold),
        "rolling": (lambda: bench.run_rolling(repeat=repeat(3)), bench.format_rolling),
        "rollingcheck": (bench.run_rolling_check, bench.format_rolling_check),
        "hollow": (bench.run_hollow, bench.format_hollow),
        "materials": (bench.run_materials, bench.format_materials),
        "cost": (bench.run_cost, bench.format_cost),
        "rules": (bench.run_rules, bench.format_rules),
        "bank": (lambda: bank.run_bank(count=args.count), bank.format_bank),
    }


def _check_options(args) -> None:
    """Refuse options that do not go together or with this benchmark (:class:`SynthError`)."""
    if args.json and (args.markdown or args.update_docs):
        raise SynthError("--json cannot be combined with --markdown or --update-docs")
    if args.random and (args.what != "analysis" or args.update_docs):
        raise SynthError(
            "--random is an option of 'synth bench analysis' alone, and its figures have "
            "no block in docs/ (--update-docs)"
        )
    if args.record and args.what != "cost":
        raise SynthError("--record is an option of 'synth bench cost' alone")


def run(args) -> int:
    """Run the benchmark ``args.what`` and print (or write into docs/) its figures."""
    import benchmarks as bench

    _check_options(args)
    measure, fmt = _runs(args)[args.what]
    result = measure()
    if args.record:
        print(f"{bench.record_rates(result)}: rates recorded")
    if args.json:
        json.dump(result, sys.stdout, indent=1)
        print()
    elif args.markdown or args.update_docs:
        block = bench.markdown_block(bench_command(args), fmt(result))
        if args.update_docs:
            from benchmarks.docs import update_bench_docs

            print(f"{update_bench_docs(args.what, block)}: block bench:{args.what} updated")
        else:
            print(block, end="")
    else:
        print(fmt(result))
    return 0


def bench_command(args) -> str:
    """The benchmark's command line, as printed in a docs/ block."""
    words = ["synth", "bench", args.what]
    if args.repeat is not None:
        words += ["--repeat", str(args.repeat)]
    if args.tolerances:
        words += ["--tolerances", *(f"{t:g}" for t in args.tolerances)]
    return " ".join(words + ["--markdown"])


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def build_parser(prog: str = "synth bench") -> argparse.ArgumentParser:
    """The benchmarks' command line: a benchmark's name and the options of the runs."""
    p = argparse.ArgumentParser(
        prog=prog, description="Error against run time, measured in one run (docs/)."
    )
    p.add_argument(
        "what",
        choices=list(BENCHMARKS),
        help="; ".join(f"{name}: {text}" for name, text in BENCHMARKS.items()),
    )
    p.add_argument(
        "--record",
        action="store_true",
        help="cost: write the rates for synth info --cost (synth/cost_rates.json)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--markdown",
        action="store_true",
        help="the block for docs/: the command, date and machine, then the tables",
    )
    p.add_argument(
        "--update-docs",
        action="store_true",
        help="write that block between its markers in docs/ (a source checkout)",
    )
    p.add_argument(
        "--repeat",
        type=_positive_int,
        help="timed calls per figure, median, >= 1 (default: "
        "contact 300, render 5, rolling 3; thesis and analysis time nothing)",
    )
    p.add_argument(
        "--tolerances", type=float, nargs="+", help="rtol values (default 1e-3 ... 1e-10)"
    )
    p.add_argument(
        "--seconds",
        type=float,
        default=30.0,
        help="live: length of each JACK dummy server phase, s (default 30)",
    )
    p.add_argument("--count", type=int, default=200, help="bank: sounds of the bank (default 200)")
    p.add_argument(
        "--random",
        type=_positive_int,
        metavar="N",
        help="analysis: N random scenes rendered by the engine, scored against its impacts "
        "(false ticks, impossible values, audible impacts missed, s per s of audio)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="analysis --random: the seed drawing the scenes"
    )
    p.add_argument(
        "--limit",
        type=float,
        default=120.0,
        metavar="S",
        help="analysis --random: longest analysis of one scene, s; a scene that takes longer "
        "is stopped and counted with every audible impact missed (default 120)",
    )
    return p


def main(argv: list[str] | None = None, prog: str = "synth bench") -> int:
    """Parse ``argv`` (a benchmark's name and options) and run it; argparse exits with
    status 2 on a malformed command line."""
    return run(build_parser(prog).parse_args(argv))
