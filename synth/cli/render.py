"""The subcommands on a preset's scene: ``info`` (impact table, cost), ``render`` (audio,
plot and report, all or none) and ``gallery`` (the reference renders)."""

from __future__ import annotations

from synth.cli.common import add_preset_args, print_json
from synth.errors import SynthError
from synth.sound.options import OPTIONS, PRESET_SAMPLERATE, declaration, default, describe


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
        description = data.get("description", "")
        return print_json(
            dict(preset=args.preset, description=description, stop_reason=seq.stop_reason)
            | dict(duration=seq.duration, impacts=rows, **ending)
        )
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


def _budget_seconds(budget) -> str:
    """The time budgets in seconds at the measured :class:`synth.cost.Rates` (radiation at
    the rectangle rule's rate), or "" without them."""
    from synth import cost

    rates = cost.Rates.load()
    if rates is None:
        return ""
    solver = budget.max_solver_flops / rates.solver
    radiation = budget.max_radiation_work / rates.radiation["rectangle"]
    return f" (about {solver:.3g} s and {radiation:.3g} s of radiation at the measured rates)"


def _print_cost(scene, section: dict, as_json: bool) -> int:
    """``synth info --cost``: the render's cost estimate and what a render would refuse."""
    from dataclasses import asdict

    from synth import cost

    budget = cost.Budget.from_environment()
    estimate = cost.estimate_render(scene, section, budget)  # the section sets samplerate
    too_big = estimate.excess(budget)
    if as_json:
        return print_json(dict(asdict(estimate), budget=asdict(budget), refused=too_big))
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


def render_options(scene_render: dict, args) -> tuple[dict, str | None]:
    """Render keywords from a preset's [render] section and the command line (which wins),
    and the output file's subtype."""
    opts = dict(scene_render)
    for key in OPTIONS + ("subtype",):
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
        settings=dict(rendered.settings),
        impacts=[
            dict(row, onset=float(onset))
            for row, onset in zip(rendered.impacts.table(), rendered.onsets)
        ],
    )


def _cmd_render(args):
    from synth.io.presets import load_preset_with_options
    from synth.sound.render import render
    from synth.store import audio as audio_io

    outputs = Outputs(  # every output path checked before any work
        {"output": args.output, "report": args.report, "plot": args.plot},
        {"output": audio_io.FORMATS, "plot": (".png",)},
    )
    scene, render_section, data = load_preset_with_options(args.preset, args.overrides)
    opts, subtype = render_options(render_section, args)
    if args.timing_from is not None or args.restitution_scale is not None:
        from synth.sound.options import RenderOptions
        from synth.stimuli import sequences as stimuli

        k = 1.0 if args.restitution_scale is None else args.restitution_scale
        bounces = RenderOptions(**opts).bounces()  # the preset's stop rules
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
        f"{rendered.info.n_modes_rendered} of {rendered.info.n_modes} modes, "
        f"normalize={rendered.info.options.normalize}"
    )
    return 0


class Outputs:
    """The output files of one command, written all or none: each path checked before any
    work; inside ``with outputs:`` each file is written to a temporary beside its target
    (:meth:`staged`), renamed onto it only when the block ends without an error."""

    def __init__(self, paths: dict, suffixes: dict | None = None):
        from pathlib import Path

        from synth.store.audio import check_output_path

        self.paths = {k: Path(v) for k, v in paths.items() if v}
        _refuse_shared_paths(self.paths)
        for field, path in self.paths.items():
            check_output_path(path, field, (suffixes or {}).get(field))
        self.temporaries: dict = {}

    def staged(self, field: str):
        from synth.store.atomic import temporary_name

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
        """Put the user's paths where ``exc`` names a temporary (any engine temporary in a
        target's folder with its suffix: a writer may stage its own beside ours)."""
        import functools
        import re

        from synth.store.atomic import TEMPORARY_PREFIX

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
    """Refuse two outputs on one file (compared resolved) before any work: only the last
    written would be left."""
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

    from synth.store.atomic import write_json_atomically

    path = Path(path)
    if not path.parent.is_dir():
        raise SynthError(f"report={str(path)!r}: the directory {str(path.parent)!r} does not exist")
    write_json_atomically(path, obj, error=SynthError)


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

    from synth.io.plot import plot_render
    from synth.io.presets import load_preset_with_options
    from synth.sound.render import render
    from synth.store import audio as audio_io

    out = Path(args.output_dir)
    if not out.is_dir():
        raise SynthError(f"output_dir={str(out)!r} is not a directory")
    names = args.names or GALLERY
    for name in names:
        scene, section, data = load_preset_with_options(name)
        opts, subtype = render_options(section, args)
        rendered = render(scene, **opts)
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


def add_option_flags(p, names) -> None:
    """A flag for each render option of ``names`` from its declaration
    (:class:`synth.sound.options.RenderOptions`); unset, the preset's value holds."""
    for name in names:
        d = declaration(name)
        value = default(name)
        shown = PRESET_SAMPLERATE if name == "samplerate" else value
        where = "the Nyquist frequency" if value is None and name != "samplerate" else shown
        p.add_argument(
            "--" + name.replace("_", "-"),
            type=OPTION_TYPES.get(name, float),
            choices=d.choices,
            metavar=d.metavar,
            help=f"{describe(name)}; default: the preset's, else {where}",
        )


#: The command line's types of the render options that are not real numbers.
OPTION_TYPES = {"samplerate": int, "normalize": str, "pulse_points": int, "max_impacts": int}


def add_render_parser(sub) -> None:
    p = sub.add_parser("render", help="render a preset to a WAV or FLAC file")
    add_preset_args(p)
    p.add_argument("-o", "--output", required=True, help="output file (.wav or .flac)")
    add_option_flags(p, OPTIONS[:1])
    p.add_argument("--subtype", help="soundfile subtype: PCM_16, PCM_24 (default), FLOAT (WAV) ...")
    add_option_flags(p, OPTIONS[1:])
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
