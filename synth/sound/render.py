"""Render a scene: bounces -> plate modes -> exact modal synthesis -> level.

``render(scene, samplerate=48000)`` returns a :class:`~synth.sound.result.Render`: the
audio (float32), the impacts with their onsets, and its
:class:`~synth.sound.result.RenderInfo`. The signal is what the scene's listener picks up
(:mod:`synth.sound.listener`): plate acceleration (m/s^2) for an Accelerometer, sound
pressure (Pa) for a Microphone above the baffled plate, scaled by ``normalize``.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import time

import numpy as np

from synth import cost
from synth.errors import ParameterError, SynthError
from synth.physics.bounces import BounceSequence, simulate_scene
from synth.physics.scene import Scene
from synth.sound.listener import (
    LISTENER_OUTPUTS,
    LISTENER_UNITS,
    ListenerOutput,
    ModalModel,
    listener_grid,
    modal_model,
    nearest_distance,
)
from synth.sound.modal_bank import synthesize
from synth.sound.options import (
    MAX_DURATION,
    MAX_IMPACTS,
    MAX_PREROLL,
    MAX_PULSE_POINTS,
    MAX_SAMPLERATE,
    MIN_LEVEL_DB,
    MIN_SAMPLERATE,
    NORMALIZE,
    OPTIONS,
    RenderOptions,
    keyword_parameters,
    parameters_doc,
)
from synth.sound.result import PathInfo, Render, RenderInfo
from synth.sound.sequence_check import SEQUENCE_RTOL, check_sequence
from synth.store import cache as disk_cache

#: The names this module has always offered (the render's pieces live in the modules
#: above; these are their old paths).
__all__ = [
    "LISTENER_OUTPUTS", "LISTENER_UNITS", "MAX_DURATION", "MAX_IMPACTS", "MAX_PREROLL",
    "MAX_PULSE_POINTS", "MAX_SAMPLERATE", "MIN_LEVEL_DB", "MIN_SAMPLERATE", "NORMALIZE",
    "OPTIONS", "SEQUENCE_RTOL", "ListenerOutput", "ModalModel", "Render", "RenderInfo",
    "RenderOptions", "check_sequence", "listener_grid", "modal_model", "nearest_distance",
    "render",
]  # fmt: skip


def render(scene, *, options=None, sequence=None, budget=None, **overrides) -> Render:
    """Render ``scene`` with the render options: ``options`` (a
    :class:`~synth.sound.options.RenderOptions`), or its fields as keywords (``samplerate``
    required: there is no default or global rate), or both (the keywords win).

    Parameters
    ----------
    scene : Scene
    options : RenderOptions, optional
        The options; a keyword below changes one of them.
    OPTIONS_DOC
    sequence : BounceSequence, optional
        Precomputed impacts of this scene (default: computed here); not empty, and its
        contacts must be this scene's (see :func:`~synth.sound.sequence_check.check_sequence`).
    budget : synth.cost.Budget, optional
        The most work the render may take on (default: ``Budget.from_environment()``):
        the scene's :func:`synth.cost.estimate` beyond it, or a contact longer than
        ``max_duration``, is refused before any work with a ``ParameterError`` naming
        what is too big and what to change.

    A tail cut by ``max_tail`` is reported in ``info.tail_cut`` and ``info.left_at_end``
    (the bound, relative to the reference amplitude, of what rings on after the end).
    """
    o = _checked_options(scene, options, overrides)
    estimate = _checked_work(scene, o, sequence, budget)
    if scene.moving:
        if sequence is not None:
            raise ParameterError(
                "sequence: a scene with drop.velocity computes its own path (bounces and "
                "rolling); pass no sequence"
            )
        return _render_moving(scene, o)
    started = time.perf_counter()
    sequence = _impacts(scene, o, sequence)
    contact_seconds = time.perf_counter() - started
    model = _heard_modes(scene, o, estimate.radiation.max_points)
    return _render_drop(scene, o, sequence, model, contact_seconds)


if render.__doc__:  # None under python -OO
    render.__doc__ = render.__doc__.replace("    OPTIONS_DOC", parameters_doc())
render.__signature__ = inspect.Signature(
    [
        inspect.Parameter("scene", inspect.Parameter.POSITIONAL_OR_KEYWORD),
        *keyword_parameters(),
        *(
            inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None)
            for name in ("options", "sequence", "budget")
        ),
    ],
    return_annotation=Render,
)


def _checked_options(scene, options, overrides) -> RenderOptions:
    """The scene and the options checked, before any work: the plate's damping law (the
    modes will need it), the cache's environment and every option."""
    if not isinstance(scene, Scene):
        raise ParameterError(f"scene={scene!r} must be a Scene")
    scene.plate.damping_law()
    disk_cache.check_environment()
    return RenderOptions.of(options, **overrides)


def _checked_work(scene, o: RenderOptions, sequence, budget) -> cost.CostEstimate:
    """The render's cost estimate, refused beyond ``budget`` (default: the environment's),
    and a first impact later than ``max_duration`` refused."""
    if sequence is None:
        first_touch = math.sqrt(2.0 * scene.drop_height / scene.gravity)
        if first_touch > o.max_duration:
            raise ParameterError(
                f"drop.height={scene.drop_height!r} m: the first impact, {first_touch:.4g} s "
                f"after release, is later than max_duration={o.max_duration!r} (s)"
            )
    if budget is None:
        budget = cost.Budget.from_environment()
    elif not isinstance(budget, cost.Budget):
        raise ParameterError(f"budget={budget!r} must be a synth.cost.Budget")
    options = dict(
        samplerate=o.samplerate, max_frequency=o.top_frequency, preroll=o.preroll,
        max_duration=o.max_duration, max_tail=o.max_tail, pulse_points=o.pulse_points,
        floor_db=o.floor_db,
    )  # fmt: skip
    try:
        hash(scene)
    except TypeError:  # a field given as a list: not kept
        estimate = cost.estimate(scene, budget=budget, **options)
    else:
        estimate = _estimate(scene, budget, **options)
    estimate.check(budget)
    return estimate


@functools.lru_cache(maxsize=64)
def _estimate(scene, budget, **options) -> cost.CostEstimate:
    """:func:`synth.cost.estimate` of ``scene`` under ``budget`` with the render ``options``,
    kept for the scene (a function of its arguments alone: every render of one scene asks
    for the same)."""
    return cost.estimate(scene, budget=budget, **options)


def _impacts(scene, o: RenderOptions, sequence) -> BounceSequence:
    """The drop's impacts: ``sequence`` checked against the scene, or the scene's bounce
    series under the options' rules; an impact the solver could not solve is refused."""
    if sequence is None:
        sequence = simulate_scene(scene, **o.bounces())
    else:
        check_sequence(scene, sequence)
    for imp in sequence:
        if not imp.result.success:
            raise SynthError(
                f"impact {imp.index} (at {imp.speed:.4g} m/s) could not be solved: "
                f"{imp.result.message} The scene is outside what the contact solver handles"
            )
    return sequence


def _heard_modes(scene, o: RenderOptions, radiation_max_points=None) -> ModalModel:
    """The plate's modes heard by the scene's listener; a plate without a ringing mode
    in the band is refused (the render would be silent)."""
    fs, f_max = o.samplerate, o.top_frequency
    model = modal_model(
        scene.plate,
        scene.listener,
        samplerate=fs,
        max_frequency=f_max,
        radiation_max_points=radiation_max_points,
    )
    if not model.poles.size:
        raise ParameterError(_silent_plate_message(f_max, fs, scene.plate, model.n_overdamped))
    return model


def _render_drop(
    scene, o: RenderOptions, sequence, model: ModalModel, contact_seconds: float = 0.0
) -> Render:
    """The drop's impacts through the modal bank, faded and levelled (``contact_seconds``:
    the wall time their contacts took, s)."""
    fs = o.samplerate
    excitation = model.excitation(scene.position)
    times = np.array([imp.time for imp in sequence])
    start = (times[0] + model.delay - o.preroll) if len(times) else 0.0
    weights = [scene.ball.mass * scene.gravity if imp.result.settled else 0.0 for imp in sequence]
    max_samples = int(math.ceil((sequence.duration + model.delay - start + o.max_tail) * fs))
    floor = 10.0 ** (o.floor_db / 20.0)
    audio, bank = synthesize(
        [imp.result for imp in sequence],
        times + model.delay - start,
        model.poles,
        excitation,
        model.output,
        fs,
        floor=floor,
        settled_weight=weights,
        direct=model.direct(excitation),
        max_samples=max_samples,
        pulse_points=o.pulse_points,
    )
    reference = bank["reference"]
    info = _info(
        scene, o, model, sequence,
        delay=model.delay,
        audio_start=start,
        n_modes_rendered=bank["n_modes_rendered"],
        mode_samples=bank["mode_samples"],
        tail_cut=bool(bank["length"] >= max_samples and bank["left_at_end"] > floor * reference),
        left_at_end=bank["left_at_end"] / reference if reference else 0.0,
        bank_seconds=bank["bank_seconds"],
        reference_amplitude=reference,
        contact_seconds=contact_seconds,
        transform_seconds=bank["transform_seconds"],
    )  # fmt: skip
    return _levelled(audio, o, model.units, sequence, info)


def _render_moving(scene, o: RenderOptions) -> Render:
    """:func:`render` of a scene with a horizontal velocity: its bounces and rolling
    (:mod:`synth.sound.path_render`), faded and levelled as every render."""
    from synth.sound.path_render import render_path_audio

    model = _heard_modes(scene, o)
    audio, path, figures = render_path_audio(scene, model, o)
    path_names = {f.name for f in dataclasses.fields(PathInfo)}
    path_info = PathInfo(**{k: v for k, v in figures.items() if k in path_names})
    rest = {k: v for k, v in figures.items() if k not in path_names}
    info = _info(scene, o, model, path.impacts, path=path_info, **rest)
    return _levelled(audio, o, model.units, path.impacts, info)


def _info(scene, o: RenderOptions, model: ModalModel, impacts, **figures) -> RenderInfo:
    """The :class:`RenderInfo` of a render: its options (``max_frequency`` the highest
    frequency rendered), listener, impacts and modes, and the synthesis' ``figures``."""
    return RenderInfo(
        options=o.replace(max_frequency=o.top_frequency),
        listener=type(scene.listener).__name__.lower(),
        listener_position=tuple(scene.listener.position),
        n_impacts=len(impacts),
        stop_reason=impacts.stop_reason,
        n_modes=int(model.poles.size),
        n_modes_overdamped=model.n_overdamped,
        **figures,
    )


def _levelled(audio, o: RenderOptions, units: str, impacts, info: RenderInfo) -> Render:
    """The :class:`Render` of the physical signal ``audio`` (``units``), faded at its end
    and scaled by the level stage."""
    from synth.store import audio as audio_io

    _fade(audio, o.fade, o.samplerate)
    scaled, gain = audio_io.normalize(
        audio, o.normalize, samplerate=o.samplerate, units=units, peak_db=o.peak_db,
        loudness_lufs=o.loudness_lufs,
    )  # fmt: skip
    return Render(
        np.asarray(scaled, dtype=np.float32), o.samplerate, impacts, units, float(gain), info
    )


def _fade(audio, fade_s, fs) -> None:
    """A raised-cosine fade of ``fade_s`` s at the end of ``audio`` (in place); refused if
    longer than the audio."""
    from synth.store import audio as audio_io

    if fade_s > audio.size / fs:
        raise ParameterError(
            f"fade={fade_s!r} s is longer than the audio "
            f"({audio.size / fs:.6g} s); it must be at most that"
        )
    if fade_s > 0 and audio.size:
        # the fade's n frames run from full level (the first) to 0 (the last)
        n = min(audio.size, int(round(fade_s * fs)))
        audio_io.apply_fade_out(audio, n - 1)


def _silent_plate_message(f_max: float, samplerate: int, plate=None, overdamped: int = 0) -> str:
    """Why a plate without a mode below ``f_max`` (Hz) is refused, and what can change:
    the damping law when every mode there is ``overdamped`` (they do not ring; ``plate``
    names it), else ``max_frequency`` only while it is below the Nyquist frequency."""
    if overdamped:
        return (
            f"plate.material.damping={plate.material.damping!r} damps all {overdamped} modes "
            f"of the plate below {f_max:g} Hz past critical (they decay faster than they "
            f"ring), so the render would be silent; a solid's loss factor is below 1"
        )
    if f_max < 0.5 * samplerate:
        return (
            f"max_frequency={f_max!r} (Hz): no mode of the plate rings below it, so the "
            f"render would be silent; raise it (at most samplerate / 2 = {samplerate / 2:g} Hz)"
        )
    return (
        f"no mode of the plate rings below the Nyquist frequency samplerate / 2 = "
        f"{samplerate / 2:g} Hz, so the render would be silent; raise the samplerate (at "
        f"most {MAX_SAMPLERATE}) or use a larger, thinner or less stiff plate"
    )
