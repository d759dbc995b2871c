"""The command line: ``synth SUBCOMMAND ...`` (argparse).

Subcommands: ``render`` (a preset to a WAV/FLAC file), ``analyze`` and ``alter`` (a
recording), ``gallery`` (the reference renders), ``info`` (the impact table of a
preset), ``presets`` (list them),
``materials`` (the material table), ``play`` (a preset through the live engine),
``bench`` (error against run time).
Errors in the input are reported in one line on stderr with exit status 2.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from synth.constants import GRAVITY
from synth.errors import SynthError


def _add_preset_args(p):
    p.add_argument("preset", help="preset file (NAME.toml) or preset name")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a preset key, e.g. --set ball.radius=0.007 (repeatable)",
    )


def _cmd_info(args):
    from synth.io.presets import load_preset_with_options
    from synth.physics.bounces import simulate_scene

    scene, section, data = load_preset_with_options(args.preset, args.overrides)
    if args.cost:
        return _print_cost(scene, section, args.json)
    path = _path_of(scene, section) if scene.moving else None
    seq = simulate_scene(scene) if path is None else path.impacts
    rows = seq.table()
    ending = {} if path is None else _path_ending(path)
    if args.json:
        json.dump(
            dict(
                preset=args.preset,
                description=data.get("description", ""),
                stop_reason=seq.stop_reason,
                duration=seq.duration,
                impacts=rows,
                **ending,
            ),
            sys.stdout,
            indent=1,
        )
        print()
        return 0
    if data.get("description"):
        print(data["description"])
    print(
        f"{'n':>4} {'time (s)':>10} {'speed (m/s)':>12} {'e':>8} {'tau (us)':>9} "
        f"{'F_max (N)':>10} {'lambda':>8}"
    )
    for r in rows:
        e = "settled" if r["settled"] else f"{r['restitution']:.4f}"
        print(
            f"{r['n']:>4} {r['time']:>10.5f} {r['speed']:>12.5f} {e:>8} "
            f"{r['contact_time'] * 1e6:>9.2f} {r['peak_force']:>10.4g} {r['inelasticity']:>8.4f}"
        )
    print(f"{len(rows)} impacts; the sequence ended: {seq.stop_reason}")
    if path is not None:
        print(
            f"rolled {ending['rolling_seconds']:.3f} s from {ending['rolling_start']} s at "
            f"{ending['rolling_speed']:.4g} m/s; the path ended: {ending['path_end']} at "
            f"{ending['path_end_time']:.4f} s, ({ending['path_end_point'][0]:.4f}, "
            f"{ending['path_end_point'][1]:.4f}) m"
        )
    return 0


def _path_of(scene, section: dict):
    """The :class:`synth.physics.path.BallPath` of a scene with a velocity, on the sample
    grid of the preset's render section."""
    import math

    from synth.physics.path import simulate_path
    from synth.sound.render import check_options

    o = check_options(**{k: v for k, v in section.items() if k != "subtype"})
    origin = math.sqrt(2.0 * scene.drop_height / scene.gravity) - o["preroll"]
    return simulate_path(
        scene, samplerate=o["samplerate"], time_origin=origin, max_duration=o["max_duration"]
    )


def _path_ending(path) -> dict:
    """How a ball's path rolled and ended (s, m/s, m), for ``synth info``."""
    rolling = path.rolling
    return dict(
        path_end=path.end,
        path_end_time=path.end_time,
        path_end_point=list(path.end_point),
        rolling_speed=path.rolling_speed,
        rolling_start=None if rolling is None else round(rolling.start, 6),
        rolling_seconds=0.0 if rolling is None else rolling.duration,
    )


def _budget_seconds(budget) -> str:
    """`` (about N s and M s of radiation at the measured rates)``: the time budgets in
    seconds (:class:`synth.cost.Rates`; the radiation budget's rectangle-term equivalents
    at the rectangle rule's rate, the same time for every rule), or nothing without
    measured rates."""
    from synth import cost

    rates = cost.Rates.load()
    if rates is None:
        return ""
    solver = budget.max_solver_flops / rates.solver
    radiation = budget.max_radiation_work / rates.radiation["rectangle"]
    return f" (about {solver:.3g} s and {radiation:.3g} s of radiation at the measured rates)"


def _print_cost(scene, section: dict, as_json: bool) -> int:
    """``synth info --cost``: the render's :func:`synth.cost.estimate` with the preset's
    render options, and what a render would refuse (nothing is solved but the first
    contact)."""
    from dataclasses import asdict

    from synth import cost

    budget = cost.Budget.from_environment()
    estimate = cost.estimate_render(scene, section, budget)  # the section sets samplerate
    too_big = estimate.excess(budget)
    if as_json:
        json.dump(
            dict(asdict(estimate), budget=asdict(budget), refused=too_big), sys.stdout, indent=1
        )
        print()
        return 0
    for name, value in estimate.rows():
        print(f"{name:<28} {value}")
    print(
        f"budget: {budget.max_modes} modes, {budget.max_pulse_points} pulse points, "
        f"{budget.max_memory_bytes / 2**20:.0f} MiB, {budget.max_solver_flops:.3g} solver "
        f"flop, {budget.max_radiation_work:.3g} radiation rectangle-term equivalents"
        f"{_budget_seconds(budget)}"
    )
    for reason in too_big:
        print(f"a render would be refused: {reason}")
    if not too_big:
        print("a render fits the budget")
    return 0


def render_options(scene_render: dict, args, source: str) -> tuple[dict, str | None]:
    """Render keywords from a preset's [render] section (checked when the preset was
    read) and the command line (which wins)."""
    opts = dict(scene_render)
    for key in ("samplerate", "normalize", "subtype", "loudness_lufs", "peak_db", "floor_db"):
        value = getattr(args, key, None)
        if value is not None:
            opts[key] = value
    subtype = opts.pop("subtype", None)
    return opts, subtype


def _report(rendered, data, preset) -> dict:
    return dict(
        preset=str(preset),
        description=data.get("description", ""),
        samplerate=rendered.samplerate,
        duration=rendered.duration,
        units=rendered.units,
        gain=rendered.gain,
        settings=rendered.settings,
        impacts=[
            dict(row, onset=float(onset))
            for row, onset in zip(rendered.impacts.table(), rendered.onsets)
        ],
    )


def _cmd_render(args):
    from synth.io import audio as audio_io
    from synth.io.presets import find, load_preset_with_options
    from synth.sound.render import render

    outputs = Outputs(  # every output path checked before any work
        {"output": args.output, "report": args.report, "plot": args.plot},
        {"output": audio_io.FORMATS, "plot": (".png",)},
    )
    scene, render_section, data = load_preset_with_options(args.preset, args.overrides)
    opts, subtype = render_options(render_section, args, str(find(args.preset)))
    if args.timing_from is not None or args.restitution_scale is not None:
        from synth.sound.render import bounce_options, check_options
        from synth.stimuli import sequences as stimuli

        k = 1.0 if args.restitution_scale is None else args.restitution_scale
        bounces = bounce_options(check_options(**opts))  # the preset's stop rules
        if args.timing_from is None:
            opts["sequence"] = stimuli.scaled_sequence(scene, k, **bounces)
        else:
            timing = load_preset_with_options(args.timing_from)[0]
            opts["sequence"] = stimuli.mismatch_sequence(
                timing, scene, restitution_scale=k, **bounces
            )
    rendered = render(scene, **opts)
    with outputs:
        audio_io.write_audio(
            outputs.staged("output"), rendered.audio, rendered.samplerate, subtype=subtype
        )
        if args.report:
            _write_json(outputs.staged("report"), _report(rendered, data, args.preset))
        if args.plot:
            from synth.io.plot import plot_render

            plot_render(rendered, outputs.staged("plot"))
    print(
        f"{args.output}: {rendered.duration:.3f} s at {rendered.samplerate} Hz, "
        f"{len(rendered.impacts)} impacts ({rendered.impacts.stop_reason}), "
        f"{rendered.settings['n_modes_rendered']} of {rendered.settings['n_modes']} modes, "
        f"normalize={rendered.settings['normalize']}"
    )
    return 0


class Outputs:
    """The output files of one command, written all or none.

    Each path is checked when the command starts (before any work): not a directory, in
    an existing folder where a file can be created. Inside ``with outputs:`` every file
    is written to a temporary name beside its target (:meth:`staged`); they are renamed
    onto their targets only when the block ends without an error, else removed, so a
    failure (or SIGTERM, SIGINT) leaves every existing output as it was.
    """

    def __init__(self, paths: dict, suffixes: dict | None = None):
        from pathlib import Path

        from synth.io.audio import check_output_path

        self.paths = {k: Path(v) for k, v in paths.items() if v}
        _refuse_shared_paths(self.paths)
        for field, path in self.paths.items():
            check_output_path(path, field, (suffixes or {}).get(field))
        self.temporaries: dict = {}

    def staged(self, field: str):
        """The temporary path to write ``field``'s file to (same folder and suffix)."""
        from synth.io.atomic import temporary_name

        target = self.paths[field]
        tmp = target.with_name(temporary_name(target.suffix))
        self.temporaries[field] = tmp
        return tmp

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        import os

        try:
            if kind is None:
                for field, tmp in self.temporaries.items():
                    os.replace(tmp, self.paths[field])
            elif exc is not None:
                self._name_the_targets(exc)
        finally:
            for tmp in self.temporaries.values():
                if tmp.exists():
                    tmp.unlink()
        return False

    def _name_the_targets(self, exc: BaseException) -> None:
        """Put the user's paths where ``exc`` names a hidden temporary (a clip refusal,
        a full disk): the temporary is removed on the way out and means nothing to the
        user. A writer may stage its file once more beside the staged one (its own atomic
        write): any engine temporary (:func:`synth.io.atomic.temporary_name`) in a
        target's folder with its suffix is that target's."""
        import functools
        import re

        from synth.io.atomic import TEMPORARY_PREFIX

        for field in self.temporaries:
            target = self.paths[field]
            hidden = re.compile(
                re.escape(str(target.with_name(TEMPORARY_PREFIX)))
                + r"\d+-[0-9a-f]+\.part"
                + re.escape(target.suffix)
            )
            named = functools.partial(hidden.sub, lambda _, path=str(target): path)
            if isinstance(exc, OSError) and exc.filename is not None:
                exc.filename = named(str(exc.filename))
            exc.args = tuple(named(a) if isinstance(a, str) else a for a in exc.args)


def _refuse_shared_paths(paths: dict) -> None:
    """Two outputs of one command on one file would leave only the last one written (the
    audio replaced by the report, say): refused before any work. Paths are compared
    resolved (``./a.wav``, ``a.wav`` and a symbolic link to it are one file)."""
    seen: dict = {}
    for field, path in paths.items():
        key = path.resolve()
        if key in seen:
            other = seen[key]
            raise SynthError(
                f"{other}={str(paths[other])!r} and {field}={str(path)!r} are the same file; "
                f"give each output its own path (nothing was written)"
            )
        seen[key] = field


def _write_json(path, obj):
    from pathlib import Path

    from synth.io.atomic import write_json_atomically

    path = Path(path)
    if not path.parent.is_dir():
        raise SynthError(f"report={str(path)!r}: the directory {str(path.parent)!r} does not exist")
    write_json_atomically(path, obj, error=SynthError)


def _cmd_analyze(args):
    from synth import analysis

    if args.plot:
        analysis.check_plot_path(args.plot)  # a bad image path fails before any output
    import warnings

    from synth.io.audio import TruncatedAudioWarning

    with warnings.catch_warnings():
        # a truncated file is one of the result's warnings, printed below
        warnings.simplefilter("ignore", TruncatedAudioWarning)
        result = analysis.analyze_file(  # options checked first; a long file read in blocks
            args.file,
            gravity=args.gravity,
            channel=_channel(args.channel),
            min_separation=args.min_separation,
            window=args.window,
            deflate=not args.no_deflate,
        )
        audio, fs = analysis.read_recording(args.file) if args.plot else (None, None)
    for warning in result.warnings:
        print(f"synth: warning: {warning}", file=sys.stderr)
    if args.json:
        json.dump(analysis.to_dict(result), sys.stdout, indent=1, default=float)
        print()
    elif args.csv:
        sys.stdout.write(analysis.to_csv(result))
    else:
        print(analysis.format_table(result, warnings=False))
    if args.plot:
        analysis.plot_analysis(result, audio, fs, args.plot)
    return 0


def _read_warned(reader, path):
    """``reader(path)``, its warnings (a truncated file) printed as the command's own."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = reader(path)
    for w in caught:
        print(f"synth: warning: {w.message}", file=sys.stderr)
    return out


def _channel(value):
    if value is None or value == "mix":
        return None
    try:
        return int(value)
    except ValueError:
        raise SynthError(
            f"channel={value!r} must be a channel number (0, 1, ...) or 'mix'"
        ) from None


def _cmd_alter(args):
    from synth.analysis import analyze
    from synth.io import audio as audio_io
    from synth.stimuli.alter import alter_restitution

    audio_io.check_output_path(args.output, "output", audio_io.FORMATS)  # before the analysis
    audio, fs = _read_warned(audio_io.read_audio, args.file)
    channel = _channel(args.channel)
    onsets = [
        t.time
        for t in analyze(
            audio, fs, gravity=args.gravity, channel=channel, min_separation=args.min_separation
        ).ticks
    ]
    out, t_new, e, e_new = alter_restitution(
        audio,
        fs,
        args.restitution_scale,
        onsets=onsets,
        gravity=args.gravity,
        scale_amplitude=not args.keep_amplitude,
        min_bounce=args.min_bounce,
        normalize=args.normalize,
    )
    peak = float(np.max(np.abs(out)))
    subtype = (args.subtype or audio_io.DEFAULT_SUBTYPE).upper()
    if peak > 1.0 and subtype not in audio_io.FLOAT_SUBTYPES:
        raise SynthError(
            f"the altered audio peaks at {20 * np.log10(peak):+.2f} dBFS, above full scale, "
            f"and {args.output!r} would clip it (nothing written); use --normalize peak "
            f"(or a .wav file with --subtype FLOAT)"
        )
    audio_io.write_audio(args.output, out, fs, subtype=args.subtype)
    dropped = len(onsets) - len(t_new)
    shortest = args.min_bounce if args.min_bounce is not None else float(np.min(np.diff(onsets)))
    end = (
        f"; the series ends after {len(t_new)} ticks ({dropped} dropped: the next bounce "
        f"would be shorter than {shortest * 1e3:.3g} ms)"
        if dropped
        else ""
    )
    print(
        f"{args.output}: {len(t_new)} ticks re-laid; e {np.mean(e):.3f} -> "
        f"{np.mean(e_new):.3f} (mean over bounces){end}, {out.shape[0] / fs:.3f} s, "
        f"normalize={args.normalize}"
    )
    return 0


#: The presets of the reference gallery in renders/ (`synth gallery`).
GALLERY = (
    "default",
    "thesis-steel10-mdf18-corner",
    "small-click-on-acrylic",
    "ceramic-cup-on-stone",
    "thesis-steel10-mdf18-rolling",
    "steel-ball-rolling-on-glass-table",
    "marble-rolling-on-wooden-floor",
)


def _cmd_gallery(args):
    from pathlib import Path

    from synth.io import audio as audio_io
    from synth.io.plot import plot_render
    from synth.io.presets import find, load_preset_with_options
    from synth.sound.render import render

    out = Path(args.output_dir)
    if not out.is_dir():
        raise SynthError(f"output_dir={str(out)!r} is not a directory")
    names = args.names or GALLERY
    for name in names:
        scene, section, data = load_preset_with_options(name)
        opts, subtype = render_options(section, args, str(find(name)))
        rendered = render(scene, **opts)
        # the file synth render writes (same options, same subtype)
        audio_io.write_audio(
            out / f"{name}.wav", rendered.audio, rendered.samplerate, subtype=subtype
        )
        plot_render(rendered, out / f"{name}.png")
        _write_json(out / f"{name}.json", _report(rendered, data, name))
        print(
            f"{out / name}.wav/.png/.json: {rendered.duration:.2f} s, "
            f"{len(rendered.impacts)} impacts"
        )
    return 0


def _cmd_presets(args):
    from synth.io.presets import available, read

    for name, path in available().items():
        try:
            desc = read(path).get("description", "")
        except SynthError as exc:
            desc = f"(unreadable: {exc})"
        print(f"{name:<28} {desc}")
    return 0


def _cmd_materials(args):
    from synth.physics import materials

    for m in (materials.get(n) for n in materials.names()):
        print(
            f"{m.name:<16} rho={m.density:>7g} kg/m^3  E={m.young / 1e9:>7.4g} GPa  "
            f"nu={m.poisson:<5g} damping={m.damping}"
        )
    return 0


def _device(value):
    """A PortAudio device: an index when the value is a number, else a name."""
    return int(value) if value.isdigit() else value


def _cmd_play(args):
    import time

    from synth.io.presets import load_preset_with_options
    from synth.live import Engine

    scene, render_section, _ = load_preset_with_options(args.preset, args.overrides)
    fs = args.samplerate or int(render_section["samplerate"])
    engine = Engine(
        samplerate=fs, blocksize=args.blocksize, device=args.device, latency=args.latency
    )
    body = engine.add(scene.plate, listener=scene.listener, gain=10.0 ** (args.gain_db / 20.0))
    engine.start()
    try:
        for n in range(args.repeat):
            voice = body.drop(
                scene.ball,
                scene.drop_height,
                position=scene.position,
                contact=scene.contact,
                gravity=scene.gravity,
            )
            onsets = voice.onsets if voice is not None else ()
            print(
                f"drop {n + 1}: {len(onsets)} impacts over {onsets[-1] - onsets[0]:.3f} s"
                if onsets
                else f"drop {n + 1}: refused (the body's ring of pending impacts is full)",
                flush=True,
            )
            deadline = time.monotonic() + args.max_seconds
            while body.awake and time.monotonic() < deadline:
                time.sleep(0.02)
    except KeyboardInterrupt:
        engine.stop()
        print("stopped", file=sys.stderr)
        return 130
    engine.stop()
    stats = engine.stats
    print(
        f"{stats.impacts_played} impacts played, {stats.output_underflows} output underflows, "
        f"callback mean {100 * stats.callback_mean:.1f} % of the block"
    )
    return 0


def _cmd_bench(args):
    from synth import bench
    from synth.live import bench as live_bench

    runs = {
        "contact": (
            lambda: bench.run_contact(
                tolerances=tuple(args.tolerances)
                if args.tolerances
                else (1e-3, 1e-4, 1e-6, 1e-8, 1e-10),
                repeat=300 if args.repeat is None else args.repeat,
                modal=True,
            ),
            bench.format_contact,
        ),
        "render": (
            lambda: bench.run_render(repeat=5 if args.repeat is None else args.repeat),
            bench.format_render,
        ),
        "thesis": (lambda: bench.thesis_comparison(modal=True), bench.format_thesis),
        "analysis": (
            (lambda: bench.run_random(args.random, args.seed, limit=args.limit))
            if args.random
            else bench.run_analysis,
            bench.format_random if args.random else bench.format_analysis,
        ),
        "long": (bench.run_long, bench.format_long),
        "live": (lambda: live_bench.run_live(seconds=args.seconds), live_bench.format_live),
        "scale": (bench.run_scale, bench.format_scale),
        "hires": (bench.run_hires, bench.format_hires),
        "cold": (bench.run_cold, bench.format_cold),
        "rolling": (
            lambda: bench.run_rolling(repeat=3 if args.repeat is None else args.repeat),
            bench.format_rolling,
        ),
        "rollingcheck": (bench.run_rolling_check, bench.format_rolling_check),
        "hollow": (bench.run_hollow, bench.format_hollow),
        "cost": (bench.run_cost, bench.format_cost),
        "bank": (
            lambda: _bank_bench().run_bank(count=args.count),
            lambda r: _bank_bench().format_bank(r),
        ),
    }
    if args.what in runs:
        run, fmt = runs[args.what]
        if args.json and (args.markdown or args.update_docs):
            raise SynthError("--json cannot be combined with --markdown or --update-docs")
        if args.random and (args.what != "analysis" or args.update_docs):
            raise SynthError(
                "--random is an option of 'synth bench analysis' alone, and its figures have "
                "no block in docs/ (--update-docs)"
            )
        if args.record and args.what != "cost":
            raise SynthError("--record is an option of 'synth bench cost' alone")
        result = run()
        if args.record:
            print(f"{bench.record_rates(result)}: rates recorded")
        if args.json:
            json.dump(result, sys.stdout, indent=1)
            print()
        elif args.markdown or args.update_docs:
            block = bench.markdown_block(_bench_command(args), fmt(result))
            if args.update_docs:
                from synth.docs import update_bench_docs

                print(f"{update_bench_docs(args.what, block)}: block bench:{args.what} updated")
            else:
                print(block, end="")
        else:
            print(fmt(result))
        return 0
    raise SystemExit(f"unknown benchmark {args.what!r}")


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


def _bank_bench():
    from synth.bank import bench

    return bench


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
    result = bank.run(
        args.spec,
        args.output,
        jobs=args.jobs,
        scheduler=args.scheduler,
        dry_run=args.dry_run,
        force=args.force,
        redo=args.redo,
        prune=args.prune,
    )
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


def _cmd_cache(args):
    from synth.io import cache

    if args.action == "clear":
        n, freed = cache.clear_disk()
        print(f"{cache.cache_dir()}: {n} files deleted, {freed / 1e6:.1f} MB freed")
        return 0
    info = cache.disk_info()
    print(
        f"{info.directory}: {info.entries} entries, {info.bytes / 1e6:.1f} MB of at most "
        f"{info.max_bytes / 1e6:.0f} MB (SYNTH_CACHE_MAX_BYTES; least recently used evicted)"
    )
    for kind, (n, size) in info.by_kind.items():
        print(f"  {kind:<32} {n:>5} entries {size / 1e6:>9.1f} MB")
    return 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 1")
    return value


def _bench_command(args) -> str:
    """The benchmark's command line, as printed in a docs/ block."""
    words = ["synth", "bench", args.what]
    if args.repeat is not None:
        words += ["--repeat", str(args.repeat)]
    if args.tolerances:
        words += ["--tolerances", *(f"{t:g}" for t in args.tolerances)]
    return " ".join(words + ["--markdown"])


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="synth", description="Physically based bouncing and impact sounds."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="print the impact table of a preset's scene")
    _add_preset_args(p)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--cost",
        action="store_true",
        help="the render's cost estimate (modes, longest contact, pulse grid, audio, memory) "
        "against the budget, before any work",
    )
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("render", help="render a preset to a WAV or FLAC file")
    _add_preset_args(p)
    p.add_argument("-o", "--output", required=True, help="output file (.wav or .flac)")
    p.add_argument("--samplerate", type=int, help="Hz (default: the preset's, else 48000)")
    p.add_argument("--subtype", help="soundfile subtype: PCM_16, PCM_24 (default), FLOAT (WAV) ...")
    p.add_argument(
        "--normalize",
        choices=["peak", "loudness", "physical", "none"],
        help="level: peak (-1 dBFS, default), loudness (LUFS), physical (1000 Pa or "
        "10 000 m/s^2 full scale), none (Pa or m/s^2; needs --subtype FLOAT)",
    )
    p.add_argument(
        "--peak-db", type=float, metavar="DBFS", help="peak level for --normalize peak (default -1)"
    )
    p.add_argument(
        "--loudness-lufs",
        type=float,
        metavar="LUFS",
        help="integrated loudness for --normalize loudness (default -23; a bouncing "
        "sound's crest factor is 30-40 dB, so a PCM file may need -40 or lower)",
    )
    p.add_argument(
        "--floor-db",
        type=float,
        metavar="DB",
        help="omission floor below the loudest tick's peak (default -80)",
    )
    p.add_argument("--plot", metavar="OUT.png", help="waveform, spectrogram, impacts, force pulses")
    p.add_argument("--report", metavar="OUT.json", help="impact table and render settings")
    p.add_argument(
        "--restitution-scale",
        type=float,
        metavar="K",
        help="perception stimulus: 1 - e' = K (1 - e) for every tick (thesis 5.2.2)",
    )
    p.add_argument(
        "--timing-from",
        metavar="PRESET",
        help="perception stimulus: impact times and speeds of another preset, ticks of this one",
    )
    p.set_defaults(func=_cmd_render)

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
    p.add_argument("--channel", help="channel number, or 'mix' (default: the mean of the channels)")
    p.add_argument("--gravity", type=float, default=GRAVITY, help="m/s^2, for the impact speeds")
    p.add_argument(
        "--min-separation",
        type=float,
        default=0.001,
        metavar="S",
        help="shortest time between two ticks, s (default 0.001): a burst closer "
        "than this to a tick is part of it (the end of a long contact); lower it "
        "(0.0002) for hard balls whose last bounces are shorter than 1 ms",
    )
    p.add_argument(
        "--window",
        type=float,
        default=0.02,
        metavar="S",
        help="length of every tick's measurement window, s (default 0.02): energy, "
        "peak, centroid, spread and decay of the tick's own sound over it",
    )
    p.add_argument(
        "--no-deflate",
        action="store_true",
        help="do not take the earlier ticks out when looking for the later ones",
    )
    p.set_defaults(func=_cmd_analyze)

    p = sub.add_parser("alter", help="change the restitution of a recording: 1 - e' = K (1 - e)")
    p.add_argument("file")
    p.add_argument("-o", "--output", required=True, help="output file (.wav or .flac)")
    p.add_argument("--restitution-scale", type=float, required=True, metavar="K")
    p.add_argument(
        "--keep-amplitude",
        action="store_true",
        help="do not scale each tick by its new impact speed over its old one",
    )
    p.add_argument("--channel", help="channel to detect the ticks on (default: the mean)")
    p.add_argument("--gravity", type=float, default=GRAVITY, help="m/s^2")
    p.add_argument(
        "--min-separation",
        type=float,
        default=0.001,
        metavar="S",
        help="shortest time between two ticks, s (as for analyze)",
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
    p.set_defaults(func=_cmd_alter)

    p = sub.add_parser(
        "gallery", help="regenerate the reference renders (WAV, PNG, JSON) in renders/"
    )
    p.add_argument(
        "names",
        nargs="*",
        metavar="PRESET",
        help=f"presets to render (default: {', '.join(GALLERY)})",
    )
    p.add_argument("--output-dir", default="renders", help="folder (default: renders)")
    p.set_defaults(func=_cmd_gallery)

    p = sub.add_parser("presets", help="list the presets")
    p.set_defaults(func=_cmd_presets)

    p = sub.add_parser("materials", help="list the built-in materials")
    p.set_defaults(func=_cmd_materials)

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
    p.add_argument("--jobs", type=int, metavar="N", help="worker processes (default: the cores)")
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on a Dask cluster (tcp://host:8786) instead of local workers",
    )
    p.add_argument(
        "--dry-run",
        action="store_true",
        help="change nothing: print the rows to render (JSON lines) and estimate the time",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="start over in a folder made by another spec (deletes its files)",
    )
    p.add_argument(
        "--redo",
        metavar="ROWS",
        help="render these rows again although complete (e.g. 17,40-45)",
    )
    p.add_argument(
        "--prune",
        action="store_true",
        help="delete the audio files in DIR that are in neither the manifest nor the plan "
        "(without it they are only reported)",
    )
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

    p = sub.add_parser("cache", help="the disk cache of plate modes and radiation gains")
    p.add_argument(
        "action",
        choices=["info", "clear"],
        help="info: entries and size; clear: delete every entry",
    )
    p.set_defaults(func=_cmd_cache)

    p = sub.add_parser("play", help="play a preset's scene through the live engine (Ctrl-C stops)")
    _add_preset_args(p)
    p.add_argument(
        "--device",
        type=_device,
        help="output device: index or name (default: the "
        "system's; list them with `python -m sounddevice`)",
    )
    p.add_argument("--samplerate", type=int, help="Hz (default: the preset's, else 48000)")
    p.add_argument("--blocksize", type=int, default=256, help="frames per block (default 256)")
    p.add_argument("--latency", default="low", help="low (default), high, or seconds")
    p.add_argument(
        "--gain-db",
        type=float,
        default=0.0,
        metavar="DB",
        help="level above the physical calibration (1000 Pa or 10 000 m/s^2 full "
        "scale), dB (default 0)",
    )
    p.add_argument("--repeat", type=int, default=1, help="drops, one after the other (default 1)")
    p.add_argument(
        "--max-seconds",
        type=float,
        default=30.0,
        metavar="S",
        help="longest wait for a drop to ring out, s (default 30)",
    )
    p.set_defaults(func=_cmd_play)

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
        choices=range(1, 5),
        metavar="N",
        help="run only step N (repeatable): 1 the presets' renders, 2 a stiff contact, "
        "3 the live example, 4 the analysis",
    )
    p.add_argument(
        "--record",
        action="store_true",
        help="keep each kernel group's compile time for the first-use note (run on an empty cache)",
    )
    p.set_defaults(func=_cmd_warmup)

    p = sub.add_parser("bench", help="error against run time")
    p.add_argument(
        "what",
        choices=[
            "contact",
            "render",
            "thesis",
            "analysis",
            "long",
            "live",
            "scale",
            "hires",
            "bank",
            "cold",
            "rolling",
            "rollingcheck",
            "hollow",
            "cost",
        ],
        help="hollow: the hollow balls against their rule books' bounce tests; contact: solver "
        "error and time per impact against scipy; render: audio "
        "error against a reference and real-time factor; thesis: the engine "
        "beside the thesis' model and measurements; analysis: recovered "
        "restitution and onsets against noise; live: the live engine's "
        "callback, hit() and add() costs, and underflows through a JACK dummy "
        "server; scale: cold and warm cost of modes, radiation gains and "
        "synthesis for a ladder of plates; hires: cold renders at 96, 192 and 384 kHz, "
        "and at 384 kHz with the previous paths; bank: sounds/s of a sound bank "
        "against one process per file; cold: CPU and wall time and peak memory of the "
        "first import synth, synth render default and live example on empty numba and "
        "plate-mode caches, and the same warm; rolling: the rolling contact's and its modal "
        "drive's time per second of audio, and the rolling presets' renders; rollingcheck: "
        "the rolling's contact-loss speed, energy balance and spectral centroid against speed; "
        "cost: this machine's rates of the cost estimate's work (a cold mode solve, each "
        "radiation rule), which synth info --cost turns into seconds",
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
    p.set_defaults(func=_cmd_bench)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C (SIGINT): every
    temporary file is removed on the way out."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """A warning as one line of the command's own (``synth: warning: ...``), never a
    Python source line: a user cannot act on the engine's file and line number."""
    print(f"synth: warning: {message}", file=sys.stderr if file is None else file)


def main(argv=None) -> int:
    import signal
    import threading
    import warnings

    parser = build_parser()
    args = parser.parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return args.func(args)
    except SynthError as exc:
        print(f"synth: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a program that stopped reading (head)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # the system refused: full disk, read-only folder, I/O error
        where = f" ({exc.filename})" if exc.filename else ""
        print(f"synth: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1
    except Terminated:
        print("synth: terminated (SIGTERM); nothing partial was left", file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
