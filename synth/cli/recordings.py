"""The subcommands on a recording: ``analyze`` (its ticks) and ``alter`` (its restitution)."""

from __future__ import annotations

import sys
import warnings

import numpy as np

from synth.cli.common import print_json
from synth.errors import SynthError


def _cmd_analyze(args):
    from synth import analysis

    if args.plot:
        analysis.check_plot_path(args.plot)  # a bad image path fails before any output
    from synth.store.audio import TruncatedAudioWarning

    with warnings.catch_warnings():
        # a truncated file is one of the result's warnings, printed below
        warnings.simplefilter("ignore", TruncatedAudioWarning)
        # options checked first; a long file read in blocks
        result = analysis.analyze_file(args.file, options=_analysis_options(args))
        audio, fs = analysis.read_recording(args.file) if args.plot else (None, None)
    for warning in result.warnings:
        print(f"synth: warning: {warning}", file=sys.stderr)
    if args.json:
        print_json(analysis.to_dict(result))
    elif args.csv:
        sys.stdout.write(analysis.to_csv(result))
    else:
        print(analysis.format_table(result, warnings=False))
    if args.plot:
        analysis.plot_analysis(result, audio, fs, args.plot)
    return 0


def _analysis_options(args):
    """The analysis options of the command's flags; unset ones keep their defaults."""
    from synth.analysis.options import OPTIONS, from_text

    return from_text(
        {name: getattr(args, name) for name in OPTIONS if getattr(args, name) is not None}
    )


def _cmd_alter(args):
    from synth.analysis import analyze
    from synth.stimuli.alter import alter_restitution
    from synth.store import audio as audio_io

    audio_io.check_output_path(args.output, "output", audio_io.FORMATS)  # before the analysis
    options = _analysis_options(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        audio, fs = audio_io.read_audio(args.file)
    for w in caught:  # a truncated file's, printed as the command's own
        print(f"synth: warning: {w.message}", file=sys.stderr)
    onsets = [t.time for t in analyze(audio, fs, options=options).ticks]
    altered = alter_restitution(
        audio,
        fs,
        args.restitution_scale,
        onsets=onsets,
        gravity=options.gravity,
        scale_amplitude=not args.keep_amplitude,
        min_bounce=args.min_bounce,
        normalize=args.normalize,
    )
    out, kept = altered.audio, len(altered.onsets)
    peak = float(np.max(np.abs(out)))
    subtype = (args.subtype or audio_io.DEFAULT_SUBTYPE).upper()
    if peak > 1.0 and subtype not in audio_io.FLOAT_SUBTYPES:
        raise SynthError(
            f"the altered audio peaks at {20 * np.log10(peak):+.2f} dBFS, above full scale, "
            f"and {args.output!r} would clip it (nothing written); use --normalize peak "
            f"(or a .wav file with --subtype FLOAT)"
        )
    audio_io.write_audio(args.output, out, fs, subtype=args.subtype)
    shortest = args.min_bounce if args.min_bounce is not None else float(np.min(np.diff(onsets)))
    end = f"; the series ends after {kept} ticks ({len(onsets) - kept} dropped: the next bounce "
    end += f"would be shorter than {shortest * 1e3:.3g} ms)"
    print(
        f"{args.output}: {kept} ticks re-laid; e {np.mean(altered.restitution):.3f} -> "
        f"{np.mean(altered.new_restitution):.3f} (mean over bounces)"
        f"{end if kept < len(onsets) else ''}, {out.shape[0] / fs:.3f} s, "
        f"normalize={args.normalize}"
    )
    return 0


def add_analyze_parser(sub) -> None:
    p = sub.add_parser(
        "analyze", help="detect and measure the ticks of a recording (WAV, FLAC, ...)"
    )
    p.add_argument("file")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="machine-readable output")
    out.add_argument("--csv", action="store_true", help="one row per tick")
    p.add_argument(
        "--plot",
        metavar="OUT.png",
        help="ticks, bounce times, restitution, energy, centroid, decay",
    )
    add_analysis_flags(p)
    p.set_defaults(func=_cmd_analyze)


def add_alter_parser(sub) -> None:
    p = sub.add_parser("alter", help="change the restitution of a recording: 1 - e' = K (1 - e)")
    p.add_argument("file")
    p.add_argument("-o", "--output", required=True, help="output file (.wav or .flac)")
    p.add_argument("--restitution-scale", type=float, required=True, metavar="K")
    p.add_argument(
        "--keep-amplitude",
        action="store_true",
        help="do not scale each tick by its new impact speed over its old one",
    )
    p.add_argument(
        "--min-bounce",
        type=float,
        metavar="S",
        help="shortest new bounce time, s: the series ends before a shorter one "
        "(default: the shortest bounce of the recording)",
    )
    p.add_argument(
        "--normalize",
        choices=["none", "peak"],
        default="none",
        help="level: none (the recording's, default) or peak (-1 dBFS)",
    )
    p.add_argument("--subtype", help="soundfile subtype of the output (default PCM_24)")
    add_analysis_flags(p)  # the ticks re-laid are the analysis'
    p.set_defaults(func=_cmd_alter)


def add_analysis_flags(p) -> None:
    """A flag for each analysis option from its declaration
    (:class:`synth.analysis.AnalysisOptions`); a switch on by default is ``--no-NAME``."""
    from synth.analysis import options

    for name in options.OPTIONS:
        d = options.declaration(name)
        if d.parse is bool:
            how = {"action": "store_const", "const": False}
        else:
            how = {"choices": d.choices, "metavar": d.metavar}
        flag = options.flag(name).split()[0]
        p.add_argument(flag, dest=name, help=options.flag_help(name), **how)
