"""The subcommands on a preset's scene: ``info`` (impact table, cost), ``render`` (audio,
plot and report, all or none) and ``gallery`` (the reference renders)."""

from __future__ import annotations

import dataclasses

from synth.cli.common import add_preset_args, print_json
from synth.errors import SynthError
from synth.sound.options import OPTIONS, PRESET_SAMPLERATE, RenderOptions, default, describe

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

#: The impact table's columns: heading, width and the cell of a row.
TABLE = (
    ("n", 4, lambda r: f"{r['n']}"),
    ("time (s)", 10, lambda r: f"{r['time']:.5f}"),
    ("speed (m/s)", 12, lambda r: f"{r['speed']:.5f}"),
    ("e", 8, lambda r: "settled" if r["settled"] else f"{r['restitution']:.4f}"),
    ("tau (us)", 9, lambda r: f"{r['contact_time'] * 1e6:.2f}"),
    ("F_max (N)", 10, lambda r: f"{r['peak_force']:.4g}"),
    ("lambda", 8, lambda r: f"{r['inelasticity']:.4f}"),
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
        head = dict(preset=args.preset, description=data.get("description", ""))
        return print_json(
            head | dict(stop_reason=seq.stop_reason, duration=seq.duration, impacts=rows, **ending)
        )
    if data.get("description"):
        print(data["description"])
    for cells in [[f"{h:>{w}}" for h, w, _ in TABLE]] + [
        [f"{cell(r):>{w}}" for _, w, cell in TABLE] for r in rows
    ]:
        print(" ".join(cells))
    print(f"{len(rows)} impacts; the sequence ended: {seq.stop_reason}")
    if path is not None:
        e = ending
        print(
            f"rolled {e['rolling_seconds']:.3f} s from {e['rolling_start']} s at "
            f"{e['rolling_speed']:.4g} m/s; the path ended: {e['path_end']} at "
            f"{e['path_end_time']:.4f} s, ({e['path_end_point'][0]:.4f}, "
            f"{e['path_end_point'][1]:.4f}) m"
        )
    return 0


def _path_of(scene, section: dict):
    """The :class:`synth.physics.path.BallPath` of a moving scene on its render's grid."""
    import math

    from synth.io.presets import render_options_of
    from synth.physics.path import simulate_path

    o = render_options_of(section)
    origin = math.sqrt(2.0 * scene.drop_height / scene.gravity) - o.preroll
    return simulate_path(
        scene, samplerate=o.samplerate, time_origin=origin, max_duration=o.max_duration
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


def _print_cost(scene, section: dict, as_json: bool) -> int:
    """``synth info --cost``: the render's cost estimate and what a render would refuse; the
    budgets in seconds at the measured :class:`synth.cost.Rates` (radiation at the
    rectangle rule's rate) where they are recorded."""
    from dataclasses import asdict

    from synth import cost

    budget = cost.Budget.from_environment()
    estimate = cost.estimate_render(scene, section, budget)  # the section sets samplerate
    too_big = estimate.excess(budget)
    if as_json:
        return print_json(dict(asdict(estimate), budget=asdict(budget), refused=too_big))
    for name, value in estimate.rows():
        print(f"{name:<28} {value}")
    rates = cost.Rates.load()
    seconds = "" if rates is None else (
        f" (about {budget.max_solver_flops / rates.solver:.3g} s and "
        f"{budget.max_radiation_work / rates.radiation['rectangle']:.3g} s of radiation at "
        f"the measured rates)"
    )  # fmt: skip
    print(
        f"budget: {budget.max_modes} modes, {budget.max_pulse_points} pulse points, "
        f"{budget.max_memory_bytes / 2**20:.0f} MiB, {budget.max_solver_flops:.3g} solver "
        f"flop, {budget.max_radiation_work:.3g} radiation rectangle-term equivalents{seconds}"
    )
    for reason in too_big:
        print(f"a render would be refused: {reason}")
    if not too_big:
        print("a render fits the budget")
    return 0


def render_options(scene_render: dict, args) -> tuple[dict, str | None]:
    """Render keywords from a preset's [render] section and the command line (which wins),
    and the output file's subtype."""
    opts = dict(scene_render)
    for key in OPTIONS + ("subtype",):
        if getattr(args, key, None) is not None:
            opts[key] = getattr(args, key)
    return opts, opts.pop("subtype", None)


def _report(rendered, data, preset) -> dict:
    onsets = zip(rendered.impacts.table(), rendered.onsets)
    return dict(
        preset=str(preset),
        description=data.get("description", ""),
        samplerate=rendered.samplerate,
        duration=rendered.duration,
        units=rendered.units,
        gain=rendered.gain,
        settings=dict(rendered.settings),
        impacts=[dict(row, onset=float(onset)) for row, onset in onsets],
    )


def _sequence(args, scene, opts: dict):
    """The impacts of a perception stimulus (``--restitution-scale``, ``--timing-from``)
    under the preset's stop rules, or None."""
    if args.timing_from is None and args.restitution_scale is None:
        return None
    from synth.io.presets import load_preset_with_options
    from synth.stimuli import sequences as stimuli

    k = 1.0 if args.restitution_scale is None else args.restitution_scale
    bounces = RenderOptions(**opts).bounces()
    if args.timing_from is None:
        return stimuli.scaled_sequence(scene, k, **bounces)
    timing = load_preset_with_options(args.timing_from)[0]
    return stimuli.mismatch_sequence(timing, scene, restitution_scale=k, **bounces)


def _cmd_render(args):
    from synth.io.presets import load_preset_with_options
    from synth.sound.render import render
    from synth.store import audio as audio_io
    from synth.store.atomic import Outputs, write_json_atomically

    outputs = Outputs(  # every output path checked before any work
        {"output": args.output, "report": args.report, "plot": args.plot},
        {"output": audio_io.FORMATS, "plot": (".png",)},
    )
    scene, render_section, data = load_preset_with_options(args.preset, args.overrides)
    opts, subtype = render_options(render_section, args)
    rendered = render(scene, **opts, sequence=_sequence(args, scene, opts))
    with outputs:
        audio_io.write_audio(
            outputs.staged("output"), rendered.audio, rendered.samplerate, subtype=subtype
        )
        if args.report:
            report = _report(rendered, data, args.preset)
            write_json_atomically(outputs.staged("report"), report, error=SynthError)
        if args.plot:
            from synth.io.plot import plot_render

            plot_render(rendered, outputs.staged("plot"))
    info = rendered.info
    print(
        f"{args.output}: {rendered.duration:.3f} s at {rendered.samplerate} Hz, "
        f"{len(rendered.impacts)} impacts ({rendered.impacts.stop_reason}), "
        f"{info.n_modes_rendered} of {info.n_modes} modes, normalize={info.options.normalize}"
    )
    return 0


def _cmd_gallery(args):
    from pathlib import Path

    from synth.io.plot import plot_render
    from synth.io.presets import load_preset_with_options
    from synth.sound.render import render
    from synth.store import audio as audio_io
    from synth.store.atomic import write_json_atomically

    out = Path(args.output_dir)
    if not out.is_dir():
        raise SynthError(f"output_dir={str(out)!r} is not a directory")
    for name in args.names or GALLERY:
        scene, section, data = load_preset_with_options(name)
        opts, subtype = render_options(section, args)
        rendered = render(scene, **opts)
        audio_io.write_audio(
            out / f"{name}.wav", rendered.audio, rendered.samplerate, subtype=subtype
        )
        plot_render(rendered, out / f"{name}.png")
        write_json_atomically(out / f"{name}.json", _report(rendered, data, name), error=SynthError)
        print(
            f"{out / name}.wav/.png/.json: {rendered.duration:.2f} s, "
            f"{len(rendered.impacts)} impacts"
        )
    return 0


def add_info_parser(sub) -> None:
    p = sub.add_parser("info", help="print the impact table of a preset's scene")
    add_preset_args(p)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument(
        "--cost",
        action="store_true",
        help="the render's cost estimate (modes, longest contact, pulse grid, audio, memory) "
        "against the budget, before any work",
    )
    p.set_defaults(func=_cmd_info)


def add_option_flags(p, fields) -> None:
    """A flag for each render option of ``fields`` (:class:`RenderOptions`' fields), its type
    the field's, its help the declaration's; unset, the preset's value holds."""
    for f in fields:
        d = f.metadata["option"]
        value = PRESET_SAMPLERATE if f.name == "samplerate" else default(f.name)
        p.add_argument(
            "--" + f.name.replace("_", "-"),
            type={"int": int, "str": str}.get(f.type, float),
            choices=d.choices,
            metavar=d.metavar,
            help=f"{describe(f.name)}; default: the preset's, else "
            f"{'the Nyquist frequency' if value is None else value}",
        )


def add_render_parser(sub) -> None:
    p = sub.add_parser("render", help="render a preset to a WAV or FLAC file")
    add_preset_args(p)
    p.add_argument("-o", "--output", required=True, help="output file (.wav or .flac)")
    fields = dataclasses.fields(RenderOptions)
    add_option_flags(p, fields[:1])
    p.add_argument("--subtype", help="soundfile subtype: PCM_16, PCM_24 (default), FLOAT (WAV) ...")
    add_option_flags(p, fields[1:])
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


def add_gallery_parser(sub) -> None:
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
