"""The sound bank subcommands: ``bank`` (render, resumable; contact sheet, preview) and
``bank-gain`` (a finished bank scaled by one gain)."""

from __future__ import annotations

import sys


def _audition(args, folder) -> None:
    from synth.bank import audition

    if args.preview:
        print(f"preview: {audition.preview(folder, args.preview)}", file=sys.stderr)
    if args.sheet:
        print(f"contact sheet: {audition.sheet(folder, args.sheet)}", file=sys.stderr)


def _cmd_bank(args):
    from pathlib import Path

    from synth import bank
    from synth.bank import manifest

    folder = Path(args.spec)
    if args.output is None and folder.is_dir() and (folder / manifest.SPEC).is_file():
        if not (args.sheet or args.preview):
            raise bank.BankSpecError(
                f"{args.spec!r} is a bank's folder: give --sheet PNG and/or --preview FILE, "
                f"or a spec and -o DIR to render"
            )
        _audition(args, folder)
        return 0
    if args.output is None:
        raise bank.BankSpecError("-o DIR is required to render a bank (the folder of its files)")
    from synth.bank.options import OPTIONS

    result = bank.run(args.spec, args.output, **{name: getattr(args, name) for name in OPTIONS})
    if args.dry_run:
        import json

        for row in result.planned_rows:
            print(json.dumps(row))
    print(result.summary(), file=sys.stderr)
    if result.ok and not args.dry_run and (args.sheet or args.preview):
        _audition(args, args.output)
    return 0 if result.ok else 1


def _cmd_bank_gain(args):
    from synth.bank.gain import apply_gain

    result = apply_gain(
        args.bank, args.output, target=args.target, level=args.level, prune=args.prune
    )
    print(result.summary(), file=sys.stderr)
    return 0


def add_bank_parser(sub) -> None:
    p = sub.add_parser(
        "bank", help="render a sound bank: many variations of a preset, resumable, with a manifest"
    )
    p.add_argument(
        "spec",
        help="bank spec (TOML: preset, [vary] axes, count, name, format) or the name of an "
        "installed example spec",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        help="folder of the files, manifest.csv/.jsonl and the stored spec (required to render)",
    )
    from synth.bank.options import OPTIONS

    for name, (keywords, text) in OPTIONS.items():
        p.add_argument("--" + name.replace("_", "-"), help=text, **keywords)
    p.add_argument(
        "--sheet",
        metavar="PNG",
        help="a contact sheet of the finished sounds (waveform, spectrogram, values)",
    )
    p.add_argument(
        "--preview",
        metavar="FILE",
        help="every finished sound in one WAV/FLAC file, with short gaps",
    )
    p.set_defaults(func=_cmd_bank)


def add_bank_gain_parser(sub) -> None:
    p = sub.add_parser(
        "bank-gain",
        help="scale a finished bank by one gain (its loudest true peak or median loudness "
        "to a target) into another folder, resumable",
    )
    p.add_argument("bank", help="folder of a finished bank (synth bank ... -o DIR)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder of the result")
    p.add_argument(
        "--target",
        choices=["true_peak", "loudness"],
        default="true_peak",
        help="the loudest true peak (default) or the median loudness to --level",
    )
    p.add_argument(
        "--level",
        type=float,
        metavar="DB",
        help="the target: dBTP for true_peak (default -1), LUFS for loudness (default -23)",
    )
    p.add_argument(
        "--prune",
        action="store_true",
        help="delete the audio files in DIR that its manifest does not name (without it "
        "they are only reported)",
    )
    p.set_defaults(func=_cmd_bank_gain)
