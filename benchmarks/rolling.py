"""``synth bench rolling``: the rolling contact's cost per second of audio.

A steel ball of 10 mm radius rolls over a rough 6 mm glass plate at three speeds, 48 kHz; its
force then drives the plate's modes below 5 kHz at the moving contact, heard by an
accelerometer, as a render drives them: the modes within their share of the render's omission
floor under the signal's peak are left out (:func:`synth.sound.rolling.audible_modes`; the
column "modes driven"). The roughness (Matern spectrum: rms 1 um, correlation length 100 um,
Hurst exponent 0.8) is a benchmark input, not a published value. Per speed: wall time per
second of audio of the contact solver and of the modal drive (best of ``repeat`` runs after
a warm-up that compiles the kernels), the real-time factor of both together in wall time and
in the process' CPU time (on a machine shared with other work the wall time includes the
time the process waited for a core; the CPU time does not), the solver's
steps per sample and the ball's flights (micro-bounces), and the steps per 48 kHz sample
the solver takes over the same second sampled at :data:`COARSE_SAMPLERATE`: what its
accuracy asks for when the sample boundaries do not cut its steps; and the share of the
samples the ball spends in flight (no contact force), which the solver crosses in closed
form, without steps.

Then the rolling presets (:data:`ROLLING_PRESETS`: a drop with sideways speed that bounces
and rolls) rendered whole as ``synth render`` renders them: the audio's length, the time
the ball rolls, the wall time of its path (bounces and rolling contact) and of the whole
render (best of ``repeat`` runs after a warm-up, which makes the path's surface: a render
again reuses it), the render's real-time factor in wall and in CPU time, and the wall time
of making that surface afresh (the profile and its envelope), as the first render over it
does.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from benchmarks.common import markdown_table, target_verdict

#: Real-time factor the rolling scenes aim at (contact plus modal drive).
TARGET_REALTIME = 100.0

SAMPLERATE = 48000
#: The samplerate (Hz) of the run that shows the steps the solver's accuracy asks for.
COARSE_SAMPLERATE = 480
DURATION = 1.0
SPEEDS = (0.1, 0.3, 0.8)
#: The presets of a ball dropped with sideways speed (bounces, then rolling).
ROLLING_PRESETS = (
    "thesis-steel10-mdf18-rolling",
    "steel-ball-rolling-on-glass-table",
    "marble-rolling-on-wooden-floor",
)


@dataclass
class SceneRun:
    """One rolling preset's render: audio and rolling length, path and render wall time,
    render CPU time (s)."""

    preset: str
    audio_s: float
    rolling_s: float
    path_s: float
    render_s: float
    surface_s: float
    render_cpu_s: float

    @property
    def realtime(self) -> float:
        return self.audio_s / self.render_s

    @property
    def cpu_realtime(self) -> float:
        return self.audio_s / self.render_cpu_s


@dataclass
class RollingRun:
    """One speed's figures: wall and CPU s per s of audio, steps per sample, flights, modes
    below 5 kHz and those driven, the share of the samples without contact force."""

    speed: float
    contact_s_per_s: float
    modes_s_per_s: float
    steps_per_sample: float
    accuracy_steps_per_sample: float
    flights: int
    modes: int
    contact_cpu_s_per_s: float
    modes_cpu_s_per_s: float
    modes_driven: int = 0
    airborne: float = 0.0

    @property
    def realtime(self) -> float:
        return 1.0 / (self.contact_s_per_s + self.modes_s_per_s)

    @property
    def cpu_realtime(self) -> float:
        return 1.0 / (self.contact_cpu_s_per_s + self.modes_cpu_s_per_s)


def _best_of(fn, repeat: int):
    """The least wall time (s) of ``repeat`` calls of ``fn`` and the last call's value."""
    best, _, value = _best_wall_and_cpu(fn, repeat)
    return best, value


def _best_wall_and_cpu(fn, repeat: int):
    """The least wall time and the least CPU time of the process (s) of ``repeat`` calls of
    ``fn``, and the last call's value."""
    wall, cpu, value = float("inf"), float("inf"), None
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        value = fn()
        cpu = min(cpu, time.process_time() - start_cpu)
        wall = min(wall, time.perf_counter() - start)
    return wall, cpu, value


def run_rolling(repeat: int = 3) -> dict:
    """Time the rolling contact and its modal drive at each of :data:`SPEEDS` (m/s)
    (``"contact"``), and the rolling presets' renders (``"scenes"``)."""
    return {"contact": run_contact_speeds(repeat), "scenes": run_scenes(repeat)}


def run_scenes(repeat: int = 3) -> list[dict]:
    """Time the renders of :data:`ROLLING_PRESETS` and of their paths."""
    import math

    from synth.io.presets import load_preset_with_options
    from synth.physics.path import simulate_path
    from synth.sound.render import render

    runs = []
    for name in ROLLING_PRESETS:
        scene, section, _ = load_preset_with_options(name)
        opts = {k: v for k, v in section.items() if k != "subtype"}
        fs = opts["samplerate"]
        origin = math.sqrt(2.0 * scene.drop_height / scene.gravity) - 0.005

        def path(scene=scene, fs=fs, origin=origin):
            return simulate_path(scene, samplerate=fs, time_origin=origin)

        render(scene, **opts)  # compiles on a cold cache, fills the modes' cache
        t_path, solved = _best_of(path, repeat)
        t_render, cpu_render, rendered = _best_wall_and_cpu(
            lambda s=scene, o=opts: render(s, **o), repeat
        )
        rolled = 0.0 if solved.rolling is None else solved.rolling.force.size / fs
        t_surface = _surface_seconds(scene, repeat)
        runs.append(
            asdict(
                SceneRun(name, rendered.duration, rolled, t_path, t_render, t_surface, cpu_render)
            )
        )
    return runs


def _surface_seconds(scene, repeat) -> float:
    """Wall time (s, best of ``repeat``) of making afresh the surface that the last render
    of ``scene`` rolled over (the profile and its contact envelope), as a first render does."""
    from synth.physics import path

    r = scene.rolling
    made = [
        key for key, _ in path._ENVELOPES
        if key[:5] == (r.rms_height, r.correlation_length, r.hurst, r.seed, r.spacing)
        and key[6] == scene.ball.radius
    ]  # fmt: skip
    length, radius = made[-1][5], made[-1][6]
    best, _ = _best_of(lambda: path.make_envelope(r, length, radius), repeat)
    return best


def run_contact_speeds(repeat: int = 3) -> list[dict]:
    """Time the rolling contact and its modal drive at each of :data:`SPEEDS` (m/s)."""
    from synth.physics import rolling, surface
    from synth.physics.scene import Accelerometer, Ball, Plate
    from synth.sound import rolling as sound
    from synth.sound.options import RenderOptions
    from synth.sound.render import modal_model

    ball = Ball("steel", 0.01)
    plate = Plate("glass", 0.006, 1.0, 0.6, boundary="simply-supported")
    spec = surface.RoughnessSpectrum(rms_height=1e-6, correlation_length=1e-4, hurst=0.8)
    envelope = surface.contact_envelope(
        surface.rough_profile(spec, length=0.9, spacing=5e-6, seed=1), ball.radius
    )
    model = modal_model(
        plate, Accelerometer((0.3, 0.2)), samplerate=SAMPLERATE, max_frequency=5000.0
    )
    floor = 10.0 ** (RenderOptions(samplerate=SAMPLERATE).floor_db / 20.0)
    runs = []
    for speed in SPEEDS:

        def solve(speed=speed, samplerate=SAMPLERATE):
            return rolling.roll(
                ball,
                plate,
                envelope,
                speed=speed,
                duration=DURATION,
                samplerate=samplerate,
                origin=(0.05, 0.3),
                start=0.01,
            )

        solve()  # compiles on a cold cache
        t_contact, cpu_contact, result = _best_wall_and_cpu(solve, repeat)
        # the render's omission floor under the signal's peak (of a drive of every mode)
        peak = float(np.max(np.abs(sound.rolling_sound(result, model))))
        t_modes, cpu_modes, _ = _best_wall_and_cpu(
            lambda r=result: sound.rolling_sound(r, model, floor=floor, reference=peak), repeat
        )
        c = result.contact_coordinate
        driven = sound.audible_modes(
            result.force,
            sound.path_excitation(model, origin=result.origin, direction=result.direction,
                                  start=c.min(), stop=c.max()),
            model.poles, model.output, SAMPLERATE, floor=floor, reference=peak,
            preload=float(result.force[0]),
        ).sum()  # fmt: skip
        coarse = solve(samplerate=COARSE_SAMPLERATE)
        runs.append(
            RollingRun(
                speed=speed,
                contact_s_per_s=t_contact / DURATION,
                modes_s_per_s=t_modes / DURATION,
                steps_per_sample=result.n_steps / result.force.size,
                accuracy_steps_per_sample=coarse.n_steps / result.force.size,
                flights=int(result.flights),
                modes=int(model.poles.size),
                modes_driven=int(driven),
                airborne=float(np.mean(result.force == 0.0)),
                contact_cpu_s_per_s=cpu_contact / DURATION,
                modes_cpu_s_per_s=cpu_modes / DURATION,
            )
        )
    return [asdict(r) for r in runs]


def format_rolling(result: dict) -> str:
    """Markdown tables of :func:`run_rolling`'s runs and the real-time target's verdicts."""
    return format_contact_speeds(result["contact"]) + "\n\n" + format_scenes(result["scenes"])


def format_scenes(rows: list[dict]) -> str:
    """A Markdown table of :func:`run_scenes`' renders and the real-time target's verdict."""
    runs = [SceneRun(**row) for row in rows]
    header = [
        "rolling preset",
        "audio s",
        "rolling s",
        "path s",
        "render s",
        "real-time factor",
        "CPU real-time factor",
        "surface afresh s",
    ]
    cells = [
        [
            r.preset,
            f"{r.audio_s:.2f}",
            f"{r.rolling_s:.2f}",
            f"{r.path_s:.3f}",
            f"{r.render_s:.3f}",
            f"{r.realtime:.0f}x",
            f"{r.cpu_realtime:.0f}x",
            f"{r.surface_s:.3f}",
        ]
        for r in runs
    ]
    return "\n".join(markdown_table(header, cells) + ["", _realtime_line("rolling preset", runs)])


def format_contact_speeds(rows: list[dict]) -> str:
    """A Markdown table of :func:`run_contact_speeds`' runs and the target's verdict."""
    runs = [RollingRun(**row) for row in rows]
    header = [
        "speed m/s",
        "contact ms per s",
        "modes ms per s",
        "real-time factor",
        "CPU real-time factor",
        "steps/sample",
        f"steps/sample at {COARSE_SAMPLERATE} Hz",
        "flights",
        "airborne",
        "modes driven",
    ]
    cells = [
        [
            f"{r.speed:.1f}",
            f"{r.contact_s_per_s * 1e3:.1f}",
            f"{r.modes_s_per_s * 1e3:.1f}",
            f"{r.realtime:.0f}x",
            f"{r.cpu_realtime:.0f}x",
            f"{r.steps_per_sample:.2f}",
            f"{r.accuracy_steps_per_sample:.2f}",
            str(r.flights),
            f"{r.airborne:.0%}",
            f"{r.modes_driven} of {r.modes}",
        ]
        for r in runs
    ]
    return "\n".join(markdown_table(header, cells) + ["", _realtime_line("speed", runs)])


def _realtime_line(what: str, runs) -> str:
    """The summary line of the slowest run's real-time factor against the target."""
    worst = min(r.realtime for r in runs)
    worst_cpu = min(r.cpu_realtime for r in runs)
    return (
        f"- slowest {what}'s real-time factor {worst:.0f}x ({worst_cpu:.0f}x in CPU time), "
        f"target at least {TARGET_REALTIME:g}x: {target_verdict(worst >= TARGET_REALTIME)}."
    )
