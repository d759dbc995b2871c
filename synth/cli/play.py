"""The ``play`` subcommand: a preset's scene through the live engine."""

from __future__ import annotations

import sys

from synth.cli.common import add_preset_args


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


def add_play_parser(sub) -> None:
    p = sub.add_parser("play", help="play a preset's scene through the live engine (Ctrl-C stops)")
    add_preset_args(p)
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
